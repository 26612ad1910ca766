"""The slice's eigen-solver: Lanczos on (S - sigma I)^-1 without restarts
(sliced.lanczos.nearest_pairs), against LAPACK, and its fallback to ARPACK in
sliced.slices.shift_invert."""
import numpy as np
import pytest
import scipy.sparse as sp

from remote_trigger.analysis.stability.sliced import SlicedStats, scaled_parts, slices
from remote_trigger.analysis.stability.sliced.inertia import Shifts, shifted
from remote_trigger.analysis.stability.sliced.lanczos import nearest_pairs
from remote_trigger.analysis.stability.sliced.strips import norm1

import qdldl

from .builders import random_packing


def _random_sparse(n, seed):
    rng = np.random.default_rng(seed)
    B = sp.random(n, n, density=8.0 / n, random_state=rng, format="csr")
    return sp.csc_matrix(B + B.T + sp.diags(rng.uniform(0.0, 4.0, n)))


def _packing_S():
    from remote_trigger.analysis.stability import jacobian
    from remote_trigger.analysis.stability.analyze import analyze

    res = analyze(random_packing(5, nx=20, ny=15), eigenvalues=False, decide=False)
    Kr, mr = jacobian.remove_dofs(res.K, res.mass, res.rattlers.keep_dofs)
    return scaled_parts(Kr, mr)[1]


@pytest.mark.parametrize("which", ["random", "packing"])
def test_nearest_pairs_are_lapacks(which):
    """The k eigenvalues nearest sigma, at three places of the spectrum: LAPACK's
    to 1e-9 relative to ||S||; the vectors orthonormal to 1e-12; every
    residual ||S v - lam v|| within the stopping rule's bound
    (slices.stopping_bound) -- which holds for exact solves, and the solves
    here are QDLDL's; the same call twice gives the same bits."""
    S = _random_sparse(900, 1) if which == "random" else _packing_S()
    n = S.shape[0]
    lam_all = np.linalg.eigvalsh(S.toarray())
    normS = norm1(S)
    k = 30
    for frac in (0.1, 0.5, 0.9):
        sigma = float(lam_all[int(frac * n)]) + 1e-3 * float(np.median(np.diff(lam_all)))
        fac = qdldl.Solver(shifted(S, sigma))
        v0 = np.random.default_rng(7).standard_normal(n)
        got = nearest_pairs(fac.solve, sigma, n, k, v0, 1e-8, 4 * k)
        assert got is not None
        lam, V, steps = got
        assert lam.shape == (k,) and V.shape == (n, k) and k < steps <= 4 * k
        want = lam_all[np.argsort(np.abs(lam_all - sigma))[:k]]
        np.testing.assert_allclose(np.sort(lam), np.sort(want), rtol=0, atol=1e-9 * normS)
        assert np.linalg.norm(V.T @ V - np.eye(k)) < 1e-12
        res = np.linalg.norm(S @ V - V * lam)
        assert res <= slices.stopping_bound(k, normS, sigma)
        again = nearest_pairs(fac.solve, sigma, n, k, v0, 1e-8, 4 * k)
        assert np.array_equal(again[0], lam) and np.array_equal(again[1], V)


def test_not_converged_or_broken_down_is_none_and_bad_input_is_refused():
    """Too few steps for the k pairs: None (the caller's fallback). A start
    vector in an invariant subspace of fewer than k eigenvectors: the
    recurrence breaks down, None (not the pairs of that subspace). k, v0 and
    max_steps out of range: one-line ValueErrors naming the value."""
    S = _random_sparse(400, 2)
    n = S.shape[0]
    sigma = 0.3
    fac = qdldl.Solver(shifted(S, sigma))
    v0 = np.random.default_rng(1).standard_normal(n)
    assert nearest_pairs(fac.solve, sigma, n, 20, v0, 1e-8, 21) is None
    D = sp.diags(np.arange(1.0, n + 1.0)).tocsc()
    facD = qdldl.Solver(shifted(D, 10.5))
    e = np.zeros(n)
    e[[3, 9, 30]] = 1.0                     # three eigenvectors of D
    assert nearest_pairs(facD.solve, 10.5, n, 5, e, 1e-8, 40) is None
    with pytest.raises(ValueError, match="k must be in"):
        nearest_pairs(fac.solve, sigma, n, n, v0, 1e-8, 4 * n)
    with pytest.raises(ValueError, match="v0 must be 400 finite values"):
        nearest_pairs(fac.solve, sigma, n, 5, np.zeros(n), 1e-8, 40)
    with pytest.raises(ValueError, match="max_steps must be >= k = 5, got 3"):
        nearest_pairs(fac.solve, sigma, n, 5, v0, 1e-8, 3)


def test_shift_invert_falls_back_to_arpack(monkeypatch):
    """Where the Lanczos does not converge within its steps (here forced:
    _LANCZOS_STEPS so small that it cannot), ``shift_invert`` runs ARPACK from
    the same start vector: the same eigenvalues, counted in
    ``stats.arpack_runs``; otherwise ARPACK does not run."""
    S = _packing_S()
    n = S.shape[0]
    lam_all = np.linalg.eigvalsh(S.toarray())
    sigma = float(lam_all[n // 3]) + 1e-3
    st = SlicedStats()
    lam, V, used = slices.shift_invert(S, Shifts(S), sigma, 20, np.random.default_rng(3), st)
    assert st.lanczos_runs == 1 and st.arpack_runs == 0 and used == sigma
    monkeypatch.setattr(slices, "_LANCZOS_STEPS", 1.02)
    st2 = SlicedStats()
    lam2, V2, _ = slices.shift_invert(S, Shifts(S), sigma, 20, np.random.default_rng(3), st2)
    assert st2.lanczos_runs == 1 and st2.arpack_runs == 1 and st2.computed == 20
    np.testing.assert_allclose(np.sort(lam2), np.sort(lam), rtol=0, atol=1e-9 * norm1(S))
