"""Newton above DENSE_NEWTON_MAX dof: sparse K, SuperLU (LSMR if singular).

The dense path (N <= 400) is the reference: the same K and residual give
the same Newton step, and a ramp forced onto the sparse path brackets the
same F_x^c.
"""
import numpy as np
import pytest

from remote_trigger.analysis.stability.jacobian import stiffness_matrix
from remote_trigger.analysis.state.dumpfile import read_dump
from remote_trigger.pywrap.stages import newton_solve


@pytest.fixture(scope="module")
def K_sparse(relaxed):
    st = read_dump(relaxed.datafile[:-len(".data")] + ".dump", require_contacts=False)
    return stiffness_matrix(st)


def test_sparse_step_equals_dense_step(K_sparse):
    G = np.random.default_rng(3).normal(size=(K_sparse.shape[0] // 3, 3))
    d_dense = newton_solve.newton_step(K_sparse.toarray(), G)
    d_sparse = newton_solve.newton_step(K_sparse, G)
    scale = float(np.max(np.abs(d_dense)))
    assert float(np.max(np.abs(d_sparse - d_dense))) <= 1e-9 * scale
    # contactless rows stay zero in both
    dead = np.asarray(K_sparse.getnnz(axis=1) == 0).reshape(-1, 3).all(axis=1)
    assert np.all(d_sparse[dead] == 0)


def test_singular_sparse_K_falls_back_to_least_squares(K_sparse):
    """A rank-deficient K (one block zeroed in a single dof) still gives a
    step that solves K dq = G wherever it is solvable."""
    import scipy.sparse as sp

    K = sp.lil_matrix(K_sparse)
    n = K.shape[0]
    j = next(i for i in range(n) if K_sparse.getrow(i).nnz)
    K[j, :] = 0.0                 # row j zero, column j kept: K singular
    K = sp.csr_matrix(K)
    G = np.zeros(n)
    G[:] = K @ np.random.default_rng(4).normal(size=n)     # consistent right-hand side
    dq = newton_solve.newton_step(K, G.reshape(-1, 3)).reshape(-1)
    res = np.linalg.norm(K @ dq - G) / np.linalg.norm(G)
    assert np.all(np.isfinite(dq)) and res < 1e-6, res


def test_ramp_on_the_sparse_path_brackets_the_same_onset(relaxed, tmp_path, monkeypatch):
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RampConfig

    cfg = RampConfig(datafile=relaxed.datafile, dF_x=0.01, tol=1e-5)
    dense = stages.ramp(cfg, str(tmp_path / "dense"), quiet=True)
    monkeypatch.setattr(newton_solve, "DENSE_NEWTON_MAX", 0)
    sparse = stages.ramp(cfg, str(tmp_path / "sparse"), quiet=True)
    assert dense.status == sparse.status == "complete"
    assert np.all(sparse.residual < 1e-10)
    assert sparse.F_x_c_low < dense.F_x_c_high and dense.F_x_c_low < sparse.F_x_c_high
