r"""A certified complex-pair verdict on the whole spectrum, by spectrum slicing.

The dense decision (:mod:`remote_trigger.analysis.stability.exceptional`)
costs O(n^3) time and 14 n x n matrices of memory; from n ~ 10^4 it no
longer fits. This module decides the same question for a sparse K -- does
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
winding number of det T(z) along its edge (:mod:`~remote_trigger.analysis.stability.winding`, rigorous
with the same error bounds, which hold for complex z with Re z in the
strip). One or more: **complex**, certified. Otherwise the strip is
**undecided** and says why, adding as a note marked "not certified" what
ARPACK sees in it (how many of its m eigenvalues, how many complex pairs).

The spectrum is *complex* if a strip is certified complex, *real* if every
strip is certified real, else *undecided*. Every bound is rigorous with the
rounding errors of the float64 computations bounded a priori (gamma_k, as
in :mod:`~remote_trigger.analysis.stability.enclosure`), except that the
sums and norms of computed nonnegative quantities (Frobenius norms, the
2-norm of a strip's derivative block) are inflated by a factor (1 + 1e-10)
rather than bounded term by term. ARPACK and LAPACK are used only to
propose vectors; nothing rests on their accuracy but through the residuals
and counts checked here.
"""
from __future__ import annotations

import contextlib
import copy
import dataclasses
import math
import os
import time

import numpy as np
import scipy.sparse as sp

from remote_trigger.analysis.errors import is_integer
from remote_trigger.analysis.stability.decision import PairDecision, SpectrumDecision
from remote_trigger.analysis.stability.enclosure import U, gamma
from remote_trigger.analysis.stability.slicing import (
    _INFLATE, SlicedStats, _Fail, _arpack_hint, _norm1, _norm2_skew, _slices, _start,
    top_eigenvalue)
from remote_trigger.analysis.stability import scan_state
from remote_trigger.analysis.stability.ritz_buffer import RitzBuffer
from remote_trigger.analysis.stability.strips import _Ctx, _coupling, _decide_strip

__all__ = ["classify_sliced", "SlicedStats", "CHECKPOINT_SECONDS"]

# largest cluster tried on the real axis (above it: the box route only); each
# real-axis evaluation of its Schur complement is a sparse LU of n + m rows,
# about m + 5 of them for a real strip (docs/results/analysis.md, "Strips of
# up to 24 on the real axis": 8 before; 4 more of 2268 points decided at
# N = 40, none contradicting the dense decision)
_MAX_STRIP = 24
# Ritz pairs per slice: ARPACK's work per pair grows with it (orthogonalization
# against its Lanczos vectors, slicing._NCV_FACTOR k + 1), the number of
# factorizations falls with it; measured at N = 6400 (n = 18 582) with 2k + 1
# Lanczos vectors: 40 -> 216 s, 60 -> 201 s, 85 -> 222 s, 124 -> 274 s of CPU
# (docs/results/analysis.md)
_SLICE_SIZE = 60
#: seconds between two saves of a scan's state (``classify_sliced``'s
#: ``checkpoint_dir``): a save writes 2.2-16.4 MB at N = 10^4 (measured; no
#: Ritz vector: a resume computes the buffer's slices again), a scan there
#: takes 5-45 min (docs/results/analysis.md, "Checkpoint of a sliced scan")
CHECKPOINT_SECONDS = 300.0


# --------------------------------------------------------------------------- the verdict
class _Stop(Exception):
    """A strip is certified complex and the scan stops (args: its upper boundary)."""


def _scaled(K, mass):
    """A = M^-1/2 K M^-1/2 (CSR), its symmetric part S (CSC) and skew part W (CSR)."""
    K = sp.csr_matrix(K, dtype=np.float64)
    n = K.shape[0]
    if K.ndim != 2 or K.shape[1] != n:
        raise ValueError(f"K must be square, got shape {K.shape}")
    if not np.all(np.isfinite(K.data)):
        raise ValueError("K has non-finite entries")
    mass = np.asarray(mass, np.float64).reshape(-1)
    if mass.size != n or not np.all(np.isfinite(mass)) or np.any(mass <= 0):
        raise ValueError(f"mass must be {n} finite positive values, got {mass.size} values "
                         f"with minimum {float(np.min(mass)) if mass.size else float('nan')!r}")
    s = 1.0 / np.sqrt(mass)
    A = sp.diags(s) @ K @ sp.diags(s)
    A = sp.csr_matrix(A)
    A.sum_duplicates()
    S = ((A + A.T) * 0.5).tocsc()
    W = ((A - A.T) * 0.5).tocsr()
    W.eliminate_zeros()
    return A, S, W


class _Scan:
    """Everything the scan carries from one slice to the next (pickled at a
    checkpoint): the slicing's position and statistics, the buffer, the
    certified boundaries, the strips decided and the eigenvalues listed."""

    def __init__(self, n, pos, stats):
        self.pos = pos
        self.stats = stats
        self.buf = RitzBuffer(n)
        self.pairs, self.lam = [], []
        self.certified = [pos.x]        # certified boundaries
        self.cert_count = [0]           # Ritz values below each
        self.n_done = 0                 # global index of the next gap to test
        self.dropped = 0                # Ritz values forgotten below the buffer
        self.margins, self.complex_margins, self.undecided_margins = [], [], []
        self.strips = {}
        self.sid = 0                    # slices added
        self.starts = {}                # slice id -> the position before it (buffered ones)
        self.t_slices = 0.0             # seconds in the slicing
        self.t_scan = 0.0               # seconds in the scan, before a resume


def classify_sliced(K, mass, rel_error=U, window=10.0, slice_size=None, stats=None,
                    stop_at_complex=False, progress=None, checkpoint_dir=None,
                    checkpoint_seconds=None, soft_rel=None):
    """Certified complex-pair verdict on the whole spectrum of M^-1 K, by slicing.

    Parameters
    ----------
    K : sparse matrix, shape (n, n)
        Stiffness K = -dG/dq after rattler removal (force/length), float64.
    mass : array_like, shape (n,)
        Diagonal of M.
    rel_error : float, optional
        Entrywise relative uncertainty of K (default u = 2^-53); the verdict
        holds for every M^-1 (K + E) with |E| <= rel_error |K|.
    window : float, optional
        Half-width Delta of the explicit window about each boundary, in units
        of ||W||_2 (default 10); larger decides more boundaries at more cost.
    slice_size : int, optional
        Ritz pairs per shift-invert slice (default 60).
    stats : SlicedStats, optional
        Filled with what was done.
    stop_at_complex : bool, optional
        Stop the scan (which runs up from the bottom of the spectrum) at the
        first strip certified complex (default False: scan to the top). The
        verdict is the same certified *complex*; ``eigenvalues`` then lists
        those below the strip's upper boundary (``scanned_below``) and
        ``lambda_max`` is ARPACK's largest eigenvalue of the symmetric part.
        What a ramp needs (its decision), at a fraction of the cost when the
        pair is low in the spectrum.
    progress : callable, optional
        Called as ``progress(done, n)`` after each slice: ``done`` of the n
        eigenvalues of S lie below the slices computed so far (their
        Sylvester count). For progress output only: it does not change the
        verdict.
    checkpoint_dir : str, optional
        A folder for the scan's state, so that a scan that is killed resumes
        where it was (default None: nothing saved). The state is saved,
        atomically, to ``<checkpoint_dir>/sliced-<key>.scan.pkl`` after the
        first slice that ends ``checkpoint_seconds`` or more after the last
        save; the finished verdict goes to ``sliced-<key>.done.pkl`` (the
        caller removes it). ``key`` is a hash of A = M^-1/2 K
        M^-1/2 to the last bit and of the options, so a call finds only its
        own state: it resumes a saved scan or returns the saved verdict, which
        are exactly those of an uninterrupted call (the scan is deterministic;
        ``timing`` adds the times before the resume). Saving a finished
        verdict removes every ``sliced-*.scan.pkl`` of the folder (a folder
        serves one scan at a time; another scan's state is stale). The state
        holds no vector of n: the buffer's Ritz vectors are computed again on
        resume from the position saved before their first slice (checked
        against the saved sha256 of their bytes; where they differ, the scan
        starts over), which costs about the time of the buffer's slices. It
        holds the buffer's k x k coupling matrix (8 k^2 bytes, k the Ritz
        vectors in the buffer): measured at N = 10^4 (n = 28 800) 2.2 MB
        with 514 vectors (restored in 32 s), 16.4 MB with 1421 near F_x^c
        (338 MB as vectors); the saved verdict 16 n bytes. Under another
        BLAS thread count than the saved scan's the vectors differ in their
        last bits and the scan starts over.
    checkpoint_seconds : float, optional
        Seconds between two saves (default :data:`CHECKPOINT_SECONDS`, 300; 0:
        after every slice).
    soft_rel : float, optional
        With ``stop_at_complex``: a strip certified complex whose eigenvalue
        estimates all have |Re lambda| < ``soft_rel`` x ARPACK's largest
        eigenvalue of the symmetric part (a *soft* pair,
        :data:`~remote_trigger.analysis.stability.verdict.SOFT_MODE_REL`) does
        not stop the scan; the first other complex strip does. Default None:
        the first complex strip stops it.

    Returns
    -------
    SpectrumDecision
        ``complex_present`` True / False / None as the dense decision
        (:func:`~remote_trigger.analysis.stability.exceptional.classify_spectrum`),
        ``coverage`` 'whole', ``start`` 'sliced'; ``pairs`` holds one entry
        per strip of two or more eigenvalues; ``eigenvalues`` are the Ritz
        values of S for single strips (the eigenvalue of A in such a strip is
        real and within the strip) and the block eigenvalues of larger strips:
        approximations, not enclosures. A strip certified complex decides the
        whole matrix, even if the slicing fails higher up: the verdict is then
        *complex* with a finite ``scanned_below`` (the reason kept as a note).

    Raises
    ------
    ValueError
        If K is empty, not square or not finite, a mass is not positive,
        ``rel_error`` is outside [0, 0.01) or so large that the set reaches
        below the Gershgorin bound, ``window`` is not a finite number > 0,
        ``slice_size`` not an integer >= 2, ``checkpoint_seconds`` is
        negative or not a number, or ``soft_rel`` is not a number in [0, 1).

    Notes
    -----
    Module docstring: what is certified and how.
    """
    t0 = time.perf_counter()
    stats = stats if stats is not None else SlicedStats()
    # the options first (rel_error = -1 gave a verdict with a negative backward error)
    if not (isinstance(rel_error, (int, float, np.floating)) and 0 <= rel_error < 0.01):
        raise ValueError(f"rel_error must be in [0, 0.01), got rel_error = {rel_error!r}")
    if not (isinstance(window, (int, float, np.floating)) and window > 0
            and np.isfinite(window)):
        raise ValueError(f"window must be a finite number > 0, got window = {window!r}")
    if slice_size is None:
        slice_size = _SLICE_SIZE
    if not is_integer(slice_size) or \
            slice_size < 2:
        raise ValueError(f"slice_size must be an integer >= 2, got slice_size = {slice_size!r}")
    checkpoint_seconds = (CHECKPOINT_SECONDS if checkpoint_seconds is None
                          else checkpoint_seconds)
    if not (isinstance(checkpoint_seconds, (int, float, np.floating))
            and checkpoint_seconds >= 0):
        raise ValueError(f"checkpoint_seconds must be a number >= 0, got "
                         f"{checkpoint_seconds!r}")
    checkpoint_seconds = float(checkpoint_seconds)
    if soft_rel is not None and not (isinstance(soft_rel, (int, float, np.floating))
                                     and not isinstance(soft_rel, bool) and 0 <= soft_rel < 1):
        raise ValueError(f"soft_rel must be a number in [0, 1) or None, got "
                         f"soft_rel = {soft_rel!r}")
    if K.shape[0] == 0:
        raise ValueError("K is empty (0 x 0): no degree of freedom to decide")
    A, S, W = _scaled(K, mass)
    n = A.shape[0]
    ckpt, saved = None, None
    if checkpoint_dir is not None:
        key = scan_state.scan_key(A, rel_error, window, slice_size, stop_at_complex,
                                  _MAX_STRIP, soft_rel if stop_at_complex else None)
        ckpt = os.path.join(os.fspath(checkpoint_dir), f"sliced-{key}")
        done = scan_state.load(ckpt + ".done.pkl", key)
        if done is not None:
            dec, st = done
            for f in dataclasses.fields(st):
                setattr(stats, f.name, getattr(st, f.name))
            return dec
        saved = scan_state.load(ckpt + ".scan.pkl", key)
    stats.n = n
    absA = abs(A)
    nA = math.sqrt(_norm1(absA) * _norm1(absA.T))
    nSW = _norm1(abs(S) + abs(W))
    eps = ((rel_error + 12 * U) * nA + U * nSW) * _INFLATE
    normW = _norm2_skew(W)
    normS = _norm1(S)
    stats.norm_W = normW
    rows = int(np.max(np.diff(A.indptr))) if n else 0
    rnd = gamma(n + rows + 4) * _norm1(abs(W)) * 4
    ctx = _Ctx(normW, normS, eps, window * normW if normW > 0 else 1e-3 * max(normS, 1.0), rnd,
               A, nA, W)
    stats.window = ctx.Delta
    absS = abs(S)
    gersh = float(np.min(S.diagonal() - (np.asarray(absS.sum(axis=1)).ravel()
                                         - np.abs(S.diagonal()))))
    # the bottom boundary: Re <x, (S + W + F) x> >= lambda_min(S) - eps >= gersh - eps,
    # so no eigenvalue of any matrix of the set has real part below lo0
    lo0 = gersh - 1e-3 * max(normS, 1.0) - 1.0
    if not eps < gersh - lo0:
        raise ValueError(f"rel_error {rel_error!r} is too large for this matrix")
    reason = ""
    scanned_below = math.inf
    sc = None
    # the real part below which a complex strip is soft (it does not stop the scan)
    soft_below = (soft_rel * top_eigenvalue(S) if stop_at_complex and soft_rel is not None
                  else -math.inf)
    t_restore = time.perf_counter()
    if saved is not None and scan_state.restore_ritz(
            saved, lambda pos: _slices(S, W, slice_size, normS, normW, pos, SlicedStats())):
        sc = saved              # a saved scan: its state, statistics included
        sc.t_slices += time.perf_counter() - t_restore     # (slices computed again)
        for f in dataclasses.fields(sc.stats):
            setattr(stats, f.name, getattr(sc.stats, f.name))
        sc.stats = stats
    t_saved = time.monotonic()

    def finish_strip(lo_idx, hi_idx, a_lo, a_hi, final):
        buf = sc.buf
        m = hi_idx - lo_idx
        sc.strips[m] = sc.strips.get(m, 0) + 1
        I = np.arange(lo_idx, hi_idx) - sc.dropped
        if m == 1:
            sc.lam.append(complex(buf.th[I[0]]))
            return
        edges = (buf.lo if sc.dropped else None, None if final else buf.hi)
        hint = {}

        def arpack():
            """ARPACK's view of the strip, once: (note, complex estimates)."""
            if not hint:
                hint["v"] = _arpack_hint(ctx.A, a_lo, a_hi, m)
            return hint["v"]

        big = m > _MAX_STRIP
        try:
            # a strip larger than a block decides: only the box route (winding)
            verdict, margin, lam_c, why = _decide_strip(
                ctx, buf, I, a_lo, a_hi, *edges, estimates=arpack, real_routes=not big)
        except _Fail as exc:
            verdict, margin, why = "undecided", 0.0, str(exc)
            lam_c = buf.th[I].astype(complex)
        if big and verdict == "undecided":
            lam_c = buf.th[I].astype(complex)
            why = f"strip of {m} eigenvalues (> {_MAX_STRIP})" + (f"; {why}" if why else "")
        sc.lam.extend(lam_c)
        ok = verdict != "undecided"
        if not ok:
            why += arpack()[0]
        sc.pairs.append(PairDecision(np.sort_complex(lam_c), verdict == "complex", ok,
                                     float(margin), method="sliced-strip", reason=why))
        (sc.complex_margins if verdict == "complex" else sc.margins if ok
         else sc.undecided_margins).append(float(margin))
        if verdict == "complex" and stop_at_complex and not (
                np.max(np.abs(np.real(lam_c))) < soft_below):
            raise _Stop(a_hi)

    try:
        if sc is None:
            sc = _Scan(n, _start(S, lo0, stats), stats)
        gen = _slices(S, W, slice_size, normS, normW, sc.pos, stats)
        final = sc.cert_count[-1] == n      # only for n = 0 (a scan is saved before its end)
        while not final:
            buf = sc.buf
            ts = time.perf_counter()
            sc.starts[sc.sid] = copy.deepcopy(sc.pos)
            sl = next(gen)
            sc.t_slices += time.perf_counter() - ts
            buf.add(sl, sc.sid)
            sc.sid += 1
            if progress is not None:
                progress(sc.dropped + buf.th.size, n)
            final = sc.dropped + buf.th.size == n
            top = n if final else None
            # test the gaps between Ritz values whose window lies in the buffer
            while True:
                j = sc.n_done             # gap between global Ritz j - 1 and j
                if j > n:
                    break
                if j == n:
                    if not final:
                        break
                    a = float(buf.th[-1]) + max(ctx.Delta, 1.0)
                else:
                    if j - sc.dropped >= buf.th.size:
                        break
                    a = (0.5 * (buf.th[j - 1 - sc.dropped] + buf.th[j - sc.dropped]) if j > 0
                         else None)
                    if a is None:
                        sc.n_done += 1
                        continue
                    if not final and a + ctx.Delta > buf.hi:
                        break
                sc.n_done += 1
                try:
                    kap = _coupling(ctx, buf, a, a, buf.lo if sc.dropped else None,
                                    None if final else buf.hi)[0]
                except _Fail:
                    kap = math.inf
                if kap < 1:
                    stats.boundaries += 1
                    stats.max_kappa = max(stats.max_kappa, kap)
                    sc.margins.append(1.0 / kap if kap > 0 else math.inf)
                    finish_strip(sc.cert_count[-1], j, sc.certified[-1], a, final)
                    sc.certified.append(a)
                    sc.cert_count.append(j)
                if top is None and len(sc.certified) > 1:
                    low = sc.certified[-1] - 2 * ctx.Delta
                    before = buf.th.size
                    buf.drop_below(low)
                    sc.dropped += before - buf.th.size
                    sc.starts = {e[0]: sc.starts[e[0]] for e in buf.edges}
            if ckpt is not None and not final and \
                    time.monotonic() - t_saved >= checkpoint_seconds:
                t_now = time.perf_counter()
                sc.t_scan += t_now - t0
                t0 = t_now
                scan_state.save(ckpt + ".scan.pkl", key, sc)
                t_saved = time.monotonic()
        if sc.cert_count[-1] != n:
            raise _Fail("the top of the spectrum has no certified boundary")
    except _Stop as stop:
        scanned_below = stop.args[0]
    except _Fail as exc:
        reason = str(exc)
        if sc is not None and sc.complex_margins:  # the strips below the last boundary are decided
            scanned_below = sc.certified[-1]
    dec = _decision(sc, n, reason, scanned_below, eps, S,
                    {"eigen": sc.t_slices if sc else 0.0,
                     "decision": (sc.t_scan if sc else 0.0) + time.perf_counter() - t0
                     - (sc.t_slices if sc else 0.0)})
    if ckpt is not None:
        scan_state.save(ckpt + ".done.pkl", key, (dec, dataclasses.replace(stats)))
        folder = os.path.dirname(ckpt)
        for name in os.listdir(folder):     # one scan at a time: the others are stale
            if name.startswith("sliced-") and name.endswith(".scan.pkl"):
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(os.path.join(folder, name))
    return dec


def _decision(sc, n, reason, scanned_below, eps, S, timing):
    """The SpectrumDecision of a finished (or failed) scan."""
    if sc is None:
        return SpectrumDecision(None, 0.0, [], 0.0, np.zeros(0, complex), timing, reason,
                                start="sliced", n_total=n)
    sc.stats.strips = dict(sorted(sc.strips.items()))
    pairs, complex_margins = sc.pairs, sc.complex_margins
    lam = np.asarray(sc.lam, complex)
    lam = lam[np.lexsort((lam.imag, lam.real))] if lam.size else lam
    if complex_margins and math.isfinite(scanned_below):
        note = ("the scan stopped at the first strip certified complex" if not reason
                else f"the slicing failed above a strip certified complex: {reason}")
        return SpectrumDecision(True, max(complex_margins), pairs, eps, lam, timing, note,
                                start="sliced", n_total=n, scanned_below=float(scanned_below),
                                lambda_max=top_eigenvalue(S))
    if reason:
        return SpectrumDecision(None, 0.0, pairs, 0.0, lam, timing, reason, start="sliced",
                                n_total=n)
    if complex_margins:
        return SpectrumDecision(True, max(complex_margins), pairs, eps, lam, timing,
                                start="sliced", n_total=n)
    if sc.undecided_margins:
        bad = [p.reason for p in pairs if not p.certified]
        why = bad[0] if len(bad) == 1 else (
            f"{len(bad)} undecided strips: " + " | ".join(bad[:3])
            + (f" | and {len(bad) - 3} more" if len(bad) > 3 else ""))
        return SpectrumDecision(None, min(sc.undecided_margins), pairs, eps, lam, timing,
                                why, start="sliced", n_total=n)
    return SpectrumDecision(False, min(sc.margins) if sc.margins else math.inf, pairs, eps,
                            lam, timing, start="sliced", n_total=n)
