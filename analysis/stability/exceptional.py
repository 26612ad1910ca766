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
evaluated with error-free products and sums (its residual as in twice the
working precision, Dot2, with a rigorous bound; rational arithmetic for
the 2 x 2 discriminant). The a-priori bounds assume a BLAS
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
   residual r = A Q_c - Q_c M~ computed as in twice the working precision
   (error-free products and sums, Dot2 of Ogita, Rump and Oishi, 2005, with
   a rigorous entrywise bound ~u |r|: ``enclosure.accurate_residual``),
   S_cc = M~ + Y_c r
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
(:func:`remote_trigger.analysis.stability.basis.from_basis`). Its answer
is kept only if certified; otherwise the decision starts from dgeev. Either
answer certifies the same thing.

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
   (:func:`remote_trigger.analysis.stability.projected.classify_projected`)
   decides for the projected matrix of the window searched; eigenvalues
   outside that window are not bounded.
"""
# Module size: the proof above with the public decision; the code of its
# steps is in analysis.stability.verification (steps 1-5 for one basis),
# .basis (the start from a previous basis), .decision (the result types) and
# .projected (the sparse path); the float64 error bounds in .enclosure and
# the pair's exponents (sqrt_law) in .eigtrack.
from __future__ import annotations

import math
import time

import numpy as np
import scipy.linalg as sla

from remote_trigger.analysis.stability.basis import from_basis
from remote_trigger.analysis.stability.decision import Decision, PairDecision, SpectrumDecision
from remote_trigger.analysis.stability.enclosure import (
    EPS, UNIT_ROUNDOFF, disc_test, frac, margin, pair_eigs)
from remote_trigger.analysis.stability.verification import (
    SparseCopy, Unit, analyse, split_units)

__all__ = ["classify_spectrum", "block_discriminant"]

_SPARSE_PRODUCT = 0.25          # nonzero fraction of A below which A X is a sparse product


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

    Raises
    ------
    ValueError
        If ``B`` is not 2 x 2.
    """
    B = np.asarray(B, dtype=np.float64)
    if B.shape != (2, 2):
        raise ValueError(f"block_discriminant needs a 2 x 2 block, got shape {B.shape}")
    p = 0.5 * (B[0, 0] - B[1, 1])
    D = p * p + B[0, 1] * B[1, 0]
    g = float(np.sqrt(2.0 * p * p + B[0, 1] ** 2 + B[1, 0] ** 2))
    rnd = 4.0 * EPS * (p * p + abs(B[0, 1] * B[1, 0]))
    return float(D), g, float(rnd)


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
    S = frac(A)
    rad = rel_error * np.abs(A) + input_error
    D, bound = disc_test(S, rad)
    cert = abs(D) > bound
    return PairDecision(pair_eigs(S), D < 0, bool(cert), margin(D, bound), float(D),
                        float(bound), float(np.linalg.norm(rad)), math.inf, None, "exact-2x2",
                        "" if cert else "discriminant within its error bound", True)


def _sparse_copy(A):
    """CSR copy of A (the same float64 entries) for the products A X, if at most
    ``_SPARSE_PRODUCT`` of its entries are nonzero (an M^-1 K: ~4 %); else None.
    A sparse product is a sum of fewer products, so the a-priori bound gamma_n
    of step 2 holds for it too."""
    if np.count_nonzero(A) > _SPARSE_PRODUCT * A.size:
        return None
    return SparseCopy(A)


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
        If A is not square, not real, or not finite, an error parameter is
        out of range, or ``basis`` is not a SpectrumBasis.
    """
    from remote_trigger.analysis.stability.decision import SpectrumBasis

    if basis is not None and not isinstance(basis, SpectrumBasis):
        raise ValueError(f"basis must be a SpectrumBasis (a decision's .basis) or None, got "
                         f"{type(basis).__name__}")
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
        warm = from_basis(A, basis, rel_error, input_error, Ap)
        if warm is not None:
            entries, ver, lam = warm
            dec = _summarize(entries, float(np.max(ver.dev)), lam,
                             {"eigen": 0.0, "decision": time.perf_counter() - t0}, "")
            if dec.decision is not Decision.UNDECIDED:
                dec.basis, dec.start = ver.basis, "basis"
                return dec
    t0e = time.perf_counter()
    lam, V = sla.eig(A, check_finite=False)
    t1 = time.perf_counter()
    lam_sorted = lam[np.lexsort((lam.imag, lam.real))]
    try:
        units = split_units(lam, V)
    except ValueError as exc:
        return SpectrumDecision(None, 0.0, [], math.inf, lam_sorted,
                                {"eigen": t1 - t0, "decision": time.perf_counter() - t1},
                                str(exc))
    entries, ver = analyse(A, lam, V, units, rel_error, input_error, Ap)
    if entries is not None and ver.conflicts:
        # neighbouring real eigenvalues whose discs touch: decide them as a pair
        taken, pairs = set(), []
        for i, j in ver.conflicts:
            if i not in taken and j not in taken:
                pairs.append(Unit((i, j), merged=True))
                taken.update((i, j))
        new = [un for un in units if not (len(un.idx) == 1 and un.idx[0] in taken)] + pairs
        entries2, ver2 = analyse(A, lam, V, new, rel_error, input_error, Ap)
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
