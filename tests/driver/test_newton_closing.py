"""Newton steps that close gaps K does not know about (equilibrium.closing_fraction).

Unit checks of the step fraction against the Hertz force it is meant to
cap (head-on, across the periodic boundary, against the wall), and the case
that made it necessary: the N = 1600 packing kept for make bench, whose
ramp step F_x = 2.5e-4 -> 5e-4 needed 4 chunks of damped dynamics between
rejected Newton steps (3.3-4.7 s) before the cap and converges by Newton alone
with it (1.1-1.9 s).
"""
import os
import sys
from types import SimpleNamespace

import numpy as np
import pytest

from remote_trigger.pywrap.stages import equilibrium as eq

K_N = 2e5
R_RES = 5e-5          # residual the step is meant to remove


def _disks(pos, radii=(0.5, 0.5), L=10.0):
    return SimpleNamespace(radii=np.asarray(radii, float), positions=np.asarray(pos, float),
                           box_lo=np.array([0.0, -1.0]), box_hi=np.array([L, 20.0]))


def _overlap(st, dq):
    p = st.positions + dq[:, :2]
    L = st.box_hi[0] - st.box_lo[0]
    d = p[1] - p[0]
    d[0] -= L * np.round(d[0] / L)
    return st.radii.sum() - np.hypot(*d)


def _d_star():
    return (eq.CLOSING_FORCE * R_RES / K_N) ** (2 / 3)


@pytest.mark.parametrize("x0", [4.0, 9.3])     # 9.3: the pair straddles the boundary
def test_head_on_closing_is_capped_at_the_residual_force(x0):
    g0 = 1e-7
    L = 10.0
    x1 = (x0 + 1.0 + g0) % L
    st = _disks([[x0, 2.0], [x1, 2.0]], L=L)
    dq = np.zeros((2, 3))
    dq[1, 0] = -3e-6                  # overshoots into an overlap of 2.9e-6
    a = eq.closing_fraction(st, dq, K_N, R_RES, wall_y=-5.0)
    assert 0 < a < 0.2
    delta = _overlap(st, a * dq)
    # head-on the gap is linear in the fraction: the new contact's force is
    # exactly the cap (to the rounding of the positions, ~1e-16 / 1e-7)
    np.testing.assert_allclose(K_N * delta ** 1.5, eq.CLOSING_FORCE * R_RES, rtol=1e-6)


def test_no_cap_without_overshoot():
    g0 = 1e-7
    st = _disks([[4.0, 2.0], [5.0 + g0, 2.0]])
    dq = np.zeros((2, 3))
    dq[1, 0] = -(g0 + 0.5 * _d_star())      # closes, but below the cap
    assert eq.closing_fraction(st, dq, K_N, R_RES, wall_y=-5.0) == 1.0
    dq[1, 0] = +3e-6                          # opens
    assert eq.closing_fraction(st, dq, K_N, R_RES, wall_y=-5.0) == 1.0
    # an existing contact (overlap now) is K's business, never capped
    st = _disks([[4.0, 2.0], [5.0 - 1e-4, 2.0]])
    dq[1, 0] = -3e-6
    assert eq.closing_fraction(st, dq, K_N, R_RES, wall_y=-5.0) == 1.0


def test_wall_gap_is_capped_too():
    g0 = 2e-7
    st = _disks([[2.0, 0.5 + g0], [6.0, 3.0]])
    dq = np.zeros((2, 3))
    dq[0, 1] = -5e-6
    a = eq.closing_fraction(st, dq, K_N, R_RES, wall_y=0.0)
    delta = -(st.positions[0, 1] + a * dq[0, 1] - 0.5)
    np.testing.assert_allclose(K_N * delta ** 1.5, eq.CLOSING_FORCE * R_RES, rtol=1e-6)


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "benchmarks"))
from bench_scale import STORED as _BENCH_PACKINGS  # noqa: E402  (make bench's stored packings)

STORED = _BENCH_PACKINGS[1600]


@pytest.mark.skipif(not os.path.exists(STORED), reason="stored N = 1600 packing not present")
def test_n1600_ramp_step_converges_by_newton_alone(tmp_path):
    """Two ramp steps of the stored N = 1600 packing as the ramp makes them
    (scene from the previous equilibrium's data file, Newton first)."""
    from remote_trigger.pywrap.stages.config import RampConfig
    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.stages.common import load_relax_scene, save_equilibrium

    start = STORED
    for k, F_x in enumerate((2.5e-4, 5e-4)):
        cfg = RampConfig(datafile=start, dF_x=2.5e-4, F_x=0.0)
        with Engine() as eng:
            load_relax_scene(eng, cfg, start, F_x, deck="in.ramp_step")
            accept = eq.accept_level(cfg, eng.gather_state())
            r, t_sim, rec = eq.equilibrate(eng, cfg, F_x, newton_first=True)
            prefix = str(tmp_path / f"p{k}")
            save_equilibrium(eng, cfg, F_x, prefix)
        start = prefix + ".data"
        assert r < accept, (k, r, accept)
        assert t_sim == 0.0 and "damped" not in rec.phase, (k, rec.phase)


QUICK_STEP = os.path.join(os.path.dirname(__file__), "..", "data",
                          "quick_N16_mu0.8_step_00007.data")


def test_no_livelock_between_newton_and_damped_chunks():
    """``ensemble --quick``'s N = 16 packing at mu = 0.8, ramp step F_x = 0.07 ->
    0.08: the state is near an unstable equilibrium that damped dynamics
    leave (r grows to ~8, then relaxes; 23 time units). With the closing cap,
    Newton accepted two shortened steps after every damped chunk and pulled
    the state back (r cycling 2.5e-3 -> 1.8e-3 -> 2.5e-3) until max_steps;
    a Newton phase that ends above the acceptance level is now retried only
    once the dynamics are below where it ended."""
    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.jobs.ensemble.config import build_config
    from remote_trigger.pywrap.jobs.paper import ramp_config
    from remote_trigger.pywrap.stages.common import load_relax_scene

    cfg = ramp_config(build_config(quick=True), QUICK_STEP, 0.8).replace(max_steps=100_000)
    with Engine() as eng:
        load_relax_scene(eng, cfg, QUICK_STEP, 0.08, deck="in.ramp_step")
        accept = eq.accept_level(cfg, eng.gather_state())
        r, t_sim, rec = eq.equilibrate(eng, cfg, 0.08, newton_first=True)
    assert r < accept and t_sim < 50.0, (r, t_sim)
