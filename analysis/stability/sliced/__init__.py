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
of a sparse factorization P^T(S - aI)P = L D L^T (QDLDL: a genuine LDL^T,
AMD ordering, no pivoting): L D L^T = P^T(S - aI)P + Z exactly, Z
symmetric with ||Z||_2 <= ||Z||_inf <= fuzz (the a-priori backward error
gamma_k |L||D||L^T| of the Cholesky-type elimination, k the longest
inner product, Higham Thm. 10.3), so #neg(D) lies
between the counts of S below a - fuzz and a + fuzz. Ritz pairs of S are
computed slice by slice (ARPACK shift-invert about a shift inside the
slice; a slice whose Kahan radius exceeds 1e-3 of its mean Ritz spacing,
as inexact solves at a shift with a tiny pivot leave it, is computed again
about a shift moved by 1 % of its span), each slice's Rayleigh-Ritz residual R bounding
its values by Kahan's theorem (|theta_i - lambda| <= ||R||_2, distinct
eigenvalues); a boundary's test subtracts the largest radius of the slices
in memory (the eigenvalues of the slices dropped lie below their edges). The slices' edges x_j lie in gaps; if every slice's count
#neg(x_{j+1}) - #neg(x_j) equals its number of Ritz values and the counts
run from 0 to n, every eigenvalue of S is matched to a Ritz value and lies
inside a slice, so none is near an edge, and the window and Delta_eff of
every boundary hold.

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
roots); a strip of more than 24 is tried there only. ARPACK's estimates of
the eigenvalues of A in the strip propose a box about a complex one,
strictly above the real axis; the box's eigenvalues are counted by the
winding number of det T(z) along its edge (:mod:`.winding`, rigorous
with the same error bounds, which hold for complex z with Re z in the
strip). One or more: **complex**, certified. Otherwise the strip is
**undecided** and says why, adding as a note marked "not certified" what
ARPACK sees in it (how many of its m eigenvalues, how many complex pairs).

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
2-norm of a strip's derivative block) are inflated by a factor (1 + 1e-10)
rather than bounded term by term. ARPACK and LAPACK are used only to
propose vectors; nothing rests on their accuracy but through the residuals
and counts checked here.

**The package.** One scan object carries the verdict from one slice to the
next, its steps named as above:

================  ============================================================
``scan``          :func:`classify_sliced`; :class:`~.scan.SlicedScan`: next
                  slice, gap test, finish a strip, save, the decision
``slices``        the Ritz slices of S (ARPACK shift-invert, Rayleigh-Ritz,
                  Kahan radii, certified edges) and the slicing's position
``inertia``       Sylvester counts of S - a I (QDLDL's LDL^T) and norm bounds
``buffer``        the Ritz pairs of the slices held (:class:`~.buffer.RitzBuffer`)
``strips``        the coupling across an interval and a strip's decision
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
