r"""Is there a complex pair? A certified decision near an exceptional point.

At the onset F_x^c two real eigenvalues of M^{-1}K collide and leave the real
axis as a complex pair (docs/model.md section 7, paper Fig. 3). At the collision
the matrix is defective (an exceptional point): the two eigenvectors become
parallel, the eigenvalue condition numbers diverge, and an O(u) rounding
error moves the eigenvalues by O(sqrt(u)). Whether a computed eigenvalue has
a nonzero imaginary part is therefore not a sound test, and neither is any
fixed threshold on Im lambda.

**What is certified.** A is a float64 matrix. Every real number within half
an ulp of A_ij rounds to A_ij, so the stored matrix stands for the whole box
``|A~ - A| <= rel_error |A|`` entrywise (``rel_error`` = u = 2^-53 by
default), plus an optional Frobenius ball ``||E||_F <= input_error``. The
answer *complex* means: every matrix of that set has a non-real eigenvalue;
*real*: every matrix of the set has only real eigenvalues; *undecided*:
neither could be proven -- at the default ``rel_error`` this happens only
where the float64 matrix itself cannot tell (some matrices that round to A
have a complex pair and others do not), up to a factor of a few. Every
bound below is rigorous: rounding errors of the float64 computations are
bounded a priori (gamma_k = k u / (1 - k u), Higham, *Accuracy and Stability
of Numerical Algorithms*, 2nd ed., section 3.5), the pair's small problem is
evaluated exactly (error-free products and ``math.fsum``; rational
arithmetic for the 2 x 2 discriminant). The a-priori bounds assume a BLAS
whose matrix product is a sum of products in any order, with or without
FMA (OpenBLAS, MKL, reference BLAS), not a Strassen-type algorithm.

**Method** (``classify_spectrum``).

1. Eigenvalues and right eigenvectors (LAPACK ``dgeev``). The spectrum is
   cut into *units*: each real eigenvalue alone, and 2 x 2 *pairs*: every
   complex-conjugate pair and every two neighbouring real eigenvalues whose
   eigenvectors are nearly parallel (|cos| > 1 - 1e-4: the real side of an
   exceptional point). A pair gets a real orthonormal basis Q_c of its
   invariant subspace ([Re v, Im v] or [v_1, v_2], orthonormalised); if that
   basis is ill-conditioned (near the exceptional point) it is refined by
   subspace iteration with (A - sigma I)^{-1}, sigma at the pair.
2. X = [units' columns], R ~ X^{-1} (LAPACK), and S = X^{-1} A X, similar to
   A, is enclosed row by row: with C = fl(R fl(A X)), F = R X - I
   (||F||_inf < 1/2 required, which also proves X nonsingular),
   S = (I + F)^{-1} R A X and S - RAX = -F S, so the total deviation of row i
   of S from row i of C is at most
   dev_i = gamma_n (|R| |AX| + |R||A||X|) 1 + f_i ||S||_inf, f_i = row sum of
   |F|; the perturbation X^{-1} dA X of every matrix of the set is added.
3. **Isolation** (block Gershgorin, Feingold & Varga, Pacific J. Math. 12
   (1962) 1241): each real unit i has the disc |z - C_ii| <= sum_{j not in
   unit} |C_ij| + dev_i; each pair c has the region
   {z : sigma_min(S_cc - z I) <= r_c}, r_c the sum of its off-block row
   entries, covered by the disc of centre (s11 + s22)/2 and radius
   rho_c = (sqrt2 r + sqrt(2 r^2 + 4(|D| + r ||N||_F)))/2 (from
   sigma_min(W) >= |det W| / ||W||_F; N = S_cc - tr/2 I). All discs are
   centred on the real axis; if neighbouring ones are disjoint, each holds
   exactly as many eigenvalues as its unit (the continuity argument of
   Gershgorin's theorem), so a real unit's eigenvalue is real (its disc is
   symmetric about the axis).
4. **The pair** (the decision that matters). M_c = S_cc + S_cr P is the
   exact 2 x 2 matrix of the pair, where P solves the Riccati equation
   S_rr P - P S_cc = -S_rc + P S_cr P; by a contraction argument
   (Stewart, SIAM J. Numer. Anal. 10 (1973) 727) ||P||_F <= 2 gamma/delta if
   4 gamma eta < delta^2, gamma = ||S_rc||_F, eta = ||S_cr||_F, delta a
   lower bound of sep(S_rr, S_cc) (block-diagonal part of S_rr against
   S_cc, minus the norm of the rest). The coupling enters only at second
   order: ||M_c - S_cc||_F <= 2 gamma eta / delta.
   S_cc itself is first computed from C (*crude*). When that does not
   decide with a margin of 1e4, or the pair was refined, it is computed
   **sharply**: with the
   exact residual r = A Q_c - Q_c M~ (each entry an exact sum of error-free
   products, rounded once by ``math.fsum``), S_cc = M~ + Y_c r
   (Y = X^{-1}), so the only first-order uncertainty left is
   Y_c dA Q_c <= rel_error |R_c| |A| |Q_c|: the float64 representation of A.
5. D(M) = ((m11 - m22)/2)^2 + m12 m21 is the similarity-invariant
   discriminant: the pair is complex iff D < 0. It is evaluated exactly
   (``fractions``) at the centre, and |dD| <= 2|p| dp + dp^2 + |m12| r21 +
   |m21| r12 + r12 r21 (dp = (r11 + r22)/2, r_kl the entrywise radius) is
   exact for a quadratic. **margin** = |D| / bound; > 1 certifies the sign.

A 2 x 2 matrix (the normal form) is decided directly: S_cc = A, radius
rel_error |A| (+ input_error), no similarity.

**From a previous basis** (``classify_spectrum(A, basis=)``, a ramp's next
step). Steps 2-5 hold for any nonsingular X, so step 1 can be replaced by
the verified basis of a nearby matrix, corrected without an eigen-solve
(:func:`_from_basis`). Its answer is kept only if certified; otherwise the
decision starts from dgeev. Either answer certifies the same thing.

The spectrum decision is *complex* if some pair is certified complex (no
isolation needed: the Riccati argument alone proves M_c's eigenvalues are
eigenvalues of every matrix of the set), *real* if every pair is certified
real and every unit is isolated, else *undecided*. Its confidence is the
largest certified-complex margin, the smallest margin (pair or isolation)
when real, the smallest failing margin when undecided.

For the normal form of docs/model.md section 8,
J = [[1 - d, eta], [-eta, 1 + d]] with eps = 1 - eta/d: D = d^2 - eta^2 =
d^2 eps (2 - eps), so the sign of D is that of eps; complex iff eps < 0.

.. warning:: The decision is about the matrix given (and the set it stands
   for), not about the physics behind it: a matrix assembled with larger
   errors needs them as ``input_error``. The sparse path
   (:func:`classify_projected`) decides for the projected matrix of the
   window searched; eigenvalues outside that window are not bounded.
"""
# Module size (~800 lines, ~95 of them this docstring): one algorithm, the
# certified decision, kept in one module so that the code of each step sits
# with the step of the proof above; its float64 error bounds are in
# analysis.enclosure and the pair's exponents (sqrt_law) in analysis.eigtrack.
from __future__ import annotations

from dataclasses import dataclass, field
import math
import time
import warnings

import numpy as np
import scipy.linalg as sla

__all__ = ["PairDecision", "SpectrumBasis", "SpectrumDecision", "block_discriminant", "exact_residual",
           "classify_spectrum", "classify_projected", "normal_form", "UNIT_ROUNDOFF"]

# unit roundoff and the rigorous floating-point bounds: analysis.enclosure
from .enclosure import (EPS, TINY, UNIT_ROUNDOFF, U, _cover_radius, _disc_test,  # noqa: E402
                        _frac, _gamma, _margin, _pair_eigs, _sigma_min_2x2_lower,
                        _sigma_min_lower, _up, exact_residual)
_PARALLEL = 1.0 - 1e-4          # |cos| of two real eigenvectors above which they form a pair
_ILL = 100.0                    # pair basis condition above which the subspace is refined
_SHARP_BELOW = 1e4              # crude margin below which a pair is also computed sharply
_BASIS_CORRECTED = 0.001         # a corrected basis is used once its verified coupling max|W| <= this
_BASIS_ITERATIONS = 3           # ... after at most this many corrections
_BASIS_DIVERGED = 1.0           # a correction |W| above this: give up, start from dgeev
_SPARSE_PRODUCT = 0.25          # nonzero fraction of A below which A X is a sparse product
_BASIS_MERGE = 0.5              # |W_ij| above which two real units of a basis become a pair


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
    """Discriminant of a 2 x 2 block and its gradient norm (float64 estimate).

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
        Bound on the rounding error in evaluating D in float64.
    """
    B = np.asarray(B, dtype=np.float64)
    p = 0.5 * (B[0, 0] - B[1, 1])
    D = p * p + B[0, 1] * B[1, 0]
    g = float(np.sqrt(2.0 * p * p + B[0, 1] ** 2 + B[1, 0] ** 2))
    rnd = 4.0 * EPS * (p * p + abs(B[0, 1] * B[1, 0]))
    return float(D), g, float(rnd)


# --------------------------------------------------------------------------- results
@dataclass
class PairDecision:
    """Decision for one pair of eigenvalues (or the isolation of two neighbours).

    Attributes
    ----------
    eigenvalues : ndarray, complex, shape (2,)
        The pair (eigenvalues of the centre of its 2 x 2 block; for an
        isolation entry the two neighbouring centres).
    is_complex : bool
        Sign of the discriminant at the centre: True if D < 0.
    certified : bool
        True if margin > 1: the sign of D (pair) or the separation of the
        two discs (isolation) holds for every matrix of the set.
    margin : float
        |D| / (bound on the change of D) for a pair; distance of the centres
        / sum of the radii for an isolation entry.
    discriminant : float
        D of the pair's 2 x 2 block (1/time^4 for M^-1 K), rounded to float.
    bound : float
        Largest change of D compatible with the errors.
    eta : float
        Frobenius radius of the pair's 2 x 2 block (all errors, coupling
        included).
    sep : float
        Lower bound of sep(S_rr, S_cc) (inf for a 2 x 2 matrix).
    kappa : tuple of float or None
        Unused (kept for compatibility); None.
    method : str
        ``'exact-2x2'`` (the matrix is 2 x 2), ``'riccati-2x2'`` (a pair of a
        larger matrix) or ``'gershgorin'`` (isolation of two neighbouring
        units).
    reason : str
        Why an entry is not certified (empty otherwise).
    sharp : bool
        The pair's block was computed with the exact residual (step 4 of the
        module docstring), not only from the float64 similarity.
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
    method: str = "riccati-2x2"
    reason: str = ""
    sharp: bool = False

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
        True: a pair is certified complex. False: every eigenvalue is
        certified real. None: undecided (a pair is too close to an
        exceptional point for the precision of the matrix, or a unit is not
        isolated).
    confidence : float
        For True, the largest margin among certified complex pairs; for
        False, the smallest margin (pairs and isolation); for None, the
        smallest margin (< 1) among the entries that failed.
    pairs : list of PairDecision
        Every pair and every isolation entry between neighbouring units.
    backward_error : float
        Largest row deviation bound dev_i of the similarity (units of A).
    eigenvalues : ndarray, complex
        All eigenvalues, sorted by real part: LAPACK's (``start`` 'dgeev'),
        or the verified basis's block centres with their second-order
        coupling term (``start`` 'basis').
    timing : dict
        Wall times in seconds: ``eigen`` (eigenvalues and vectors; 0 for a
        decision from a previous basis) and ``decision`` (everything else).
    reason : str
        For an undecided spectrum, why.
    basis : SpectrumBasis or None
        The verified basis, to start the decision of a nearby matrix from
        (``classify_spectrum(..., basis=)``); None if verification failed.
    start : str
        ``'dgeev'`` (eigenvectors computed for this matrix) or ``'basis'``
        (the basis of a previous decision, corrected; see
        :func:`classify_spectrum`).
    """

    complex_present: bool | None
    confidence: float
    pairs: list = field(default_factory=list)
    backward_error: float = 0.0
    eigenvalues: np.ndarray | None = None
    timing: dict = field(default_factory=dict)
    reason: str = ""
    basis: "SpectrumBasis | None" = None
    start: str = "dgeev"

    @property
    def critical_pair(self):
        """The pair that decided (largest-margin complex pair if present, else least certain)."""
        cands = [p for p in self.pairs if p.method != "gershgorin"] or self.pairs
        if not cands:
            return None
        if self.complex_present:
            return max((p for p in cands if p.is_complex and p.certified),
                       key=lambda p: p.margin)
        return min(cands, key=lambda p: p.margin)


@dataclass
class SpectrumBasis:
    """A verified basis of a decision: the start of the next one.

    Attributes
    ----------
    X : ndarray, shape (n, n)
        Columns: the units' bases (a real eigenvector, or two columns
        spanning a pair's invariant subspace), unit ``b`` in columns
        ``blocks[b][0] : blocks[b][0] + blocks[b][1]``.
    R : ndarray, shape (n, n)
        The float64 inverse of X used in the verification.
    blocks : list of (int, int)
        (first column, size 1 or 2) of each unit.
    """

    X: np.ndarray
    R: np.ndarray
    blocks: list

    @property
    def pairs(self):
        """ndarray of bool, shape (len(blocks),): the unit is a pair (a complex
        pair or two near-parallel real eigenvectors), i.e. has two columns."""
        return np.array([k == 2 for _, k in self.blocks], dtype=bool)

    def save(self, path):
        """Write X and the block layout to ``path`` (``.npz``; R is recomputed on load)."""
        b = np.asarray(self.blocks, np.int64).reshape(-1, 2)
        with open(path, "wb") as fh:
            np.savez(fh, X=self.X, blocks=b)

    @classmethod
    def load(cls, path):
        """Read a basis written by :meth:`save` (R = inv(X), as the verification computes it).

        Raises
        ------
        ValueError
            If the file is not a saved basis (the message names it).
        """
        try:
            with np.load(path) as z:
                X, b = z["X"], z["blocks"]
        except (OSError, KeyError, ValueError) as exc:
            raise ValueError(f"cannot read spectrum basis {path!r}: {exc}") from exc
        n = X.shape[0]
        if (X.ndim != 2 or X.shape != (n, n) or b.ndim != 2 or b.shape[1] != 2
                or int(b[:, 1].sum()) != n):
            raise ValueError(f"cannot read spectrum basis {path!r}: inconsistent shapes")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            R = np.linalg.inv(X)
        return cls(X, R, [(int(s), int(k)) for s, k in b])


# --------------------------------------------------------------------------- units and bases
@dataclass
class _Unit:
    idx: tuple                 # eigenvalue indices (1 or 2)
    complex_pair: bool = False
    merged: bool = False       # real pair formed because the eigenvectors are parallel


def _units(lam, V):
    """Split the spectrum into real units and pairs (complex pairs, parallel real pairs)."""
    n = lam.size
    units = []
    nonreal = np.flatnonzero(lam.imag != 0.0).tolist()
    k = 0
    while k < len(nonreal):             # LAPACK stores a complex pair as neighbours
        j = nonreal[k]
        if j + 1 < n and lam[j + 1] == np.conj(lam[j]):
            units.append(_Unit((j, j + 1), complex_pair=True))
            k += 2
            continue
        raise ValueError("eigenvalue solver returned an unpaired complex eigenvalue")
    reals = np.flatnonzero(lam.imag == 0.0)
    reals = reals[np.argsort(lam.real[reals], kind="stable")]
    # |cos| of the angle between the eigenvectors of sorted neighbours (one
    # array operation; only compared with _PARALLEL)
    Vr = V[:, reals].real
    nrm = np.sqrt(np.einsum("ij,ij->j", Vr, Vr))
    parallel = (np.abs(np.einsum("ij,ij->j", Vr[:, :-1], Vr[:, 1:]))
                / (nrm[:-1] * nrm[1:]) > _PARALLEL).tolist()
    reals = reals.tolist()
    k = 0
    while k < len(reals):
        if k + 1 < len(reals) and parallel[k]:
            units.append(_Unit((reals[k], reals[k + 1]), merged=True))
            k += 2
            continue
        units.append(_Unit((reals[k],)))
        k += 1
    return units


def _refine(A, sigma, Q, iters=4):
    """Orthonormal basis of the 2-dimensional invariant subspace nearest sigma.

    Subspace iteration with (A - sigma I)^{-1} from Q; returns Q unchanged if
    the shifted matrix cannot be factorised or the iteration breaks down.
    """
    n = A.shape[0]
    B = A - sigma * np.eye(n)
    for _ in range(3):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            lu, piv = sla.lu_factor(B, check_finite=False)
        if np.all(np.diag(lu) != 0):
            break
        sigma = sigma * (1 + 64 * EPS) + 64 * TINY
        B = A - sigma * np.eye(n)
    else:
        return Q
    W = Q
    for _ in range(iters):
        Y = sla.lu_solve((lu, piv), W, check_finite=False)
        if not np.all(np.isfinite(Y)):
            return Q
        W, _ = np.linalg.qr(Y)
    return W


def _pair_basis(A, lam, V, unit):
    """Real orthonormal basis (n x 2) of a pair's invariant subspace (refined near an EP)."""
    i, j = unit.idx
    if unit.complex_pair:
        V0 = np.column_stack([V[:, i].real, V[:, i].imag])
    else:
        V0 = np.column_stack([V[:, i].real, V[:, j].real])
    V0 = V0 / np.maximum(np.linalg.norm(V0, axis=0), TINY)
    sv = np.linalg.svd(V0, compute_uv=False)
    Q, _ = np.linalg.qr(V0)
    cond = sv[0] / sv[1] if sv[1] > 0 else math.inf
    if unit.merged or cond > _ILL:
        sigma = 0.5 * (lam[i].real + lam[j].real)
        return _refine(A, sigma, Q), True
    return Q, False


# --------------------------------------------------------------------------- verification
class _Verified:
    """Enclosure of S = X^{-1} A~ X, row by row (step 2 of the module docstring)."""

    def __init__(self, A, X, blocks, rel_error, input_error, Ap=None):
        n = A.shape[0]
        self.n = n
        self.ok = False
        self.reason = ""
        g = _gamma(n + 2)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                R = np.linalg.inv(X)
            except np.linalg.LinAlgError:
                self.reason = "eigenvector basis is singular"
                return
        if not np.all(np.isfinite(R)):
            self.reason = "eigenvector basis is singular"
            return
        aA, aX, aR = np.abs(A), np.abs(X), np.abs(R)
        G = (A if Ap is None else Ap) @ X
        C = R @ G
        H = R @ X
        xs = aX.sum(axis=1)
        axs = aA @ xs
        raxs = aR @ axs
        rgs = aR @ np.abs(G).sum(axis=1)
        rxs = aR @ xs
        Fh = H
        Fh[np.diag_indices(n)] -= 1.0
        f = _up(np.abs(Fh).sum(axis=1) + g * rxs, n)
        fmax = float(f.max())
        if not fmax < 0.5:
            self.reason = f"eigenvector basis too ill-conditioned (||R X - I|| = {fmax:.2g})"
            return
        e1 = g * (rgs + raxs)
        absC = np.abs(C)
        nrax = _up(float((absC.sum(axis=1) + e1).max()), n)
        dev = e1 + f * (nrax / (1.0 - fmax))
        ynorm_inf = _up(float(aR.sum(axis=1).max()), n) / (1.0 - fmax)
        if rel_error > 0:
            w = rel_error * raxs
            dev = dev + w + f * (float(w.max()) / (1.0 - fmax))
        if input_error > 0:
            Rn = np.linalg.norm(R, axis=1)
            Yn = Rn + f * (float(Rn.max()) / (1.0 - fmax))
            dev = dev + Yn * input_error * float(np.linalg.norm(X, axis=0).sum())
        self.dev = _up(dev, n)
        one = [s for s, k in blocks if k == 1]
        absC[one, one] = 0.0
        for s, k in blocks:
            if k > 1:
                absC[s:s + k, s:s + k] = 0.0
        self.off = _up(absC.sum(axis=1), n)       # row sums outside the own block
        self.absC = absC
        self.C, self.R, self.f, self.fmax = C, R, f, fmax
        self.ynorm_inf = ynorm_inf
        self.raxs = raxs
        self.ok = True

    def crude_block(self, s):
        """Centre (float) and entrywise radius of S_cc from the row enclosure."""
        S = self.C[s:s + 2, s:s + 2].copy()
        d = self.dev[s:s + 2]
        return S, np.column_stack([d, d])

    def sharp_block(self, A, Q, s, rel_error, input_error):
        """S_cc = M~ + Y_c r with the exact residual r = A Q - Q M~ (step 4)."""
        n = self.n
        Mt = self.C[s:s + 2, s:s + 2].copy()
        r, er = exact_residual(A, Q, Mt)
        Rc = self.R[s:s + 2]
        aRc = np.abs(Rc)
        t = Rc @ r
        rad = _gamma(n + 2) * (aRc @ np.abs(r)) + aRc @ er
        # Y_c = R_c - (F Y)_c:  |(F Y r)_ik| <= f_i ||Y||_inf ||r_k + er_k||_inf
        rcol = (np.abs(r) + er).max(axis=0)
        rad = rad + np.outer(self.f[s:s + 2], self.ynorm_inf * rcol)
        if rel_error > 0:
            aAQ = np.abs(A) @ np.abs(Q)
            rad = rad + rel_error * (aRc @ aAQ
                                     + np.outer(self.f[s:s + 2], self.ynorm_inf
                                                * aAQ.max(axis=0)))
        if input_error > 0:
            yc = float(np.linalg.norm(Rc)) + math.sqrt(2.0 * n) * float(self.f[s:s + 2].max()) \
                * self.ynorm_inf
            rad = rad + yc * input_error * float(np.linalg.norm(Q))
        Sf = _frac(Mt)
        Tf = _frac(t)
        S = [[Sf[a][b] + Tf[a][b] for b in range(2)] for a in range(2)]
        return S, _up(rad, n)


@dataclass
class _Block:
    """What the decision of one pair c needs from the rest of S (step 4)."""

    rest: bool                 # the matrix has more than the pair
    gam: float                 # >= ||S_rc||_F
    eta: float                 # >= ||S_cr||_F
    err_rr: float              # >= ||S_rr - blockdiag||_F
    r_c: float                 # block Gershgorin radius of the pair's rows
    lam1: np.ndarray           # centres of the real units
    others: list               # centres (2 x 2) of the other pairs

    def decide(self, S, rad, sharp):
        """PairDecision and cover radius for centre S (Fractions) and radius rad (2 x 2)."""
        Sfl = np.array([[float(S[0][0]), float(S[0][1])], [float(S[1][0]), float(S[1][1])]])
        rad = rad + U * np.abs(Sfl)          # float copy of the exact centre
        D0 = ((S[0][0] - S[1][1]) / 2) ** 2 + S[0][1] * S[1][0]
        if not np.all(np.isfinite(rad)):
            return PairDecision(_pair_eigs(S), D0 < 0, False, 0.0, float(D0), eta=math.inf,
                                reason="no finite bound on the block", sharp=sharp), math.inf
        radn = _up(float(np.linalg.norm(rad)), 4)
        sep = math.inf
        if self.lam1.size:
            sep = float(_sigma_min_2x2_lower(self.lam1 - Sfl[0, 0], -Sfl[1, 0], -Sfl[0, 1],
                                             self.lam1 - Sfl[1, 1]).min())
        for B in self.others:
            Kr = np.kron(np.eye(2), B) - np.kron(Sfl.T, np.eye(2))
            sep = min(sep, _sigma_min_lower(Kr))
        delta = sep - self.err_rr - radn
        ric = 0.0
        if self.rest:
            if not (delta > 0 and 4.0 * self.gam * self.eta < delta * delta * (1 - 8 * U)):
                return PairDecision(
                    _pair_eigs(S), D0 < 0, False, 0.0, float(D0), sep=float(sep), eta=radn,
                    reason=f"pair not separated from the rest: sep >= {sep:.3g}, coupling "
                           f"{self.gam:.3g} x {self.eta:.3g}", sharp=sharp), math.inf
            ric = _up(2.0 * self.gam * self.eta / delta, 4)
        D, bound = _disc_test(S, rad + ric)
        cert = abs(D) > bound
        dec = PairDecision(_pair_eigs(S), D < 0, bool(cert), _margin(D, bound), float(D),
                           float(bound), _up(radn + 2 * ric, 4),
                           float(delta if self.rest else math.inf), None, "riccati-2x2",
                           "" if cert else "discriminant within its error bound", sharp)
        # eig(M_c) lies in the block region only if the coupling term is below r_c
        cover = math.inf if ric > self.r_c else _cover_radius(S, self.r_c + radn)
        return dec, cover


def _analyse(A, lam, V, units, rel_error, input_error, Ap=None):
    """One verification pass over the given units. Returns (entries, summary data)."""
    n = A.shape[0]
    # column layout: units sorted by the real part of their eigenvalues
    lr = lam.real.tolist()
    key = [lr[un.idx[0]] if len(un.idx) == 1 else (lr[un.idx[0]] + lr[un.idx[1]]) / 2
           for un in units]
    order = sorted(range(len(units)), key=key.__getitem__)
    units = [units[k] for k in order]
    blocks, refined, single = [], [], []
    s = 0
    for un in units:
        k = len(un.idx)
        blocks.append((s, k))
        if k == 1:
            single.append((s, un.idx[0]))
        s += k
    X = np.empty((n, s))
    if single:
        at, idx = (np.array(c) for c in zip(*single))
        Vs = V[:, idx].real
        X[:, at] = Vs / np.sqrt(np.einsum("ij,ij->j", Vs, Vs))
    for un, (s, k) in zip(units, blocks):
        if k == 2:
            X[:, s:s + 2], ref = _pair_basis(A, lam, V, un)
        refined.append(k == 2 and ref)
    return _verify(A, X, blocks, units, refined, rel_error, input_error, Ap)


def _verify(A, X, blocks, units, refined, rel_error, input_error, Ap=None, ver=None):
    """Steps 2-5 for the basis X (units' columns at ``blocks``): (entries, _Verified).

    ``Ap``: A in a form for the product A X (a sparse copy; None: A). ``ver``:
    the step-2 enclosure of this X and ``blocks`` if already made."""
    n = A.shape[0]
    if ver is None:
        ver = _Verified(A, X, blocks, rel_error, input_error, Ap)
    if not ver.ok:
        return None, ver
    ver.basis = SpectrumBasis(X, ver.R, blocks)
    dev, off, C = ver.dev, ver.off, ver.C
    one = np.array([b for b, (s, k) in enumerate(blocks) if k == 1], dtype=np.intp)
    s_one = np.array([blocks[b][0] for b in one.tolist()], dtype=np.intp)
    lam1 = C[s_one, s_one]
    offdev = off + dev
    # discs (centre, radius, block index): the real units', then the pairs'
    discs = [lam1.tolist(), offdev[s_one].tolist(), one.tolist()]
    pending = []                     # (block, start, _Block, crude decision, cover, centre)
    pair_out = []
    for b, (s, k) in enumerate(blocks):
        if k == 1:
            continue
        c = [s, s + 1]
        rest = np.ones(n, bool)
        rest[c] = False
        blk = _Block(
            rest=bool(rest.any()),
            gam=_up(math.sqrt(float(np.sum((ver.absC[:, c].sum(axis=1)[rest]
                                            + dev[rest]) ** 2))), n),
            eta=_up(math.sqrt(float(np.sum(offdev[c] ** 2))), 2),
            err_rr=_up(math.sqrt(float(np.sum(offdev[rest] ** 2))), n),
            r_c=_up(float(offdev[c].sum()), 4),
            lam1=lam1,
            others=[C[s2:s2 + 2, s2:s2 + 2] for s2, k2 in blocks if k2 == 2 and s2 != s])
        S0 = _frac(ver.crude_block(s)[0])
        dec, cover = blk.decide(S0, ver.crude_block(s)[1], False)
        pending.append((b, s, blk, dec, cover, S0))
    # sharp enclosure: the pair nearest an exceptional point (smallest crude
    # margin), refined pairs, and every pair the crude enclosure leaves unsure
    crit = min(range(len(pending)), key=lambda q: pending[q][3].margin) if pending else -1
    for q, (b, s, blk, dec, cover, S) in enumerate(pending):
        if q == crit or refined[b] or not dec.certified or dec.margin < _SHARP_BELOW:
            try:
                Sx, radx = ver.sharp_block(A, X[:, s:s + 2], s, rel_error, input_error)
            except ValueError:
                Sx = None
            if Sx is not None:
                dec2, cover2 = blk.decide(Sx, radx, True)
                if dec2.certified or not dec.certified:
                    dec, cover, S = dec2, cover2, Sx
        centre = float((S[0][0] + S[1][1]) / 2)
        for lst, v in zip(discs, (centre, cover + U * abs(centre), b)):
            lst.append(v)
        pair_out.append(dec)
    iso, ver.conflicts = _isolation(discs, blocks, units)
    return pair_out + iso, ver


def _from_basis(A, basis, rel_error, input_error, Ap=None):
    """Steps 2-5 from a previous decision's basis, corrected (no eigen-solve).

    With C = R A X (block diagonal up to the change of A since X was
    verified), X <- X (I + W), W_ij = C_ij / (C_jj - C_ii) for i, j in
    different units, removes the off-block part of C to first order. The
    corrected X is enclosed (step 2, R = X^{-1} anew); the enclosure's C gives
    the next W, and the correction is repeated (a Newton-type iteration whose
    |W| fell quadratically on the ramps tried) until the enclosed X's own
    max |W| <= ``_BASIS_CORRECTED``, at most ``_BASIS_ITERATIONS`` times (one
    correction was enough for 293 of the 297 N = 100 ramp steps tried). The
    verification of X is the same rigorous one as for dgeev's vectors (it
    holds for any nonsingular X). Returns (entries, _Verified, eigenvalues)
    or None if the basis does not fit (size), the correction diverges or it
    has not converged after ``_BASIS_ITERATIONS`` corrections.
    """
    X, R, blocks = basis.X, basis.R, basis.blocks
    n = A.shape[0]
    if X.shape != (n, n):
        return None
    def layout(blocks):
        unit = np.repeat(np.arange(len(blocks)), [k for _, k in blocks])
        return unit[:, None] == unit[None, :]

    def correction(C0, same):
        d = C0.diagonal()
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            W = C0 / (d[None, :] - d[:, None])
        W[same] = 0.0
        return W

    same = layout(blocks)
    C0 = R @ ((A if Ap is None else Ap) @ X)
    ver = None
    for it in range(_BASIS_ITERATIONS + 1):
        W = correction(C0, same)
        if it == 0:
            new = _merge_coupled(W, blocks)
            if new is None:
                return None
            if new is not blocks:       # strongly coupled real units become pairs
                perm = np.concatenate([np.arange(s0, s0 + k) for s0, k in new[1]])
                X, R, C0 = X[:, perm], R[perm], C0[np.ix_(perm, perm)]
                blocks = new[0]
                same = layout(blocks)
                W = correction(C0, same)
        wmax = float(np.abs(W).max()) if W.size else 0.0
        if not wmax <= _BASIS_DIVERGED:          # also NaN / inf
            return None
        if it and wmax <= _BASIS_CORRECTED:      # the verified X's coupling is small
            break
        if it == _BASIS_ITERATIONS:  # not converged: the eigenvalue estimates would be poor
            return None
        X = X + X @ W
        X /= np.sqrt(np.einsum("ij,ij->j", X, X))
        # the enclosure's C = X^-1 A X is the next iteration's C0
        ver = _Verified(A, X, blocks, rel_error, input_error, Ap)
        if not ver.ok:
            return None
        C0 = ver.C
    units = [_Unit(tuple(range(s0, s0 + k)), merged=k == 2) for s0, k in blocks]
    entries, ver = _verify(A, X, blocks, units, [False] * len(blocks), rel_error,
                           input_error, Ap, ver)
    if entries is None or ver.conflicts:
        return None
    # eigenvalues: a unit's diagonal entry of C, plus the second-order
    # coupling sum_j C_ij C_ji / (C_ii - C_jj) (measured on ramps, relative to
    # max |lambda|: dgeev's to 2e-14-4e-11; 1e-13-4e-8 without the coupling
    # term); a pair's 2 x 2 block
    C = ver.C
    d = C.diagonal()
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        T = C * C.T / (d[:, None] - d[None, :])
    T[same] = 0.0
    for s0, k in blocks:            # a pair's coupling through its 2 x 2 resolvent
        if k == 2:
            p, q, r, t = C[s0, s0], C[s0, s0 + 1], C[s0 + 1, s0], C[s0 + 1, s0 + 1]
            a, b = C[:, s0], C[:, s0 + 1]            # C_ic
            e, f = C[s0, :], C[s0 + 1, :]            # C_ci
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                det = (d - p) * (d - t) - q * r
                T[:, s0] = (a * ((d - t) * e + q * f) + b * (r * e + (d - p) * f)) / det
            T[:, s0 + 1] = 0.0
            T[s0:s0 + 2, s0] = 0.0
    lam = (d + T.sum(axis=1)).astype(complex)
    if not np.all(np.isfinite(lam)):
        lam = d.astype(complex)
    for s0, k in blocks:
        if k == 2:
            # the pair's eigenvalues mu with the same second-order coupling:
            # those of C_cc + C_cr (mu I - D_r)^-1 C_rc (two fixed-point sweeps
            # from the block's own eigenvalues); a complex pair stays an exact
            # conjugate pair, a real one real (else the block's own are kept)
            c = slice(s0, s0 + 2)
            own = np.linalg.eigvals(C[c, c]).astype(complex)
            mus = own.copy()
            for h in range(2):
                mu = mus[h]
                for _ in range(2):
                    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                        w = 1.0 / (mu - d)
                    w[c] = 0.0
                    M = C[c, c] + (C[c, :] * w) @ C[:, c]
                    if not np.all(np.isfinite(M)):
                        break
                    ev = np.linalg.eigvals(M)
                    mu = ev[np.argmin(np.abs(ev - mu))]
                mus[h] = mu
            if own.imag.any():
                z = mus[int(np.argmax(mus.imag))]
                mus = np.array([z.conjugate(), z]) if z.imag > 0 else own
            elif mus.imag.any():
                mus = own
            lam[c] = mus
    return entries, ver, lam[np.lexsort((lam.imag, lam.real))]


def _merge_coupled(W, blocks):
    """Pair up the real units that a first-order correction cannot separate.

    Two single units i, j with max(|W_ij|, |W_ji|) > ``_BASIS_MERGE`` (their
    eigenvalues close compared with their coupling: the two sides of an
    exceptional point) become one 2 x 2 unit, decided by step 4. Returns
    ``blocks`` itself if nothing is merged, else (new blocks, the old blocks
    in the new column order); None if a unit is strongly coupled to more than
    one other, or a pair to anything (no 2 x 2 layout separates them).
    """
    strong = np.argwhere(np.maximum(np.abs(W), np.abs(W.T)) > _BASIS_MERGE)
    strong = strong[strong[:, 0] < strong[:, 1]]
    if strong.size == 0:
        return blocks
    start = {s0: b for b, (s0, k) in enumerate(blocks)}
    partner = {}
    for i, j in strong.tolist():
        if i not in start or j not in start or blocks[start[i]][1] != 1 \
                or blocks[start[j]][1] != 1 or i in partner or j in partner:
            return None
        partner[i], partner[j] = j, i
    order, done = [], set()
    for s0, k in blocks:
        if s0 in done:
            continue
        order.append((s0, k))
        if s0 in partner:
            order.append((partner[s0], 1))
            done.add(partner[s0])
    new, col, b = [], 0, 0
    while b < len(order):
        s0, k = order[b]
        if k == 1 and s0 in partner:
            new.append((col, 2))
            col, b = col + 2, b + 2
        else:
            new.append((col, k))
            col, b = col + k, b + 1
    return new, order


def _isolation(discs, blocks, units):
    """Isolation of neighbouring discs (all centred on the real axis).

    ``discs`` holds three lists: centres, radii and block indices. Returns
    the PairDecision of each neighbouring pair of discs and the eigenvalue
    index pairs of two real units whose discs overlap.
    """
    c, r, b = (np.asarray(v) for v in discs)
    order = np.argsort(c, kind="stable")
    c, r, b = c[order], r[order], b[order].tolist()
    gap = (c[1:] - c[:-1]) * (1 - 2 * U)
    rr = (r[:-1] + r[1:]) * (1 + 2 * U)
    pos = rr > 0
    m = np.full(gap.shape, math.inf)
    m[pos] = gap[pos] / rr[pos]
    ok = (gap > rr).tolist()
    c, m, rr = c.tolist(), m.tolist(), rr.tolist()
    iso = [PairDecision(np.array([c[k], c[k + 1]], complex), False, ok[k], m[k],
                        method="gershgorin", reason="" if ok[k] else "discs overlap",
                        bound=rr[k])
           for k in range(len(ok))]
    conflicts = [(units[b[k]].idx[0], units[b[k + 1]].idx[0]) for k in range(len(ok))
                 if not ok[k] and blocks[b[k]][1] == 1 and blocks[b[k + 1]][1] == 1]
    return iso, conflicts


def _validate(A, input_error, rel_error):
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
    if not (input_error >= 0) or not math.isfinite(input_error):
        raise ValueError(f"input_error must be finite and >= 0, got {input_error!r}")
    if not (rel_error >= 0) or not rel_error < 0.01:
        raise ValueError(f"rel_error must be in [0, 0.01), got {rel_error!r}")
    return A


def _decide_2x2(A, input_error, rel_error):
    S = _frac(A)
    rad = rel_error * np.abs(A) + input_error
    D, bound = _disc_test(S, rad)
    cert = abs(D) > bound
    return PairDecision(_pair_eigs(S), D < 0, bool(cert), _margin(D, bound), float(D),
                        float(bound), float(np.linalg.norm(rad)), math.inf, None, "exact-2x2",
                        "" if cert else "discriminant within its error bound", True)


def _sparse_copy(A):
    """CSR copy of A (the same float64 entries) for the products A X, if at most
    ``_SPARSE_PRODUCT`` of its entries are nonzero (an M^-1 K: ~4 %); else None.
    A sparse product is a sum of fewer products, so the a-priori bound gamma_n
    of step 2 holds for it too."""
    import scipy.sparse as sp

    if np.count_nonzero(A) > _SPARSE_PRODUCT * A.size:
        return None
    return sp.csr_matrix(A)


def classify_spectrum(A, input_error=0.0, rel_error=UNIT_ROUNDOFF, basis=None):
    """Decide soundly whether the real matrix A has a complex pair of eigenvalues.

    Parameters
    ----------
    A : ndarray or sparse matrix, shape (n, n)
        Real matrix, e.g. M^{-1} K after rattler removal (dense; a sparse
        matrix is densified).
    input_error : float, optional
        Absolute uncertainty (Frobenius norm) of A, on top of
        ``rel_error`` (default 0).
    rel_error : float, optional
        Entrywise relative uncertainty of A (default u = 2^-53: every real
        matrix that rounds to A; 0 decides for A exactly as stored).
    basis : SpectrumBasis, optional
        The ``basis`` of the decision of a nearby matrix (the previous step
        of a ramp). Tried first: corrected to first order (no eigen-solve)
        and verified rigorously like dgeev's vectors; its answer is used
        only if it is certified (*complex* or *real*), else the decision
        starts from dgeev. Either way the answer certifies the same thing;
        the margins differ (the corrected basis leaves more coupling).

    Returns
    -------
    SpectrumDecision
        See the module docstring for what each answer certifies;
        ``start`` says which basis it came from.

    Raises
    ------
    ValueError
        If A is not square, not real, or not finite, or an error parameter
        is out of range.
    """
    A = _validate(A, input_error, rel_error)
    n = A.shape[0]
    t0 = time.perf_counter()
    if n < 2:
        lam = A.diagonal().astype(complex)
        return SpectrumDecision(False, math.inf, [], 0.0, lam, {"eigen": 0.0, "decision": 0.0})
    if n == 2:
        lam = np.linalg.eigvals(A).astype(complex)
        t1 = time.perf_counter()
        p = _decide_2x2(A, input_error, rel_error)
        lam = lam[np.lexsort((lam.imag, lam.real))]
        return _summarize([p], 0.0, lam, {"eigen": t1 - t0,
                                          "decision": time.perf_counter() - t1}, "")
    Ap = _sparse_copy(A)
    if basis is not None:
        warm = _from_basis(A, basis, rel_error, input_error, Ap)
        if warm is not None:
            entries, ver, lam = warm
            dec = _summarize(entries, float(np.max(ver.dev)), lam,
                             {"eigen": 0.0, "decision": time.perf_counter() - t0}, "")
            if dec.complex_present is not None:
                dec.basis, dec.start = ver.basis, "basis"
                return dec
    t0e = time.perf_counter()
    lam, V = sla.eig(A, check_finite=False)
    t1 = time.perf_counter()
    lam_sorted = lam[np.lexsort((lam.imag, lam.real))]
    try:
        units = _units(lam, V)
    except ValueError as exc:
        return SpectrumDecision(None, 0.0, [], math.inf, lam_sorted,
                                {"eigen": t1 - t0, "decision": time.perf_counter() - t1},
                                str(exc))
    entries, ver = _analyse(A, lam, V, units, rel_error, input_error, Ap)
    if entries is not None and ver.conflicts:
        # neighbouring real eigenvalues whose discs touch: decide them as a pair
        taken, pairs = set(), []
        for i, j in ver.conflicts:
            if i not in taken and j not in taken:
                pairs.append(_Unit((i, j), merged=True))
                taken.update((i, j))
        new = [un for un in units if not (len(un.idx) == 1 and un.idx[0] in taken)] + pairs
        entries2, ver2 = _analyse(A, lam, V, new, rel_error, input_error, Ap)
        if entries2 is not None:
            entries, ver = entries2, ver2
    timing = {"eigen": t1 - t0e, "decision": time.perf_counter() - t1 + t0e - t0}
    if entries is None:
        return SpectrumDecision(None, 0.0, [], math.inf, lam_sorted, timing, ver.reason)
    dec = _summarize(entries, float(np.max(ver.dev)), lam_sorted, timing, "")
    dec.basis = ver.basis
    return dec


def _summarize(pairs, e, lam, timing, reason):
    cert_c = [p for p in pairs if p.method != "gershgorin" and p.is_complex and p.certified]
    if cert_c:
        return SpectrumDecision(True, max(p.margin for p in cert_c), pairs, e, lam, timing)
    unsure = [p for p in pairs if not p.certified]
    if unsure:
        worst = min(unsure, key=lambda p: p.margin)
        return SpectrumDecision(None, worst.margin, pairs, e, lam, timing,
                                reason or worst.reason)
    conf = min((p.margin for p in pairs), default=math.inf)
    return SpectrumDecision(False, conf, pairs, e, lam, timing)


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
        On the k eigenvalues nearest sigma (``decision.eigenvalues``);
        ``decision.timing`` has ``eigen`` (ARPACK, enrichment, Rayleigh-Ritz)
        and ``decision`` (the classification of T_k).
    residual : float
        ||A Q_k - Q_k T_k||_F.

    Raises
    ------
    ValueError
        Bad k, or sigma is an eigenvalue (singular shifted matrix).
    """
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    t0 = time.perf_counter()
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
    t1 = time.perf_counter()
    dec = classify_spectrum(Tk, input_error=res + input_error)
    dec.timing = {"eigen": t1 - t0 + dec.timing.get("eigen", 0.0),
                  "decision": dec.timing.get("decision", 0.0)}
    return dec, res


# the exponents of the tracked pair live with the track (analysis.eigtrack)
from .eigtrack import sqrt_law  # noqa: E402,F401
