"""Sylvester counts of a sparse symmetric matrix: its eigenvalues below a shift.

:func:`count_below` counts the eigenvalues of a symmetric S below a shift a
from a sparse LDL^T factorization of S - a I, with a rigorous bound of how
far that count can be off (its *fuzz*); :class:`Shifts` factorizes S - a I
at many shifts with one ordering, for the counts and for the shift-invert
solves of the slices (:mod:`.slices`; where the factor is dense, as for
large sphere packings, the solves use SuperLU's supernodal LU instead,
:class:`SymmetricLU`, and the counts the multifrontal LDL^T of
:class:`~.supernodal.SupernodalLDL`, both in SuperLU's order);
:func:`norm1` and :func:`norm2_skew` bound the norms the verdict needs. The proof they serve:
:mod:`remote_trigger.analysis.stability.sliced` (*Counting*).
"""
from __future__ import annotations

import ctypes
import functools
import math
import os

import numpy as np
import qdldl
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from remote_trigger.analysis.stability.enclosure import TINY, U, gamma
from remote_trigger.analysis.stability.sliced.numerics import INFLATE, SliceFailure
from remote_trigger.analysis.stability.sliced.stats import SlicedStats
from remote_trigger.analysis.stability.sliced.supernodal import SupernodalLDL

__all__ = ["count_below", "count_below_dw", "Shifts", "SymmetricLU", "shifted", "norm1",
           "norm2_skew", "U_DW", "DW_FUZZ_FRACTION", "fuzz_limit", "SUPERNODAL_FILL"]

#: Relative error bound of every double-word operation of the factorization of
#: :func:`count_below_dw` (``ldl_dd.cpp``): addition (AccurateDWPlusDW) 3 u^2 +
#: 13 u^3, multiplication (DWTimesDW1 with FMA) 4 u^2, division (DWDivDW2)
#: 15 u^2 + 56 u^3 (Joldes, Muller and Popescu, ACM TOMS 44(2), 2017; Muller
#: and Rideau, ACM TOMS 48(1), 2022), all below 16 u^2.
U_DW = 16.0 * U * U

#: A float64 count whose fuzz exceeds this fraction of the mean eigenvalue
#: spacing of S (bounded above by 2 ||S|| / n: :func:`fuzz_limit`) is counted
#: again in double-word arithmetic by :meth:`Shifts.count_below`; below it, a
#: slice edge that only the float64 fuzz keeps too close to a Ritz value is
#: counted again too (:mod:`.slices`), so the fraction decides cost, not the
#: proof. Measured (docs/results/analysis.md, "Counting in double-word
#: arithmetic" and "Spheres at N = 2560: where a slice's time goes"): the
#: float64 fuzz is 0.1-0.6 % of that spacing at three places of an N = 10^4
#: disk spectrum, 20-180 % at N = 10^5, 1-2.2 % over most of the spectrum of
#: spheres at N = 2560, where a double-word count costs 15 s (twice a slice):
#: there four slices took 22.5-24 s each at 1 %, 6.6-7.2 s at 10 % (one
#: 20.9 s: its edge needed a double-word count), with the same edges.
DW_FUZZ_FRACTION = 0.1


#: Entries of the factor per row (SuperLU's ``nnz`` / 2n at the first shift,
#: in its own order) from which :class:`Shifts` makes its shift-invert
#: factorizations with SuperLU's supernodal LU (:class:`SymmetricLU`) instead
#: of QDLDL's LDL^T. Measured (docs/results/analysis.md, "Spheres at N = 2560:
#: where a slice's time goes"; benchmarks/bench_sphere_factor.py): at 41 per
#: row (disks, N = 6400) QDLDL refactorizes in 0.035 s, SuperLU in 0.048 s; at
#: 65 (spheres, N = 160) 0.002 s against 0.003 s; at 143-145 (spheres,
#: N = 640) 0.035 s against 0.029 s on idle cores but 0.034-0.040 s against
#: 0.045-0.049 s beside other jobs, and a whole scan took 16.1 s with
#: QDLDL's solves, 16.9 s with SuperLU's; at 401 (spheres, N = 2560) 4.7 s
#: against 1.0 s, a solve 15.6 ms against 10.4 ms. The threshold lies
#: between the last two.
SUPERNODAL_FILL = 200.0


def fuzz_limit(normS, n):
    """The fuzz above which :class:`Shifts` counts in double-word arithmetic:
    :data:`DW_FUZZ_FRACTION` x 2 ``normS`` / ``n`` (``normS`` >= ||S||_2, n the
    dimension of S)."""
    return DW_FUZZ_FRACTION * 2.0 * float(normS) / max(int(n), 1)


def shifted(S, a):
    """S - a I (CSC) with every diagonal entry stored, zero or not (QDLDL needs them)."""
    C = sp.coo_matrix(S)
    n = C.shape[0]
    off = C.row != C.col
    i = np.arange(n)
    return sp.coo_matrix((np.concatenate([C.data[off], S.diagonal() - a]),
                          (np.concatenate([C.row[off], i]), np.concatenate([C.col[off], i]))),
                         shape=C.shape).tocsc()


def _ldl(H, what, upper=False):
    """QDLDL's P^T H P = (I + L) D (I + L)^T of a symmetric H (AMD ordering, no
    pivoting); ``upper``: H is given by its upper triangle (CSC), which is all
    QDLDL reads (given the whole H, it takes that triangle itself)."""
    try:
        return qdldl.Solver(H, upper=upper)
    except RuntimeError as exc:      # a zero pivot (QDLDL: "not quasi-definite")
        raise SliceFailure(f"no LDL^T factorization of {what}: {exc}") from None


def _diagonal_at(H):
    """Where the diagonal of the CSC H (every diagonal entry stored) sits in ``H.data``."""
    cols = np.repeat(np.arange(H.shape[0]), np.diff(H.indptr))
    on = H.indices == cols
    return np.nonzero(on)[0][np.argsort(cols[on], kind="stable")]


class SymmetricLU:
    """SuperLU's supernodal P^T H P = L U of a symmetric H, without pivoting,
    for solves with H.

    Parameters
    ----------
    H : scipy.sparse.csc_matrix, shape (n, n)
        Symmetric, float64, every diagonal entry stored (:func:`shifted`).
    perm : ndarray of int, shape (n,), optional
        The elimination order: the matrix factorized is H[perm][:, perm].
        Default None: SuperLU's minimum degree ordering of H + H^T
        (``MMD_AT_PLUS_A``), which depends only on H's pattern.
    what : str
        Names the matrix in an error.

    Attributes
    ----------
    lu : scipy.sparse.linalg.SuperLU
    perm : ndarray of int, shape (n,)
        The whole elimination order: L U = H[perm][:, perm].

    Raises
    ------
    SliceFailure
        If SuperLU met an exactly singular column or took an off-diagonal
        pivot (a zero pivot on the diagonal).

    Notes
    -----
    ``diag_pivot_thresh = 0`` and ``SymmetricMode`` make SuperLU take every
    diagonal entry as its pivot (checked: its row and column permutations are
    equal) and ``Equil = False`` keeps H unscaled: the elimination of QDLDL's
    LDL^T in another order, in dense blocks (supernodes). Given ``perm``,
    SuperLU's own order of the permuted matrix (its postorder of the
    elimination tree, the identity where ``perm`` is SuperLU's) depends only
    on the pattern, so the factors at a shift do not depend on what was
    factorized before (as ``qdldl.Solver.update``). No Sylvester count is
    taken from it: its L and U are two roundings of one factor, and the
    bound of :func:`count_below` does not cover their difference (measured at
    N = 2560 spheres: a bound ~100 x QDLDL's).
    """

    def __init__(self, H, perm=None, what="S - a I"):
        X = H if perm is None else sp.csc_matrix(H[perm][:, perm])
        try:
            lu = spla.splu(X, permc_spec="MMD_AT_PLUS_A" if perm is None else "NATURAL",
                           diag_pivot_thresh=0.0, options=dict(SymmetricMode=True, Equil=False))
        except RuntimeError as exc:     # "Factor is exactly singular"
            raise SliceFailure(f"no LDL^T factorization of {what}: {exc}") from None
        if not np.array_equal(lu.perm_r, lu.perm_c):
            raise SliceFailure(f"no LDL^T factorization of {what}: an off-diagonal pivot "
                               f"(a zero pivot on the diagonal)")
        order = np.argsort(lu.perm_c)           # L U = X[order][:, order]
        self.lu = lu
        self._given = perm is not None
        self.perm = np.asarray(perm)[order] if self._given else order

    @property
    def fill(self):
        """Entries of the factor per row: SuperLU's ``nnz`` (L and U) / 2n."""
        return self.lu.nnz / (2.0 * max(self.lu.shape[0], 1))

    def solve(self, b):
        """x with H x = b; b of shape (n,)."""
        if not self._given:
            return self.lu.solve(b)
        x = np.empty(b.shape[0], dtype=np.float64)
        x[self.perm] = self.lu.solve(np.ascontiguousarray(b[self.perm], dtype=np.float64))
        return x


class Shifts:
    """Factorizations of S - a I for many shifts a, for counting and for
    shift-invert solves, the ordering computed once.

    S - a I has the same pattern for every a. Which factorizations are made
    is decided once, at the first shift (:meth:`count_below` or
    :meth:`factor_checked`), by the fill of SuperLU's factor of S - a I in
    its own minimum degree order (a property of the pattern; ``solves`` says
    which, ``'qdldl'`` or ``'superlu'``):

    * up to :data:`SUPERNODAL_FILL` entries per row (disks; spheres up to
      N ~ 1000), QDLDL's: its AMD ordering and elimination tree are those of
      the first factorization, and ``Solver.update`` redoes only the
      numerical factorization, with factors bitwise those of a new
      ``Solver`` (the same permutation, L, D and solves: checked on the
      N = 10^4 matrices and in the tests) in ~0.75 of its time at
      n = 28 800. ``update`` does not report a zero pivot (a new ``Solver``
      raises): D then holds a zero, which :func:`count_below` refuses, and
      the factors after it are those of the previous shift, which
      :meth:`factor_checked` sees in the residual of a probe solve. The
      counts and the shift-invert solves of a slice use the same object;
      each call overwrites the previous factorization.
    * above it (large sphere packings), SuperLU's order ``order`` for
      everything: the shift-invert factorizations are :class:`SymmetricLU`
      in that order, made anew at each shift; the counts are those of a
      :class:`~.supernodal.SupernodalLDL` in the same order (the multifrontal
      LDL^T, with :func:`count_below`'s fuzz bound).

    ``fuzz_limit`` (default: none): a count whose float64 fuzz exceeds it is
    made again by :func:`count_below_dw` in the same ordering (``perm``;
    the float64 factorization is kept for the solves). ``stats.dw_counts``
    (a :class:`~.stats.SlicedStats`, a new one if none is given) counts
    every count made in double-word arithmetic, whether :meth:`count_below`
    or a caller asked for it (:meth:`count_below_dw`); :attr:`dw_counts`
    reads it.
    """

    def __init__(self, S, fuzz_limit=math.inf, stats=None):
        self.S = S
        self.fuzz_limit = float(fuzz_limit)
        self.stats = SlicedStats() if stats is None else stats
        self.perm = None          # the order of the counts (QDLDL's AMD, or ``order``)
        self.H = shifted(S, 0.0)
        # where the diagonal sits in H's data (every diagonal entry is stored);
        # QDLDL's factorizations read the upper triangle Hu, kept beside H
        self.diag_at = _diagonal_at(self.H)
        self.diag = self.H.data[self.diag_at].copy()
        self.Hu = sp.triu(self.H, format="csc")
        self.diag_at_u = _diagonal_at(self.Hu)
        self.solver = None
        self.held = None          # the shift of the QDLDL factorization ``solver`` holds
        self.solves = None        # 'qdldl' or 'superlu', decided at the first shift
        self.order = None         # SuperLU: the elimination order of every factorization
        self.supernodal = None    # SuperLU: the counts' SupernodalLDL
        self.probe = math.nan

    @property
    def dw_counts(self):
        """Counts made in double-word arithmetic so far (``stats.dw_counts``)."""
        return self.stats.dw_counts

    def _decide(self, a, what="S - a I"):
        """``solves`` (and ``order``) from SuperLU's factor of S - a I, once."""
        if self.solves is not None:
            return
        self.H.data[self.diag_at] = self.diag - a
        try:
            first = SymmetricLU(self.H, what=what)
        except SliceFailure:
            first = None        # QDLDL decides (its own ordering)
        if first is not None and first.fill > SUPERNODAL_FILL:
            self.solves, self.order = "superlu", first.perm
        else:
            self.solves = "qdldl"

    def factor(self, a, what="S - a I"):
        """QDLDL's factorization of S - a I (``what`` names it in an error)."""
        self.H.data[self.diag_at] = self.diag - a
        self.Hu.data[self.diag_at_u] = self.diag - a
        self.held = None
        if self.solver is None:
            self.solver = _ldl(self.Hu, what, upper=True)
        else:
            self.solver.update(self.Hu, upper=True)
        self.held = a
        return self.solver

    def count(self, a):
        """The float64 Sylvester count of S below a and its fuzz (:func:`count_below`'s,
        or :class:`~.supernodal.SupernodalLDL`'s where ``solves`` is 'superlu').
        Where QDLDL's factorization of S - a I is the one held (``held`` == a:
        the last shift factorized, as after a slice's solves there), it is
        counted without a new factorization (the same factors either way).

        Raises
        ------
        ValueError
            At a zero pivot (no inertia in this order).
        SliceFailure
            If QDLDL refuses the factorization (a zero pivot).
        """
        self._decide(a)
        if self.solves == "superlu":
            if self.supernodal is None:
                self.supernodal = SupernodalLDL(self.S, self.order)
                self.perm = self.order
            return self.supernodal.count_below(a)
        fac = self.solver if self.held == a else self.factor(a)
        return count_below(self.S, a, fac)[:2]

    def count_below(self, a):
        """:meth:`count` at a, made again by :meth:`count_below_dw` where its
        fuzz exceeds ``fuzz_limit``: (count, fuzz)."""
        cnt, fz = self.count(a)
        if fz > self.fuzz_limit:
            cnt, fz = self.count_below_dw(a)
        return cnt, fz

    def count_at_hand(self, a):
        """:meth:`count` at a where it is at hand and usable: None where each
        count is a factorization of its own (``solves`` 'superlu') or the
        float64 count's fuzz exceeds ``fuzz_limit`` (it would be made again in
        double-word arithmetic by :meth:`count_below`). Raises as :meth:`count`."""
        self._decide(a)
        if self.solves == "superlu":
            return None
        cnt, fz = self.count(a)
        return None if fz > self.fuzz_limit else (cnt, fz)

    def count_below_dw(self, a):
        """:func:`count_below_dw` of S at a, in the ordering of the float64
        counts (one is made first if none was): (count, fuzz)."""
        self._decide(a)
        if self.perm is None:
            if self.solves == "superlu":
                self.perm = self.order
            else:
                if self.solver is None:
                    self.factor(a)
                self.perm = self.solver.factors()[2]
        self.stats.dw_counts += 1
        return count_below_dw(self.S, a, self.perm)

    def factor_checked(self, a, what="S - a I"):
        """A factorization of S - a I for solves (shift-invert).

        Where ``solves`` is 'superlu', a new :class:`SymmetricLU` in
        ``order``, which refuses a zero pivot itself; its probe residual is
        left in ``self.probe`` as below. Otherwise :meth:`factor`'s, checked
        by a probe solve: ``Solver.update`` does not report a zero pivot (a
        new ``Solver`` raises); it then stops there and leaves the rest of the
        factors of the previous shift. A probe whose residual is not small
        takes a new factorization instead (bitwise the same factors where
        there is no zero pivot), which refuses a zero pivot
        (:class:`~.numerics.SliceFailure`, naming ``what``). The probe's
        residual ||(S - a I) x - 1|| / ||1|| of the factorization returned is
        left in ``self.probe`` (a tiny pivot's growth of D makes it large:
        :func:`~.slices.shift_invert` then moves the shift).
        """
        n = self.S.shape[0]
        self._decide(a, what)
        self.H.data[self.diag_at] = self.diag - a
        if self.solves == "superlu":
            # in the first factorization's order at every shift, the first
            # one included: the factors do not depend on what came before
            fac = SymmetricLU(self.H, self.order, what)
        else:
            fac = self.factor(a, what)
        one = np.ones(n)

        def probe(fac):
            x = fac.solve(one)
            if not np.all(np.isfinite(x)):
                return math.inf
            return float(np.linalg.norm(self.H @ x - one)) / math.sqrt(n)

        self.probe = probe(fac)
        if not self.probe <= 1e-6 and self.solves == "qdldl":
            self.held = None        # ``solver`` holds the update that went wrong
            fac = _ldl(self.Hu, what, upper=True)
            self.probe = probe(fac)
        return fac


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
        factor = factor or _ldl(shifted(S, a), "S - a I")
    except SliceFailure as exc:
        raise ValueError(f"no inertia of S - a I at a = {a!r}: {exc}") from None
    L, d, _ = factor.factors()
    if not np.all(np.isfinite(d)) or np.any(d == 0):
        raise ValueError(f"no inertia of S - a I at a = {a!r}: zero pivot")
    aL = abs(sp.csc_matrix(L))      # L strictly lower: the unit diagonal is not stored
    # entries of I + L per column and per row
    depth = 1 + int(max(np.max(np.diff(aL.indptr), initial=0),
                        np.max(np.bincount(aL.indices, minlength=n), initial=0)))
    t = np.abs(d) * (1.0 + aL.T @ np.ones(n))     # |D| |I + L|^T 1
    rows = t + aL @ t                              # |I + L| |D| |I + L|^T 1
    diag_err = U * float(np.max(np.abs(S.diagonal() - a)))      # rounding of S_ii - a
    fuzz = (gamma(2 * depth + 4) * float(np.max(rows)) + diag_err) * INFLATE
    return int(np.count_nonzero(d < 0)), fuzz, factor


@functools.lru_cache(maxsize=None)
def _ldl_dd():
    """The compiled ``ldl_dd_inertia`` (``ldl_dd.cpp``, built with the package into
    ``native/``)."""
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "native", "libldl_dd.so")
    if not os.path.exists(path):
        raise RuntimeError(f"the double-word LDL^T library is missing: {path} (make install)")
    fn = ctypes.CDLL(path).ldl_dd_inertia
    i64p = ctypes.POINTER(ctypes.c_int64)
    f64p = ctypes.POINTER(ctypes.c_double)
    fn.argtypes = [ctypes.c_int64, i64p, i64p, f64p, ctypes.c_double, i64p, i64p, f64p]
    fn.restype = ctypes.c_int
    return fn


def count_below_dw(S, a, perm=None):
    """Sylvester count of the eigenvalues of the symmetric S below a, from a
    double-word LDL^T: the count of :func:`count_below` with a fuzz ~1e15 x smaller.

    Parameters
    ----------
    S : sparse matrix, shape (n, n)
        Symmetric, float64 (its upper triangle is used).
    a : float
        The shift.
    perm : ndarray of int, shape (n,), optional
        The elimination order (that of a QDLDL factorization of S - a I,
        ``Solver.factors()[2]``: the matrix factorized is (S - a I)[perm][:, perm]);
        default: the order of the rows.

    Returns
    -------
    count : int
        Number of negative pivots: the number of eigenvalues below a of a
        symmetric S + Z with ||Z||_2 <= fuzz.
    fuzz : float
        Rigorous bound of ||Z||_2 (same units as S).

    Raises
    ------
    ValueError
        If ``perm`` is not a permutation of range(n), or the factorization met
        a zero pivot (no inertia in this order).
    RuntimeError
        If the compiled library is missing or ran out of memory.

    Notes
    -----
    The factorization is :func:`count_below`'s (up-looking, no pivoting), with
    every operation in double-word arithmetic (``ldl_dd.cpp``), each with
    relative error at most :data:`U_DW` = 16 u^2 (the bounds assume no
    underflow: the entries of S and the pivots are far above 1e-290 here);
    S_ii - a is exact there.
    The analysis of :func:`count_below` with u replaced by U_DW gives
    |Z| <= gamma'_{2m+4} |I + L| |D| |I + L|^T (gamma' of U_DW). The row sums
    of that matrix are computed in float64 from the leading words of L and D;
    they are inflated by 1 + gamma_{4m+8} for that rounding and by
    :data:`~.numerics.INFLATE`. At N = 10^5 disks the float64 count's fuzz
    exceeds the eigenvalue spacing (docs/results/analysis.md, "A point at
    N = 10^5"), this one does not.
    """
    S = sp.csr_matrix(S)
    n = S.shape[0]
    if perm is None:
        perm = np.arange(n)
    perm = np.asarray(perm)
    if perm.shape != (n,) or not np.array_equal(np.sort(perm), np.arange(n)):
        raise ValueError(f"perm must be a permutation of range({n}), got shape {perm.shape}")
    # the upper triangle of S[perm][:, perm], every diagonal entry stored
    C = sp.coo_matrix(S)
    inv = np.empty(n, dtype=np.int64)
    inv[perm] = np.arange(n)
    r, c = inv[C.row], inv[C.col]
    up = r < c
    i = np.arange(n)
    H = sp.csc_matrix((np.concatenate([C.data[up], S.diagonal()[perm]]),
                       (np.concatenate([r[up], i]), np.concatenate([c[up], i]))), shape=(n, n))
    H.sort_indices()
    Ap = np.ascontiguousarray(H.indptr, dtype=np.int64)
    Ai = np.ascontiguousarray(H.indices, dtype=np.int64)
    Ax = np.ascontiguousarray(H.data, dtype=np.float64)
    i64 = ctypes.POINTER(ctypes.c_int64)
    f64 = ctypes.POINTER(ctypes.c_double)
    neg, depth, max_row = ctypes.c_int64(), ctypes.c_int64(), ctypes.c_double()
    rc = _ldl_dd()(n, Ap.ctypes.data_as(i64), Ai.ctypes.data_as(i64), Ax.ctypes.data_as(f64),
                   float(a), ctypes.byref(neg), ctypes.byref(depth), ctypes.byref(max_row))
    if rc == -1:
        raise RuntimeError(f"out of memory in the double-word LDL^T of S - a I (n = {n})")
    if rc != 0:
        raise ValueError(f"no inertia of S - a I at a = {a!r}: zero pivot (double-word, row {rc - 1})")
    m = int(depth.value)
    rows = float(max_row.value) * (1.0 + gamma(4 * m + 8)) + (4 * m + 8) * TINY
    return int(neg.value), gamma(2 * m + 4, U_DW) * rows * INFLATE


def norm1(X):
    """Rigorous upper bound of ||X||_1 (the largest column sum of |X|, rounding included)."""
    return float(abs(X).sum(axis=0).max()) * (1 + gamma(X.shape[0]))


def _augmented_count(W, aug, a):
    """:func:`count_below` of ``aug`` = [[0, W], [W^T, 0]] at a: (count, fuzz).

    Where the pattern of W fills its factor densely (SuperLU's factor of
    |W| + |W|^T + diag(its row sums + 1), a matrix with that pattern and no
    zero pivot, has more than :data:`SUPERNODAL_FILL` entries per row: large
    sphere packings), the count is :class:`~.supernodal.SupernodalLDL`'s in
    the order that eliminates i and n + i one after the other, i in
    SuperLU's order (the same bound; measured at N = 2560 spheres:
    ``norm2_skew`` 23.5 s in all where QDLDL's count alone took 86.4 s,
    docs/results/analysis.md); elsewhere QDLDL's.
    """
    n = W.shape[0]
    P = abs(sp.csc_matrix(W))
    P = P + P.T
    P = sp.csc_matrix(P + sp.diags(np.asarray(P.sum(axis=1)).ravel() + 1.0))
    try:
        lu = SymmetricLU(P, what="the pattern of |W| + |W|^T")
    except SliceFailure:
        lu = None
    if lu is None or lu.fill <= SUPERNODAL_FILL:
        return count_below(aug, a)[:2]
    perm = np.empty(2 * n, dtype=np.int64)
    perm[0::2], perm[1::2] = lu.perm, lu.perm + n
    return SupernodalLDL(aug, perm).count_below(a)


def norm2_skew(W):
    """Rigorous upper bound of ||W||_2 for a skew W: ||W||_1 (= ||W||_inf), sharpened
    by the inertia of [[t I, W], [W^T, t I]] (eigenvalues t +- sigma_i(W))."""
    crude = norm1(W)
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
        cnt, fuzz = _augmented_count(W, aug, -t)
    except (ValueError, SliceFailure):
        return crude
    # the augmented matrix minus (-t) ... shifted: eigenvalues of aug are +- sigma_i,
    # so no eigenvalue below -t - fuzz means ||W|| <= t + fuzz
    return min(crude, (t + fuzz) * (1 + 4 * U)) if cnt == 0 else crude

