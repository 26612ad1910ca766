"""Relaxation: the equilibrium is checked by independent force evaluations."""
import numpy as np
import pytest

from remote_trigger.pywrap.bindings.engine import Engine
from remote_trigger.pywrap.stages import equilibrium as eq


def _lammps_residual(datafile, F_x, F_y=3.0, k_n=2e5, mu=1.0):
    """Fresh LAMMPS instance: read the data file, run 0, per-atom forces."""
    with Engine() as eng:
        eng.load_deck("in.relax", {"datafile": datafile, "Fx": F_x, "Fy": F_y,
                                   "kn": k_n, "mu": mu}, ("scene",))
        eng.command("run 0")
        st = eng.gather_state()
    G = np.column_stack([st.forces, st.torques / st.radii])
    return G, st


def _floor(st, k_n=2e5, F=3.0):
    """Round-off floor k_eff eps max|x| of the force evaluation (docs/driver.md)."""
    delta = (F / k_n) ** (2.0 / 3.0)
    k_eff = 1.5 * k_n * np.sqrt(delta)
    return k_eff * np.finfo(float).eps * float(np.max(np.abs(st.positions)))


def test_relax_reaches_round_off_floor(relaxed):
    G, st = _lammps_residual(relaxed.datafile, 0.0)
    r = max(np.max(np.hypot(G[:, 0], G[:, 1])), np.max(np.abs(G[:, 2])))
    # the reported residual is what an independent run 0 finds, bit for bit
    assert r == relaxed.residual
    # within a few times the double-precision floor of the force evaluation
    assert r < 10 * _floor(st), (r, _floor(st))
    assert r < 1e-10
    assert np.all(st.velocities == 0) and np.all(st.omega == 0)


def test_independent_python_force_law(relaxed):
    """The analyzer's own force law on the dump agrees: G ~ 0."""
    from remote_trigger.analysis.state.dumpfile import read_dump
    from remote_trigger.analysis.stability.jacobian import generalized_forces

    st = read_dump(relaxed.dumpfile, require_contacts=False)
    G = generalized_forces(st).reshape(-1, 3)
    assert np.max(np.abs(G)) < 1e-10
    # the dump carries contact forces only: with the loads they balance
    res = st.contact_forces[:, :2] + st.external
    assert np.max(np.abs(res)) < 1e-10
    assert np.all(st.external[:, 1] <= 0) and np.count_nonzero(st.external[:, 1]) > 0


def test_residual_history_monotone_after_polishing(relaxed):
    ph = np.asarray(relaxed.history.phase)
    res = np.asarray(relaxed.history.residual)
    first = int(np.argmax(ph == "newton"))
    assert ph[first] == "newton" and relaxed.newton_iterations >= 2
    polished = res[first:][ph[first:] == "newton"]
    assert np.all(np.diff(polished) <= 0), polished
    # Newton gains many decades over the damped estimate where it started
    assert polished[-1] < 1e-6 * polished[0]


def test_soft_contacts_reach_1e_13(tmp_path, relaxed):
    """With a softer contact law the round-off floor is below 1e-13, and polishing
    reaches it (the floor scales as k_n^(2/3) F_y^(1/3), docs/driver.md)."""
    from remote_trigger.pywrap.stages.config import RelaxConfig
    from remote_trigger.pywrap import stages

    cfg = RelaxConfig(datafile=relaxed.datafile, k_n=2e3, F_y=0.003, gamma=0.2,
                      f_min=1e-15, f_accept=1e-13, dt=0.005)
    res = stages.relax(cfg, str(tmp_path), quiet=True)
    G, st = _lammps_residual(res.datafile, 0.0, F_y=0.003, k_n=2e3)
    r = max(np.max(np.hypot(G[:, 0], G[:, 1])), np.max(np.abs(G[:, 2])))
    assert r < 1e-13 and r == res.residual


def test_no_equilibrium_is_detected(relaxed):
    """A horizontal load far above the static friction makes the top slide."""
    from remote_trigger.pywrap.stages.config import RelaxConfig
    from remote_trigger.pywrap.stages import load_relax_scene

    cfg = RelaxConfig(datafile=relaxed.datafile, F_x=3.0, slide=0.5, check_every=500)
    with Engine() as eng:
        load_relax_scene(eng, cfg, cfg.datafile, cfg.F_x)
        with pytest.raises(eq.NoEquilibriumError, match="slid"):
            eq.equilibrate(eng, cfg, cfg.F_x)


def test_modified_newton_reuses_one_factorisation(relaxed, monkeypatch):
    """A ramp step (F_x 0 -> 2.5e-4 from the relaxed equilibrium): the modified
    Newton iteration (K reused while it contracts, equilibrium.polish) reaches
    the acceptance level with one K, Newton's method with one per step; both
    end at the round-off floor."""
    import time

    from remote_trigger.pywrap.stages.config import RelaxConfig
    from remote_trigger.pywrap.stages import load_relax_scene

    calls = []
    real = eq.stiffness
    monkeypatch.setattr(eq, "stiffness", lambda *a, **k: calls.append(1) or real(*a, **k))
    out = {}
    for mode in ("newton", "modified"):
        cfg = RelaxConfig(datafile=relaxed.datafile, F_x=2.5e-4)
        with Engine() as eng:
            load_relax_scene(eng, cfg, cfg.datafile, cfg.F_x)
            eng.command(f"variable load_x equal {cfg.F_x!r}")
            eng.unfix(*eq.DAMPING_FIXES, *eq.INTEGRATOR_FIXES)
            eng.command("velocity all set 0.0 0.0 0.0")
            accept = eq.accept_level(cfg, eng.gather_state())
            calls.clear()
            rec = eq.RelaxRecord()
            r, _ = eq.polish(eng, cfg, cfg.F_x, rec, time.perf_counter(), 0.0,
                             chord_below=accept if mode == "modified" else None)
            out[mode] = (r, len(calls), np.asarray(rec.residual))
    (r_n, k_n, res_n), (r_m, k_m, res_m) = out["newton"], out["modified"]
    floor = _floor(_lammps_residual(relaxed.datafile, 0.0)[1])
    assert r_n < accept and r_m < accept and r_m < 10 * floor
    # Newton: one K per accepted step and one for the step that found the floor
    assert k_m == 1 and k_n == res_n.size and k_n >= 3, (k_m, k_n, res_n)
    # the chord step contracts like the Newton step: both reach the floor in two
    assert res_m[2] < accept and res_n[2] < accept, (res_m, res_n)
    assert np.all(np.diff(res_m) < 0) and np.all(np.diff(res_n) < 0)


def test_damped_dynamics_alone_stop_at_the_acceptance_level(packing_file, tmp_path):
    """newton = False (``relax --no-newton``) with the default f_min = 1e-15:
    the damped dynamics stall near the round-off floor, so they stop at the
    acceptance level (they ran until max_steps, minutes at N = 100)."""
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RelaxConfig

    cfg = RelaxConfig(datafile=packing_file, newton=False, max_steps=2_000_000)
    res = stages.relax(cfg, str(tmp_path), quiet=True)
    with Engine() as eng:
        eng.load_deck("in.relax", {"datafile": res.datafile}, ("scene",))
        accept = eq.accept_level(cfg, eng.gather_state())
    assert res.residual < accept and res.residual > cfg.f_min
    assert "newton" not in res.history.phase and res.newton_iterations == 0
