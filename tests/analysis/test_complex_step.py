"""K against the complex-step derivative of the independent reference force law.

``forcelaw_ref`` recomputes G(q) from the paper's vector formulas (Eqs. 1-3,
14, 31) without the assembly code, analytically continued so that
Im G(q0 + i h e_k) / h is dG/dq_k to rounding (h = 1e-30, no cancellation).
"""
import numpy as np
import pytest

from remote_trigger.analysis.forcelaw_ref import (
    ReferenceSystem, complex_step_jacobian, reference_forces)
from remote_trigger.analysis.stability.jacobian import (
    contact_terms, displaced_state, find_rattlers, generalized_forces, stiffness_matrix)
from remote_trigger.analysis.state.state import ContactParams, build_state

from .builders import KN, KT, random_packing


def reference_K(state):
    ref = ReferenceSystem.from_state(state)
    return -complex_step_jacobian(lambda q: reference_forces(ref, q), ref.q0)


def rel_err(A, B):
    return np.linalg.norm(A - B) / np.linalg.norm(B)


@pytest.mark.parametrize("seed", range(6))
def test_K_matches_complex_step(seed):
    st = random_packing(seed, cap_fraction=0.6)
    t = contact_terms(st.params, *_deltas(st))
    # the configuration exercises every branch
    assert np.any(t.u == 1.0) and np.any(t.capped) and np.any(t.u == 0.0)
    assert np.any((t.u > 0.99) & (t.u < 1.0)) and st.wall_index.size > 0
    K = stiffness_matrix(st).toarray()
    Kref = reference_K(st)
    assert rel_err(K, Kref) < 1e-12
    # entry-wise, relative to the largest entry of each row
    scale = np.abs(Kref).max(axis=1, keepdims=True)
    assert np.all(np.abs(K - Kref) <= 1e-10 * scale)


def _deltas(st):
    d = st.separation(st.contact_i, st.contact_j)
    delta = st.radii[st.contact_i] + st.radii[st.contact_j] - np.hypot(d[:, 0], d[:, 1])
    return delta, st.contact_xi


@pytest.mark.parametrize("kt,mu", [(KT, 0.0), (0.0, 1.0), (KT, 0.3)])
def test_frictionless_limits_and_other_mu(kt, mu):
    st = random_packing(3, kt=kt, mu=mu)
    K = stiffness_matrix(st).toarray()
    assert rel_err(K, reference_K(st)) < 1e-12
    if mu == 0.0 or kt == 0.0:
        # no tangential force: K is symmetric and the phi columns vanish
        assert np.abs(K - K.T).max() <= 1e-12 * np.abs(K).max()
        assert np.all(K[:, 2::3] == 0.0)


def test_forces_match_reference():
    st = random_packing(4, cap_fraction=0.5)
    ref = ReferenceSystem.from_state(st)
    G = generalized_forces(st, external=False)
    Gref = reference_forces(ref, ref.q0)
    assert np.abs(G - Gref).max() <= 1e-12 * np.abs(Gref).max()


def test_antisymmetric_part_vanishes_with_tangential_displacements():
    """K - K^T is linear in the xi's (for small xi) and exactly zero at xi = 0."""
    st = random_packing(5, cap_fraction=0.0, xi_scale=0.5)
    norms = []
    for a in (1.0, 0.1, 0.01, 0.001):
        K = stiffness_matrix(st.with_xi(st.contact_xi * a, st.wall_xi * a)).toarray()
        norms.append(np.linalg.norm(K - K.T) / np.linalg.norm(K))
    norms = np.array(norms)
    ratios = norms[:-1] / norms[1:]
    assert np.all(ratios > 8.0) and np.all(ratios < 12.5), norms
    K0 = stiffness_matrix(st.with_xi(st.contact_xi * 0, st.wall_xi * 0)).toarray()
    assert np.abs(K0 - K0.T).max() <= 4 * np.finfo(float).eps * np.abs(K0).max()
    assert norms[0] > 1e-3                     # the xi's used do break the symmetry


def test_newton_residual_model_is_second_order():
    """G(q + dq) with the history rule = G(q) - K dq + O(dq^2) (for Newton polishing)."""
    st = random_packing(2, cap_fraction=0.0, xi_scale=0.5)
    K = stiffness_matrix(st)
    G0 = generalized_forces(st)
    rng = np.random.default_rng(0)
    d = rng.standard_normal(st.ndof)
    errs = []
    for h in (1e-6, 1e-7):
        G1 = generalized_forces(st, dq=h * d)
        errs.append(np.linalg.norm(G1 - (G0 - K @ (h * d))))
    assert errs[1] < errs[0] / 50.0, errs
    moved = displaced_state(st, 1e-6 * d)
    assert moved.n_contacts == st.n_contacts
    with pytest.raises(ValueError, match="shape"):
        displaced_state(st, np.zeros(5))


def test_rattlers_are_removed_iteratively():
    """A chain hanging from the packing is peeled off one disk per round."""
    params = ContactParams(KN, KT, 1.0)
    # a triangle of three disks on the wall (each has 2+ contacts), and a chain
    # of two disks sticking out from the top: the tip has 1 contact, and once it
    # is removed its neighbour has 1 as well.
    pos = np.array([[2.0, 0.499], [2.999, 0.499], [2.5, 1.36], [2.5, 2.358], [2.5, 3.356]])
    st = build_state(ids=[1, 2, 3, 4, 5], positions=pos, radii=[0.5] * 5, masses=[1.0] * 5,
                     box_lo=[0, -1], box_hi=[10, 10], params=params, wall_y=0.0)
    assert st.contact_counts().tolist() == [3, 3, 3, 2, 1]
    rat = find_rattlers(st)
    assert sorted(rat.ids.tolist()) == [4, 5] and rat.rounds == 2
    assert rat.keep_dofs.tolist() == list(range(9))
    rat3 = find_rattlers(st, min_contacts=3)          # frictionless criterion: all go
    assert rat3.ids.size == 5
    with pytest.raises(ValueError, match="min_contacts"):
        find_rattlers(st, min_contacts=-1)
