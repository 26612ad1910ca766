"""The sparse path: the certified decision on the k eigenvalues nearest a shift.

:func:`classify_projected` projects A onto a shift-invert subspace
(ARPACK, enriched near an exceptional point), and decides the projected
matrix with :func:`remote_trigger.analysis.stability.exceptional.classify_spectrum`.
Eigenvalues outside the window searched are not bounded.
"""
from __future__ import annotations

import time

import numpy as np
import scipy.linalg as sla

from remote_trigger.analysis.errors import is_integer, is_real
from remote_trigger.analysis.stability.exceptional import classify_spectrum

__all__ = ["classify_projected"]


def _orth(W, rtol=1e-10):
    """Orthonormal basis of the column span of W (SVD, tiny directions dropped)."""
    U_, sv, _ = np.linalg.svd(W, full_matrices=False)
    if sv.size == 0 or sv[0] == 0:
        return U_[:, :0]
    return U_[:, sv > rtol * sv[0]]


def classify_projected(A, sigma, k=12, enrich=2, input_error=0.0, tol=0.0, v0=None):
    """Sparse path: decide on the k eigenvalues of A nearest ``sigma``.

    1. ARPACK shift-invert (:func:`scipy.sparse.linalg.eigs`, sparse LU of
       A - sigma I) gives the k Ritz pairs nearest sigma.
    2. Their real and imaginary parts are enriched with ``enrich`` steps of
       (A - sigma I)^{-1}: near an exceptional point the two eigenvectors are
       nearly parallel and their span misses the second direction of the
       pair's invariant subspace (the generalized eigenvector); the
       shift-invert images restore it.
    3. Rayleigh-Ritz on the orthonormal basis Q: B = Q^T A Q; the real Schur
       form of B is reordered so that its k eigenvalues nearest sigma come
       first, giving an orthonormal Q_k and a quasi-triangular T_k with
       A Q_k - Q_k T_k = R.
    4. T_k holds exactly the eigenvalues of A - R Q_k^T, so it is classified
       by :func:`classify_spectrum` with ``input_error = ||R||_F +
       input_error``.

    The separation of the pair from eigenvalues *outside* the subspace does
    not enter the bound (only the k inside do); with sigma placed at the
    pair and k >= 6 these are the nearer ones.

    Parameters
    ----------
    A : sparse matrix, shape (n, n)
        Real, e.g. M^{-1} K after rattler removal.
    sigma : float
        Real shift, not an eigenvalue.
    k : int, optional
        Number of eigenvalues decided on (default 12), 2 <= k < n - 1.
    enrich : int, optional
        Shift-invert enrichment steps (default 2).
    input_error : float, optional
        Uncertainty of A itself (Frobenius norm).
    tol : float, optional
        ARPACK tolerance (0: machine precision).
    v0 : ndarray, shape (n,), optional
        ARPACK starting vector.

    Returns
    -------
    decision : SpectrumDecision
        On the k eigenvalues nearest sigma (``decision.eigenvalues``), with
        ``coverage = 'partial'``, ``n_total = n`` and ``sigma``: **not a
        stability verdict** (a pair elsewhere in the spectrum is not seen,
        and T_k is certified for A - R Q_k^T, within ``residual`` of A);
        ``decision.timing`` has ``eigen`` (ARPACK, enrichment, Rayleigh-Ritz)
        and ``decision`` (the classification of T_k).
    residual : float
        ||A Q_k - Q_k T_k||_F.

    Raises
    ------
    ValueError
        Bad k or enrich, sigma not a finite real number, or sigma an
        eigenvalue (singular shifted matrix).
    """
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    t0 = time.perf_counter()
    if np.iscomplexobj(A):
        raise ValueError("A must be real, got a complex matrix")
    A = sp.csr_matrix(A, dtype=np.float64)
    n = A.shape[0]
    if not is_integer(k) or not (2 <= k < n - 1):
        raise ValueError(f"k must be an integer with 2 <= k < n - 1 = {n - 1}, got {k!r}")
    if not is_real(sigma) \
            or not np.isfinite(sigma):
        raise ValueError(f"sigma must be a finite real number, got sigma = {sigma!r}")
    if not is_integer(enrich) or enrich < 0:
        raise ValueError(f"enrich must be an integer >= 0, got enrich = {enrich!r}")
    try:
        lu = spla.splu((A - sigma * sp.identity(n, format="csr")).tocsc())
    except RuntimeError as exc:
        raise ValueError(f"sigma = {sigma!r} is an eigenvalue (singular shifted matrix: "
                         f"{exc})") from None
    opinv = spla.LinearOperator((n, n), matvec=lu.solve, dtype=np.float64)
    lam, V = spla.eigs(A, k=k, sigma=sigma, OPinv=opinv, tol=tol, v0=v0)
    Q = _orth(np.column_stack([V.real, V.imag]))
    block = Q
    for _ in range(int(enrich)):
        block = _orth(lu.solve(block))
        Q = _orth(np.column_stack([Q, block]))
    AQ = A @ Q
    B = Q.T @ AQ
    dist = np.sort(np.abs(np.linalg.eigvals(B) - sigma))
    r_k = dist[min(k, dist.size) - 1] * (1.0 + 1e-9)
    T, W, sdim = sla.schur(B, output="real",
                           sort=lambda re, im: np.hypot(re - sigma, im) <= r_k)
    Qk = Q @ W[:, :sdim]
    Tk = T[:sdim, :sdim]
    R = A @ Qk - Qk @ Tk
    res = float(np.linalg.norm(R))
    t1 = time.perf_counter()
    dec = classify_spectrum(Tk, input_error=res + input_error)
    dec.timing = {"eigen": t1 - t0 + dec.timing.get("eigen", 0.0),
                  "decision": dec.timing.get("decision", 0.0)}
    dec.coverage, dec.n_total, dec.sigma = "partial", int(n), float(sigma)
    return dec, res
