"""Per-contact blocks of the vectorized K against the C++ kernel the plugin runs."""
import numpy as np

from remote_trigger.analysis.stability.jacobian import (
    contact_blocks, contact_terms, wall_blocks, wall_terms)
from remote_trigger.pywrap.bindings import kernel

from .builders import random_packing


def test_pair_blocks_match_kernel():
    st = random_packing(8, cap_fraction=0.6)
    B, dofs = contact_blocks(st)
    p = st.params
    d = st.separation(st.contact_i, st.contact_j)
    worst = 0.0
    for c in range(st.n_contacts):
        ri, rj = st.radii[st.contact_i[c]], st.radii[st.contact_j[c]]
        Kc = kernel.pair_stiffness(p.k_n, p.k_t, p.mu, d[c, 0], d[c, 1], ri, rj,
                                   st.contact_xi[c])
        worst = max(worst, np.abs(B[c, :3, :] - Kc).max() / np.abs(Kc).max())
        # rows of j: minus the force rows of i, plus the torque row of i
        Kj = kernel.pair_stiffness(p.k_n, p.k_t, p.mu, -d[c, 0], -d[c, 1], rj, ri,
                                   st.contact_xi[c])
        perm = [3, 4, 5, 0, 1, 2]
        worst = max(worst, np.abs(B[c, 3:, :][:, perm] - Kj).max() / np.abs(Kj).max())
    assert worst < 1e-13
    assert dofs.shape == (st.n_contacts, 6)


def test_wall_blocks_and_terms_match_kernel():
    st = random_packing(9, cap_fraction=0.8)
    B, _ = wall_blocks(st)
    p = st.params
    t = wall_terms(st)
    for w in range(st.wall_index.size):
        Kw = kernel.wall_stiffness(p.k_n, p.k_t, p.mu, st.wall_delta[w], st.wall_xi[w])
        np.testing.assert_allclose(B[w], Kw, rtol=0, atol=1e-13 * np.abs(Kw).max())
        ev = kernel.evaluate(p.k_n, p.k_t, p.mu, st.wall_delta[w], st.wall_xi[w])
        assert ev["sliding"] == bool(t.capped[w])
        np.testing.assert_allclose([t.fn[w], t.ft[w], t.xi[w], t.u[w]],
                                   [ev["fn"], ev["ft"], ev["xi"], ev["u"]], rtol=1e-14,
                                   atol=1e-300)


def test_contact_terms_match_kernel_derivatives():
    rng = np.random.default_rng(1)
    p = random_packing(0).params
    delta = 10 ** rng.uniform(-5, -1.5, 300)
    ts = p.mu * p.k_n * delta / p.k_t
    u = rng.choice([0.0, 0.2, 0.7, 0.9999, 1.0, 1.3], 300) * rng.choice([-1, 1], 300)
    t = contact_terms(p, delta, u * ts)
    for k in range(300):
        d = kernel.derivatives(p.k_n, p.k_t, p.mu, delta[k], u[k] * ts[k])
        np.testing.assert_allclose([t.dfn[k], t.dft_ddelta[k], t.dft_dxi[k]], d,
                                   rtol=1e-13, atol=1e-13 * abs(d[0]))
