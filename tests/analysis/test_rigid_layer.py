"""A rigid top layer of spheres: K' = P^T K P against LAMMPS's fix aveforce.

The reduced system of a state with ``rigid_layer`` ties the x, y and z of
those spheres into three dofs (``system.tie_dofs``). The independent check:
LAMMPS itself with ``fix aveforce 0.0 0.0 0.0`` on the layer (each sphere of
the layer gets the layer's mean force), finite differences of the forces it
computes when the whole layer moves along x, y or z by +-h, or when one
other coordinate moves; the layer's generalized force along an axis is the
sum of its spheres' forces (L x the mean).
"""
import numpy as np
import pytest
import scipy.sparse as sp

from remote_trigger.analysis.stability.jacobian3d import find_rattlers3d, stiffness_matrix3d
from remote_trigger.analysis.stability.system import reduced_system, tie_dofs

from .lammps_fd3d import DT, LammpsFD3D, sheared_packing_3d, state_from_lammps


def test_tie_dofs_is_PtKP():
    rng = np.random.default_rng(3)
    A = rng.standard_normal((9, 9))
    K = A + A.T
    mass = rng.uniform(1.0, 2.0, 9)
    Kt, mt = tie_dofs(sp.csr_matrix(K), mass, [[1, 4, 7], [2, 8]])
    P = np.zeros((9, 6))
    col = [0, 1, 2, 3, 1, 4, 5, 1, 2]
    P[np.arange(9), col] = 1.0
    np.testing.assert_allclose(Kt.toarray(), P.T @ K @ P, rtol=0, atol=1e-14)
    np.testing.assert_allclose(mt, P.T @ mass, rtol=0, atol=1e-15)
    assert mt[1] == pytest.approx(mass[1] + mass[4] + mass[7])


@pytest.mark.parametrize("groups, match", [
    ([[2, 1]], "ascending distinct"), ([[0, 0]], "ascending distinct"),
    ([[-1, 3]], "ascending distinct"), ([[3, 9]], "ascending distinct"),
    ([[1, 3], [3, 5]], "disjoint: index 3")])
def test_tie_dofs_refuses_bad_groups(groups, match):
    with pytest.raises(ValueError, match=match):
        tie_dofs(sp.identity(9, format="csr"), np.ones(9), groups)


class TiedFD(LammpsFD3D):
    """Finite differences of G' = P^T G: the layer's force along an axis is the sum."""

    def __init__(self, lmp, layer):
        self.layer = layer
        super().__init__(lmp)
        self.tied = np.concatenate([6 * layer[1:] + c for c in range(3)])
        kept = np.delete(np.arange(6 * self.nl), self.tied)
        self.first = [int(np.searchsorted(kept, 6 * layer[0] + c)) for c in range(3)]

    def all_forces(self):
        return super().forces()

    def forces(self):
        g = self.all_forces().reshape(-1, 6)
        out = np.delete(g.reshape(-1), self.tied)
        out[self.first] = np.sum(g[self.layer, :3], axis=0)
        return out

    def evaluate_layer(self, axis, h):
        """G' after moving the whole layer along ``axis`` by h through one step."""
        for k in self.layer:
            loc = self.order[k]
            self._arr("x")[loc, axis] += h
            self._arr("v")[loc, axis] = h / DT
        self.lmp.command("run 1 pre no post no")
        g = self.forces()
        self.restore()
        return g


@pytest.fixture(scope="module")
def packing():
    lmp = sheared_packing_3d(n=27, steps=20000, shear=0.4)
    state = state_from_lammps(lmp)
    layer = np.sort(np.argsort(state.positions[:, 1])[-5:])    # the five highest
    ids = " ".join(str(int(a)) for a in state.ids[layer])
    lmp.commands_list([f"group layer id {ids}", "fix plate layer aveforce 0.0 0.0 0.0"])
    fd = TiedFD(lmp, layer)                 # (its run 0 sets the fix up)
    yield lmp, state, layer, fd
    lmp.close()


def _with_layer(state, layer):
    return state.__class__(**{**state.__dict__, "rigid_layer": layer})


def test_the_layer_moves_as_one_under_aveforce(packing):
    lmp, state, layer, fd = packing
    fd.lmp.command("run 1 pre no post no")
    f = fd.all_forces().reshape(-1, 6)
    fd.restore()
    # each sphere of the layer carries the same force (the mean), the others their own
    assert np.ptp(f[layer, :3], axis=0).max() <= 1e-12 * np.abs(f).max()
    assert np.ptp(np.delete(f[:, 1], layer)) > 1e-3 * np.abs(f).max()


def test_tied_K_matches_lammps_finite_differences(packing):
    lmp, state, layer, fd = packing
    st = _with_layer(state, layer)
    system = reduced_system(st, min_contacts=0)           # every sphere kept
    assert system.n == 6 * st.n - 3 * (layer.size - 1)
    assert system.tied.shape == (2, 3 * (layer.size - 1))
    assert set(system.tied[1]) == {6 * layer[0], 6 * layer[0] + 1, 6 * layer[0] + 2}
    Kt = system.K.toarray()
    h = 1e-9
    cols = {fd.first[a]: -(fd.evaluate_layer(a, h) - fd.evaluate_layer(a, -h)) / (2 * h)
            for a in range(3)}
    for j, dof in enumerate(system.keep_dofs):
        if j not in cols:
            cols[j] = -(fd.evaluate(dof, h) - fd.evaluate(dof, -h)) / (2 * h)
    D = np.column_stack([cols[j] for j in range(system.n)])
    err = np.linalg.norm(D - Kt) / np.linalg.norm(Kt)
    print(f"rigid layer of {layer.size} spheres: ||K_fd - P^T K P|| / ||P^T K P|| = "
          f"{err:.2g} at h = {h:g}")
    assert err <= 2e-6, err
    # the layer's own columns: a wrong fold (one sphere's force instead of
    # the sum) would be off by O(1)
    for j in fd.first:
        col_err = np.linalg.norm(D[:, j] - Kt[:, j]) / np.linalg.norm(Kt[:, j])
        print(f"  the layer's column {j}: {col_err:.2g}")
        assert col_err <= 2e-6, (j, col_err)
    K = stiffness_matrix3d(st).toarray()
    ydofs = 6 * layer + 1
    np.testing.assert_allclose(Kt[fd.first[1], fd.first[1]], K[np.ix_(ydofs, ydofs)].sum(),
                               rtol=1e-12)
    np.testing.assert_allclose(system.mass[fd.first], st.masses[layer].sum(), rtol=1e-15)


def test_expand_and_the_residual_of_a_layer(packing):
    lmp, state, layer, fd = packing
    st = _with_layer(state, layer)
    system = reduced_system(st, min_contacts=0)
    v = np.arange(system.n, dtype=float) + 1.0
    full = system.expand(v).reshape(-1, 6)
    assert full.shape == (st.n, 6)
    assert np.all(full[layer, :3] == full[layer[0], :3])
    np.testing.assert_array_equal(full.reshape(-1)[system.keep_dofs], v)
    with pytest.raises(ValueError, match="expand needs"):
        system.expand(v[:-1])
    # the residual as LAMMPS shows it: the layer's mean force on each, own torques
    G = reduced_system(state, min_contacts=0).residual.reshape(-1, 6)
    Gl = system.residual.reshape(-1, 6)
    np.testing.assert_allclose(Gl[layer, :3], np.broadcast_to(G[layer, :3].mean(axis=0),
                                                              (layer.size, 3)), rtol=1e-15)
    rest = np.ones(G.shape, bool)
    rest[layer, :3] = False
    np.testing.assert_array_equal(Gl[rest], G[rest])


def test_the_rattler_rule_keeps_the_layer(packing):
    lmp, state, _, fd = packing
    free = find_rattlers3d(state, min_contacts=3)
    # a "layer" of the free rule's rattlers (spheres of few contacts)
    layer = np.sort(free.indices)
    z = state.contact_counts()
    assert layer.size >= 2 and np.any(z[layer] < 3)
    held = find_rattlers3d(_with_layer(state, layer), min_contacts=3)
    assert not np.any(np.isin(layer, held.indices))       # none of it removed
    kept = held.keep_dofs
    for k in layer:
        assert np.all(np.isin(6 * k + np.arange(3), kept))
        # its rotations go where it has fewer than 3 contacts among the kept
        # (every sphere is kept here: no other is a rattler once these stay)
        assert np.all(np.isin(6 * k + np.arange(3, 6), kept) == (z[k] >= 3)), (k, z[k])
    assert held.indices.size == 0
    # the layer tied: three translations for the layer
    system = reduced_system(_with_layer(state, layer))
    assert system.n == kept.size - 3 * (layer.size - 1)
