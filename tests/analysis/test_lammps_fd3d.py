"""The 3D K against finite differences computed through LAMMPS (its own 3D step).

Sphere-sphere blocks: 36 spheres are settled on a floor and sheared so that some contacts slide
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

Wall blocks: one sphere on an xplane, yplane or zplane wall (either side),
its history built by an imposed slip or spin, each displaced evaluation in a
fresh instance.
"""
import numpy as np
import pytest

from remote_trigger.analysis.stability.jacobian3d import (
    contact_terms3d, generalized_forces3d, stiffness_matrix3d)
from remote_trigger.analysis.state.state import ContactParams
from remote_trigger.analysis.state.state3d import build_state3d

from ..plugin.lmputil import KN, KT, MU, add_sphere, box_commands_3d, new_lammps, set_per_atom
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


# ------------------------------------------------------------------ walls
# One sphere on a wall. The wall fix keeps its 3D history itself, so every
# displaced evaluation starts a fresh LAMMPS instance that builds the same
# history (nsteps steps of an imposed slip, no integrator) and then takes
# the displaced step.

R_W, DELTA_W, DT_W = 0.7, 1.0e-3, 1.0e-4
WALL_CASES = {   # wall args, centre, (normal, offset), motion that builds t, steps
    "zplane lo, below the cap": ("zplane -4.0 NULL", [0.3, -0.2, -4.0 + R_W - DELTA_W],
                                 ([0, 0, 1.0], -4.0), dict(v=(0.3, -0.2, 0.1)), 40),
    "yplane hi, spin": ("yplane -4.0 4.0", [0.1, 4.0 - R_W + DELTA_W, 0.2],
                        ([0, -1.0, 0], -4.0), dict(w=(0.5, 0.3, -0.8)), 20),
    "xplane lo, capped": ("xplane -4.0 4.0", [-4.0 + R_W - DELTA_W, 0.1, 0.2],
                          ([1.0, 0, 0], -4.0), dict(v=(0.1, 0.3, -0.25)), 200),
}


def _wall_run(case, dof=None, h=0.0):
    args, centre, _, motion, nsteps = WALL_CASES[case]
    lmp = new_lammps()
    lmp.commands_list(box_commands_3d(size=10.0, lo=-5.0, boundary="f f f"))
    add_sphere(lmp, 2, R_W, centre)
    lmp.commands_list(["pair_style mindlin/smooth", f"pair_coeff * * {KN!r} {KT!r} {MU!r}",
                       f"fix w all wall/mindlin/smooth {KN!r} {KT!r} {MU!r} {args}",
                       f"timestep {DT_W!r}"])
    set_per_atom(lmp, "v", 1, motion.get("v", (0, 0, 0)))
    set_per_atom(lmp, "omega", 1, motion.get("w", (0, 0, 0)))
    lmp.command(f"run {nsteps}")
    t = np.array(lmp.numpy.extract_fix("w", 1, 2)[0][4:7])
    v, w = np.zeros(3), np.zeros(3)
    if dof is not None and dof < 3:
        lmp.numpy.extract_atom("x")[0, dof] += h
        v[dof] = h / DT_W
    elif dof is not None:
        w[dof - 3] = h / (R_W * DT_W)
    set_per_atom(lmp, "v", 1, v)
    set_per_atom(lmp, "omega", 1, w)
    lmp.command("run 1 pre no post no")
    G = np.concatenate([np.array(lmp.numpy.extract_atom("f")[0]),
                        np.array(lmp.numpy.extract_atom("torque")[0]) / R_W])
    lmp.close()
    return G, t


def _wall_state(case, t):
    _, centre, (normal, offset), _, _ = WALL_CASES[case]
    return build_state3d(ids=[1], positions=[centre], radii=[R_W], masses=[1.0],
                         box_lo=[-5.0] * 3, box_hi=[5.0] * 3, params=ContactParams(KN, KT, MU),
                         periodic=(False,) * 3, walls=[(1, normal, offset)], wall_t=[t])


@pytest.mark.parametrize("case", WALL_CASES)
def test_wall_block_matches_lammps_finite_differences(case):
    G0, t = _wall_run(case)
    st = _wall_state(case, t)
    u = contact_terms3d(st.params, st.wall_delta(), st.wall_t).u[0]
    assert (u == 1.0) == ("capped" in case) and u > 0.1
    assert np.abs(generalized_forces3d(st, external=False) - G0).max() <= \
        1e-12 * np.abs(G0).max()
    K = stiffness_matrix3d(st).toarray()
    fd = {}
    for h in (1e-7, 1e-8):
        fd[h] = -np.column_stack([(_wall_run(case, q, h)[0] - _wall_run(case, q, -h)[0])
                                  / (2 * h) for q in range(6)])
    if "capped" in case:                   # one-sided kink: O(h), extrapolated away
        e7, e8 = rel(fd[1e-7], K), rel(fd[1e-8], K)
        assert 8 < e7 / e8 < 12 and e8 < 1e-5, (e7, e8)
        assert rel((10 * fd[1e-8] - fd[1e-7]) / 9, K) < 5e-8
    else:
        assert rel(fd[1e-7], K) < 1e-8, (rel(fd[1e-7], K), rel(fd[1e-8], K))
