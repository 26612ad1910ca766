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
