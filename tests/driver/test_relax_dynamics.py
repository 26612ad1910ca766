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


def _stalling_polish(monkeypatch, stall):
    """Newton phases for which ``stall(record)`` is true stop at once (as after FIRE at N = 10^4)."""
    import importlib

    eq = importlib.import_module("remote_trigger.pywrap.stages.equilibrium")
    real, calls = eq.polish, []

    def polish(eng, cfg, F_x, record, t0, t_sim, target=None, chord_below=None):
        calls.append(eq.exact_residual(eng)[2])
        if stall(record):
            record.add(t_sim, calls[-1], "newton", t0)
            return calls[-1], "stagnated"
        return real(eng, cfg, F_x, record, t0, t_sim, target, chord_below)

    monkeypatch.setattr(eq, "polish", polish)
    return calls


def _fire_relax(tmp_path, n=100):
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.packing import generate, write_data

    data = str(tmp_path / "p.data")
    write_data(generate(n, seed=1), data)
    return stages.relax(RelaxConfig(datafile=data, relax_dynamics="fire"), str(tmp_path),
                        quiet=True)


def test_stalled_newton_after_fire_runs_fire_again_tighter(tmp_path, monkeypatch):
    from remote_trigger.pywrap.stages.relax import FIRE_FTOL, FIRE_RETRY_FACTOR

    # the first Newton phase of each placement of the line stalls
    _stalling_polish(monkeypatch, lambda record: record.phase.count("fire") < 2)
    res = _fire_relax(tmp_path)
    ph = list(res.history.phase)
    fires = [r for r, p in zip(res.history.residual, ph) if p == "fire"]
    assert len(fires) == 2 and "damped" not in ph          # FIRE again, no damped fallback
    assert fires[0] < FIRE_FTOL * 3.0 and fires[1] < FIRE_FTOL * 3.0 / FIRE_RETRY_FACTOR
    assert ph[ph.index("fire", 1) + 1] == "newton"         # Newton again, from FIRE's state
    G, _ = _lammps_residual(res.datafile, 0.0)
    r = max(np.max(np.hypot(G[:, 0], G[:, 1])), np.max(np.abs(G[:, 2])))
    assert r == res.residual and r < 1e-10 and res.top_clearance > 0


def test_newton_stalling_after_every_fire_falls_back_to_damped(tmp_path, monkeypatch):
    import importlib

    rx = importlib.import_module("remote_trigger.pywrap.stages.relax")
    # one retry (FIRE to 3e-8, above the acceptance level 1e-10), Newton stalls after both
    monkeypatch.setattr(rx, "FIRE_RETRIES", 1)
    _stalling_polish(monkeypatch, lambda record: "damped" not in record.phase)
    res = _fire_relax(tmp_path)
    ph = list(res.history.phase)
    assert ph.count("fire") == 2
    assert "damped" in ph and res.residual < 1e-10 and res.top_clearance > 0
