"""The LAMMPS examples of README.md and of the pair style page run on a packing from
`remote-trigger generate` (in the Python module, and with the `lmp` of the environment);
the deck blocks of README.md and docs/driver.md run as pasted on generate's default
packing."""
import os
import subprocess
import sys

import pytest

from .lmputil import new_lammps

README = os.path.join(os.path.dirname(__file__), "..", "..", "README.md")


PAIR_PAGE = os.path.join(os.path.dirname(README), "pair_mindlin_smooth", "doc",
                         "pair_mindlin_smooth.rst")


def snippet():
    return next(b for b in _fenced_blocks(README) if "pair_style mindlin/smooth" in b)


def pair_page_deck():
    """The 2d deck of pair_mindlin_smooth.rst's Examples."""
    return next(b for b in _lammps_blocks(PAIR_PAGE) if b.startswith("dimension 2"))


def test_readme_snippet_reads_a_generated_packing(tmp_path):
    from remote_trigger.pywrap.stages.packing import generate, write_data

    write_data(generate(20, seed=1), tmp_path / "packing.data")
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        lmp = new_lammps()
        lmp.commands_string(snippet())
        lmp.commands_list(["timestep 1e-4", "run 100"])
        assert lmp.get_natoms() == 20
        lmp.close()
    finally:
        os.chdir(cwd)


def test_pair_style_doc_example_reads_a_generated_packing(tmp_path):
    """The 2d part of pair_mindlin_smooth.rst's Examples runs on a packing
    from `remote-trigger generate` (its read_data line lacked the per-atom
    sections' fixes: "Unknown identifier in data file: hist")."""
    from remote_trigger.pywrap.stages.packing import generate, write_data

    deck = pair_page_deck()
    write_data(generate(20, seed=1), tmp_path / "packing.data")
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        lmp = new_lammps()
        lmp.commands_string("units lj\n" + deck)
        # (the example defines the wall, which fix mu/velocity needs, and the
        # integrator itself)
        lmp.commands_list(["timestep 1e-4", "run 10"])
        assert lmp.get_natoms() == 20
        assert lmp.extract_global("ntimestep") == 10
        lmp.close()
    finally:
        os.chdir(cwd)


def _fenced_blocks(path):
    """The ``` blocks of a Markdown file, as text."""
    blocks, block = [], None
    with open(path) as fh:
        for line in fh:
            if line.startswith("```"):          # a fence opens or closes a block
                if block is not None:
                    blocks.append("".join(block))
                block = [] if block is None else None
            elif block is not None:
                block.append(line)
    return blocks


def _lammps_blocks(path):
    """The ``.. code-block:: LAMMPS`` blocks of a reST page, dedented."""
    import textwrap

    blocks, block = [], None
    with open(path) as fh:
        for line in fh:
            if line.startswith(".. code-block:: LAMMPS"):
                block = []
            elif block is not None:
                if line.strip() and not line.startswith(" "):     # the block ends
                    blocks.append(textwrap.dedent("".join(block)).strip() + "\n")
                    block = None
                else:
                    block.append(line)
    return blocks


def _run_on_a_generated_packing(tmp_path, deck):
    """``deck`` + ``run 20`` with ``lmp`` beside `remote-trigger generate`'s
    packing.data; returns LAMMPS's screen output (the run must succeed)."""
    bindir = os.path.dirname(sys.executable)
    if not (tmp_path / "packing.data").exists():
        gen = subprocess.run([os.path.join(bindir, "remote-trigger"), "generate", "-o",
                              "packing.data"], capture_output=True, text=True, cwd=tmp_path,
                             timeout=120)
        assert gen.returncode == 0, gen.stderr
    (tmp_path / "in.doc").write_text(deck + "run 20\n")
    res = subprocess.run([os.path.join(bindir, "lmp"), "-in", "in.doc", "-log", "none"],
                         capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert res.returncode == 0 and "ERROR" not in res.stdout, \
        res.stdout[-2000:] + res.stderr[-2000:]
    assert "Loop time of" in res.stdout
    return res.stdout


def test_the_readme_decks_run_on_a_generated_packing(tmp_path):
    """The two LAMMPS blocks of README.md "Using the plugin", pasted one after
    the other on `remote-trigger generate`'s packing, run with `lmp` (the
    Fig. 5 fixes act on group `top`, which the README defines)."""
    blocks = _fenced_blocks(README)
    setup = [b for b in blocks if b.startswith("units lj")]
    fig5 = [b for b in blocks if "addforce/oscillating" in b]
    assert len(setup) == 1 and len(fig5) == 1, blocks
    _run_on_a_generated_packing(tmp_path, setup[0] + fig5[0])


def test_the_pair_style_page_example_runs(tmp_path):
    """The 2d example of pair_mindlin_smooth.rst, and with its fix adapt
    alternative in place of fix mu/velocity, run on a generated packing (the
    example's fix mu/velocity had no wall fix to set mu of, and stopped)."""
    blocks = _lammps_blocks(PAIR_PAGE)
    deck = [b for b in blocks if b.startswith("dimension 2")]
    adapt = [b for b in blocks if " adapt " in b and "dimension" not in b]
    assert len(deck) == 1 and len(adapt) == 1, blocks
    _run_on_a_generated_packing(tmp_path, deck[0])
    alternative = "\n".join(ln for ln in deck[0].splitlines() if "mu/velocity" not in ln)
    _run_on_a_generated_packing(tmp_path, alternative + "\n" + adapt[0])


def _driver_page_deck_block():
    """The indented block of docs/driver.md "Decks" that runs the decks standalone."""
    path = os.path.join(os.path.dirname(README), "docs", "driver.md")
    with open(path) as fh:
        text = fh.read()
    head = "Each deck documents its variables at the top and runs standalone:\n\n"
    assert text.count(head) == 1
    lines = []
    for line in text.split(head, 1)[1].splitlines():
        if not line.startswith("    "):
            break
        lines.append(line[4:])
    return "\n".join(lines) + "\n"


def _run_shell_block(tmp_path, block):
    """``sh -e`` of a documentation block in an empty folder that has the
    repository's ``.venv`` and ``lammps_inputs`` (links to this environment
    and its installed decks); returns the screen output."""
    from remote_trigger.pywrap.bindings.decks import DECK_DIR

    os.symlink(sys.prefix, tmp_path / ".venv")
    os.symlink(DECK_DIR, tmp_path / "lammps_inputs")
    for name in os.listdir(DECK_DIR):
        os.symlink(os.path.join(DECK_DIR, name), tmp_path / name)
    env = dict(os.environ, OMP_NUM_THREADS="1")
    env["PATH"] = os.path.dirname(sys.executable) + os.pathsep + env.get("PATH", "")
    res = subprocess.run(["sh", "-e", "-c", block], cwd=tmp_path, env=env, capture_output=True,
                         text=True, timeout=900)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    return res.stdout


def _placements(out):
    return [ln.split(" (line shifted")[0] + (" kept" if ") kept" in ln else " not kept")
            for ln in out.splitlines() if ln.startswith("in.relax: placement")]


@pytest.mark.slow
def test_the_readme_deck_block_runs_as_pasted(tmp_path):
    """README.md's deck block on generate's default packing (seed 0): in.relax
    keeps the second placement, as it says, and the ramp step and the
    perturbation run write their outputs (two ranks:
    tests/driver/test_deck_placements_mpi.py, the same packing)."""
    blocks = [b for b in _fenced_blocks(README) if "lammps_inputs/in.relax" in b]
    assert len(blocks) == 1, blocks
    assert "generate --overwrite " in blocks[0] and "--seed" not in blocks[0]
    out = _run_shell_block(tmp_path, blocks[0])
    want = ["in.relax: placement 1 of 4 not kept", "in.relax: placement 2 of 4 kept"]
    assert _placements(out) == want, out[-3000:]
    for name in ("relaxed.dump", "step.dump", "perturb.txt"):
        assert os.path.getsize(tmp_path / name) > 0, name
    assert "seed = 0" in (tmp_path / "packing.data").read_text().splitlines()[0]


@pytest.mark.slow
def test_the_driver_page_deck_block_runs_as_pasted(tmp_path):
    """docs/driver.md's deck block (decks in the current folder, the
    environment's bin on PATH) on generate's default packing."""
    block = _driver_page_deck_block()
    assert block.startswith("remote-trigger generate -o packing.data\n"), block
    out = _run_shell_block(tmp_path, block)
    assert _placements(out) == ["in.relax: placement 1 of 4 not kept",
                                "in.relax: placement 2 of 4 kept"], out[-3000:]
    for name in ("relaxed.dump", "step.dump", "perturb.txt"):
        assert os.path.getsize(tmp_path / name) > 0, name
