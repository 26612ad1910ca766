r"""Is there a complex pair? A certified decision near an exceptional point.

At the onset F_x^c two real eigenvalues of M^{-1}K collide and leave the real
axis as a complex pair (MODEL.md section 7, paper Fig. 3). At the collision
the matrix is defective (an exceptional point): the two eigenvectors become
parallel, the eigenvalue condition numbers diverge, and an O(u) rounding
error moves the eigenvalues by O(sqrt(u)). Whether a computed eigenvalue has
a nonzero imaginary part is therefore not a sound test, and neither is any
fixed threshold on Im lambda.

The test here works on the **2 x 2 block** of the pair in the real Schur
form, which stays well conditioned at an exceptional point because the
two-dimensional invariant subspace of the pair does (as long as the pair is
separated from the rest of the spectrum). For a real matrix A:

1. Compute the real Schur form A Z = Z T (LAPACK ``dgees`` via
   :func:`scipy.linalg.schur`) and a bound e on the backward error,
   e = ||A Z - Z T||_F + ||A||_F ||Z^T Z - I||_F + 2 n u ||A||_F
   (+ a user-supplied uncertainty of A itself). T is then the exact Schur
   form of some A + E0 with ||E0|| <= e.
2. Move the pair to the leading 2 x 2 block B = T_11 with LAPACK
   ``dtrsen``, which also estimates sep = sep(T_11, T_22).
3. The pair is complex iff the discriminant
   D = ((b11 - b22)/2)^2 + b12 b21 < 0 (invariant under similarity).
4. Any matrix within e of A + E0 (A itself in particular) has its pair
   equal to the eigenvalues of T_11 + dB with (Stewart's perturbation bound
   for invariant subspaces, SIAM J. Numer. Anal. 10 (1973) 727; Golub &
   Van Loan, Matrix Computations, section 7.2)
   ||dB||_F <= eta = e + 2 e (||T_12||_F + e) / (sep - 2e),
   valid when sep > 2e and 4 e (||T_12||_F + e) < (sep - 2e)^2; otherwise
   the pair is not isolated at this precision and the decision is
   "undecided".
5. D is quadratic in B, so |dD| <= g eta + eta^2 exactly, with
   g = ||grad D|| = sqrt(2 p^2 + b12^2 + b21^2), p = (b11 - b22)/2; a
   rounding term 4u(p^2 + |b12 b21|) is added.
6. **margin** = |D| / bound. margin > 1 certifies the sign of D: the pair is
   complex (D < 0) or real (D > 0) for every matrix compatible with the
   computation. The margin is the confidence reported with each decision
   (log10(margin) = digits to spare). margin <= 1 gives "undecided".

Near the exceptional point D ~ (lambda_1 - lambda_2)^2 / 4 vanishes linearly
in the distance eps to it while the bound stays ~ |b12| e, so the test
resolves eps down to ~ e/|b12| instead of the sqrt(e) that a test on the
computed eigenvalues could resolve at best.

For the normal form of MODEL.md section 8,
J = [[1 - d, eta], [-eta, 1 + d]] with eps = 1 - eta/d: D = d^2 - eta^2 =
d^2 eps (2 - eps), so the sign of D is that of eps; complex iff eps < 0.

Screening. Real eigenvalues far apart (gap > ``screen`` x (kappa_a +
kappa_b) e, first-order perturbation theory with the condition numbers
kappa from left/right eigenvectors) are reported as certified real with that
first-order margin; only close pairs and all complex pairs get the 2 x 2
test.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
from scipy.linalg import lapack

__all__ = ["PairDecision", "SpectrumDecision", "block_discriminant", "schur_backward_error",
           "decide_pair", "classify_spectrum", "classify_projected", "normal_form"]

EPS = np.finfo(np.float64).eps


def normal_form(d, eps):
    """The normal-form matrix J = [[1 - d, eta], [-eta, 1 + d]], eta = d (1 - eps).

    Parameters
    ----------
    d : float
        Half splitting delta of the paper (Eqs. 9-10), 0 < d < 1.
    eps : float
        epsilon = 1 - eta/delta; the eigenvalues 1 -+ d sqrt(1 - (1 - eps)^2)
        are real for eps > 0 and complex for eps < 0 (paper Eq. 11).

    Returns
    -------
    ndarray, shape (2, 2)
    """
    eta = d * (1.0 - eps)
    return np.array([[1.0 - d, eta], [-eta, 1.0 + d]])


def block_discriminant(B):
    """Discriminant of a 2 x 2 block and its gradient norm.

    Parameters
    ----------
    B : array_like, shape (2, 2)

    Returns
    -------
    D : float
        ((b11 - b22)/2)^2 + b12 b21; the eigenvalues are
        (b11 + b22)/2 +- sqrt(D): complex iff D < 0.
    g : float
        Euclidean norm of dD/dB.
    rnd : float
        Bound on the rounding error in evaluating D.
    """
    B = np.asarray(B, dtype=np.float64)
    p = 0.5 * (B[0, 0] - B[1, 1])
    D = p * p + B[0, 1] * B[1, 0]
    g = float(np.sqrt(2.0 * p * p + B[0, 1] ** 2 + B[1, 0] ** 2))
    rnd = 4.0 * EPS * (p * p + abs(B[0, 1] * B[1, 0]))
    return float(D), g, float(rnd)


def _gamma(n):
    return n * EPS / (1.0 - n * EPS)


def schur_backward_error(A, T, Z):
    """Bound e such that T is the exact real Schur form of A + E0, ||E0||_F <= e.

    With R = A Z - Z T and w = ||Z^T Z - I||_F (both as computed), an
    orthogonal U with ||U - Z||_F <= w exists and A U - U T = R + A (U - Z) -
    (U - Z) T, so ||E0||_F <= ||R||_F + w (||A||_F + ||T||_F). The rounding
    of the computed R and w themselves is bounded by gamma_n || |A||Z| + |Z||T| ||_F
    and gamma_n || |Z|^T |Z| ||_F, gamma_n = n u / (1 - n u) (Higham, Accuracy
    and Stability of Numerical Algorithms, section 3.5), and is added.

    Parameters
    ----------
    A, T, Z : ndarray, shape (n, n)

    Returns
    -------
    float
    """
    n = A.shape[0]
    g = _gamma(n)
    aZ = np.abs(Z)
    res = np.linalg.norm(A @ Z - Z @ T) + g * np.linalg.norm(np.abs(A) @ aZ + aZ @ np.abs(T))
    orth = np.linalg.norm(Z.T @ Z - np.eye(n)) + g * np.linalg.norm(aZ.T @ aZ)
    return float(res + orth * (np.linalg.norm(A) + np.linalg.norm(T)))


@dataclass
class PairDecision:
    """Decision for one pair of eigenvalues.

    Attributes
    ----------
    eigenvalues : ndarray, complex, shape (2,)
        The pair (from its 2 x 2 block, or the computed eigenvalues).
    is_complex : bool
        Sign of the discriminant: True if the computed block has D < 0.
    certified : bool
        True if margin > 1: the sign holds for every matrix within the
        error bound.
    margin : float
        |D| / (bound on the change of D); the confidence of the decision.
    discriminant : float
        D of the 2 x 2 block (1/time^4 for M^-1 K).
    bound : float
        Largest change of D compatible with the errors.
    eta : float
        Bound on the perturbation of the 2 x 2 block.
    sep : float
        LAPACK's estimate of sep(T_11, T_22) (inf for a 2 x 2 matrix).
    kappa : tuple of float or None
        Condition numbers of the two eigenvalues (left/right eigenvectors).
    method : str
        ``'schur-2x2'`` or ``'first-order'`` (screened real pair).
    reason : str
        Why a pair is undecided (empty otherwise).
    """

    eigenvalues: np.ndarray
    is_complex: bool
    certified: bool
    margin: float
    discriminant: float = float("nan")
    bound: float = float("nan")
    eta: float = float("nan")
    sep: float = float("inf")
    kappa: tuple | None = None
    method: str = "schur-2x2"
    reason: str = ""

    @property
    def decision(self):
        """``'complex'``, ``'real'`` or ``'undecided'``."""
        if not self.certified:
            return "undecided"
        return "complex" if self.is_complex else "real"


@dataclass
class SpectrumDecision:
    """Is a complex pair present in the spectrum?

    Attributes
    ----------
    complex_present : bool or None
        True: at least one pair is certified complex. False: every computed
        pair is certified real. None: undecided (a pair is too close to an
        exceptional point for the precision of the computation).
    confidence : float
        For True, the largest margin among certified complex pairs; for
        False, the smallest margin among all real pairs; for None, the
        margin of the least certain pair (< 1).
    pairs : list of PairDecision
        Every complex pair and every tested real pair.
    backward_error : float
        e used (Frobenius norm, units of A).
    eigenvalues : ndarray, complex
        All eigenvalues from the Schur form, sorted by real part.
    """

    complex_present: bool | None
    confidence: float
    pairs: list = field(default_factory=list)
    backward_error: float = 0.0
    eigenvalues: np.ndarray | None = None

    @property
    def critical_pair(self):
        """The pair that decided (largest-margin complex pair if present, else least certain)."""
        if not self.pairs:
            return None
        if self.complex_present:
            cands = [p for p in self.pairs if p.is_complex and p.certified]
            return max(cands, key=lambda p: p.margin)
        return min(self.pairs, key=lambda p: p.margin)


def _blocks(T):
    """(position, size) of the diagonal blocks of a quasi-triangular T."""
    n = T.shape[0]
    out = []
    k = 0
    while k < n:
        if k + 1 < n and T[k + 1, k] != 0.0:
            out.append((k, 2))
            k += 2
        else:
            out.append((k, 1))
            k += 1
    return out


def _block_eigs(B):
    tr = 0.5 * (B[0, 0] + B[1, 1])
    D, _, _ = block_discriminant(B)
    r = np.sqrt(complex(D))
    return np.array([tr - r, tr + r])


def decide_pair(A, T, Z, positions, e, kappa=None, e_schur=None, recheck_max=600):
    """2 x 2 Schur-block test for the eigenvalues at ``positions`` of T.

    Parameters
    ----------
    A : ndarray, shape (n, n)
        The matrix (only used to recompute the backward error after the
        reordering).
    T, Z : ndarray, shape (n, n)
        Real Schur form A Z = Z T.
    positions : sequence of two int
        Diagonal positions of the pair (both rows of a 2 x 2 block, or two
        1 x 1 blocks).
    e : float
        Uncertainty of A to add to the backward error of the reordered Schur
        form (e.g. the uncertainty of A itself); >= 0.
    kappa : tuple, optional
        Condition numbers to report.
    e_schur : float, optional
        Backward-error bound of (T, Z) already computed. Above ``recheck_max``
        dofs the reordered form is not re-verified (an O(n^3) product per
        pair); its error is then *estimated* as e_schur + 20 n u ||T||_F
        (each block swap of ``dtrexc`` is backward stable, Bai & Demmel 1993;
        the constant is a generous estimate, not a proven bound).
    recheck_max : int, optional
        Largest n for which the reordered Schur form is re-verified.

    Returns
    -------
    PairDecision
    """
    n = T.shape[0]
    if n == 2:
        B = T.copy()
        T12n = 0.0
        sep = np.inf
        e_tot = e + schur_backward_error(A, T, Z)
    else:
        sel = np.zeros(n, np.int32)
        sel[list(positions)] = 1
        work, iwork, info = lapack.dtrsen_lwork(sel, T, job="B")
        ts, qs, wr, wi, m, s, sep, info = lapack.dtrsen(
            sel, T, Z, job="B", lwork=max(int(work), 1), liwork=max(int(iwork), 1))
        if info != 0 or m != 2:
            return PairDecision(np.full(2, np.nan + 0j), False, False, 0.0,
                                reason=f"reordering failed (dtrsen info = {info}, m = {m})",
                                kappa=kappa)
        B = ts[:2, :2].copy()
        T12n = float(np.linalg.norm(ts[:2, 2:]))
        if n > recheck_max and e_schur is not None:
            e_tot = e + e_schur + 20.0 * n * EPS * float(np.linalg.norm(T))
        else:
            e_tot = e + schur_backward_error(A, ts, qs)
    lam = _block_eigs(B)
    D, g, rnd = block_discriminant(B)
    if np.isfinite(sep):
        sep2 = sep - 2.0 * e_tot
        if sep2 <= 0 or 4.0 * e_tot * (T12n + e_tot) >= sep2 ** 2:
            return PairDecision(lam, D < 0, False, 0.0, D, np.inf, np.inf, float(sep), kappa,
                                reason=f"pair not isolated: sep = {sep:.3g} vs error "
                                       f"{e_tot:.3g}")
        eta = e_tot + 2.0 * e_tot * (T12n + e_tot) / sep2
    else:
        eta = e_tot
    bound = g * eta + eta * eta + rnd
    margin = abs(D) / bound if bound > 0 else np.inf
    return PairDecision(lam, D < 0, margin > 1.0, float(margin), D, float(bound), float(eta),
                        float(sep), kappa,
                        reason="" if margin > 1.0 else "discriminant within its error bound")


def _match(lam_ref, lam):
    """Index into lam of the nearest value to each lam_ref (greedy, unique)."""
    used = np.zeros(lam.size, bool)
    out = np.empty(lam_ref.size, np.int64)
    for k, v in enumerate(lam_ref):
        d = np.abs(lam - v)
        d[used] = np.inf
        out[k] = int(np.argmin(d))
        used[out[k]] = True
    return out


def classify_spectrum(A, input_error=0.0, screen=100.0):
    """Decide soundly whether the real matrix A has a complex pair of eigenvalues.

    Parameters
    ----------
    A : ndarray or sparse matrix, shape (n, n)
        Real matrix, e.g. M^{-1} K after rattler removal (dense; a sparse
        matrix is densified).
    input_error : float, optional
        Absolute uncertainty (Frobenius norm) of A itself, added to the
        backward error of the computation (default 0: decide for A exactly
        as stored).
    screen : float, optional
        First-order margin above which a real pair is accepted without the
        2 x 2 test (default 100).

    Returns
    -------
    SpectrumDecision

    Raises
    ------
    ValueError
        If A is not square, not real, or not finite, or input_error < 0.
    """
    if hasattr(A, "toarray"):
        A = A.toarray()
    A = np.asarray(A)
    if A.ndim != 2 or A.shape[0] != A.shape[1]:
        raise ValueError(f"A must be square, got shape {A.shape}")
    if np.iscomplexobj(A):
        raise ValueError("A must be real (complex pairs are a property of real matrices)")
    A = A.astype(np.float64)
    if not np.all(np.isfinite(A)):
        raise ValueError("A has non-finite entries")
    if not (input_error >= 0):
        raise ValueError(f"input_error must be >= 0, got {input_error!r}")
    n = A.shape[0]
    if n < 2:
        lam = np.linalg.eigvals(A).astype(complex) if n else np.zeros(0, complex)
        return SpectrumDecision(False, np.inf, [], 0.0, lam)
    T, Z = sla.schur(A, output="real")
    e0 = schur_backward_error(A, T, Z)
    e = e0 + input_error
    blocks = _blocks(T)
    lam_all = []
    for p, sz in blocks:
        lam_all.extend(_block_eigs(T[p:p + 2, p:p + 2]) if sz == 2 else [T[p, p] + 0j])
    lam_all = np.array(lam_all)
    # condition numbers from left/right eigenvectors (diagnostic and screening)
    lam_e, vl, vr = sla.eig(A, left=True, right=True)
    from .eigen import condition_numbers

    kap_e = condition_numbers(vl, vr)
    kap = kap_e[_match(lam_all, lam_e.astype(complex))]

    pairs = []
    # complex pairs
    idx = 0
    reals = []
    for p, sz in blocks:
        if sz == 2:
            pairs.append(decide_pair(A, T, Z, (p, p + 1), input_error,
                                     (float(kap[idx]), float(kap[idx + 1])), e_schur=e0))
        else:
            reals.append((lam_all[idx].real, p, float(kap[idx])))
        idx += sz
    reals.sort()
    for (la, pa, ka), (lb, pb, kb) in zip(reals[:-1], reals[1:]):
        gap = lb - la
        first = gap / ((ka + kb) * e) if e > 0 else np.inf
        if first > screen:
            pairs.append(PairDecision(np.array([la, lb], complex), False, True, float(first),
                                      kappa=(ka, kb), method="first-order"))
        else:
            pairs.append(decide_pair(A, T, Z, (pa, pb), input_error, (ka, kb), e_schur=e0))
    lam_sorted = lam_all[np.lexsort((lam_all.imag, lam_all.real))]
    return _summarize(pairs, e, lam_sorted)


def _summarize(pairs, e, lam):
    cert_c = [p for p in pairs if p.is_complex and p.certified]
    if cert_c:
        return SpectrumDecision(True, max(p.margin for p in cert_c), pairs, e, lam)
    unsure = [p for p in pairs if not p.certified]
    if unsure:
        return SpectrumDecision(None, min(p.margin for p in unsure), pairs, e, lam)
    conf = min((p.margin for p in pairs), default=np.inf)
    return SpectrumDecision(False, conf, pairs, e, lam)


def _orth(W, rtol=1e-10):
    """Orthonormal basis of the column span of W (SVD, tiny directions dropped)."""
    U, sv, _ = np.linalg.svd(W, full_matrices=False)
    if sv.size == 0 or sv[0] == 0:
        return U[:, :0]
    return U[:, sv > rtol * sv[0]]


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
        On the k eigenvalues nearest sigma (``decision.eigenvalues``).
    residual : float
        ||A Q_k - Q_k T_k||_F.

    Raises
    ------
    ValueError
        Bad k, or sigma is an eigenvalue (singular shifted matrix).
    """
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    A = sp.csr_matrix(A, dtype=np.float64)
    n = A.shape[0]
    if not (2 <= k < n - 1):
        raise ValueError(f"k must satisfy 2 <= k < n - 1 = {n - 1}, got {k}")
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
    return classify_spectrum(Tk, input_error=res + input_error), res
