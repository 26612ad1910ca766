"""A layer of spheres rigid along y: K' = P^T K P against LAMMPS's fix aveforce.

The reduced system of a state with ``rigid_y`` ties the y of those spheres
into one dof (``system.tie_dofs``). The independent check: LAMMPS itself with
``fix aveforce NULL 0.0 NULL`` on the layer (each sphere of the layer gets the
layer's mean y force), finite differences of the forces it computes when the
whole layer moves along y by +-h, or when one other coordinate moves; the
layer's generalized force is the sum of its y forces (L x the mean).
"""
import numpy as np
import pytest
import scipy.sparse as sp

from remote_trigger.analysis.stability.jacobian3d import stiffness_matrix3d
from remote_trigger.analysis.stability.system import reduced_system, tie_dofs

from .lammps_fd3d import DT, LammpsFD3D, sheared_packing_3d, state_from_lammps


def test_tie_dofs_is_PtKP():
    rng = np.random.default_rng(3)
    A = rng.standard_normal((9, 9))
    K = A + A.T
    mass = rng.uniform(1.0, 2.0, 9)
    group = np.array([1, 4, 7])
    Kt, mt = tie_dofs(sp.csr_matrix(K), mass, group)
    P = np.zeros((9, 7))
    col = [0, 1, 2, 3, 1, 4, 5, 1, 6]
    P[np.arange(9), col] = 1.0
    np.testing.assert_allclose(Kt.toarray(), P.T @ K @ P, rtol=0, atol=1e-14)
    np.testing.assert_allclose(mt, P.T @ mass, rtol=0, atol=1e-15)
    assert mt[1] == pytest.approx(mass[1] + mass[4] + mass[7])


@pytest.mark.parametrize("group", [[2, 1], [0, 0], [-1, 3], [3, 9]])
def test_tie_dofs_refuses_a_bad_group(group):
    with pytest.raises(ValueError, match="group must be ascending distinct indices"):
        tie_dofs(sp.identity(9, format="csr"), np.ones(9), group)


class TiedFD(LammpsFD3D):
    """Finite differences of G' = P^T G: the layer's y force is the sum of its own."""

    def __init__(self, lmp, layer):
        self.layer = layer
        super().__init__(lmp)
        kept = np.delete(np.arange(6 * self.nl), 6 * layer[1:] + 1)
        self.first = int(np.searchsorted(kept, 6 * layer[0] + 1))

    def all_forces(self):
        return super().forces()

    def forces(self):
        g = self.all_forces().reshape(-1, 6)
        out = np.delete(g.reshape(-1), 6 * self.layer[1:] + 1)
        out[self.first] = np.sum(g[self.layer, 1])
        return out

    def evaluate_layer(self, h):
        """G' after moving the whole layer along y by h through one step."""
        for k in self.layer:
            loc = self.order[k]
            self._arr("x")[loc, 1] += h
            self._arr("v")[loc, 1] = h / DT
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
    lmp.commands_list([f"group layer id {ids}", "fix plate layer aveforce NULL 0.0 NULL"])
    fd = TiedFD(lmp, layer)                 # (its run 0 sets the fix up)
    yield lmp, state, layer, fd
    lmp.close()


def test_the_layer_moves_as_one_under_aveforce(packing):
    lmp, state, layer, fd = packing
    fd.lmp.command("run 1 pre no post no")
    f = fd.all_forces().reshape(-1, 6)
    fd.restore()
    # each sphere of the layer carries the same y force (the mean), the others their own
    assert np.ptp(f[layer, 1]) <= 1e-12 * np.abs(f).max()
    assert np.ptp(np.delete(f[:, 1], layer)) > 1e-3 * np.abs(f).max()


def test_tied_K_matches_lammps_finite_differences(packing):
    lmp, state, layer, fd = packing
    st = state.__class__(**{**state.__dict__, "rigid_y": layer})
    system = reduced_system(st, min_contacts=0)           # every sphere kept
    assert system.n == 6 * st.n - (layer.size - 1)
    assert system.tied.shape == (2, layer.size - 1)
    assert np.all(system.tied[1] == 6 * layer[0] + 1)
    Kt = system.K.toarray()
    first = fd.first
    h = 1e-9
    cols = {first: -(fd.evaluate_layer(h) - fd.evaluate_layer(-h)) / (2 * h)}
    for j, dof in enumerate(system.keep_dofs):
        if j != first:
            cols[j] = -(fd.evaluate(dof, h) - fd.evaluate(dof, -h)) / (2 * h)
    D = np.column_stack([cols[j] for j in range(system.n)])
    err = np.linalg.norm(D - Kt) / np.linalg.norm(Kt)
    assert err <= 2e-6, err
    # the layer's own column and row: a wrong fold (one sphere's y instead of
    # the sum) would be off by O(1)
    col_err = np.linalg.norm(D[:, first] - Kt[:, first]) / np.linalg.norm(Kt[:, first])
    assert col_err <= 2e-6, col_err
    K = stiffness_matrix3d(st).toarray()
    ydofs = 6 * layer + 1
    np.testing.assert_allclose(Kt[first, first], K[np.ix_(ydofs, ydofs)].sum(),
                               rtol=1e-12)
    assert system.mass[first] == pytest.approx(st.masses[layer].sum())


def test_expand_and_the_residual_of_a_layer(packing):
    lmp, state, layer, fd = packing
    st = state.__class__(**{**state.__dict__, "rigid_y": layer})
    system = reduced_system(st, min_contacts=0)
    v = np.arange(system.n, dtype=float) + 1.0
    full = system.expand(v)
    assert full.shape == (6 * st.n,)
    assert np.all(full[6 * layer + 1] == full[6 * layer[0] + 1])
    np.testing.assert_array_equal(full[system.keep_dofs], v)
    with pytest.raises(ValueError, match="expand needs"):
        system.expand(v[:-1])
    # the residual as LAMMPS shows it: the layer's mean y force on each
    free = reduced_system(state, min_contacts=0)
    G = free.residual
    np.testing.assert_allclose(system.residual[6 * layer + 1], np.mean(G[6 * layer + 1]),
                               rtol=1e-15)
    keep = np.setdiff1d(np.arange(G.size), 6 * layer + 1)
    np.testing.assert_array_equal(system.residual[keep], G[keep])
