"""Rigorous floating-point bounds used by the certified decision (:mod:`.exceptional`).

Error-free products (Dekker's TwoProduct) and a residual R = A Q - Q M
computed as in twice the working precision, with an entrywise error bound
(:func:`accurate_residual`);
upper bounds of float64 sums (:func:`rounded_up`, the gamma_k of Higham, "Accuracy
and Stability of Numerical Algorithms", 2nd ed., section 3.1); the exact
discriminant test of a 2 x 2 block with Fractions and the bound of its
change (:func:`disc_test`); rigorous lower bounds of the smallest singular
value (:func:`sigma_min_2x2_lower`, :func:`sigma_min_lower`) and the
radius of a pseudospectral disc (:func:`cover_radius`). Steps 2-4 of
:mod:`.exceptional`'s docstring are built from these.
"""
from fractions import Fraction
import math

import numpy as np

__all__ = ["UNIT_ROUNDOFF", "accurate_residual"]

#: unit roundoff of float64 (half an ulp of 1): the default entrywise relative
#: uncertainty of the matrix (every real within half an ulp rounds to it)
UNIT_ROUNDOFF = 2.0 ** -53
U = UNIT_ROUNDOFF
EPS = np.finfo(np.float64).eps
TINY = np.finfo(np.float64).tiny
_SPLIT = 134217729.0            # 2^27 + 1, Veltkamp splitting constant


def gamma(k, u=U):
    """Higham's gamma_k = k u / (1 - k u): the relative error bound of a float64
    computation of depth k (a sum or inner product of k terms); ``u`` another
    arithmetic's bound per operation (e.g. double-word, ``sliced.inertia.U_DW``)."""
    return k * u / (1.0 - k * u)


def rounded_up(x, k):
    """Upper bound of a nonnegative quantity computed in float64 with depth-k sums."""
    return x * (1.0 + 8.0 * gamma(k + 4)) + (k + 4) * TINY


# --------------------------------------------------------------------------- exact residual
def _two_prod(a, b):
    """p = fl(a b) and e with a b = p + e exactly (Dekker; no FMA, arrays)."""
    p = a * b
    c = _SPLIT * a
    ah = c - (c - a)
    al = a - ah
    c = _SPLIT * b
    bh = c - (c - b)
    bl = b - bh
    e = ((ah * bh - p) + ah * bl + al * bh) + al * bl
    return p, e


def _two_sum(a, b):
    """s = fl(a + b) and e with a + b = s + e exactly (Knuth's TwoSum, arrays)."""
    s = a + b
    z = s - a
    return s, (a - (s - z)) + (b - z)


def accurate_residual(A, Q, M):
    """R = A Q - Q M as if computed in twice the working precision, with a
    rigorous entrywise bound of its error.

    Each entry is an inner product of L = (nonzeros of the row) + b terms
    (b: M's block size, k for a full M), evaluated by Dot2 of Ogita, Rump
    and Oishi ("Accurate sum and dot product", SIAM J. Sci. Comput. 26
    (2005) 1955): every product split error-free (Dekker's TwoProduct), the
    products summed by Knuth's TwoSum and the errors gathered in a second
    sum. Their error bound for Dot2 (section 5 there), |R - R_exact| <=
    u |R_exact| + gamma_L^2 sum|exact products|, gives the bound returned,
    2u |R| + 4 gamma_L^2 fl(sum|products|), plus a term for products near
    underflow, where TwoProduct is not error-free. It is within a few u of
    |R| unless the terms cancel to below ~1e-13 of their sum. All rows and
    columns are evaluated at once (vectorised over the entries).

    Parameters
    ----------
    A : ndarray or scipy.sparse matrix, shape (n, n)
        Real, finite; zeros are skipped (sparse structure; a sparse A gives
        the same R and err as its dense copy, bit for bit).
    Q : ndarray, shape (n, k)
    M : ndarray, shape (k, k), or (p, b, b) with k = p b
        M, or the diagonal blocks of a block-diagonal M (p blocks of b x b:
        the residuals of p invariant subspaces of dimension b at once; each
        column the same bits as its block's own call).

    Returns
    -------
    R : ndarray, shape (n, k)
    err : ndarray, shape (n, k)
        Entrywise bound on |A Q - Q M - R| (exact arithmetic).

    Raises
    ------
    ValueError
        If an entry is too large to be split exactly (|x| >= 2^995) or not
        finite.
    """
    import scipy.sparse as sp

    if sp.issparse(A):
        A = sp.csr_matrix(A, dtype=np.float64)
        A.sum_duplicates()
        A.sort_indices()
        rows = np.repeat(np.arange(A.shape[0]), np.diff(A.indptr))
        cols, a, bounds = A.indices, A.data, A.indptr
        Ad = a                  # (the entries, for the checks below)
    else:
        A = np.asarray(A, np.float64)
        rows = cols = None
        Ad = A
    Q = np.asarray(Q, np.float64)
    M = np.asarray(M, np.float64)
    n, k = Q.shape
    blocks = M if M.ndim == 3 else M[None]
    p, b = blocks.shape[0], blocks.shape[1]
    if blocks.shape != (p, b, b) or p * b != k:
        raise ValueError(f"accurate_residual: M of shape {M.shape} does not fit Q of "
                         f"shape {Q.shape} (want ({k}, {k}) or (p, b, b) with p b = {k})")
    for name, X in (("A", Ad), ("Q", Q), ("M", M)):
        if not np.all(np.isfinite(X)):
            raise ValueError(f"accurate_residual: {name} has non-finite entries")
        if X.size and np.max(np.abs(X)) >= 2.0 ** 995:
            raise ValueError(f"accurate_residual: |{name}| too large to split exactly "
                             f"({np.max(np.abs(X)):.3g} >= 2^995)")
    if rows is None:
        rows, cols = np.nonzero(A)
        a = A[rows, cols]
        bounds = np.searchsorted(rows, np.arange(n + 1))
    # the row's products in its columns' order, padded with zeros (exact terms)
    length = np.diff(bounds)
    width = int(length.max()) if n and length.size else 0
    pos = np.arange(rows.size) - bounds[rows]
    prod, err_prod = _two_prod(a[:, None], Q[cols, :])   # (nnz, k)
    P = np.zeros((width, n, k))
    E = np.zeros((width, n, k))
    P[pos, rows] = prod
    E[pos, rows] = err_prod
    terms = [(P[j], E[j]) for j in range(width)]
    # the l-th column of each block times its row l of the block: b terms per entry
    Qb = Q.reshape(n, p, b)
    terms += [tuple(x.reshape(n, k) for x in
                    _two_prod(-Qb[:, :, l][:, :, None], blocks[:, l, :][None, :, :]))
              for l in range(b)]
    s = np.zeros((n, k))
    c = np.zeros((n, k))
    total = np.zeros((n, k))
    slack = np.zeros((n, k))
    for pj, ej in terms:
        s, q = _two_sum(s, pj)
        c = c + (q + ej)
        apj = np.abs(pj)
        total = total + apj
        small = (pj != 0) & (apj < 2.0 ** -960)
        if np.any(small):
            slack = slack + np.where(small, 2.0 * U * apj + 2.0 ** -1070, 0.0)
    out = s + c
    L = width + b
    err = 2.0 * U * np.abs(out) + 4.0 * gamma(L) ** 2 * total + slack + 2.0 ** -1070
    return out, err


# --------------------------------------------------------------------------- 2 x 2 algebra
def frac(M):
    """The 2 x 2 float matrix M as exact Fractions (list of rows)."""
    return [[Fraction(float(M[0, 0])), Fraction(float(M[0, 1]))],
            [Fraction(float(M[1, 0])), Fraction(float(M[1, 1]))]]


def disc_test(S, rad):
    """Exact D of the centre S (Fractions) and a rigorous bound of its change.

    Parameters
    ----------
    S : list of list of Fraction, 2 x 2
    rad : ndarray, shape (2, 2)
        Entrywise radius (>= 0).

    Returns
    -------
    D : Fraction
    bound : Fraction
    """
    r = [[Fraction(float(rad[i, j])) for j in range(2)] for i in range(2)]
    p = (S[0][0] - S[1][1]) / 2
    D = p * p + S[0][1] * S[1][0]
    dp = (r[0][0] + r[1][1]) / 2
    bound = 2 * abs(p) * dp + dp * dp + abs(S[0][1]) * r[1][0] + abs(S[1][0]) * r[0][1] \
        + r[0][1] * r[1][0]
    return D, bound


def pair_eigs(S):
    """The two eigenvalues of the 2 x 2 Fraction matrix S, in float (complex)."""
    tr = 0.5 * float(S[0][0] + S[1][1])
    D = float(((S[0][0] - S[1][1]) / 2) ** 2 + S[0][1] * S[1][0])
    r = np.sqrt(complex(D))
    return np.array([tr - r, tr + r])


def margin(D, bound):
    """|D| / bound: how far the sign of a discriminant D is from changing within
    its bound (inf for an exact nonzero D, 0 for D = 0 exactly)."""
    if bound == 0:
        return math.inf if D != 0 else 0.0
    return float(abs(D) / bound)


def cover_radius(S, r):
    """Radius of a disc about tr(S)/2 containing {z : sigma_min(S - z I) <= r}.

    S is the 2 x 2 centre (Fractions, exact); r >= 0 (float). With w = z -
    tr/2, det(S - z I) = w^2 - D and ||S - z I||_F <= ||N||_F + sqrt2 |w|,
    so sigma_min >= (|w|^2 - |D|) / (||N||_F + sqrt2 |w|), increasing in |w|.
    """
    p = (S[0][0] - S[1][1]) / 2
    D = abs(float(p * p + S[0][1] * S[1][0])) * (1 + 4 * U)
    nf = math.sqrt(float(2 * p * p + S[0][1] ** 2 + S[1][0] ** 2)) * (1 + 8 * U)
    s2 = math.sqrt(2.0) * (1 + 2 * U)
    rho = 0.5 * (s2 * r + math.sqrt(2.0 * r * r + 4.0 * (D + r * nf)))
    return rho * (1 + 32 * U) + TINY


def sigma_min_2x2_lower(a, b, c, d):
    """Vectorised rigorous lower bound of sigma_min([[a, b], [c, d]]) = |det| / sigma_max."""
    det = a * d - b * c
    err = gamma(4) * (np.abs(a * d) + np.abs(b * c)) * (1 + 4 * U) + TINY
    fro = np.sqrt(a * a + b * b + c * c + d * d) * (1 + gamma(8))
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.maximum(np.abs(det) - err, 0.0) / fro
    return np.where(fro > 0, out * (1 - 4 * U), 0.0)


def inverse_residual(K):
    """Z ~ K^{-1} of a small square matrix and a rigorous e >= ||I - Z K||_F
    (the rounding of Z K bounded by gamma |Z||K|, doubled for complex
    arithmetic); None if the inverse is not finite."""
    p = K.shape[0]
    try:
        Z = np.linalg.inv(K)
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(Z)):
        return None
    c = 2.0 if np.iscomplexobj(Z) else 1.0
    E = np.abs(np.eye(p) - Z @ K) * (1 + 2 * c * U) + c * gamma(p + 2) * (np.abs(Z) @ np.abs(K))
    return Z, rounded_up(float(np.linalg.norm(E)), p * p)


def sigma_min_lower(K, norm="frobenius"):
    """Rigorous lower bound of sigma_min(K) for a small square real or complex matrix.

    Z ~ K^{-1}; with E = I - Z K bounded (:func:`inverse_residual`: gamma_p
    |Z||K| for the product), ||E||_F = e < 1 gives ||K^{-1}||_2 <=
    ||Z||_2 / (1 - e), and ||Z||_2 is bounded by

    * ``norm = 'frobenius'`` (default): ||Z||_F, rounded up;
    * ``norm = 'spectral'``: the square root of the largest row sum of
      |Z^H Z| (a Hermitian matrix's 2-norm is at most its infinity norm),
      with the rounding of the product added (twice the real gamma for
      complex products). Often the tighter of the two (neither always is),
      for one more p x p product.

    Parameters
    ----------
    K : ndarray, shape (p, p)
        float64 or complex128.
    norm : {'frobenius', 'spectral'}

    Returns
    -------
    float
        >= 0; 0 where the bound fails (Z not finite, or e >= 1).

    Raises
    ------
    ValueError
        For another ``norm``.
    """
    if norm not in ("frobenius", "spectral"):
        raise ValueError(f"norm must be 'frobenius' or 'spectral', got norm = {norm!r}")
    K = np.asarray(K)
    inv = inverse_residual(K)
    if inv is None or not inv[1] < 1.0:
        return 0.0
    Z, e = inv
    p = K.shape[0]
    if norm == "frobenius":
        return (1.0 - e) / rounded_up(float(np.linalg.norm(Z)), p * p) * (1 - 4 * U)
    aZ = np.abs(Z)
    g = 2 * gamma(p + 4)      # complex products: twice the real gamma
    G = np.abs(Z.conj().T @ Z) + g * (aZ.T @ aZ)
    z2 = math.sqrt(float(np.max(G.sum(axis=1))) * (1 + g))
    return (1.0 - e) / z2 * (1 - 4 * U)

# --------------------------------------------------------------------------- sep of 2 x 2 blocks
def sep_2x2_lower(S, others):
    """Rigorous lower bound of min_j sigma_min(I (x) B_j - S^T (x) I) over 2 x 2 blocks B_j.

    sigma_min(I (x) B - S^T (x) I) is sep(B, S), the separation of the pair S
    from the pair B (step 4 of :mod:`.exceptional`). Two bounds of it are
    combined, each rigorous: with b, s half the traces and N_B, N_S the
    traceless parts, I (x) B - S^T (x) I = (b - s) I + I (x) N_B - N_S^T (x) I,
    so sep(B, S) >= |b - s| - ||N_B||_F - ||N_S||_F (Weyl); and for the blocks
    where that is below the running minimum, the inverse bound of
    :func:`sigma_min_lower` of the 4 x 4 matrix, evaluated for all of them
    at once (a block j whose first bound is at least the minimum of the
    bounds found cannot lower it). The result is min_j max(both bounds) >=
    min_j :func:`sigma_min_lower`: the value of one
    :func:`sigma_min_lower` per block, or larger.

    Parameters
    ----------
    S : ndarray, shape (2, 2)
        The pair's block (float64).
    others : ndarray, shape (p, 2, 2)
        The other pairs' blocks.

    Returns
    -------
    float
        inf if p = 0.
    """
    others = np.asarray(others, np.float64).reshape(-1, 2, 2)
    if others.shape[0] == 0:
        return math.inf
    S = np.asarray(S, np.float64)
    s = 0.5 * (S[0, 0] + S[1, 1])
    ns = math.sqrt(0.25 * (S[0, 0] - S[1, 1]) ** 2 * 2 + S[0, 1] ** 2 + S[1, 0] ** 2)
    b = 0.5 * (others[:, 0, 0] + others[:, 1, 1])
    nb = np.sqrt(0.5 * (others[:, 0, 0] - others[:, 1, 1]) ** 2 + others[:, 0, 1] ** 2
                 + others[:, 1, 0] ** 2)
    # every operation above has a relative error <= u: 16 u covers the chains, and
    # (1 - 4 u) the three roundings of the combination below
    cheap = (np.abs(b - s) * (1 - 16 * U) - (nb + ns) * (1 + 16 * U)
             - 16 * U * (np.abs(b) + abs(s))) * (1 - 4 * U) - TINY
    cheap = np.where(cheap > 0, cheap, 0.0)          # (and 0 for a NaN)
    order = np.argsort(cheap, kind="stable")
    e2 = np.eye(2)
    best = math.inf
    k, p, step = 0, order.size, 8
    while k < p and cheap[order[k]] < best:
        idx = order[k:k + step]
        idx = idx[cheap[idx] < best]
        B = others[idx]
        K = np.empty((idx.size, 4, 4))      # I (x) B - S^T (x) I, as np.kron forms it
        K[:, :2, :2] = B - S[0, 0] * e2
        K[:, 2:, 2:] = B - S[1, 1] * e2
        K[:, :2, 2:] = -S[1, 0] * e2
        K[:, 2:, :2] = -S[0, 1] * e2
        best = min(best, float(np.min(np.maximum(cheap[idx], sigma_min_lower_many(K)))))
        k += step
        step *= 2
    # the blocks left have cheap >= best
    return best


def sigma_min_lower_many(K):
    """:func:`sigma_min_lower` of each matrix of the stack K (q, p, p), at once."""
    q, p = K.shape[0], K.shape[1]
    out = np.zeros(q)
    try:
        Z = np.linalg.inv(K)
    except np.linalg.LinAlgError:       # a singular one: one at a time
        return np.array([sigma_min_lower(Kj) for Kj in K])
    fin = np.all(np.isfinite(Z), axis=(1, 2))
    E = np.abs(np.eye(p) - Z @ K) * (1 + 2 * U) + gamma(p + 2) * (np.abs(Z) @ np.abs(K))
    e = rounded_up(np.sqrt(np.sum(E * E, axis=(1, 2))), p * p)
    zn = rounded_up(np.sqrt(np.sum(Z * Z, axis=(1, 2))), p * p)
    ok = fin & (e < 1.0)
    out[ok] = (1.0 - e[ok]) / zn[ok] * (1 - 4 * U)
    return out
