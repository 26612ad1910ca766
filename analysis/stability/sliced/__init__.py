r"""A certified complex-pair verdict on the whole spectrum, by spectrum slicing.

The dense decision (:mod:`remote_trigger.analysis.stability.exceptional`)
costs O(n^3) time and 14 n x n matrices of memory; from n ~ 10^4 it no
longer fits. This package decides the same question for a sparse K -- does
M^{-1}(K + E) have a complex pair, for every E with |E| <= rel_error |K|
entrywise -- at the cost of computing the eigenpairs of the *symmetric part*
in slices with sparse factorizations, O(n^2 k) time and O(n k) memory
(k a slice's size).

**Setting.** M is diagonal, so M^{-1}K is similar to A = M^{-1/2} K M^{-1/2}
= S + W, S symmetric, W skew-symmetric. In the paper's systems W is small
(||W||_2 ~ 1e-3 lambda_max at the onset: the tangential stiffness's
asymmetry) but larger than the mean spacing of S's eigenvalues from
N ~ 1000 on, so eigenvalue inclusion discs of radius ||W|| (Bauer-Fike)
overlap everywhere and decide nothing. What decides is the *local* coupling
across a point of the real axis.

**Boundary lemma.** Let a be real, not an eigenvalue of S, and write S in an
orthonormal basis where it is block diagonal up to small terms:
S = H + a + (symmetric rest), H = diag(Theta_N - a, H_2), Theta_N the Ritz
values of S within Delta of a (their vectors computed), H_2 the
compression of S to the orthogonal complement (eigenvalues at least
Delta_eff from a, shown by counting, below). Put Gamma = |H|, J = sign(H)
(they commute) and B = A + F - a - H (F any matrix of the set, ||F||_2 <=
eps). For z = a + iy, Gamma^{-1/2}(A + F - z)Gamma^{-1/2} = J + B' -
iy Gamma^{-1} with B' = Gamma^{-1/2} B Gamma^{-1/2}. Since J and Gamma^{-1}
commute, v^* J Gamma^{-1} v is real, so
Re <Jv, (J + B' - iy Gamma^{-1}) v> >= (1 - ||herm(J B')||) ||v||^2.
If kappa(a) := ||herm(J B')|| < 1, no matrix S + t(W + F + rest), 0 <= t
<= 1, has an eigenvalue on the line Re z = a, and by continuity in t **the
number of eigenvalues of A + F with real part below a equals the number of
eigenvalues of S below a**. For the skew W, herm(J W') = (J W' - W' J)/2
couples only directions on opposite sides of a, each weighted by
1/sqrt(|theta_i - a| |theta_j - a|): a pair (i, j) with a between them
counts as |w_ij| / sqrt(g_i g_j) (the exact 2 x 2 condition for a real pair
is |w_ij| < sqrt(g_i g_j) with a at its centre). kappa(a) is bounded by the
2-norm of the 2 x 2 matrix of block norms: x11 the Frobenius norm of the
near block (explicit), x12 = ||W Q_N Gamma_N^{-1/2}||_F / sqrt(Delta_eff),
x22 = ||W||_2 / Delta_eff, plus ||symmetric rest + F|| / min Gamma.

**Counting.** The number of eigenvalues of S below a is Sylvester's inertia
of a sparse factorization P^T(S - aI)P = L D L^T (a genuine LDL^T, no
pivoting: QDLDL's in its AMD ordering, or where the factor is dense the
multifrontal one of ``supernodal.SupernodalLDL`` in SuperLU's minimum
degree ordering, the same elimination in dense blocks): L D L^T =
P^T(S - aI)P + Z exactly, Z symmetric with ||Z||_2 <= ||Z||_inf <= fuzz
(the a-priori backward error gamma_k |L||D||L^T| of the Cholesky-type
elimination, k the longest inner product, in any order of its sums,
Higham Thm. 10.3), so #neg(D) lies
between the counts of S below a - fuzz and a + fuzz. Where that fuzz
exceeds 10 % of the mean eigenvalue spacing bound 2 ||S|| / n (at N = 10^5
it outgrows the spacing: the growth of the unpivoted elimination), the
count is made again by the same elimination in double-word arithmetic
(``ldl_dd.cpp``, every operation within U_DW = 16 u^2), whose fuzz is the
same bound with U_DW for u. Ritz pairs of S are
computed slice by slice (shift-invert Lanczos without restarts,
:mod:`.lanczos`, or ARPACK where it has not converged, about a shift inside
the slice -- the first slice's just below the lowest eigenvalue, found by
bisection on the counts, not at the Gershgorin bound far below it --
moved down before the eigen-solver runs where the probe solve of its
factorization shows a tiny pivot's inexact solves; a slice whose Kahan
radius still exceeds what the stopping rule gives for exact solves is
computed again about a shift moved by 1 % of its span), each slice's
Rayleigh-Ritz residual R bounding
its values by Kahan's theorem (|theta_i - lambda| <= ||R||_2, distinct
eigenvalues); a boundary's test subtracts the largest radius of the slices
in memory (the eigenvalues of the slices dropped lie below their edges).
The counts are made at *counted points*: a run's shift (the factorization
its solves used; its Ritz values farther than 2 (radius + fuzz) from it)
or, where that does not hold, a gap of its Ritz values. Between two
consecutive counted points p < q lie the Ritz values of one run, or of
consecutive runs split at points y farther than twice each adjacent run's
radius from both runs' values (two runs; up to four where a run's count
is not at hand -- its float64 count too fuzzy, or every count a
factorization of its own, as with SuperLU's solves -- and the runs between
two counted ones leave theirs out); the Ritz values kept are those of each
run between its split points, and their number must equal #neg(q) -
#neg(p).
Each kept value's eigenvalue (Kahan, within its run's radius) then lies in
its own part of (p, q), so these are distinct eigenvalues; if every
interval's count holds and the counts run from 0 to n, every eigenvalue of
S is matched to a Ritz value and lies inside a slice (the slices' edges
are the split points and the counted gaps, all farther than twice the
radii from the Ritz values), so none is near an edge, and the window and
Delta_eff of every boundary hold.

**Strips.** Certified boundaries cut the real axis into strips; a strip
with one eigenvalue of S holds exactly one eigenvalue of A + F, which is
real (conjugate symmetry). A strip with m >= 2 (a strongly coupled
cluster: a complex pair or a real pair near its exceptional point) is
decided from its m x m block T = Theta_I + Q_I^T W Q_I: for real x in the
strip, A + F - x is singular iff the Schur complement T - x + E(x) is, with
||E(x)|| <= eta(x) = b(x)^2 / (1 - kappa_r(x)) + rho_T (b the scaled
coupling of the strip to the rest, kappa_r the rest's boundary bound at x,
rho_T the error of T). If sigma_min(T - x) > eta(x) on the whole strip, it
holds no real eigenvalue: its m eigenvalues are complex pairs
(**complex**, certified). If det(T - x) changes sign m times at points where
sigma_min(T - x) > eta(x), there are m real roots (**real**). Otherwise
the strip is tried once more off the real axis (a strip of real and complex
eigenvalues together, a *mixed* strip, is neither all real nor free of real
roots); a strip of more than 24 is tried there only by these routes (by
the deflated route below on the real axis too). ARPACK's estimates of
the eigenvalues of A in the strip propose a box about a complex one,
strictly above the real axis; the box's eigenvalues are counted by the
winding number of det T(z) along its edge (:mod:`.winding`, rigorous
with the same error bounds, which hold for complex z with Re z in the
strip). One or more: **complex**, certified. Otherwise the strip is
**undecided** and says why, adding as a note marked "not certified" what
ARPACK sees in it (how many of its m eigenvalues, how many complex pairs).

**Deflated strips.** The routes above evaluate T by a sparse LU of the
bordered matrix [[A - x, Q_I], [Q_I^T, 0]] at every x, and a strip whose
rest is coupled to it across its whole width (kappa_r near 1, so that the
curvature bound of T is large) takes tens of them. So a strip is first
decided by its *deflated* complement (tried after the projected cluster,
Y = 0, which needs no solve; the LU routes run only where it leaves the
strip undecided). For a piece [l, h] of the strip the explicit block E is
the strip's Ritz vectors and the rest's within ``REACH`` (h - l) of the
piece (p of them; Q orthonormal). The rest of the space, the far rest, is
coupled across the piece by kappa_f < 1 (the bound of the lemma with E
explicit), so for Re z in [l, h] (z real or not: the lemma's bound holds
for every Im z) det(A + F - z) = det(far rest) det T_F(z), T_F the Schur
complement onto span(Q). One sparse LU of [[A - c, Q], [Q^T, 0]] at the
piece's centre c gives Y_0 in range(Q_r) with P_r (A - c) Y_0 = P_r A Q,
and Y_k the same solve with Y_{k-1} on the right; the polynomial
Y(z) = sum_{k<K} (z - c)^k Y_k has the residual Z(z) = sum_k (z - c)^k Z_k
- (z - c)^K Y_{K-1}, each Z_k computed, so ||Z(z)|| <= sum_k |z - c|^k
||Z_k|| + |z - c|^K ||Y_{K-1}|| for every z (a bound that holds whether or
not the series converges; it is truncated where its last term is below a
tolerance). The bound b ||Z|| / (sqrt(g_min) (1 - kappa_f)), which holds for
every Y in range(Q_r), with the rounding of the coefficients and the error
rho of Q^T A Q, bounds ||T_F(z) - T~(z)|| <= err(|z - c|) for the explicit
p x p polynomial T~(z) = Q^T A Q - z - sum_k (z - c)^k Q^T A Y_k. Every test
then evaluates T~ only (with the rounding of its evaluation added): the
strip is **complex** if sigma_min(T~(x)) exceeds err and that rounding on
the whole strip (a walk from its lower edge: at x, sigma_min s above the
slack excludes a root from [x, x + (s - slack) / (2 L)], L a bound of
||T~'|| on the piece); **real** if it is one piece and det T~ changes sign m
times at points where sigma_min(T~) exceeds the slack (the far rest's
determinant keeps its sign on the piece); **complex** if the winding count
of det(d T~) (d a constant diagonal row scaling, 0 < d <= 1, which moves
no zero and no error bound up) along a box about a complex estimate, off
the real axis, is one or more. A piece whose far rest cannot be bounded
(kappa_f >= 1, or a step of the bound fails) or whose series does not
reach its tolerance in 60 terms is halved (at most 6 times); strips of any
size are tried.

**Large strips in pieces.** A strip of more than 16 Ritz values (a cluster as
wide as a Bloch band of a tiled packing holds hundreds or thousands) is
first cut into pieces, from its lower edge up: a piece ends midway between
two of the strip's Ritz values and holds the next 16 of them, doubled until
its far rest is coupled weakly across it (kappa_f < 1) and its series
converges; each piece has its own explicit block, LU and polynomial T~, as a
halved piece has. Nothing else is needed for the proof: each statement
above is about one piece, [l, h], whatever cut it. The walk covers every
piece (complex); a box lies inside one piece (complex; it is tried first,
with only that piece's series extended); for *real*, in each piece det T~
is evaluated at its edges and between consecutive estimated real roots,
where sigma_min(T~) exceeds the slack: within a piece the far rest's
determinant keeps its sign (it is nonsingular for every real x in the
piece), so a sign change of det T~ between two such points is a real
eigenvalue of A + F between them; the intervals are disjoint, and if the
changes over all pieces number m, the strip's m eigenvalues are all real. A
strip of at most 200 left undecided in pieces is tried once more as one
piece; a larger one is left undecided (its one block would hold thousands
of dense columns), and ARPACK's note is not asked for it.

**Parts.** A strip's decision needs three things of its edges: each is a
certified boundary (the lemma: a statement about A + F, whichever
computation proves it); the count of S between them equals the number of
Ritz values of the strip's block (so the strip holds exactly m eigenvalues of
A + F); the rest is coupled weakly across the strip (kappa_r < 1, computed
from the deciding scan's own Ritz pairs and edges). So a scan may take as a
boundary a point certified by another scan of the same matrix, provided it
checks that the point lies between the same two of its own Ritz values (the
count) and bounds the rest itself: :mod:`.parts` splits the spectrum into
parts scanned independently, each ending at the first boundary certified by
the part above (the argument in full there).

The spectrum is *complex* if a strip is certified complex, *real* if every
strip is certified real, else *undecided*. Every bound is rigorous with the
rounding errors of the float64 computations bounded a priori (gamma_k, as
in :mod:`~remote_trigger.analysis.stability.enclosure`), except that the
sums and norms of computed nonnegative quantities (Frobenius norms, the
2-norm of a strip's derivative block, the norms of a deflated complement's
Taylor coefficients) are inflated by a factor (1 + 1e-10) rather than
bounded term by term. The Lanczos, ARPACK and LAPACK are used only to
propose vectors; nothing rests on their accuracy but through the residuals
and counts checked here.

**The package.** One scan object carries the verdict from one slice to the
next, its steps named as above:

================  ============================================================
``scan``          :func:`classify_sliced`; :class:`~.scan.SlicedScan`: next
                  slice, gap test, finish a strip, save, the decision
``slices``        the Ritz slices of S (shift-invert, Rayleigh-Ritz,
                  Kahan radii, certified edges) and the slicing's position
``lanczos``       a slice's eigen-solver: Lanczos on (S - sigma I)^-1
                  without restarts (:func:`~.lanczos.nearest_pairs`)
``inertia``       Sylvester counts of S - a I (QDLDL's LDL^T) and norm bounds
``supernodal``    the same counts by a multifrontal LDL^T where the factor is
                  dense (:class:`~.supernodal.SupernodalLDL`)
``buffer``        the Ritz pairs of the slices held (:class:`~.buffer.RitzBuffer`)
``strips``        the coupling across an interval and a strip's decision
                  (the deflated complement of a piece: ``DeflatedComplement``;
                  a large strip's pieces)
``winding``       the count of eigenvalues in a box off the real axis
``parts``         a scan in parts run side by side: cuts, parts, merge
``checkpoint``    the saved scan and verdict: files, key, format, restore
``numerics``      the inflation factor and the failure of a step
``stats``         :class:`SlicedStats`
================  ============================================================
"""
from remote_trigger.analysis.stability.sliced.checkpoint import saved_scans
from remote_trigger.analysis.stability.sliced.inertia import count_below
from remote_trigger.analysis.stability.sliced.scan import (
    CHECKPOINT_SECONDS, classify_sliced, scaled_parts)
from remote_trigger.analysis.stability.sliced.slices import top_eigenvalue
from remote_trigger.analysis.stability.sliced.stats import SlicedStats

__all__ = ["classify_sliced", "SlicedStats", "CHECKPOINT_SECONDS", "scaled_parts",
           "top_eigenvalue", "count_below", "saved_scans"]
