"""K against finite differences computed through LAMMPS (its own history update).

A ~100-disk packing is settled and sheared so that several contacts slide
(u = |xi|/t* = 1) or come close to it. The dump LAMMPS writes is read with
the analyzer, K is assembled, and every column is compared with central
differences of the forces and torques that LAMMPS computes after displacing
one coordinate by +-h (``lammps_fd``). The step h is chosen from a sweep by
the finite differences' own self-consistency (the h where K_fd(h) and
K_fd(h/10) agree best), not by comparing with K.

Why the optimum is h ~ 1e-9 and the agreement ~ 4e-7 rather than ~ 1e-10:
the smoothed force law is C^1 but not C^2 — f_t'' jumps at u = 1 (the cap)
and |xi| xi has a jump of its second derivative at xi = 0 — so for columns
touching a contact at such a point the central difference converges like
O(h), not O(h^2). Columns away from those points show the O(h^2) law.
"""
import numpy as np
import pytest

from remote_trigger.analysis.stability.jacobian import (
    contact_terms, generalized_forces, stiffness_matrix, wall_terms)
from remote_trigger.analysis.state.dumpfile import read_dump

from .lammps_fd import LammpsFD, sheared_packing, write_equilibrium_dump

STEPS = [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10]


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    lmp = sheared_packing()
    path = write_equilibrium_dump(lmp, tmp_path_factory.mktemp("fd") / "sheared.dump")
    state = read_dump(path)
    fd = LammpsFD(lmp)
    sweep = {h: fd.jacobian(h) for h in STEPS}
    yield lmp, state, fd, sweep
    lmp.close()


def rel(A, B):
    return np.linalg.norm(A - B) / np.linalg.norm(B)


def test_packing_has_sliding_and_near_sliding_contacts(setup):
    _, st, _, _ = setup
    d = st.separation(st.contact_i, st.contact_j)
    delta = st.radii[st.contact_i] + st.radii[st.contact_j] - np.hypot(d[:, 0], d[:, 1])
    u = contact_terms(st.params, delta, st.contact_xi).u
    assert st.n == 100 and st.n_contacts > 100 and st.wall_index.size > 3
    assert np.sum(u >= 0.9) >= 3, np.sort(u)[-5:]
    assert np.sum(u == 1.0) >= 1


def test_reader_and_force_law_reproduce_lammps_forces(setup):
    _, st, fd, _ = setup
    G = generalized_forces(st, external=False)
    Glmp = fd.evaluate()                                  # zero displacement, one step
    ref = st.contact_forces.copy()
    ref[:, 2] /= st.radii
    scale = np.abs(Glmp).max()
    assert np.abs(G - Glmp).max() <= 1e-11 * scale
    assert np.abs(ref.reshape(-1) - Glmp).max() <= 1e-11 * scale


def test_K_matches_lammps_finite_differences(setup):
    _, st, _, sweep = setup
    K = stiffness_matrix(st).toarray()
    errs = {h: rel(sweep[h], K) for h in STEPS}
    # step chosen without looking at K: best self-consistency of the sweep
    consist = {h: rel(sweep[h], sweep[h2]) for h, h2 in zip(STEPS[:-1], STEPS[1:])}
    h_best = min(consist, key=consist.get)
    msg = ", ".join(f"h={h:.0e}: {e:.2e}" for h, e in errs.items())
    print(f"FD sweep (chosen h = {h_best:.0e}): {msg}")
    assert errs[h_best] <= 1e-6, f"chosen h = {h_best:.0e}; {msg}"
    assert min(errs.values()) <= 1e-6, msg


def test_smooth_columns_converge_quadratically(setup):
    """Away from the kinks of f_t'' (u = 0 and u = 1) the error is O(h^2)."""
    _, st, _, sweep = setup
    K = stiffness_matrix(st).toarray()
    d = st.separation(st.contact_i, st.contact_j)
    delta = st.radii[st.contact_i] + st.radii[st.contact_j] - np.hypot(d[:, 0], d[:, 1])
    u = contact_terms(st.params, delta, st.contact_xi).u
    uw = wall_terms(st).u
    kink = (u > 1 - 1e-4) | (u < 1e-4)
    disks = set(st.contact_i[kink]) | set(st.contact_j[kink]) | \
        set(st.wall_index[(uw > 1 - 1e-4) | (uw < 1e-4)])
    cols = np.ones(st.ndof, bool)
    for k in disks:
        cols[3 * k:3 * k + 3] = False
    assert cols.sum() > 0.5 * st.ndof
    e5 = rel(sweep[1e-5][:, cols], K[:, cols])
    e6 = rel(sweep[1e-6][:, cols], K[:, cols])
    assert 50 < e5 / e6 < 200, (e5, e6)
    assert min(rel(sweep[h][:, cols], K[:, cols]) for h in STEPS) < 1e-7


def test_kink_term_is_first_order_and_extrapolates_away(setup):
    """FD(h) = K + a h + O(h^2) on the kinked columns: (10 FD(h/10) - FD(h))/9 removes a h."""
    _, st, _, sweep = setup
    K = stiffness_matrix(st).toarray()
    e7, e8 = rel(sweep[1e-7], K), rel(sweep[1e-8], K)
    assert 8 < e7 / e8 < 12                               # first order overall
    extrap = (10.0 * sweep[1e-8] - sweep[1e-7]) / 9.0
    assert rel(extrap, K) < 1e-7, rel(extrap, K)
