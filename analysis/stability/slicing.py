"""Sylvester counts and Ritz slices of a sparse symmetric matrix (for the sliced verdict).

:func:`count_below` counts the eigenvalues of a symmetric S below a shift
from a sparse factorization, with a rigorous bound of how far that count can
be off (its *fuzz*); :func:`_slices` computes S's eigenpairs slice by slice
with ARPACK shift-invert and checks every slice against two such counts, so
that no eigenvalue is missed. The proof they serve and how they are used:
:mod:`remote_trigger.analysis.stability.sliced`.
"""
from __future__ import annotations

from dataclasses import dataclass, field
import math

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from remote_trigger.analysis.stability.enclosure import U, _gamma

__all__ = ["count_below", "SlicedStats"]

_INFLATE = 1.0 + 1e-10          # inflation of computed sums of nonnegative terms
_ARPACK_TOL = 1e-8              # ARPACK stopping tolerance (only the checked residuals matter)


class _Fail(Exception):
    """A step could not be certified; the message is the reason."""


@dataclass
class SlicedStats:
    """What the sliced verdict did (``SpectrumDecision.timing`` holds the times).

    Attributes
    ----------
    n : int
        Order of A.
    slices : int
        Number of shift-invert slices of S.
    boundaries : int
        Certified boundaries (a strip between two).
    strips : dict
        Number of strips per size m.
    norm_W : float
        Rigorous upper bound of ||W||_2 (1/time^2).
    window : float
        Delta, the half-width of the explicit window (1/time^2).
    max_kappa : float
        Largest kappa(a) among certified boundaries.
    fuzz : float
        Largest inertia fuzz (1/time^2).
    ritz_radius : float
        Largest Ritz radius ||R||_2 of a slice (1/time^2).
    """

    n: int = 0
    slices: int = 0
    boundaries: int = 0
    strips: dict = field(default_factory=dict)
    norm_W: float = 0.0
    window: float = 0.0
    max_kappa: float = 0.0
    fuzz: float = 0.0
    ritz_radius: float = 0.0


# --------------------------------------------------------------------------- counting
def _lu(H):
    """SuperLU of a symmetric matrix with a symmetric permutation and diagonal pivots."""
    lu = spla.splu(sp.csc_matrix(H), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                   options=dict(SymmetricMode=True, Equil=False))
    if not np.array_equal(lu.perm_r, lu.perm_c):
        raise _Fail("the inertia factorization pivoted off the diagonal")
    return lu


def count_below(S, a, lu=None):
    """Sylvester count of the eigenvalues of the symmetric S below a, with its fuzz.

    Parameters
    ----------
    S : sparse matrix, shape (n, n)
        Symmetric, float64.
    a : float
        The shift.
    lu : SuperLU, optional
        A factorization of S - a I made by this module (reused).

    Returns
    -------
    count : int
        Number of negative pivots: the number of eigenvalues below a of a
        symmetric S + Z with ||Z||_2 <= fuzz, hence between the counts of S
        below a - fuzz and below a + fuzz.
    fuzz : float
        Rigorous bound of ||Z||_2 (same units as S).
    lu : SuperLU
        The factorization (for solves with S - a I).

    Raises
    ------
    ValueError
        If the factorization met a zero pivot or pivoted off the diagonal
        (a is an eigenvalue, or S - a I is too ill-conditioned here).
    """
    n = S.shape[0]
    H = sp.csc_matrix(S - a * sp.identity(n, format="csc"))
    try:
        lu = lu or _lu(H)
    except (_Fail, RuntimeError) as exc:
        raise ValueError(f"no inertia of S - a I at a = {a!r}: {exc}") from None
    L, Uf = lu.L.tocsr(), lu.U.tocsr()
    d = Uf.diagonal()
    if not np.all(np.isfinite(d)) or np.any(d == 0):
        raise ValueError(f"no inertia of S - a I at a = {a!r}: zero pivot")
    aL, aU = abs(L), abs(Uf)
    one = np.ones(n)
    depth = int(max(np.max(np.diff(L.indptr)), np.max(np.diff(Uf.tocsc().indptr))))
    ge = _gamma(depth + 2) * float(np.max(aL @ (aU @ one)))
    E2 = (sp.diags(d) @ L.T.tocsr() - Uf)           # D L^T - U: exact would be 0
    e2 = float(np.max(aL @ (abs(E2) @ one) + U * (aL @ (abs(sp.diags(d) @ L.T) @ one))))
    diag_err = U * float(np.max(np.abs(S.diagonal() - a)))      # rounding of S_ii - a
    fuzz = (ge + e2 * (1 + 4 * U) + diag_err) * _INFLATE
    return int(np.count_nonzero(d < 0)), fuzz, lu


def _norm1(X):
    return float(abs(X).sum(axis=0).max()) * (1 + _gamma(X.shape[0]))


def _norm2_skew(W):
    """Rigorous upper bound of ||W||_2 for a skew W: ||W||_1 (= ||W||_inf), sharpened
    by the inertia of [[t I, W], [W^T, t I]] (eigenvalues t +- sigma_i(W))."""
    crude = _norm1(W)
    n = W.shape[0]
    if n < 3 or crude == 0:
        return crude
    try:
        # a fixed start vector, so that the bound does not depend on earlier
        # ARPACK calls in the process
        est = spla.svds(W, k=1, return_singular_vectors=False, tol=1e-6,
                        v0=np.random.default_rng(0).standard_normal(n))[0]
    except Exception:            # ARPACK failures leave the crude bound
        return crude
    t = 1.02 * est
    aug = sp.bmat([[None, W], [W.T, None]], format="csc")
    try:
        cnt, fuzz, _ = count_below(aug, -t)
    except ValueError:
        return crude
    # the augmented matrix minus (-t) ... shifted: eigenvalues of aug are +- sigma_i,
    # so no eigenvalue below -t - fuzz means ||W|| <= t + fuzz
    return min(crude, (t + fuzz) * (1 + 4 * U)) if cnt == 0 else crude


# --------------------------------------------------------------------------- slices
@dataclass
class _Slice:
    lo: float                   # lower edge (a gap point)
    hi: float                   # upper edge
    theta: np.ndarray           # Ritz values in (lo, hi)
    Q: np.ndarray               # n x k Ritz vectors
    WQ: np.ndarray              # W Q
    radius: float               # Kahan radius ||R||_2 bound
    resid: np.ndarray           # per-vector residual norm bounds
    phi: float                  # ||Q^T Q - I||_2 bound


def _ritz(S, W, Q, normS, normW):
    """Rayleigh-Ritz of S on span(Q); vectors, values, radius, residuals, phi."""
    Q, _ = np.linalg.qr(Q)
    H = Q.T @ (S @ Q)
    theta, Y = np.linalg.eigh((H + H.T) / 2)
    Q = Q @ Y
    SQ = S @ Q
    R = SQ - Q * theta
    n, k = Q.shape
    G = Q.T @ Q - np.eye(k)
    phi = (np.linalg.norm(G) + _gamma(n) * k) * _INFLATE
    round_r = _gamma(n + 2) * (normS + float(np.max(np.abs(theta)))) * math.sqrt(k)
    resid = (np.linalg.norm(R, axis=0) + round_r) * _INFLATE
    # Kahan for the exactly orthonormal Q (Q^T Q)^{-1/2}: ||R|| (1 + phi) + 2 phi |theta|
    radius = (math.sqrt(float(np.sum(resid ** 2))) * (1 + phi)
              + 2 * phi * float(np.max(np.abs(theta)))) * _INFLATE
    return theta, Q, W @ Q, radius, resid, phi


def _slices(S, W, k, normS, normW, lo0, stats):
    """Yield the Ritz slices of S from ``lo0`` (below the spectrum) upwards.

    Each slice: the k eigenvalues of S nearest a shift sigma (ARPACK
    shift-invert), sigma placed about half a slice above the previous upper
    edge x so that the k nearest reach below x (no hole: checked, and the
    count below proves it); the new upper edge y lies in the widest gap of
    the slice's upper part whose distance to its Ritz values exceeds the
    Ritz radius and the inertia fuzz; the inertia count of (x, y) must equal
    the number of Ritz values kept.
    """
    n = S.shape[0]
    x = lo0
    cnt_x, fz, _ = count_below(S, x)
    if cnt_x != 0:
        raise _Fail(f"{cnt_x} eigenvalues of S below the Gershgorin bound {x:.6g}")
    stats.fuzz = max(stats.fuzz, fz)
    fz_x = fz
    rng = np.random.default_rng(12345)
    width = None                # estimated width of k eigenvalues
    while cnt_x < n:
        kk = min(k, n - 2)
        sigma = x if width is None else x + 0.5 * width
        for attempt in range(12):
            if kk >= n - 2:
                lam, V = np.linalg.eigh(S.toarray())
                sel = lam > x
                lam, V = lam[sel], V[:, sel]
                whole = True
            else:
                lu = _lu(S - sigma * sp.identity(n, format="csc"))
                op = spla.LinearOperator((n, n), matvec=lu.solve, dtype=np.float64)
                lam, V = spla.eigsh(S, k=kk, sigma=sigma, which="LM", OPinv=op, tol=_ARPACK_TOL,
                                    v0=rng.standard_normal(n), ncv=min(n, 2 * kk + 1))
                whole = False
            if whole or sigma == x or np.min(lam) < x:
                break
            sigma = x + 0.5 * (sigma - x) if attempt < 10 else x   # a hole above x: lower
        else:
            raise _Fail(f"no shift above {x:.6g} reached the slice edge")
        theta, Q, WQ, radius, resid, phi = _ritz(S, W, V, normS, normW)
        above = theta > x
        if not whole and np.max(theta) <= x:
            raise _Fail(f"no Ritz value above the slice edge {x:.6g}")
        theta, Q, WQ, resid = theta[above], Q[:, above], WQ[:, above], resid[above]
        if theta[0] - x <= 2 * (radius + fz_x):
            raise _Fail(f"slice edge {x:.9g} within {2 * (radius + fz_x):.3g} of a Ritz value")
        reach = np.max(lam) if not whole else math.inf
        if whole or cnt_x + theta.size >= n:
            y = float(theta[-1]) + max(1.0, abs(float(theta[-1]))) * 1e-3 + 2 * radius + 1.0
            cands = [(y, theta.size)]
        else:
            # all eigenvalues up to the largest |lam - sigma| are found; edges in the
            # widest gaps of the upper quarter of what lies below that reach
            ok = theta < reach
            th = theta[ok]
            lo_i = max(1, (th.size * 3) // 4)
            gaps = np.diff(th[lo_i - 1:])
            order = np.argsort(gaps)[::-1][:8]
            cands = [(0.5 * (th[lo_i - 1 + j] + th[lo_i + j]), lo_i + j) for j in order]
        for y, nkeep in cands:
            try:
                cnt_y, fz, lu_y = count_below(S, y)
            except ValueError:
                continue
            d = min(abs(theta - y))
            if d > 2 * (radius + fz) and cnt_y - cnt_x == nkeep:
                break
        else:
            raise _Fail(f"no certified edge above {x:.9g}: inertia count and Ritz values "
                        f"differ or the edge is within the Ritz radius {radius:.3g} + "
                        f"inertia fuzz of a Ritz value")
        stats.fuzz = max(stats.fuzz, fz)
        stats.slices += 1
        stats.ritz_radius = max(stats.ritz_radius, radius)
        keep = slice(0, nkeep)
        width = float(theta[nkeep - 1] - theta[0]) * k / max(nkeep - 1, 1)
        yield _Slice(x, y, theta[keep], Q[:, keep], WQ[:, keep], radius, resid[keep], phi)
        x, cnt_x, fz_x = y, cnt_y, fz
