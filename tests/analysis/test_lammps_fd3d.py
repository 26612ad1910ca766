"""The 3D K against finite differences computed through LAMMPS (its own 3D step).

36 spheres are settled on a floor and sheared so that some contacts slide
(u = 1) or come close to it; the floor and the integrator are removed
(``lammps_fd3d``: the wall fix's 3D history cannot be restored from Python).
The state is read back from LAMMPS (positions, the pair's history t), K is
assembled by ``jacobian3d`` and every one of its 6N columns is compared with
central differences of the forces and torques LAMMPS computes after
displacing one coordinate (a translation, or a rotation through omega) by
+-h and taking one step.

As in 2D (``test_lammps_fd``) the law is C^1 but not C^2 at u = 1 (a capped
contact is capped on one side of the step only), so the columns of spheres
with such a contact converge like O(h); the others like O(h^2), and the
Richardson combination (10 FD(h/10) - FD(h))/9 removes the O(h) term.
"""
import numpy as np
import pytest

from remote_trigger.analysis.stability.jacobian3d import (
    contact_terms3d, generalized_forces3d, stiffness_matrix3d)

from .lammps_fd3d import LammpsFD3D, sheared_packing_3d, state_from_lammps

STEPS = [1e-6, 1e-7, 1e-8, 1e-9]


@pytest.fixture(scope="module")
def setup():
    lmp = sheared_packing_3d(n=36, steps=20000, shear=0.4)
    state = state_from_lammps(lmp)
    fd = LammpsFD3D(lmp)
    sweep = {h: fd.jacobian(h) for h in STEPS}
    yield state, fd, sweep
    lmp.close()


def rel(A, B):
    return np.linalg.norm(A - B) / np.linalg.norm(B)


def _u(st):
    d = st.separation(st.contact_i, st.contact_j)
    delta = st.radii[st.contact_i] + st.radii[st.contact_j] - np.linalg.norm(d, axis=1)
    return contact_terms3d(st.params, delta, st.contact_t).u


def test_packing_has_sliding_contacts_in_general_directions(setup):
    st, _, _ = setup
    u = _u(st)
    assert st.n == 36 and st.n_contacts > 50
    assert np.sum(u == 1.0) >= 1 and np.sum(u > 0.9) >= 2, np.sort(u)[-5:]
    # the histories are not confined to a plane or an axis
    t = st.contact_t / np.linalg.norm(st.contact_t, axis=1)[:, None]
    assert np.linalg.svd(t, compute_uv=False)[-1] > 0.1 * np.sqrt(st.n_contacts)


def test_force_law_reproduces_lammps_forces(setup):
    st, fd, _ = setup
    G = generalized_forces3d(st, external=False)
    Glmp = fd.evaluate()                       # zero displacement, one step
    assert np.abs(G - Glmp).max() <= 1e-11 * np.abs(Glmp).max()


def test_K_matches_lammps_finite_differences(setup):
    st, _, sweep = setup
    K = stiffness_matrix3d(st).toarray()
    errs = {h: rel(sweep[h], K) for h in STEPS}
    msg = ", ".join(f"h={h:.0e}: {e:.2e}" for h, e in errs.items())
    print(f"3D FD sweep: {msg}")
    assert errs[1e-9] <= 2e-6, msg
    assert 8 < errs[1e-8] / errs[1e-9] < 12, msg          # first order overall (kinks)
    extrap = (10.0 * sweep[1e-8] - sweep[1e-7]) / 9.0
    assert rel(extrap, K) < 2e-7, rel(extrap, K)


def test_smooth_columns_converge_quadratically(setup):
    """Columns of spheres without a contact at the cap converge like O(h^2)."""
    st, _, sweep = setup
    K = stiffness_matrix3d(st).toarray()
    u = _u(st)
    kink = u > 1 - 1e-4
    spheres = set(st.contact_i[kink]) | set(st.contact_j[kink])
    cols = np.ones(st.ndof, bool)
    for k in spheres:
        cols[6 * k:6 * k + 6] = False
    assert cols.sum() > 0.5 * st.ndof
    e6 = rel(sweep[1e-6][:, cols], K[:, cols])
    e7 = rel(sweep[1e-7][:, cols], K[:, cols])
    assert 50 < e6 / e7 < 200, (e6, e7)
    assert min(rel(sweep[h][:, cols], K[:, cols]) for h in STEPS) < 1e-8
