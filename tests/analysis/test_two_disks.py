"""The two-disk system of the paper's Appendix C, entry by entry, by hand.

The expected 6 x 6 K is built here without the analyzer: derivatives are
written out by hand in the frame where n = e_x (then s = (0, -1)), using the
force law expanded in powers of delta,

    f_t = -k_t [d^{1/2} xi + d^{-1/2} xi |xi| / c - d^{-3/2} xi^3 / c^2],  c = mu k_n / k_t,

and rotated to the actual contact direction: K = T K' T^T with
T = diag(Q, 1, Q, 1). A capped contact has f_t = -sign(xi) mu k_n d^{3/2}.
"""
import numpy as np
import pytest

from remote_trigger.analysis.stability.jacobian import stiffness_matrix
from remote_trigger.analysis.state.state import ContactParams, build_state

KN, KT, MU = 2.0e5, 2.0e5 * 2 / 7, 0.8


def hand_partials(delta, xi, kn=KN, kt=KT, mu=MU):
    """(f_n, f_n', f_t, df_t/ddelta, df_t/dxi), expanded form / capped form."""
    c = mu * kn / kt
    fn = kn * delta**1.5
    dfn = 1.5 * kn * delta**0.5
    if abs(xi) > c * delta:                          # sliding: capped
        sg = np.sign(xi)
        return fn, dfn, -sg * mu * kn * delta**1.5, -1.5 * sg * mu * kn * delta**0.5, 0.0
    a = abs(xi)
    ft = -kt * (delta**0.5 * xi + delta**-0.5 * xi * a / c - delta**-1.5 * xi**3 / c**2)
    ftx = -kt * (delta**0.5 + 2 * delta**-0.5 * a / c - 3 * delta**-1.5 * xi**2 / c**2)
    ftd = -kt * (0.5 * delta**-0.5 * xi - 0.5 * delta**-1.5 * xi * a / c
                 + 1.5 * delta**-2.5 * xi**3 / c**2)
    return fn, dfn, ft, ftd, ftx


def hand_K(delta, rho, xi, angle):
    """K = -dG/dq (6 x 6) for disks (1, 2), n = (cos a, sin a) from 2 to 1."""
    fn, dfn, ft, ftd, ftx = hand_partials(delta, xi)
    # derivatives of G_1 = (F_1x, F_1y, T_1/R_1) in the frame n = e_x, s = (0, -1);
    # columns (x1, y1, phi1, x2, y2, phi2)
    dF1 = np.array([
        [-dfn, ft / rho, 0.0],
        [ftd, fn / rho + ftx, -ftx],
        [-ftd, -ftx, ftx],
    ])
    D = np.zeros((6, 6))
    D[0:3, 0:2] = dF1[:, 0:2]
    D[0:3, 3:5] = -dF1[:, 0:2]          # r_2 enters through r_1 - r_2
    D[0:3, 2] = dF1[:, 2]
    D[0:3, 5] = dF1[:, 2]               # phi_1 and phi_2 enter xi alike
    D[3:5] = -D[0:2]                    # F_2 = -F_1
    D[5] = D[2]                         # T_2/R_2 = f_t = T_1/R_1
    c, s = np.cos(angle), np.sin(angle)
    Q = np.array([[c, -s], [s, c]])
    T = np.zeros((6, 6))
    T[0:2, 0:2] = Q
    T[2, 2] = 1.0
    T[3:5, 3:5] = Q
    T[5, 5] = 1.0
    return -(T @ D @ T.T)


def two_disk_state(angle, delta, xi, r1=0.5, r2=0.7, ids=(1, 2)):
    rho = r1 + r2 - delta
    x1 = np.array([5.0, 6.0])
    x2 = x1 - rho * np.array([np.cos(angle), np.sin(angle)])
    st = build_state(ids=list(ids), positions=[x1, x2], radii=[r1, r2], masses=[1.0, 1.0],
                     box_lo=[0.0, -1.0], box_hi=[20.0, 20.0],
                     params=ContactParams(KN, KT, MU), wall_y=None)
    assert st.n_contacts == 1
    # the state orders disks by id; xi is defined from the lower id's side, and
    # xi_ji = xi_ij, so the same xi describes the contact from either side
    return st.with_xi([xi]), rho


@pytest.mark.parametrize("angle", [0.0, 0.37, 2.1, -2.9])
@pytest.mark.parametrize("u", [0.0, 0.3, -0.55, 0.999, 1.0, -1.0, 1.4])
def test_two_disk_K_every_entry(angle, u):
    delta = 1.3e-3
    ts = MU * KN * delta / KT
    st, rho = two_disk_state(angle, delta, u * ts)
    K = stiffness_matrix(st).toarray()
    exp = hand_K(delta, rho, u * ts, angle)
    scale = np.abs(exp).max()
    for a in range(6):
        for b in range(6):
            assert abs(K[a, b] - exp[a, b]) <= 1e-12 * scale, (a, b, K[a, b], exp[a, b])


def test_two_disk_order_of_ids_does_not_matter():
    """Disk 1 with the larger id: rows/columns swap, xi is unchanged (xi_ji = xi_ij)."""
    delta, u, angle = 2e-3, 0.6, 0.8
    ts = MU * KN * delta / KT
    st, rho = two_disk_state(angle, delta, u * ts)
    st2, _ = two_disk_state(angle, delta, u * ts, ids=(7, 3))
    # in st2 the disk at x1 has id 7 > 3, so it is index 1
    perm = [3, 4, 5, 0, 1, 2]
    K1 = stiffness_matrix(st).toarray()
    K2 = stiffness_matrix(st2).toarray()
    np.testing.assert_allclose(K2, K1[np.ix_(perm, perm)], rtol=0, atol=1e-12 * np.abs(K1).max())


def test_disk_on_wall_by_hand():
    """Wall contact: n = +y, s = +x; delta = R - (y - y_w); xi changes by dx + dphi."""
    R, yw = 0.7, 0.25
    for u in (0.0, 0.4, -0.8, 1.0, 1.2):
        delta = 8e-4
        ts = MU * KN * delta / KT
        st = build_state(ids=[4], positions=[[3.0, yw + R - delta]], radii=[R], masses=[1.0],
                         box_lo=[0.0, -1.0], box_hi=[10.0, 10.0],
                         params=ContactParams(KN, KT, MU), wall_y=yw)
        st = st.with_xi(wall_xi=[u * ts])
        fn, dfn, ft, ftd, ftx = hand_partials(delta, u * ts)
        # G = (f_t, f_n, f_t); d delta/dy = -1; d xi/dx = d xi/dphi = 1
        dG = np.array([[ftx, -ftd, ftx], [0.0, -dfn, 0.0], [ftx, -ftd, ftx]])
        K = stiffness_matrix(st).toarray()
        np.testing.assert_allclose(K, -dG, rtol=0, atol=1e-12 * np.abs(dG).max())


def test_capped_and_free_branches_meet_at_the_cap():
    """At u = 1 the hand formulas of both branches coincide (C^1 smoothing)."""
    delta = 1e-3
    ts = MU * KN * delta / KT
    below = hand_partials(delta, ts * (1 - 1e-12))
    above = hand_partials(delta, ts * (1 + 1e-12))
    np.testing.assert_allclose(below[2:4], above[2:4], rtol=1e-9)
    assert abs(below[4]) < 1e-8 * KT * delta**0.5 and above[4] == 0.0
