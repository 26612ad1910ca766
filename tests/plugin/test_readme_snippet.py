"""The plugin snippet of README.md runs on a packing from `remote-trigger generate`."""
import os
import re

from .lmputil import new_lammps

README = os.path.join(os.path.dirname(__file__), "..", "..", "README.md")


def snippet():
    blocks = re.findall(r"```\n(.*?)```", open(README).read(), flags=re.S)
    return next(b for b in blocks if "pair_style mindlin/smooth" in b)


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

    rst = os.path.join(os.path.dirname(README), "pair_mindlin_smooth", "doc",
                       "pair_mindlin_smooth.rst")
    block = open(rst).read().split('Examples\n""""""""', 1)[1]
    block = block.split(".. code-block:: LAMMPS", 1)[1].split("# spheres in 3d", 1)[0]
    deck = "\n".join(ln.strip() for ln in block.splitlines())
    write_data(generate(20, seed=1), tmp_path / "packing.data")
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        lmp = new_lammps()
        lmp.commands_string("units lj\n" + deck)
        lmp.commands_list(["fix floor all wall/mindlin/smooth 2.0e5 57142.857142857145 1.0 "
                           "yplane 0.0", "fix nve all nve/sphere disc", "fix 2d all enforce2d",
                           "timestep 1e-4", "run 10"])
        assert lmp.get_natoms() == 20
        assert lmp.extract_global("ntimestep") == 10
        lmp.close()
    finally:
        os.chdir(cwd)
