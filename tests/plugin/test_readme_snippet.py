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
