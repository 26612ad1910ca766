"""Sylvester counts from a multifrontal (supernodal) LDL^T without pivoting.

Where the factor of S - a I is dense (sphere packings from N ~ 2000: ~400
entries of L per row), QDLDL's column-by-column LDL^T runs at ~1 Gflop/s and
a count takes seconds (4.7-5.4 s at N = 2560, docs/results/analysis.md,
"Spheres at N = 2560: where a slice's time goes"). :class:`SupernodalLDL`
makes the same elimination (one order, no pivoting, a genuine L D L^T of one
triangle) in dense blocks with BLAS: the columns of a supernode share their
row pattern, each is eliminated in a dense frontal matrix, and what it
leaves for the rest (the update matrix) is added into its parent's front
(the multifrontal method: Duff and Reid, ACM TOMS 9(3), 1983; Liu, SIAM
Review 34(1), 1992). Its count has the rigorous fuzz of
:func:`~.inertia.count_below` (Notes of :meth:`SupernodalLDL.count_below`).
:class:`~.inertia.Shifts` uses it where it makes its solves with SuperLU
(:data:`~.inertia.SUPERNODAL_FILL`).
"""
from __future__ import annotations

import math

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp

from remote_trigger.analysis.stability.enclosure import U, gamma
from remote_trigger.analysis.stability.sliced.numerics import INFLATE

__all__ = ["SupernodalLDL"]

# Fronts up to this many pivot columns are eliminated column by column (a
# Python loop of rank-one updates), wider ones split in two halves with a
# triangular solve and a matrix product between them.
_COLUMNWISE = 32

# A child's update matrix goes into its parent's front as blocks of runs of
# consecutive rows (a child's rows are mostly a few runs: a particle's dofs)
# while they are at most this many; past it, by one fancy-indexed addition.
_MAX_RUNS = 64


class _ZeroPivot(ValueError):
    """A pivot of the elimination is zero or not finite (no inertia in this order)."""


def _runs(e):
    """Where a child's update rows go in its parent's front (``e``: increasing
    local rows): the index array itself, or (if at most :data:`_MAX_RUNS`
    runs of consecutive rows) the runs as (start in the update, start in the
    front, length)."""
    cut = np.flatnonzero(np.diff(e) != 1) + 1
    if cut.size + 1 > _MAX_RUNS:
        return e
    starts = np.concatenate([[0], cut])
    ends = np.concatenate([cut, [e.size]])
    return [(int(a), int(e[a]), int(b - a)) for a, b in zip(starts, ends)]


def _extend_add(F, Uc, e):
    """F[e, e] += Uc on (at least) the lower triangle, e from :func:`_runs`."""
    if isinstance(e, np.ndarray):
        F[np.ix_(e, e)] += Uc
        return
    for i, (ui, fi, ni) in enumerate(e):
        for uj, fj, nj in e[:i + 1]:
            F[fi:fi + ni, fj:fj + nj] += Uc[ui:ui + ni, uj:uj + nj]


def _ldl_dense(A):
    """Unit lower L and d with L diag(d) L^T = A, no pivoting; reads A's lower
    triangle only (A: float64 array, shape (w, w), overwritten).

    Raises
    ------
    _ZeroPivot
        If a pivot is zero or not finite.
    """
    w = A.shape[0]
    if w <= _COLUMNWISE:
        return _front(A, w)[:2]             # a front that is all pivot block
    h = w // 2
    L11, d1 = _ldl_dense(A[:h, :h])
    X = la.solve_triangular(L11, A[h:, :h].T, lower=True, unit_diagonal=True,
                            check_finite=False).T            # X = A21 L11^-T = L21 D1
    L21 = X / d1
    A22 = A[h:, h:] - L21 @ X.T
    L22, d2 = _ldl_dense(A22)
    L = np.zeros((w, w))
    L[:h, :h], L[h:, :h], L[h:, h:] = L11, L21, L22
    return L, np.concatenate([d1, d2])


def _front(F, w):
    """Eliminate the first w columns of a front F (shape (f, f), lower triangle
    read, its first w columns overwritten): (L, d, X), L of shape (f, w) unit
    lower (its rows w: are L21), X = L21 diag(d) as computed (shape (f - w, w)).

    Up to :data:`_COLUMNWISE` columns, right-looking within the panel F[:, :w]
    (each column's rank-one update of the panel's later columns only; the
    trailing block is updated by the caller with one product); wider, the
    pivot block by :func:`_ldl_dense` and L21 by a triangular solve.

    Raises
    ------
    _ZeroPivot
        If a pivot is zero or not finite.
    """
    f = F.shape[0]
    if w > _COLUMNWISE:
        L11, d = _ldl_dense(F[:w, :w])
        X = la.solve_triangular(L11, F[w:, :w].T, lower=True, unit_diagonal=True,
                                check_finite=False).T                  # A21 L11^-T = L21 D
        return np.vstack([L11, X / d]), d, X
    P = F[:, :w]
    d = np.empty(w)
    X = np.empty((f - w, w))
    for k in range(w):
        dk = P[k, k]
        if dk == 0.0 or not math.isfinite(dk):
            raise _ZeroPivot(f"pivot {k} of a front is {dk!r}")
        d[k] = dk
        x = P[k + 1:, k].copy()                  # l_ik d_k, i > k
        X[:, k] = x[w - k - 1:]
        lk = x / dk
        P[k + 1:, k] = lk
        if k + 1 < w:
            P[k + 1:, k + 1:w] -= lk[:, None] * x[:w - k - 1]
    L = np.tril(P, -1)
    L[np.arange(w), np.arange(w)] = 1.0
    return L, d, X


class SupernodalLDL:
    """Sylvester counts of S - a I at many shifts a, from a multifrontal
    P^T (S - a I) P = L D L^T in one elimination order.

    Parameters
    ----------
    S : scipy.sparse matrix, shape (n, n)
        Symmetric, float64, both triangles stored (its lower triangle after
        the permutation is used).
    perm : ndarray of int, shape (n,)
        The elimination order: the matrix factorized is (S - a I)[perm][:, perm]
        (e.g. :attr:`~.inertia.SymmetricLU.perm`, SuperLU's minimum degree order).

    Attributes
    ----------
    perm : ndarray of int, shape (n,)
    supernodes : int
        Number of supernodes (fronts).
    depth : int
        The largest row or column count of I + L (the m of the fuzz bound).
    nnz_L : int
        Entries of L below the diagonal (the pattern, zeros of cancellation
        included).

    Raises
    ------
    ValueError
        If ``perm`` is not a permutation of range(n), S is not square, or S
        stores one triangle only (its two strict triangles have different
        numbers of entries).

    Notes
    -----
    The symbolic factorization (pattern of each column of L, the elimination
    tree, the supernodes: maximal runs of columns j, j + 1 with parent(j) =
    j + 1 and the pattern of column j that of j + 1 plus j + 1; Liu, SIAM
    Review 34(1), 1992) is made once from the pattern of S; each shift only
    fills the fronts. The pattern is that of any LDL^T of S in this order
    (QDLDL's included), so the fuzz bound's m is the same as QDLDL's there.
    """

    def __init__(self, S, perm):
        S = sp.coo_matrix(S)
        n = S.shape[0]
        if S.shape != (n, n):
            raise ValueError(f"S must be square, got shape {S.shape}")
        perm = np.asarray(perm)
        if perm.shape != (n,) or not np.array_equal(np.sort(perm), np.arange(n)):
            raise ValueError(f"perm must be a permutation of range({n}), got shape {perm.shape}")
        self.n, self.perm = n, perm
        inv = np.empty(n, dtype=np.int64)
        inv[perm] = np.arange(n)
        r, c = inv[S.row], inv[S.col]
        low = r > c
        if np.count_nonzero(low) != np.count_nonzero(r < c):
            raise ValueError(f"S must store both triangles: {np.count_nonzero(S.row > S.col)} "
                             f"entries below the diagonal, {np.count_nonzero(S.row < S.col)} "
                             f"above")
        i = np.arange(n)
        # lower triangle of the permuted matrix, every diagonal entry stored (CSC)
        A = sp.csc_matrix((np.concatenate([S.data[low], S.diagonal()[perm]]),
                           (np.concatenate([r[low], i]), np.concatenate([c[low], i]))),
                          shape=(n, n))
        A.sum_duplicates()
        A.sort_indices()
        self._A = A
        self._diag = np.empty(n, dtype=np.int64)      # where A's diagonal sits in A.data
        self._symbolic(A)

    # ------------------------------------------------------------------ symbolic
    def _symbolic(self, A):
        n = self.n
        Ap, Ai = A.indptr, A.indices
        parent = np.full(n, -1, dtype=np.int64)
        children = [[] for _ in range(n)]
        struct = [None] * n                     # rows below the diagonal of L[:, j]
        for j in range(n):
            rows = Ai[Ap[j]:Ap[j + 1]]
            self._diag[j] = Ap[j] + int(np.searchsorted(rows, j))
            parts = [rows[rows > j]]
            for ch in children[j]:
                s = struct[ch]
                parts.append(s[1:])             # s[0] == j
            s = np.unique(np.concatenate(parts)) if len(parts) > 1 else parts[0]
            struct[j] = s
            if s.size:
                parent[j] = s[0]
                children[s[0]].append(j)
        counts = np.array([s.size for s in struct], dtype=np.int64)
        self.nnz_L = int(counts.sum())
        rowcount = np.bincount(np.concatenate(struct) if self.nnz_L else np.zeros(0, np.int64),
                               minlength=n) + 1
        self.depth = int(max(counts.max(initial=0) + 1, rowcount.max(initial=1)))
        # supernodes: j + 1 joins j's where L[:, j]'s pattern is {j + 1} and L[:, j + 1]'s
        start = [0]
        for j in range(n - 1):
            if not (parent[j] == j + 1 and counts[j] == counts[j + 1] + 1):
                start.append(j + 1)
        start.append(n)
        start = np.array(start, dtype=np.int64)
        ns = start.size - 1
        owner = np.repeat(np.arange(ns), np.diff(start))
        self.supernodes = ns
        fronts, kids = [], [[] for _ in range(ns)]
        for s in range(ns):
            c0, c1 = start[s], start[s + 1]
            fronts.append(np.concatenate([np.arange(c0, c1), struct[c1 - 1]]))
            if parent[c1 - 1] >= 0:
                kids[owner[parent[c1 - 1]]].append(s)
        # per front: where S's entries go (flat index into the f x f front, index
        # into A.data), and where each child's update matrix goes (local rows)
        loc = np.empty(n, dtype=np.int64)
        assemble, extend = [], [None] * ns
        for s in range(ns):
            c0, c1 = start[s], start[s + 1]
            R = fronts[s]
            f = R.size
            loc[R] = np.arange(f)
            lo, hi = Ap[c0], Ap[c1]
            cols = np.repeat(np.arange(c0, c1), np.diff(Ap[c0:c1 + 1]))
            assemble.append((loc[Ai[lo:hi]] * f + (cols - c0), np.arange(lo, hi)))
            for ch in kids[s]:
                wch = start[ch + 1] - start[ch]
                extend[ch] = _runs(loc[fronts[ch][wch:]])
        self._start, self._fronts, self._kids = start, fronts, kids
        self._assemble, self._extend = assemble, extend

    # ------------------------------------------------------------------ numeric
    def count_below(self, a):
        """The Sylvester count of the eigenvalues of S below a, with its fuzz.

        Parameters
        ----------
        a : float
            The shift.

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
            If a pivot is zero or not finite (no inertia in this order).

        Notes
        -----
        Each front eliminates its w columns (right-looking, or in halves
        joined by a triangular solve and a matrix product, BLAS), and its
        update matrix -L21 D L21^T is added into its parent's front. An entry
        (i, j), i >= j, of the lower triangle is thus computed as
        a_ij - sum_k t_k over the k < j with l_ik l_jk != 0 (at most m - 1
        terms), in some order, where each term t_k is a product of two
        rounded numbers (l_ik and l_jk d_k as computed, or their product with
        d_k), then divided by d_j (i > j) or kept as d_j (i = j); only the
        lower triangle of a front is read. So each computed entry carries at
        most m + 3 roundings of relative size u, and the computed factors
        satisfy L D L^T = P^T (S - a I) P + Z with |Z| <= gamma_{m+3} |L| |D|
        |L|^T entrywise (the argument of Higham, *Accuracy and Stability of
        Numerical Algorithms*, 2nd ed., Thm. 10.3, which holds for any order
        of the sums); the bound used is :func:`~.inertia.count_below`'s,
        gamma_{2m+4} |L| |D| |L|^T plus u max|S_ii - a| for the shifted
        diagonal, its row sums computed from the blocks and inflated by
        :data:`~.numerics.INFLATE`. By Sylvester's law of inertia the count
        of negative d_i is that of S - a I + P Z P^T.
        """
        a = float(a)
        vals = self._A.data.copy()
        vals[self._diag] -= a
        start, fronts, kids = self._start, self._fronts, self._kids
        updates = {}
        neg = 0
        rows = np.zeros(self.n)
        for s in range(self.supernodes):
            R = fronts[s]
            f, w = R.size, int(start[s + 1] - start[s])
            F = np.zeros((f, f))
            at, src = self._assemble[s]
            F.flat[at] = vals[src]
            for ch in kids[s]:
                _extend_add(F, updates.pop(ch), self._extend[ch])
            try:
                Lf, d, X = _front(F, w)
            except _ZeroPivot as exc:
                raise ValueError(f"no inertia of S - a I at a = {a!r}: zero pivot "
                                 f"(column {int(start[s])} of the elimination; {exc})") from None
            if not np.all(np.isfinite(Lf)):
                raise ValueError(f"no inertia of S - a I at a = {a!r}: a factor entry "
                                 f"not finite (front of column {int(start[s])})")
            neg += int(np.count_nonzero(d < 0))
            if f > w:
                updates[s] = F[w:, w:] - Lf[w:] @ X.T          # - L21 D L21^T
            Lf = np.abs(Lf)
            wts = np.abs(d) * Lf.sum(axis=0)            # |D| |L|^T 1 on the front's columns
            rows[R] += Lf @ wts                         # |L| |D| |L|^T 1 on its rows
        diag_err = U * float(np.max(np.abs(vals[self._diag]))) if self.n else 0.0
        fuzz = (gamma(2 * self.depth + 4) * float(np.max(rows, initial=0.0)) + diag_err) * INFLATE
        return neg, fuzz
