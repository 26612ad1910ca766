"""``relax_dynamics``: the FIRE path of the frictionless relaxation, and its switch.

The FIRE path (forced on a small packing) must end in the same kind of
state as the damped path: Newton-polished below the acceptance level,
checked by an independent ``run 0``, zero tangential history with friction
on, every top centre above every bulk centre, no overlap beyond a Hertz
contact's. ``'auto'`` keeps the damped path for N <= 400.
"""
import numpy as np
import pytest

from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.stages.config import RELAX_DYNAMICS_AUTO_N, RelaxConfig

from .test_relax import _lammps_residual


def test_bad_value_is_a_one_line_error(packing_file):
    with pytest.raises(ConfigError) as exc:
        RelaxConfig(datafile=packing_file, relax_dynamics="fast")
    msg = str(exc.value)
    assert "relax_dynamics" in msg and "'fast'" in msg and "\n" not in msg


def test_auto_is_damped_up_to_400_disks(packing_file):
    from remote_trigger.pywrap.stages.relax import relax_dynamics

    cfg = RelaxConfig(datafile=packing_file)
    assert cfg.relax_dynamics == "auto" and RELAX_DYNAMICS_AUTO_N == 400
    assert [relax_dynamics(cfg, n) for n in (20, 100, 400, 401, 1600)] == \
        ["damped"] * 3 + ["fire"] * 2
    for forced in ("damped", "fire"):
        assert relax_dynamics(cfg.replace(relax_dynamics=forced), 100) == forced


def test_default_small_packing_takes_the_damped_path(relaxed):
    assert "fire" not in relaxed.history.phase and "damped" in relaxed.history.phase


@pytest.fixture(scope="module")
def relaxed_fire(tmp_path_factory):
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.packing import generate, write_data

    out = tmp_path_factory.mktemp("relax_fire")
    data = str(out / "p100.data")
    write_data(generate(100, seed=1), data)
    cfg = RelaxConfig(datafile=data, relax_dynamics="fire")
    return stages.relax(cfg, str(out), quiet=True)


def test_fire_path_reaches_the_same_criteria(relaxed_fire):
    res = relaxed_fire
    ph = list(res.history.phase)
    assert ph[0] == "fire" and "newton" in ph and ph[-1] == "friction-on"
    G, st = _lammps_residual(res.datafile, 0.0)
    r = max(np.max(np.hypot(G[:, 0], G[:, 1])), np.max(np.abs(G[:, 2])))
    assert r == res.residual and r < 1e-10          # the acceptance level of the default model
    assert np.all(st.velocities == 0) and np.all(st.omega == 0)
    assert res.antisymmetry < 1e-14                 # friction on with zero history: K symmetric
    assert res.top_clearance > 0                    # the line on top
    assert 0.79 < res.packing_fraction < 0.83       # docs/driver.md: 0.80-0.817

    from remote_trigger.analysis.state.dumpfile import read_dump

    dump = read_dump(res.dumpfile, require_contacts=False)
    assert np.all(dump.contact_xi == 0) and np.all(dump.wall_xi == 0)
    # overlaps: at most the Hertz overlap of the largest contact force (< 5 F_y)
    from remote_trigger.analysis.state.contacts import find_contacts

    i, j, rho = find_contacts(dump.positions, dump.radii, dump.box_lo, dump.box_hi)
    assert np.max(dump.radii[i] + dump.radii[j] - rho) < (5 * 3.0 / 2e5) ** (2 / 3)
