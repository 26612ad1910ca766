"""The 3D stiffness matrix (``jacobian3d``) against independent oracles.

* the complex step of the reference force law ``forcelaw_ref3d`` (written
  from the vector formulas, analytic along the complex step, h = 1e-30);
* the 2D Jacobian on a planar configuration (itself tested against LAMMPS);
* identities: rotating the contact rotates K, Newton's third law, rigid
  translations, free rolling and spin about n, symmetry without history.
"""
import numpy as np
import pytest

from remote_trigger.analysis.forcelaw_ref import complex_step_jacobian
from remote_trigger.analysis.forcelaw_ref3d import ReferenceSystem3D, reference_forces3d
from remote_trigger.analysis.stability.exceptional import classify_spectrum
from remote_trigger.analysis.stability.jacobian import remove_dofs, stiffness_matrix
from remote_trigger.analysis.stability.jacobian3d import (
    contact_blocks3d, contact_terms3d, find_rattlers3d, generalized_forces3d,
    stiffness_matrix3d, wall_blocks3d)
from remote_trigger.analysis.state.state import ContactParams
from remote_trigger.analysis.state.state3d import build_state3d, plane_wall

from .builders import KN, KT, random_packing
from .builders3d import random_packing3d, tangent_t
from remote_trigger.analysis.stability.decision import Decision

EPS = np.finfo(float).eps


def reference_K(state):
    ref = ReferenceSystem3D.from_state(state)
    return -complex_step_jacobian(lambda q: reference_forces3d(ref, q), ref.q0)


def rel_err(A, B):
    return np.linalg.norm(A - B) / np.linalg.norm(B)


def _u(st):
    d = st.separation(st.contact_i, st.contact_j)
    delta = st.radii[st.contact_i] + st.radii[st.contact_j] - np.linalg.norm(d, axis=1)
    return contact_terms3d(st.params, delta, st.contact_t)


@pytest.mark.parametrize("seed", range(4))
def test_K_matches_complex_step(seed):
    st = random_packing3d(seed, cap_fraction=0.6)
    t = _u(st)
    # every branch: zero history, below the cap, at it, just below, beyond it
    assert np.any(t.u == 0.0) and np.any(t.capped) and np.any(t.u == 1.0)
    assert np.any((t.u > 0.99) & (t.u < 1.0)) and st.wall_index.size > 0
    K = stiffness_matrix3d(st).toarray()
    Kref = reference_K(st)
    assert rel_err(K, Kref) < 1e-13
    scale = np.abs(Kref).max(axis=1, keepdims=True)
    assert np.all(np.abs(K - Kref) <= 1e-12 * scale)


@pytest.mark.parametrize("kt,mu", [(KT, 0.0), (0.0, 1.0), (KT, 0.3)])
def test_frictionless_limits_and_other_mu(kt, mu):
    st = random_packing3d(2, kt=kt, mu=mu)
    K = stiffness_matrix3d(st).toarray()
    assert rel_err(K, reference_K(st)) < 1e-13
    if mu == 0.0 or kt == 0.0:
        assert np.abs(K - K.T).max() <= 1e-12 * np.abs(K).max()
        rot = np.nonzero(np.arange(K.shape[0]) % 6 >= 3)[0]
        assert np.all(K[:, rot] == 0.0) and np.all(K[rot, :] == 0.0)


def test_symmetric_without_history_and_not_with_it():
    st = random_packing3d(5, cap_fraction=0.0, t_scale=0.5)
    K0 = stiffness_matrix3d(st.with_t(st.contact_t * 0, st.wall_t * 0)).toarray()
    assert np.abs(K0 - K0.T).max() <= 8 * EPS * np.abs(K0).max()
    norms = []
    for a in (1.0, 0.1, 0.01):
        K = stiffness_matrix3d(st.with_t(st.contact_t * a, st.wall_t * a)).toarray()
        norms.append(np.linalg.norm(K - K.T) / np.linalg.norm(K))
    assert norms[0] > 1e-3 and 8 < norms[0] / norms[1] < 12.5 and 8 < norms[1] / norms[2] < 12.5


def test_forces_match_reference():
    st = random_packing3d(4, cap_fraction=0.5)
    ref = ReferenceSystem3D.from_state(st)
    G = generalized_forces3d(st, external=False)
    Gref = reference_forces3d(ref, ref.q0)
    assert np.abs(G - Gref).max() <= 1e-14 * np.abs(Gref).max()


def _rotation(rng):
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return Q * np.sign(np.linalg.det(Q))


@pytest.mark.parametrize("u", [0.0, 0.4, 1.0, 1.3])
def test_rotating_the_contact_rotates_K(u):
    """Two spheres and a wall-free contact, then the same rotated by Q: K -> Qb K Qb^T."""
    rng = np.random.default_rng(7)
    p = ContactParams(KN, KT, 1.0)

    def pair_state(pos, t):
        return build_state3d(ids=[1, 2], positions=pos, radii=[0.5, 0.7], masses=[1.0, 1.0],
                             box_lo=[-10] * 3, box_hi=[10] * 3, params=p,
                             periodic=(False,) * 3, pairs=[[1, 2]], pair_t=[t])

    pos = np.array([[0.1, -0.2, 0.3], [0.5, 0.6, -0.4]])
    pos[1] = pos[0] + 1.17 * (pos[1] - pos[0]) / np.linalg.norm(pos[1] - pos[0])
    n = (pos[0] - pos[1]) / np.linalg.norm(pos[0] - pos[1])
    ts = KN * (1.2 - 1.17) / KT
    t = tangent_t(rng, n[None], [u * ts])[0]
    K = stiffness_matrix3d(pair_state(pos, t)).toarray()
    for _ in range(3):
        Q = _rotation(rng)
        Kq = stiffness_matrix3d(pair_state(pos @ Q.T, Q @ t)).toarray()
        Qb = np.kron(np.eye(4), Q)
        assert np.abs(Kq - Qb @ K @ Qb.T).max() <= 1e-13 * np.abs(K).max()


def test_newton_third_law_and_rigid_translation():
    """Without walls: the force rows sum to zero and a rigid translation costs nothing."""
    st = random_packing3d(1, cap_fraction=0.5)
    K = stiffness_matrix3d(st, wall=False).toarray()
    scale = np.abs(K).max()
    for c in range(3):
        assert np.abs(K[c::6].sum(axis=0)).max() <= 1e-11 * scale
        v = np.zeros(st.ndof)
        v[c::6] = 1.0
        assert np.abs(K @ v).max() <= 1e-11 * scale


def test_rolling_and_spin_about_the_normal_are_free():
    """Per contact: dphi_i = -dphi_j (rolling) and dphi_i, dphi_j along n cost nothing."""
    st = random_packing3d(3, cap_fraction=0.5)
    B, _ = contact_blocks3d(st)
    d = st.separation(st.contact_i, st.contact_j)
    n = d / np.linalg.norm(d, axis=1)[:, None]
    rng = np.random.default_rng(0)
    roll = np.zeros((st.n_contacts, 12))
    roll[:, 3:6] = rng.normal(size=(st.n_contacts, 3))
    roll[:, 9:12] = -roll[:, 3:6]
    spin = np.zeros((st.n_contacts, 12))
    spin[:, 3:6] = n * rng.normal(size=(st.n_contacts, 1))
    spin[:, 9:12] = n * rng.normal(size=(st.n_contacts, 1))
    scale = np.abs(B).max()
    assert np.abs(np.einsum("cab,cb->ca", B, roll)).max() <= 1e-11 * scale
    assert np.abs(np.einsum("cab,cb->ca", B, spin)).max() <= 1e-11 * scale
    W, _ = wall_blocks3d(st)
    wspin = np.zeros((W.shape[0], 6))
    wspin[:, 3:6] = st.wall_normal
    assert np.abs(np.einsum("cab,cb->ca", W, wspin)).max() <= 1e-11 * scale


def _lift(st2, z=0.3):
    """A 2D State as spheres in the plane z = const, t = xi s, wall yplane lo."""
    n2 = st2.n
    pos = np.column_stack([st2.positions, np.full(n2, z)])
    d = st2.separation(st2.contact_i, st2.contact_j)
    nrm = d / np.hypot(d[:, 0], d[:, 1])[:, None]
    t = np.column_stack([nrm[:, 1], -nrm[:, 0], np.zeros(st2.n_contacts)]) * \
        st2.contact_xi[:, None]
    nw, off = plane_wall("y", "lo", st2.wall_y)
    walls = [(st2.ids[k], nw, off) for k in st2.wall_index]
    wt = np.column_stack([st2.wall_xi, np.zeros((st2.wall_index.size, 2))])
    return build_state3d(ids=st2.ids, positions=pos, radii=st2.radii, masses=st2.masses,
                         box_lo=[*st2.box_lo, -5.0], box_hi=[*st2.box_hi, 5.0],
                         params=st2.params, periodic=(*st2.periodic, False),
                         pairs=np.column_stack([st2.ids[st2.contact_i],
                                                st2.ids[st2.contact_j]]),
                         pair_t=t, walls=walls, wall_t=wt)


@pytest.mark.parametrize("seed", range(3))
def test_planar_configuration_gives_the_2d_K(seed):
    st2 = random_packing(seed, cap_fraction=0.6)
    st3 = _lift(st2)
    K2 = stiffness_matrix(st2).toarray()
    K3 = stiffness_matrix3d(st3).toarray()
    k = np.arange(st2.n)
    inplane = np.column_stack([6 * k, 6 * k + 1, 6 * k + 5]).reshape(-1)
    outplane = np.column_stack([6 * k + 2, 6 * k + 3, 6 * k + 4]).reshape(-1)
    scale = np.abs(K2).max()
    assert np.abs(K3[np.ix_(inplane, inplane)] - K2).max() <= 1e-13 * scale
    # mirror symmetry z -> -z: in-plane and out-of-plane motions decouple
    assert np.abs(K3[np.ix_(inplane, outplane)]).max() <= 1e-13 * scale
    assert np.abs(K3[np.ix_(outplane, inplane)]).max() <= 1e-13 * scale


def test_mass_diagonal_uses_sphere_inertia():
    st = random_packing3d(0)
    md = st.mass_diagonal().reshape(-1, 6)
    assert np.all(md[:, :3] == st.masses[:, None])
    assert np.allclose(md[:, 3:], 0.4 * st.masses[:, None], rtol=4 * EPS, atol=0)


def test_decision_runs_on_a_3d_cluster():
    """classify_spectrum on M^-1 K of a small 3D cluster after rattler removal.

    Without history K is symmetric, so M^-1 K has a real spectrum (M > 0
    diagonal): the decision must not report a complex pair. With history it
    runs and returns a decision with finite eigenvalues.
    """
    st = random_packing3d(0, nx=3, ny=2, nz=2, cap_fraction=0.3)
    rat = find_rattlers3d(st)
    assert rat.keep_dofs.size % 6 == 0 and rat.keep_dofs.size > 0
    for state in (st.with_t(st.contact_t * 0, st.wall_t * 0), st):
        K, m = remove_dofs(stiffness_matrix3d(state), state.mass_diagonal(), rat.keep_dofs)
        A = K.toarray() / m[:, None]
        dec = classify_spectrum(A)
        assert np.all(np.isfinite(dec.eigenvalues))
        assert dec.eigenvalues.size == A.shape[0]
        if state is not st:
            assert dec.decision is not Decision.COMPLEX


def test_decision_and_pair_tracking_through_a_coalescence():
    """The history scaled by a in [0, 0.08] (K(a) a one-parameter family): the
    certified decision is real up to a coalescence and complex after it, and
    ``track_pair`` follows the pair: its real ancestors approach, and Im^2
    grows linearly in a past the exceptional point (the square-root law)."""
    from remote_trigger.analysis.stability.eigtrack import track_pair

    st = random_packing3d(0, nx=3, ny=2, nz=2, cap_fraction=0.3)
    rat = find_rattlers3d(st)
    points = []
    for a in np.linspace(0.0, 0.08, 17):
        s = st.with_t(st.contact_t * a, st.wall_t * a)
        K, m = remove_dofs(stiffness_matrix3d(s), s.mass_diagonal(), rat.keep_dofs)
        dec = classify_spectrum(K.toarray() / m[:, None])
        assert dec.decision is not Decision.UNDECIDED, a
        points.append((a, dec.eigenvalues, dec.decision))
    flags = [p[2] is Decision.COMPLEX for p in points]
    first = flags.index(True)
    assert 3 < first and not any(flags[:first]) and all(flags[first:]), flags
    tr = track_pair(points)
    assert list(tr.complex_pair) == flags
    gap = np.abs(tr.lam_b - tr.lam_a)
    assert np.all(np.diff(gap[first - 3:first]) < 0)              # ancestors approach
    im2 = np.abs(tr.lam_b[first:].imag) ** 2
    slopes = np.diff(im2) / np.diff(tr.F_x[first:])
    assert np.all(slopes > 0) and slopes.max() / slopes.min() < 1.2, slopes


def test_build_state3d_refuses_bad_contacts_and_projects_t():
    p = ContactParams(KN, KT, 1.0)
    kw = dict(radii=[0.5, 0.5], masses=[1.0, 1.0], box_lo=[-5] * 3, box_hi=[5] * 3,
              params=p, periodic=(False,) * 3)
    with pytest.raises(ValueError, match="contact 1-2 has overlap"):
        build_state3d(ids=[1, 2], positions=[[0, 0, 0], [1.2, 0, 0]], pairs=[[1, 2]], **kw)
    with pytest.raises(ValueError, match="atom id 7"):
        build_state3d(ids=[1, 2], positions=[[0, 0, 0], [0.99, 0, 0]], pairs=[[1, 7]], **kw)
    with pytest.raises(ValueError, match="wall contact of atom id 2"):
        build_state3d(ids=[1, 2], positions=[[0, 0, 1], [0, 0, 2]],
                      walls=[(2, *plane_wall("z", "lo", 0.0))], **kw)
    # given from the larger id: stored from the smaller one with t_ij = -t_ji,
    # and a t with a normal component is projected with its length kept
    st = build_state3d(ids=[2, 1], positions=[[0.99, 0, 0], [0, 0, 0]], pairs=[[2, 1]],
                       pair_t=[[1e-4, 2e-4, 0.0]], **kw)
    assert list(st.ids) == [1, 2] and st.contact_i[0] == 0
    np.testing.assert_allclose(st.contact_t[0], [0.0, -np.sqrt(5e-8), 0.0], rtol=1e-15)
    assert st.notes["projected_t"] == pytest.approx(1 / np.sqrt(5), rel=1e-15)
