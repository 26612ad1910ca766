"""F_x far beyond sliding: no equilibrium, a clear message, no hang.

With mu = 1 and F_y = 3 per top disk, F_x = 30 is ten times the Coulomb
limit of the whole top line; the driver's relaxation must raise
NoEquilibriumError (Python) / exit with status 3 (command line) within a
bounded number of steps (not seconds: a wall-time bound fails on a loaded machine).
"""
import os
import re
import subprocess
import sys

import pytest

N = 20


@pytest.fixture(scope="module")
def datafile(tmp_path_factory):
    from remote_trigger.pywrap.stages.packing import generate, write_data

    path = tmp_path_factory.mktemp("noeq") / "p.data"
    write_data(generate(N, seed=2), path)
    return str(path)


def test_equilibrate_raises_clear_error_quickly(datafile, tmp_path):
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RelaxConfig
    from remote_trigger.pywrap.stages.equilibrium import NoEquilibriumError

    # the frictional protocol: the default one refuses any F_x != 0 at once
    # (test_default_protocol_refuses_a_horizontal_load)
    cfg = RelaxConfig(datafile=datafile, F_x=30.0, max_steps=200000, protocol="frictional")
    with pytest.raises(NoEquilibriumError, match=r"no equilibrium at F_x = 30\.0: the top "
                                                 r"layer slid .* in t = ") as info:
        stages.relax(cfg, str(tmp_path / "out"), quiet=True)
    # "quickly" in steps, not seconds: the slide criterion ended the run long
    # before max_steps (a wall-time bound would fail on a loaded machine)
    t_sim = float(re.search(r"in t = (\S+)$", str(info.value)).group(1))
    assert t_sim / cfg.dt < 0.1 * cfg.max_steps


def test_max_steps_bounds_a_slow_case(datafile, tmp_path):
    """Even when the slide criterion is not met, max_steps ends the run with a message."""
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RelaxConfig
    from remote_trigger.pywrap.stages.equilibrium import NoEquilibriumError

    cfg = RelaxConfig(datafile=datafile, F_x=30.0, slide=1e9, max_steps=3000,
                      check_every=1000, protocol="frictional")
    # bounded by the step count the message names, not by a wall time
    with pytest.raises(NoEquilibriumError, match="within max_steps = 3000"):
        stages.relax(cfg, str(tmp_path / "out2"), quiet=True)


def test_command_line_exit_status_3(datafile, tmp_path):
    cli = os.path.join(os.path.dirname(sys.executable), "remote-trigger")
    env = dict(os.environ, OMP_NUM_THREADS="1")
    p = subprocess.run([cli, "relax", "--datafile", datafile, "--out", str(tmp_path / "o"),
                        "--F-x", "30", "--quiet"], capture_output=True, text=True, timeout=60,
                       env=env)
    assert p.returncode == 3, (p.returncode, p.stderr[-500:])
    assert "no equilibrium" in p.stderr + p.stdout


def test_default_protocol_refuses_a_horizontal_load(datafile, tmp_path):
    """The default protocol relaxes without friction (step iii), where a
    horizontal load has no equilibrium (the flat wall pushes along y only):
    F_x != 0 is refused before any dynamics, and nothing is written (it drifted
    for minutes before the slide criterion stopped it)."""
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RelaxConfig
    from remote_trigger.pywrap.stages.equilibrium import NoEquilibriumError

    out = tmp_path / "o"
    with pytest.raises(NoEquilibriumError, match=r"no equilibrium at F_x = 0\.005 in the "
                                                 r"frictionless step .*protocol 'frictional'"):
        stages.relax(RelaxConfig(datafile=datafile, F_x=0.005), str(out), quiet=True)
    assert not out.exists()
    cli = os.path.join(os.path.dirname(sys.executable), "remote-trigger")
    p = subprocess.run([cli, "relax", "--datafile", datafile, "--out", str(out),
                        "--F-x", "0.005", "--quiet"], capture_output=True, text=True,
                       timeout=60)
    assert p.returncode == 3, (p.returncode, p.stderr[-500:])
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "F_x = 0.005" in lines[0], p.stderr
    assert not out.exists()
