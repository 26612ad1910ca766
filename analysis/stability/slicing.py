"""Sylvester counts and Ritz slices of a sparse symmetric matrix (for the sliced verdict).

:func:`count_below` counts the eigenvalues of a symmetric S below a shift
from a sparse factorization, with a rigorous bound of how far that count can
be off (its *fuzz*); :func:`_slices` computes S's eigenpairs slice by slice
with ARPACK shift-invert and checks every slice against two such counts, so
that no eigenvalue is missed; :func:`_arpack_hint` says what ARPACK sees in
a strip the verdict leaves undecided (a note, not certified). The proof they serve and how they are used:
:mod:`remote_trigger.analysis.stability.sliced`.
"""
from __future__ import annotations

from dataclasses import dataclass, field
import math

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
import qdldl

from remote_trigger.analysis.stability.enclosure import U, gamma

__all__ = ["count_below", "SlicedStats"]

_INFLATE = 1.0 + 1e-10          # inflation of computed sums of nonnegative terms
_ARPACK_TOL = 1e-8              # ARPACK stopping tolerance (only the checked residuals matter)
# shift-invert shift above a slice's lower edge, in slice widths: the k pairs
# nearest it reach ~0.08 of a width below the edge (pairs computed twice); a
# shift too high misses the edge and the slice is computed again. Measured
# (docs/results/analysis.md, "The shift of a slice"): pairs computed for the
# n kept at N = 1600 / 6400 / 10^4, 1.38 / 1.35 / 1.34 n at 0.35, 1.32 /
# 1.24 / 1.25 n at 0.42 (3, 0 and 4 misses); at 0.46, 17 misses at N = 6400
_SHIFT_FRACTION = 0.42
# ARPACK's Lanczos basis: NCV = _NCV_FACTOR k + 1 vectors for the k pairs of a
# slice (scipy's default is 2k + 1). A shorter basis restarts more often but
# each restart and reorthogonalization moves fewer vectors: measured
# (docs/results/analysis.md, "The Lanczos basis of a slice"), CPU of a
# certified-real scan at N = 6400: 252 s at 2k + 1, 200 s at 1.4 k + 1 (side
# by side; QDLDL solves 8 % fewer), 238 s at 1.2 k + 1, 224 s at 1.6 k + 1;
# at N = 10^4 664 s and 587 s side by side; at N = 1600 8.2-8.6 s at 2k + 1,
# 7.4-7.6 s at 1.33-1.5 k + 1
_NCV_FACTOR = 1.4
# a slice whose Kahan radius exceeds this fraction of its mean Ritz value
# spacing is computed again about a moved shift (docs/results/analysis.md, "A
# shift at a tiny pivot"): at N = 10^4 the first 100 slices of a real point at
# F_x = 1.25e-4 have radii 3e-5 - 6e-5 of their spacing, the slice about such a
# shift 0.012
_REFINE = 1e-3


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
    arpack_runs : int
        Shift-invert eigen-solves (a slice whose shift missed its lower edge
        takes more than one).
    computed : int
        Eigenpairs computed by those solves (n of them are kept).
    reshifted : int
        Slices computed again about a shift moved by 1 % of their span (their
        Kahan radius above ``_REFINE`` times their mean Ritz value spacing:
        inexact solves at a shift where the factorization met a tiny pivot).
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
    arpack_runs: int = 0
    computed: int = 0
    reshifted: int = 0


# --------------------------------------------------------------------------- counting
def _shifted(S, a):
    """S - a I (CSC) with every diagonal entry stored, zero or not (QDLDL needs them)."""
    C = sp.coo_matrix(S)
    n = C.shape[0]
    off = C.row != C.col
    i = np.arange(n)
    return sp.coo_matrix((np.concatenate([C.data[off], S.diagonal() - a]),
                          (np.concatenate([C.row[off], i]), np.concatenate([C.col[off], i]))),
                         shape=C.shape).tocsc()


def _ldl(H, what):
    """QDLDL's P^T H P = (I + L) D (I + L)^T of a symmetric H (AMD ordering, no pivoting)."""
    try:
        return qdldl.Solver(H)
    except RuntimeError as exc:      # a zero pivot (QDLDL: "not quasi-definite")
        raise _Fail(f"no LDL^T factorization of {what}: {exc}") from None


class _Shifts:
    """Factorizations of S - a I for many shifts a, for counting and for
    shift-invert solves, the ordering computed once.

    S - a I has the same pattern for every a, so QDLDL's AMD ordering and
    elimination tree are those of the first factorization; ``Solver.update``
    redoes only the numerical factorization, with factors bitwise those of a
    new ``Solver`` (the same permutation, L, D and solves: checked on the
    N = 10^4 matrices and in the tests) in ~0.75 of its time at n = 28 800.
    ``update`` does not report a zero pivot (a new ``Solver`` raises): D then
    holds a zero, which :func:`count_below` refuses, and the factors after it
    are those of the previous shift, which :func:`_shift_invert` sees in the
    residual of a probe solve. The shift-invert solves of a slice use the same
    object. Each call overwrites the previous factorization.
    """

    def __init__(self, S):
        self.S = S
        self.H = _shifted(S, 0.0)
        # where the diagonal sits in H's data (every diagonal entry is stored)
        H = self.H
        cols = np.repeat(np.arange(H.shape[0]), np.diff(H.indptr))
        on = H.indices == cols
        self.diag_at = np.nonzero(on)[0][np.argsort(cols[on], kind="stable")]
        self.diag = H.data[self.diag_at].copy()
        self.solver = None

    def factor(self, a, what="S - a I"):
        """The factorization of S - a I (``what`` names it in an error)."""
        self.H.data[self.diag_at] = self.diag - a
        if self.solver is None:
            self.solver = _ldl(self.H, what)
        else:
            self.solver.update(self.H)
        return self.solver

    def count_below(self, a):
        """:func:`count_below` of S (the matrix of the constructor) at a."""
        return count_below(self.S, a, self.factor(a))


def count_below(S, a, factor=None):
    """Sylvester count of the eigenvalues of the symmetric S below a, with its fuzz.

    Parameters
    ----------
    S : sparse matrix, shape (n, n)
        Symmetric, float64.
    a : float
        The shift.
    factor : qdldl.Solver, optional
        A factorization of S - a I made by this module (reused).

    Returns
    -------
    count : int
        Number of negative pivots: the number of eigenvalues below a of a
        symmetric S + Z with ||Z||_2 <= fuzz, hence between the counts of S
        below a - fuzz and below a + fuzz.
    fuzz : float
        Rigorous bound of ||Z||_2 (same units as S).
    factor : qdldl.Solver
        The factorization (for solves with S - a I).

    Raises
    ------
    ValueError
        If the factorization met a zero pivot (a is an eigenvalue of a
        leading block: no inertia from this ordering).

    Notes
    -----
    The factorization is QDLDL's up-looking P^T (S - a I) P = (I + L) D
    (I + L)^T, a genuine LDL^T (one triangle, one D). Each computed entry of
    L and D is an inner product of at most m terms (m the largest row or
    column count of I + L), a division and a reciprocal, so the computed
    factors satisfy (I + L) D (I + L)^T = P^T (S - a I) P + Z exactly with
    |Z| <= gamma_{m+3} |I + L| |D| |I + L|^T entrywise (the analysis of
    Cholesky, Higham, *Accuracy and Stability of Numerical Algorithms*,
    2nd ed., Thm. 10.3; gamma_{2m+4} is used, a margin of two). Z is
    symmetric, so ||Z||_2 <= ||Z||_inf, bounded by the largest row sum; the
    rounding of the diagonal S_ii - a adds u max|S_ii - a|. By Sylvester's
    law of inertia the count of negative d_i is that of S - a I + P Z P^T.
    """
    n = S.shape[0]
    try:
        factor = factor or _ldl(_shifted(S, a), "S - a I")
    except _Fail as exc:
        raise ValueError(f"no inertia of S - a I at a = {a!r}: {exc}") from None
    L, d, _ = factor.factors()
    if not np.all(np.isfinite(d)) or np.any(d == 0):
        raise ValueError(f"no inertia of S - a I at a = {a!r}: zero pivot")
    aL = (abs(sp.csc_matrix(L)) + sp.identity(n, format="csc")).tocsc()
    depth = int(max(np.max(np.diff(aL.indptr)), np.max(np.bincount(aL.indices, minlength=n))))
    one = np.ones(n)
    rows = aL @ (np.abs(d) * (aL.T @ one))       # |I + L| |D| |I + L|^T 1
    diag_err = U * float(np.max(np.abs(S.diagonal() - a)))      # rounding of S_ii - a
    fuzz = (gamma(2 * depth + 4) * float(np.max(rows)) + diag_err) * _INFLATE
    return int(np.count_nonzero(d < 0)), fuzz, factor


def _norm1(X):
    return float(abs(X).sum(axis=0).max()) * (1 + gamma(X.shape[0]))


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
    """Rayleigh-Ritz of S on span(Q); vectors, values, radius, residuals, phi.

    Q is ARPACK's (or LAPACK's) orthonormal to working precision; it is
    orthonormalized again (QR) only where it is not, to 1e-10 in the Frobenius
    norm (the bounds below hold for any Q: phi measures what is left).
    """
    k = Q.shape[1]
    if np.linalg.norm(Q.T @ Q - np.eye(k)) > 1e-10:
        Q, _ = np.linalg.qr(Q)
    H = Q.T @ (S @ Q)
    theta, Y = np.linalg.eigh((H + H.T) / 2)
    Q = Q @ Y
    SQ = S @ Q
    R = SQ - Q * theta
    n, k = Q.shape
    G = Q.T @ Q - np.eye(k)
    phi = (np.linalg.norm(G) + gamma(n) * k) * _INFLATE
    round_r = gamma(n + 2) * (normS + float(np.max(np.abs(theta)))) * math.sqrt(k)
    resid = (np.linalg.norm(R, axis=0) + round_r) * _INFLATE
    # Kahan for the exactly orthonormal Q (Q^T Q)^{-1/2}: ||R|| (1 + phi) + 2 phi |theta|
    radius = (math.sqrt(float(np.sum(resid ** 2))) * (1 + phi)
              + 2 * phi * float(np.max(np.abs(theta)))) * _INFLATE
    return theta, Q, W @ Q, radius, resid, phi


@dataclass
class _Position:
    """Where the slicing stands between two slices (pickled at a checkpoint).

    x is the next slice's lower edge, ``count`` the Sylvester count of S
    below it and ``fuzz`` that count's fuzz; ``rng`` draws ARPACK's start
    vectors; ``width`` is the estimated width of a slice (None before the
    first).
    """

    x: float
    count: int
    fuzz: float
    rng: np.random.Generator
    width: float | None = None


def _start(S, lo0, stats):
    """The position below the spectrum: no eigenvalue of S below ``lo0``, counted."""
    cnt, fz, _ = count_below(S, lo0)
    if cnt != 0:
        raise _Fail(f"{cnt} eigenvalues of S below the Gershgorin bound {lo0:.6g}")
    stats.fuzz = max(stats.fuzz, fz)
    return _Position(lo0, 0, fz, np.random.default_rng(12345))


def _shift_invert(S, shifts, sigma, k, rng, stats):
    """ARPACK's k eigenpairs of S nearest sigma (shift-invert with QDLDL's
    factorization of S - sigma I from ``shifts``, a :class:`_Shifts` of S,
    start vector drawn from ``rng``)."""
    n = S.shape[0]
    what = f"S - sigma I at sigma = {sigma:.9g}"
    fac = shifts.factor(sigma, what)
    # Solver.update does not report a zero pivot (a new Solver raises); it
    # then stops there and leaves the rest of the factors of the previous
    # shift. A probe solve whose residual is not small takes a new
    # factorization instead (bitwise the same factors where there is no zero
    # pivot), which refuses a zero pivot
    one = np.ones(n)
    x = fac.solve(one)
    if not (np.all(np.isfinite(x)) and np.linalg.norm(shifts.H @ x - one) <= 1e-6 * math.sqrt(n)):
        fac = _ldl(_shifted(S, sigma), what)
    op = spla.LinearOperator((n, n), matvec=fac.solve, dtype=np.float64)
    lam, V = spla.eigsh(S, k=k, sigma=sigma, which="LM", OPinv=op, tol=_ARPACK_TOL,
                        v0=rng.standard_normal(n), ncv=min(n, int(_NCV_FACTOR * k) + 1))
    stats.arpack_runs += 1
    stats.computed += lam.size
    return lam, V


def _slices(S, W, k, normS, normW, pos, stats):
    """Yield the Ritz slices of S from ``pos`` (a :class:`_Position`) upwards.

    Each slice: the k eigenvalues of S nearest a shift sigma (ARPACK
    shift-invert), sigma placed ``_SHIFT_FRACTION`` (0.42) of a slice above
    the previous upper edge x so that the k nearest reach below x (no hole:
    checked, and the count below proves it); the new upper edge y lies in the
    widest gap of the slice's upper part whose distance to its Ritz values
    exceeds the Ritz radius and the inertia fuzz; the inertia count of (x, y) must equal
    the number of Ritz values kept. ``pos`` is advanced to y before each
    slice is yielded, so that a scan saved after a slice resumes from it
    (:func:`~remote_trigger.analysis.stability.sliced.classify_sliced`,
    ``checkpoint_dir``) exactly as it would have gone on.
    """
    n = S.shape[0]
    rng = pos.rng
    shifts = _Shifts(S)
    while pos.count < n:
        x, cnt_x, fz_x, width = pos.x, pos.count, pos.fuzz, pos.width
        kk = min(k, n - 2)
        # the k nearest to sigma reach below x unless (x, sigma) holds more than
        # k/2 of them: sigma 0.42 of a slice above x leaves a margin for the
        # variation of the eigenvalue density (a miss costs a second ARPACK run)
        sigma = x if width is None else x + _SHIFT_FRACTION * width
        for attempt in range(12):
            if kk >= n - 2:
                lam, V = np.linalg.eigh(S.toarray())
                sel = lam > x
                lam, V = lam[sel], V[:, sel]
                whole = True
            else:
                lam, V = _shift_invert(S, shifts, sigma, kk, rng, stats)
                whole = False
            if whole or sigma == x or np.min(lam) < x:
                break
            sigma = x + 0.5 * (sigma - x) if attempt < 10 else x   # a hole above x: lower
        else:
            raise _Fail(f"no shift above {x:.6g} reached the slice edge")
        theta, Q, WQ, radius, resid, phi = _ritz(S, W, V, normS, normW)
        if not whole and radius > _REFINE * (theta[-1] - theta[0]) / max(theta.size - 1, 1):
            # a shift where QDLDL's elimination (no pivoting) met a tiny pivot:
            # the growth of D makes the solves inexact (N = 10^4: relative error
            # 4.5e-6, max |d| 1.1e13, inertia fuzz 1394 at one shift) and ARPACK
            # converges to vectors of that inexact operator whatever its
            # tolerance (residuals ~1e-3 on all 60). The slice is computed again
            # about a shift 1 % of its span lower (the window still reaches below
            # x), kept if its radius is smaller
            lam2, V = _shift_invert(S, shifts, sigma - 0.01 * float(theta[-1] - theta[0]), kk,
                                    rng, stats)
            stats.reshifted += 1
            better = _ritz(S, W, V, normS, normW)
            if better[3] < radius:
                lam = lam2
                theta, Q, WQ, radius, resid, phi = better
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
            # all eigenvalues up to the largest |lam - sigma| are found; edges in
            # gaps of what lies below that reach: the widest of the top sixth first
            # (the higher the edge, the fewer Ritz pairs are computed twice), then
            # the widest of the rest of the upper half
            th = theta[theta < reach]
            top = max(1, (th.size * 5) // 6)
            half = max(1, th.size // 2)
            cands = []
            for lo_i, hi_i in ((top, th.size), (half, top)):
                gaps = np.diff(th[lo_i - 1:hi_i])
                cands += [(0.5 * (th[lo_i - 1 + j] + th[lo_i + j]), lo_i + j)
                          for j in np.argsort(gaps)[::-1][:8]]
        for y, nkeep in cands:
            try:
                cnt_y, fz, _ = shifts.count_below(y)
            except (ValueError, _Fail):
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
        pos.width = float(theta[nkeep - 1] - theta[0]) * k / max(nkeep - 1, 1)
        pos.x, pos.count, pos.fuzz = y, cnt_y, fz
        yield _Slice(x, y, theta[keep], Q[:, keep], WQ[:, keep], radius, resid[keep], phi)


def _arpack_hint(A, a_lo, a_hi, m):
    """What ARPACK sees in an undecided strip [a_lo, a_hi] of m eigenvalues: a
    note for its reason, marked not certified ('' if ARPACK fails), and the
    estimates with real part in the strip (ndarray of complex, by real part).

    The 2 m + 6 eigenvalues of A nearest the strip's centre (shift-invert);
    those with real part in the strip are counted (a complex pair far from the
    real axis may be missed: the note says how many of the m were seen) and
    the complex ones named. Nothing is decided from it.
    """
    n = A.shape[0]
    k = min(2 * m + 6, n - 2)
    none = np.zeros(0, complex)
    if k < 1:
        return "", none
    c = 0.5 * (a_lo + a_hi)
    try:
        lu = spla.splu(sp.csc_matrix(A - c * sp.identity(n, format="csr")))
        op = spla.LinearOperator((n, n), matvec=lu.solve, dtype=float)
        # a fixed start vector: the note does not depend on earlier ARPACK calls
        nu = spla.eigs(op, k=k, which="LM", return_eigenvectors=False, maxiter=50 * n,
                       v0=np.random.default_rng(0).standard_normal(n))
    except (RuntimeError, spla.ArpackError):
        return "", none
    lam = c + 1.0 / nu
    inside = lam[(lam.real >= a_lo) & (lam.real <= a_hi)]
    cx = inside[inside.imag > 0]
    note = f"; ARPACK, not certified: {inside.size} of its {m} eigenvalues seen, "
    inside = inside[np.lexsort((inside.imag, inside.real))]
    if not cx.size:
        return note + "none complex", inside
    z = cx[int(np.argmax(cx.imag))]
    return note + f"{cx.size} complex pair(s), e.g. {z.real:.6g} +- {z.imag:.4g}i", inside


def top_eigenvalue(S):
    """ARPACK's largest eigenvalue of the symmetric S (an approximation; NaN if
    ARPACK does not converge)."""
    from scipy.sparse.linalg import ArpackError, eigsh

    if S.shape[0] < 10:
        return float(np.linalg.eigvalsh(S.toarray())[-1])
    v0 = np.random.default_rng(0).standard_normal(S.shape[0])
    try:
        return float(eigsh(S, k=1, which="LA", v0=v0, return_eigenvectors=False)[0])
    except ArpackError:         # ArpackNoConvergence included
        return math.nan
