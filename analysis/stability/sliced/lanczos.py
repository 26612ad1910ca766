"""The eigenpairs of a symmetric S nearest a shift: Lanczos on (S - sigma I)^-1.

:func:`nearest_pairs` is the eigen-solver of a slice (:mod:`.slices`): the
Lanczos recurrence on the shift-inverted operator (S - sigma I)^-1, given as
its solve, with every new Lanczos vector orthogonalized against all the
previous ones by classical Gram-Schmidt and the Daniel-Gragg-Kaufman-Stewart
(DGKS) test for a second pass (Daniel, Gragg, Kaufman and Stewart, Math.
Comp. 30, 1976; the test ARPACK's ``dsaitr`` makes), and no restart: the
basis grows until the k eigenvalues of the tridiagonal matrix largest in
modulus have converged by ARPACK's rule, or ``max_steps`` is reached.

Why not ARPACK's implicitly restarted Lanczos (``scipy.sparse.linalg.eigsh``),
which this replaces as the first choice: for the k = 60 pairs of a slice it
takes about as many solves (measured at N = 10^4, n = 28 836: 125-138 for
ARPACK with NCV = 1.4 k + 1, 130-140 here) but its own work (the
reorthogonalization over its NCV vectors, the restarts' updates of the
basis) is memory-bound BLAS-2 work about as long as the solves; here one
Gram-Schmidt pass per step sufficed on the slices measured, and the Ritz
vectors are one matrix product. A whole scan: 0.75 and 0.73 x ARPACK's CPU
time at N = 6400 and 10^4, side by side on a 2-core Intel Xeon; at N = 640
spheres (n = 3537, the solves dominate) 1.04 x (docs/results/analysis.md,
"The slice's Lanczos without restarts"). Nothing here is part of the proof:
the slice's Ritz pairs are checked by Rayleigh-Ritz and Kahan's theorem and
its edges by Sylvester counts (:mod:`.slices`), whatever produced them.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as sla

__all__ = ["nearest_pairs"]

# a second Gram-Schmidt pass where one pass left less than this fraction of
# the vector's norm (DGKS; ARPACK's dsaitr uses 0.717 ~ 1 / sqrt(2))
_DGKS = 0.717
# the tridiagonal matrix's eigenvalues are checked every this many steps once
# the basis holds k + _FIRST_CHECK vectors (at most _CHECK - 1 solves past
# convergence; an eigh of the tridiagonal matrix of ~150 costs ~1 ms)
_CHECK = 5
_FIRST_CHECK = 20


def nearest_pairs(solve, sigma, n, k, v0, tol, max_steps):
    """The k eigenpairs of a symmetric S nearest ``sigma``, by Lanczos on
    (S - sigma I)^-1 without restarts.

    Parameters
    ----------
    solve : callable
        ``solve(b)`` returns x with (S - sigma I) x = b, for b of shape (n,)
        float64 (a factorization's solve).
    sigma : float
        The shift.
    n : int
        Order of S.
    k : int
        Pairs wanted, 1 <= k < n.
    v0 : ndarray, shape (n,)
        Start vector (not zero; normalized here).
    tol : float
        Stopping rule (ARPACK's): each of the k Ritz pairs (mu, x) of
        (S - sigma I)^-1 has the residual estimate |beta_m z_m| <= tol |mu|.
    max_steps : int
        Largest basis (capped at n); memory max_steps x n float64.

    Returns
    -------
    (lam, V, steps) or None
        lam, shape (k,): sigma + 1 / mu for the k Ritz values mu largest in
        modulus, in that order; V, shape (n, k): their Ritz vectors
        (orthonormal to working precision); steps: solves made. None if they
        have not converged within ``max_steps`` steps or the recurrence broke
        down (an invariant subspace of fewer than k converged pairs): the
        caller then uses another solver.

    Raises
    ------
    ValueError
        If k is not in [1, n), ``v0`` is not n finite values not all zero,
        or ``max_steps`` < k.
    """
    if not 1 <= k < n:
        raise ValueError(f"k must be in [1, n = {n}), got {k}")
    if max_steps < k:
        raise ValueError(f"max_steps must be >= k = {k}, got {max_steps}")
    v = np.array(v0, dtype=np.float64).reshape(-1)
    norm0 = float(np.linalg.norm(v)) if v.size == n and np.all(np.isfinite(v)) else 0.0
    if norm0 == 0.0:
        raise ValueError(f"v0 must be {n} finite values, not all zero")
    m_max = min(int(max_steps), n)
    V = np.empty((m_max + 1, n))            # the Lanczos vectors, one per row
    V[0] = v / norm0
    alpha = np.zeros(m_max)
    beta = np.zeros(m_max + 1)              # beta[j]: between vectors j - 1 and j
    tiny = n * np.finfo(np.float64).eps
    for j in range(m_max):
        w = np.asarray(solve(V[j]), dtype=np.float64)
        if j > 0:
            w -= beta[j] * V[j - 1]
        alpha[j] = float(V[j] @ w)
        w -= alpha[j] * V[j]
        before = float(np.linalg.norm(w))
        for _ in range(2):                  # Gram-Schmidt against all, DGKS
            c = V[:j + 1] @ w
            w -= c @ V[:j + 1]
            alpha[j] += c[j]
            after = float(np.linalg.norm(w))
            if after >= _DGKS * before:
                break
            before = after
        beta[j + 1] = after
        m = j + 1
        scale = max(float(np.max(np.abs(alpha[:m]))), float(np.max(beta[1:m + 1])))
        broke = after <= tiny * scale
        if broke or (m >= min(k + _FIRST_CHECK, m_max) and
                     ((m - k) % _CHECK == 0 or m == m_max)):
            mu, Z = sla.eigh_tridiagonal(alpha[:m], beta[1:m]) if m > 1 else \
                (alpha[:1].copy(), np.ones((1, 1)))
            if mu.size >= k:
                order = np.argsort(-np.abs(mu), kind="stable")[:k]
                resid = np.abs(beta[m] * Z[m - 1, order])
                if np.all(resid <= tol * np.abs(mu[order])) and np.all(mu[order] != 0):
                    X = V[:m].T @ Z[:, order]
                    return sigma + 1.0 / mu[order], X, m
            if broke or m == m_max:
                return None
        V[j + 1] = w / after
    return None
