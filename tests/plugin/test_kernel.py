"""The LAMMPS-free contact-law kernel (the code the pair style runs), via ctypes.

Reference values are evaluated by hand from Eq. (3) written in a different
algebraic form: with xi = u t* and t* = mu k_n delta / k_t,
f_t = -k_t delta^{1/2} g(u) xi = -mu f_n u g(u), f_n = k_n delta^{3/2}.
"""
import math

import numpy as np
import pytest

from remote_trigger.pywrap.bindings import kernel

KN, KT, MU = 2.0e5, 2.0e5 * 2.0 / 7.0, 1.0
DELTA = 1.0e-3
FN = 6.324555320336759          # 2e5 * (1e-3)**1.5, by hand
TSTAR = 3.5e-3                  # mu * k_n/k_t * delta = 3.5 * 1e-3


@pytest.mark.parametrize("u, ft_over_fn", [
    (0.0, 0.0),
    (0.5, -0.5 * 1.25),                       # g(0.5) = 1.25
    (0.999, -0.999 * (1 + 0.999 - 0.999**2)),
    (1.0, -1.0),                              # g(1) = 1: Coulomb limit
])
def test_force_law_hand_values(u, ft_over_fn):
    r = kernel.evaluate(KN, KT, MU, DELTA, u * TSTAR)
    assert r["fn"] == pytest.approx(FN, rel=1e-15)
    assert r["ft"] == pytest.approx(ft_over_fn * FN, rel=1e-13, abs=1e-300)
    assert r["u"] == pytest.approx(u, rel=1e-14, abs=0)
    assert not r["sliding"]


@pytest.mark.parametrize("u_trial", [1.0 + 1e-12, 1.5, 40.0])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_sliding_beyond_coulomb_limit_rescales_history(u_trial, sign):
    r = kernel.evaluate(KN, KT, MU, DELTA, sign * u_trial * TSTAR)
    assert r["sliding"]
    assert r["xi"] == pytest.approx(sign * TSTAR, rel=1e-15)
    assert r["u"] == 1.0
    assert r["ft"] == pytest.approx(-sign * MU * FN, rel=1e-14)


@pytest.mark.parametrize("mu", [0.3, 0.8, 1.0, 2.5])
def test_coulomb_limit_and_zero_slope(mu):
    ts = mu * KN * DELTA / KT
    r = kernel.evaluate(KN, KT, mu, DELTA, ts)
    assert abs(r["ft"]) == pytest.approx(mu * r["fn"], rel=1e-14)
    _, _, dft_dxi = kernel.derivatives(KN, KT, mu, DELTA, ts)
    assert dft_dxi == 0.0
    # one-sided difference from below: slope -> 0 linearly in h
    for h in (1e-4 * ts, 1e-6 * ts):
        lo = kernel.evaluate(KN, KT, mu, DELTA, ts - h)["ft"]
        slope = (r["ft"] - lo) / h
        assert abs(slope) < 5.0 * KT * math.sqrt(DELTA) * h / ts


def test_no_tangential_force_without_friction_or_stiffness():
    for kt, mu in [(KT, 0.0), (0.0, 1.0)]:
        r = kernel.evaluate(KN, kt, mu, DELTA, 2e-3)
        assert r["ft"] == 0.0 and r["xi"] == 0.0
        assert r["fn"] == pytest.approx(FN, rel=1e-15)
        assert kernel.derivatives(KN, kt, mu, DELTA, 2e-3)[1:] == (0.0, 0.0)


@pytest.mark.parametrize("mu, delta", [(5e-324, 1e-3), (1e-300, 1e-30), (1e-10, 5e-324)])
def test_underflowing_sliding_length_means_no_friction(mu, delta):
    # t* = mu k_n delta / k_t underflows to 0: no tangential force, never 0/0
    r = kernel.evaluate(KN, KT, mu, delta, 1e-3)
    assert r["ft"] == 0.0 and r["xi"] == 0.0 and r["u"] == 0.0
    assert all(np.isfinite(kernel.derivatives(KN, KT, mu, delta, 1e-3)))


def test_force_continuous_at_zero_overlap():
    for d in (1e-6, 1e-10, 1e-14):
        r = kernel.evaluate(KN, KT, MU, d, 0.5 * MU * KN * d / KT)
        assert r["fn"] == pytest.approx(KN * d**1.5, rel=1e-14)
        assert abs(r["ft"]) <= MU * r["fn"] * (1 + 1e-14)
    out = kernel.pair_force(KN, KT, MU, 1.2, 0.0, 0.5, 0.7, 1e-3)   # delta = 0
    assert np.all(out == 0.0)


def _best_fd(f, x, scale):
    """Central differences over a step sweep; returns (best estimate list)."""
    return [(f(x + h) - f(x - h)) / (2 * h) for h in scale * np.logspace(-2, -7, 11)]


@pytest.mark.parametrize("u", [0.0, 0.1, 0.5, 0.9, 0.999, -0.7])
@pytest.mark.parametrize("delta", [1e-5, 1e-3, 2e-2])
def test_derivatives_against_finite_differences(u, delta):
    ts = MU * KN * delta / KT
    xi = u * ts
    dfn, dftd, dftx = kernel.derivatives(KN, KT, MU, delta, xi)

    def fn(d):
        return kernel.evaluate(KN, KT, MU, d, xi)["fn"]

    def ft_d(d):
        return kernel.evaluate(KN, KT, MU, d, xi)["ft"]

    def ft_x(x):
        return kernel.evaluate(KN, KT, MU, delta, x)["ft"]

    # step sweeps; the best step must agree to 1e-8 relative.  At xi = 0 the
    # law is only C^1 (f_t contains xi |xi|), so central differences
    # converge linearly in h there and 1e-6 is the level reachable.
    tol = 1e-6 if u == 0.0 else 1e-8
    for ana, fd, scale in [(dfn, _best_fd(fn, delta, delta), 1.5 * KN * math.sqrt(delta)),
                           (dftd, _best_fd(ft_d, delta, delta), 1.5 * KN * math.sqrt(delta)),
                           (dftx, _best_fd(ft_x, xi, ts), KT * math.sqrt(delta))]:
        err = min(abs(ana - v) for v in fd) / scale
        assert err < tol, (u, delta, ana, fd)


def _rot(n):
    return np.array([n[1], -n[0]])


def _generalized_force(q, ri, rj, xi0, q0, kn=KN, kt=KT, mu=MU):
    """G of disks i and j after displacing q0 -> q along the update rule.

    q = (x_i, y_i, phi_i, x_j, y_j, phi_j).  xi = xi0 + s(q).(dr_i - dr_j)
    + dphi_i + dphi_j, with s at the displaced positions (what one MD step
    with velocity dq/dt does).
    """
    dq = q - q0
    d = q[:2] - q[3:5]
    s = _rot(d / np.hypot(*d))
    xi = xi0 + s @ (dq[:2] - dq[3:5]) + dq[2] + dq[5]
    gi = kernel.pair_force(kn, kt, mu, d[0], d[1], ri, rj, xi)
    gj = kernel.pair_force(kn, kt, mu, -d[0], -d[1], rj, ri, xi)   # xi_ji = xi_ij
    return np.concatenate([gi, gj])


@pytest.mark.parametrize("seed", range(6))
def test_pair_stiffness_against_finite_differences_along_update_rule(seed):
    rng = np.random.default_rng(seed)
    ri, rj = rng.choice([0.5, 0.7], size=2)
    ang = rng.uniform(0, 2 * np.pi)
    delta = 10 ** rng.uniform(-4, -2)
    rho = ri + rj - delta
    q0 = np.array([3.0, 4.0, 0.0, 3.0 - rho * np.cos(ang), 4.0 - rho * np.sin(ang), 0.0])
    u = [0.0, 0.3, 0.8, 0.97, 1.0, -0.5][seed]
    xi0 = u * MU * KN * delta / KT
    ki = kernel.pair_stiffness(KN, KT, MU, q0[0] - q0[3], q0[1] - q0[4], ri, rj, xi0)
    kj = kernel.pair_stiffness(KN, KT, MU, q0[3] - q0[0], q0[4] - q0[1], rj, ri, xi0)
    kj = kj[:, [3, 4, 5, 0, 1, 2]]                       # reorder to q of (i, j)
    K = np.vstack([ki, kj])
    # rows of j follow from i: force rows negated, torque row equal
    np.testing.assert_allclose(kj[:2], -ki[:2], rtol=1e-13, atol=1e-12 * np.abs(K).max())
    np.testing.assert_allclose(kj[2], ki[2], rtol=1e-13, atol=1e-12 * np.abs(K).max())
    scale = np.abs(K).max()
    best = np.inf
    for h in delta * np.logspace(-2, -6, 9):
        fd = np.empty((6, 6))
        for b in range(6):
            e = np.zeros(6)
            e[b] = h
            fd[:, b] = -(_generalized_force(q0 + e, ri, rj, xi0, q0)
                         - _generalized_force(q0 - e, ri, rj, xi0, q0)) / (2 * h)
        best = min(best, np.abs(fd - K).max() / scale)
    # at xi = 0 and at the cap (u = 1) the law is C^1 but not C^2: the
    # second derivative jumps, and central differences converge only linearly
    assert best < (1e-6 if abs(u) in (0.0, 1.0) else 1e-7), best


@pytest.mark.parametrize("u", [0.0, 0.4, 0.95, -0.99])
def test_wall_stiffness_against_finite_differences(u):
    R, delta = 0.7, 3e-3
    xi0 = u * MU * KN * delta / KT
    K = kernel.wall_stiffness(KN, KT, MU, delta, xi0)

    def G(dq):
        # dq = (dx, dy, dphi): delta decreases with y; xi grows with dx + dphi
        return kernel.wall_force(KN, KT, MU, delta - dq[1], xi0 + dq[0] + dq[2])

    best = np.inf
    for h in delta * np.logspace(-2, -6, 9):
        fd = np.column_stack([-(G(h * e) - G(-h * e)) / (2 * h) for e in np.eye(3)])
        best = min(best, np.abs(fd - K).max() / np.abs(K).max())
    assert best < 1e-7, best
    # the wall is the R_j -> infinity limit of a disk contact
    big = 1e5   # large enough for 1/rho terms to vanish, small enough to keep delta exact
    Kd = kernel.pair_stiffness(KN, KT, MU, 0.0, R + big - delta, R, big, xi0)
    np.testing.assert_allclose(Kd[:, :3], K, rtol=1e-6, atol=1e-6 * np.abs(K).max())
