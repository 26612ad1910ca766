"""The 3D contact-law kernel (``mindlin_smooth_kernel_3d.h``) via ctypes.

Reference values are written in the algebraic form of test_kernel.py:
with |t| = u t*, F_t = -k_t delta^{1/2} g(u) t = -mu f_n u g(u) t/|t|.
"""
import math

import numpy as np
import pytest

from remote_trigger.pywrap.bindings import kernel

KN, KT, MU = 2.0e5, 2.0e5 * 2.0 / 7.0, 1.0
DELTA = 1.0e-3
FN = 6.324555320336759          # 2e5 * (1e-3)**1.5, by hand
TSTAR = 3.5e-3                  # mu * k_n/k_t * delta


def unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def tangent_pair(n):
    """Two unit vectors spanning the plane normal to n."""
    a = unit(np.cross(n, [0.3, -0.2, 0.9]))
    return a, np.cross(n, a)


N0 = unit([0.3, -0.5, 0.8])
E1, E2 = tangent_pair(N0)


@pytest.mark.parametrize("u", [0.0, 0.5, 0.999, 1.0])
@pytest.mark.parametrize("angle", [0.0, 1.1, 2.7])
def test_force_law_hand_values(u, angle):
    """|F_t| = mu f_n u g(u) along -t, for t in any direction of the plane."""
    d = math.cos(angle) * E1 + math.sin(angle) * E2
    r = kernel.evaluate3(KN, KT, MU, DELTA, u * TSTAR * d)
    g = 1.0 + u - u * u
    assert r["fn"] == pytest.approx(FN, rel=1e-15)
    np.testing.assert_allclose(r["ft"], -MU * FN * u * g * d, rtol=0, atol=1e-13 * FN)
    assert r["u"] == pytest.approx(u, rel=1e-14, abs=0)
    if u < 1.0:        # at u = 1, |t| rounds to either side of t*
        assert not r["sliding"]
        np.testing.assert_array_equal(r["t"], u * TSTAR * d)


@pytest.mark.parametrize("u_trial", [1.0 + 1e-12, 1.5, 40.0])
def test_sliding_rescales_t_to_tstar_along_its_direction(u_trial):
    d = unit(0.6 * E1 - 0.8 * E2)
    r = kernel.evaluate3(KN, KT, MU, DELTA, u_trial * TSTAR * d)
    assert r["sliding"] and r["u"] == 1.0
    np.testing.assert_allclose(r["t"], TSTAR * d, rtol=0, atol=1e-15 * TSTAR)
    np.testing.assert_allclose(r["ft"], -MU * FN * d, rtol=0, atol=1e-14 * FN)
    assert np.linalg.norm(r["ft"]) == pytest.approx(MU * FN, rel=1e-14)


@pytest.mark.parametrize("mu", [0.3, 0.8, 1.0, 2.5])
def test_coulomb_limit_reached_with_zero_slope(mu):
    """|F_t| = mu |F_n| at |t| = t*, and d|F_t|/d|t| -> 0 there (one-sided)."""
    ts = mu * KN * DELTA / KT
    d = unit(E1 + 0.3 * E2)
    top = np.linalg.norm(kernel.evaluate3(KN, KT, mu, DELTA, ts * d)["ft"])
    assert top == pytest.approx(mu * FN, rel=1e-14)
    for h in (1e-4 * ts, 1e-6 * ts):
        lo = np.linalg.norm(kernel.evaluate3(KN, KT, mu, DELTA, (ts - h) * d)["ft"])
        slope = (top - lo) / h
        assert abs(slope) < 5.0 * KT * math.sqrt(DELTA) * h / ts


def test_no_tangential_force_without_friction_or_stiffness():
    for kt, mu in [(KT, 0.0), (0.0, 1.0)]:
        r = kernel.evaluate3(KN, kt, mu, DELTA, 2e-3 * E1)
        assert np.all(r["ft"] == 0.0) and np.all(r["t"] == 0.0)
        assert r["fn"] == pytest.approx(FN, rel=1e-15)


def test_projection_keeps_length_and_removes_normal_part():
    """History rule: stored t off the plane is projected and rescaled."""
    stored = 1e-3 * unit(E1 + 0.4 * N0)
    r = kernel.step3(KN, KT, MU, DELTA, N0, stored, np.zeros(3), np.zeros(3), 1e-3)
    assert abs(r["t"] @ N0) < 1e-18
    assert np.linalg.norm(r["t"]) == pytest.approx(1e-3, rel=1e-15)
    np.testing.assert_allclose(unit(r["t"]), E1, atol=1e-15)


def test_slip_velocity_of_the_contact_point():
    """slip = P[(v_i - v_j) - (R_i om_i + R_j om_j) x n], by hand for one case:
    n = z, v_i - v_j = (1, 2, 3), w = (0, 0, 5): w x n = 0, slip = (1, 2, 0);
    w = (4, 0, 0): w x z = (0, -4, 0), slip = (1, 6, 0)."""
    z = np.array([0.0, 0.0, 1.0])
    r = kernel.step3(KN, KT, MU, DELTA, z, np.zeros(3), [1.0, 2.0, 3.0], [0.0, 0.0, 5.0], 1e-4)
    np.testing.assert_array_equal(r["slip"], [1.0, 2.0, 0.0])
    r = kernel.step3(KN, KT, MU, DELTA, z, np.zeros(3), [1.0, 2.0, 3.0], [4.0, 0.0, 0.0], 1e-4)
    np.testing.assert_array_equal(r["slip"], [1.0, 6.0, 0.0])
    np.testing.assert_allclose(r["t"], [1e-4, 6e-4, 0.0], rtol=1e-15)


def random_rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q @ np.diag(np.sign(np.diag(r)))
    return q if np.linalg.det(q) > 0 else -q


@pytest.mark.parametrize("seed", range(5))
def test_rotational_invariance(seed):
    """A contact rotated rigidly gives the rotated t, slip, force and torque."""
    rng = np.random.default_rng(seed)
    q = random_rotation(rng)
    d = rng.normal(size=3)
    ri, rj = 0.5, 0.7
    d *= (ri + rj - 2e-3) / np.linalg.norm(d)
    n = d / np.linalg.norm(d)
    e1, e2 = tangent_pair(n)
    stored = 2e-3 * (rng.normal() * e1 + rng.normal() * e2) + 1e-4 * n   # a turned contact
    dv, w = rng.normal(size=3), rng.normal(size=3)
    for u_scale in (1.0, 5.0):                 # below and beyond the Coulomb limit
        a = kernel.step3(KN, KT, MU, 2e-3, n, u_scale * stored, dv, w, 1e-3)
        b = kernel.step3(KN, KT, MU, 2e-3, q @ n, q @ (u_scale * stored), q @ dv, q @ w, 1e-3)
        for key in ("t", "ft", "slip"):
            scale = np.abs(a[key]).max()
            np.testing.assert_allclose(b[key], q @ a[key], rtol=0, atol=1e-14 * scale)
        assert a["sliding"] == b["sliding"] == (u_scale > 1.0)
        # from positions: |q d| rounds differently from |d|, and the overlap
        # delta = R_i + R_j - |d| carries that round-off amplified by
        # (R_i + R_j)/delta = 600
        fa = kernel.pair_force3(KN, KT, MU, d, ri, rj, u_scale * stored)
        fb = kernel.pair_force3(KN, KT, MU, q @ d, ri, rj, q @ (u_scale * stored))
        for sl in (slice(0, 3), slice(3, 6)):
            np.testing.assert_allclose(fb[sl], q @ fa[sl], rtol=0,
                                       atol=1e-14 * 600 * np.abs(fa[sl]).max())


@pytest.mark.parametrize("xi", [0.0, 1.3e-3, -2.9e-3, 8e-3])
def test_planar_contact_reduces_to_the_2d_law(xi):
    """n, t in the xy plane, t = xi s with s = (n_y, -n_x): the 2D kernel's
    (F_x, F_y, T/R) to round-off, and F_z = T_x = T_y = 0 exactly."""
    dx, dy, ri, rj = 0.71, -0.93, 0.5, 0.7
    r = math.hypot(dx, dy)
    dx, dy = dx * (ri + rj - 1.5e-3) / r, dy * (ri + rj - 1.5e-3) / r
    r = math.hypot(dx, dy)
    s = np.array([dy / r, -dx / r, 0.0])
    f2 = kernel.pair_force(KN, KT, MU, dx, dy, ri, rj, xi)
    f3 = kernel.pair_force3(KN, KT, MU, [dx, dy, 0.0], ri, rj, xi * s)
    scale = np.abs(f2).max()
    np.testing.assert_allclose(f3[:2], f2[:2], rtol=0, atol=1e-14 * scale)
    assert f3[5] / ri == pytest.approx(f2[2], rel=1e-13, abs=1e-14 * scale)
    assert f3[2] == 0.0 and f3[3] == 0.0 and f3[4] == 0.0


def test_planar_step_reduces_to_the_2d_increment():
    """In-plane slip and spin about z advance t = xi s by
    dt [s.(v_i - v_j) + R_i om_i + R_j om_j] (the 2D rule), after the normal
    turned: the projection carries xi s_old to xi s_new."""
    ang_old, ang_new = 0.4, 0.43
    n_old = np.array([math.cos(ang_old), math.sin(ang_old), 0.0])
    n_new = np.array([math.cos(ang_new), math.sin(ang_new), 0.0])
    s = lambda n: np.array([n[1], -n[0], 0.0])        # noqa: E731
    xi, dt = 1.1e-3, 1e-3
    dv = np.array([0.3, -0.7, 0.0])
    om_i, om_j, ri, rj = 0.9, -0.2, 0.5, 0.7
    w = np.array([0.0, 0.0, ri * om_i + rj * om_j])
    r = kernel.step3(KN, KT, MU, 2e-3, n_new, xi * s(n_old), dv, w, dt)
    xi_2d = xi + dt * (s(n_new) @ dv + ri * om_i + rj * om_j)
    np.testing.assert_allclose(r["t"], xi_2d * s(n_new), rtol=0, atol=1e-16)
    ref = kernel.evaluate(KN, KT, MU, 2e-3, xi_2d)
    np.testing.assert_allclose(r["ft"], ref["ft"] * s(n_new), rtol=0,
                               atol=1e-14 * abs(ref["ft"]))


def test_mirror_symmetry_bitwise():
    """Side j (n, v_i - v_j and t negated) gets exactly -t and -F."""
    rng = np.random.default_rng(3)
    n = unit(rng.normal(size=3))
    stored = 1e-3 * unit(np.cross(n, rng.normal(size=3))) + 1e-5 * n
    dv, w = rng.normal(size=3), rng.normal(size=3)
    for scale in (1.0, 9.0):
        a = kernel.step3(KN, KT, MU, 2e-3, n, scale * stored, dv, w, 1e-3)
        b = kernel.step3(KN, KT, MU, 2e-3, -n, -scale * stored, -dv, w, 1e-3)
        np.testing.assert_array_equal(b["t"], -a["t"])
        np.testing.assert_array_equal(b["ft"], -a["ft"])
        np.testing.assert_array_equal(b["slip"], -a["slip"])
