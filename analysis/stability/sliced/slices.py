"""Ritz slices of the symmetric part S: its eigenpairs, slice by slice, none missed.

:func:`ritz_slices` computes the eigenpairs of S from the bottom of the
spectrum up, k at a time, by shift-invert Lanczos (:func:`shift_invert`)
about a shift inside the slice; their Rayleigh-Ritz values bound the
eigenvalues of S by Kahan's theorem (:func:`rayleigh_ritz`). Sylvester
counts (:mod:`.inertia`) at the shifts, taken from the factorizations the
solves used, or at gaps where a shift's cannot serve, prove that between
two counted points the Ritz values of the runs there number the
eigenvalues of S there, so no eigenvalue is missed. The slicing's
:class:`Position` between two slices is what a checkpoint saves of it
(:mod:`.checkpoint`). The proof they serve:
:mod:`remote_trigger.analysis.stability.sliced` (*Counting*).
"""
from __future__ import annotations

import copy
from dataclasses import dataclass
import math

import numpy as np
import scipy.sparse.linalg as spla

from remote_trigger.analysis.stability.enclosure import gamma
from remote_trigger.analysis.stability.sliced.inertia import Shifts, fuzz_limit
from remote_trigger.analysis.stability.sliced.lanczos import nearest_pairs
from remote_trigger.analysis.stability.sliced.numerics import INFLATE, SliceFailure
from remote_trigger.analysis.stability.sliced.stats import SlicedStats

__all__ = ["Slice", "Position", "ritz_slices", "rayleigh_ritz", "shift_invert", "stopping_bound",
           "start_position", "top_eigenvalue"]

_STOP_TOL = 1e-8                # the eigen-solver's stopping tolerance (only the checked residuals matter)
# shift-invert shift above a slice's lower edge, in slice widths: the k pairs
# nearest it reach ~0.08 of a width below the edge (pairs computed twice); a
# shift too high misses the edge and the slice is computed again. Measured
# (docs/results/analysis.md, "The shift of a slice"): pairs computed for the
# n kept at N = 1600 / 6400 / 10^4, 1.38 / 1.35 / 1.34 n at 0.35, 1.32 /
# 1.24 / 1.25 n at 0.42 (3, 0 and 4 misses); at 0.46, 17 misses at N = 6400
_SHIFT_FRACTION = 0.42
# the next run's shift lies past a run's reach by this fraction of half the
# width of k values there (an overlap of ~0.1 k eigenvalues for the split
# point), halved up to _NEXT_TRIES - 1 times where it does not reach back.
# Measured (a throwaway slicing, N = 6400, docs/results/analysis.md, "The
# counts' fuzz without a new matrix, and the counts at the shifts tried"): 0.8,
# 357 runs of which 7 made again; 0.9, 399 of which 55
_NEXT_STEP = 0.8
_NEXT_TRIES = 4
# runs per count where a run's count is not at hand: its float64 count too
# fuzzy to use (it would be made again in double-word arithmetic), or every
# count a factorization of its own (SuperLU's solves). The counts of the
# CHAIN_RUNS - 1 runs between two counted ones are left out, and one pair
# of counts proves the whole chain (:func:`ritz_slices`). Measured
# (docs/results/analysis.md, "Chains of runs between double-word counts"):
# at N = 10^5 a double-word count costs ~12-18 s, the rest of a run ~17 s
CHAIN_RUNS = 4
# the Lanczos of a slice (:func:`.lanczos.nearest_pairs`, no restarts) stops
# after at most _LANCZOS_STEPS k solves (then ARPACK): measured 130-140 solves
# for k = 60 at N = 10^4 (docs/results/analysis.md, "The slice's Lanczos
# without restarts"); its basis then holds up to 4 k vectors of n (55 MB at
# n = 28 836, 0.55 GB at n = 288 360; ~130 of them in the slices measured)
_LANCZOS_STEPS = 4
# ARPACK's Lanczos basis (where the Lanczos above did not converge): NCV =
# _NCV_FACTOR k + 1 vectors for the k pairs of a slice (scipy's default is
# 2k + 1). A shorter basis restarts more often but each restart and
# reorthogonalization moves fewer vectors: measured
# (docs/results/analysis.md, "The Lanczos basis of a slice"), CPU of a
# certified-real scan at N = 6400: 252 s at 2k + 1, 200 s at 1.4 k + 1 (side
# by side; QDLDL solves 8 % fewer), 238 s at 1.2 k + 1, 224 s at 1.6 k + 1;
# at N = 10^4 664 s and 587 s side by side; at N = 1600 8.2-8.6 s at 2k + 1,
# 7.4-7.6 s at 1.33-1.5 k + 1
_NCV_FACTOR = 1.4
# a shift whose factorization's probe solve (``Shifts.factor_checked``: the
# residual of (S - sigma I) x = 1, relative to ||1||) exceeds this is moved
# down by 1 % of a slice width before the eigen-solver runs, up to _MOVES times
# (docs/results/analysis.md, "A shift at a tiny pivot"). Measured on the
# N = 10^4 point of bench_parallel_point: 5e-16 - 1.5e-9 at 4 shifts, 2.5e-9 -
# 6e-9 at 3 shifts of the N = 10^5 tiled state; at a shift planted 1e-13 / 1e-11 /
# 1e-10 (relative) from a zero pivot of the N = 10^4 elimination, 4.4e-5 /
# 2.5e-7 / 5.4e-8, and the slice's Kahan radius 0.092 / 1.5e-3 / 2.0e-4 against
# 2.3e-5 at a clean shift. Whole scans: N = 10^4, 2 of 594 shifts above (3.2e-7,
# 1.15e-7; moved), the largest kept 4.4e-8; N = 6400, the largest 7.2e-8
_PROBE_LIMIT = 1e-7
_MOVES = 3
# a slice whose Kahan radius exceeds this multiple of the eigen-solver's own
# bound for its k pairs (:func:`stopping_bound`) is computed again about a
# shift 1 % of its span lower: the eigen-solver then converged to vectors of an
# inexact operator. Measured (with ARPACK as the eigen-solver)
# radius / bound: 0.003 - 0.005 and 0.029 - 0.036 at the N = 10^4 and 10^5
# shifts above, 12 at the shift planted 1e-13 from a zero pivot; the largest
# of every slice of whole scans of bench_degenerate's states and the N = 1600
# point: 0.002 - 0.042
_RECOMPUTE_ABOVE = 1.0


@dataclass
class Slice:
    """One slice of Ritz pairs of S, between two certified edges.

    Attributes
    ----------
    lo, hi : float
        Lower and upper edge (gap points: no eigenvalue of S within the Ritz
        radius plus the inertia fuzz of them).
    theta : ndarray, shape (k,)
        The Ritz values in (lo, hi), ascending.
    Q : ndarray, shape (n, k)
        Their Ritz vectors.
    WQ : ndarray, shape (n, k)
        W Q (W the skew part).
    radius : float
        Kahan radius: every eigenvalue of S matched to a Ritz value of the
        slice lies within it of that value.
    resid : ndarray, shape (k,)
        Bounds of the residual norms ||S q_i - theta_i q_i||.
    phi : float
        Bound of ||Q^T Q - I||_2.
    """

    lo: float
    hi: float
    theta: np.ndarray
    Q: np.ndarray
    WQ: np.ndarray
    radius: float
    resid: np.ndarray
    phi: float


def rayleigh_ritz(S, W, Q, normS):
    """Rayleigh-Ritz of S on span(Q): values, vectors, W times them, radius, residuals, phi.

    Q is the eigen-solver's (or LAPACK's) orthonormal to working precision; it is
    orthonormalized again (QR) only where it is not, to 1e-10 in the Frobenius
    norm (the bounds below hold for any Q: phi measures what is left).

    Returns
    -------
    theta, Q, WQ, radius, resid, phi
        As the fields of :class:`Slice` (``normS`` bounds ||S||_2 for the
        rounding of the residuals).
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
    phi = (np.linalg.norm(G) + gamma(n) * k) * INFLATE
    round_r = gamma(n + 2) * (normS + float(np.max(np.abs(theta)))) * math.sqrt(k)
    resid = (np.linalg.norm(R, axis=0) + round_r) * INFLATE
    # Kahan for the exactly orthonormal Q (Q^T Q)^{-1/2}: ||R|| (1 + phi) + 2 phi |theta|
    radius = (math.sqrt(float(np.sum(resid ** 2))) * (1 + phi)
              + 2 * phi * float(np.max(np.abs(theta)))) * INFLATE
    return theta, Q, W @ Q, radius, resid, phi


@dataclass
class Position:
    """Where the slicing stands between two slices (pickled at a checkpoint).

    x is the next slice's lower edge, ``count`` the number of eigenvalues of S
    below it (its Sylvester count, or the count at a shift plus the Ritz values
    between, :func:`ritz_slices`) and ``fuzz`` that count's fuzz (0 where no
    count was made at x); ``rng`` draws the eigen-solver's start vectors;
    ``width`` is the estimated width of a slice (None before the first);
    ``pending`` (shift, step): the run that proved the slice below x and
    holds the pairs above it, asked for at that shift with that step of
    :func:`shift_invert` (None: the next slice starts a new run), made again
    the same way with start vectors drawn from ``rng``; ``deferred``: the
    runs since the last counted one whose counts were left out (a chain,
    :func:`ritz_slices`), the pending run included; ``recount_to``: no run
    whose shift lies at or below it leaves its count out (a chain that did
    not prove its slices is made again so, run by run).
    """

    x: float
    count: int
    fuzz: float
    rng: np.random.Generator
    width: float | None = None
    pending: tuple | None = None
    deferred: int = 0
    recount_to: float = -math.inf


def start_position(S, lo0, stats, shifts=None):
    """The position below the spectrum: no eigenvalue of S below ``lo0``, counted
    (by ``shifts``, a :class:`~.inertia.Shifts` of S, or a new one).

    Raises
    ------
    SliceFailure
        If S has eigenvalues below ``lo0`` (their count named).
    """
    cnt, fz = (Shifts(S) if shifts is None else shifts).count(lo0)
    if cnt != 0:
        raise SliceFailure(f"{cnt} eigenvalues of S below the Gershgorin bound {lo0:.6g}")
    stats.fuzz = max(stats.fuzz, fz)
    return Position(lo0, 0, fz, np.random.default_rng(12345))


def stopping_bound(k, normS, sigma):
    """What the eigen-solver's stopping rule gives for the residuals of k
    pairs of S: sqrt(k) tol (||S|| + |sigma|), ``normS`` >= ||S||_2.

    The Lanczos of :func:`~.lanczos.nearest_pairs`, as ARPACK, stops when each
    Ritz pair (mu, x) of (S - sigma I)^-1 has ||(S - sigma I)^-1 x - mu x|| <=
    tol |mu|; multiplied by (S - sigma I), the pair (sigma + 1/mu, x) of S has
    residual <= tol ||S - sigma I||, for exact solves. The k residuals'
    Frobenius norm, which a Rayleigh-Ritz rotation within their span leaves
    unchanged, is then <= sqrt(k) times that.
    """
    return math.sqrt(k) * _STOP_TOL * (float(normS) + abs(float(sigma)))


def shift_invert(S, shifts, sigma, k, rng, stats, step=None):
    """The k eigenpairs of S nearest sigma by shift-invert with the
    factorization of S - sigma I from ``shifts`` (a :class:`~.inertia.Shifts`
    of S), start vector drawn from ``rng``: (lam, V, sigma used).

    The eigen-solver is :func:`~.lanczos.nearest_pairs` (Lanczos without
    restarts, at most ``_LANCZOS_STEPS`` k solves; ``stats.lanczos_runs``);
    where it has not converged by then, ARPACK's implicitly restarted Lanczos
    (``eigsh``, NCV = ``_NCV_FACTOR`` k + 1; ``stats.arpack_runs``) from the
    same start vector. Both stop by the same rule (:func:`stopping_bound`).

    With ``step`` (> 0), a shift whose factorization's probe solve has a
    relative residual above ``_PROBE_LIMIT`` (1e-7; a tiny pivot of the
    elimination without pivoting, whose growth of D makes every solve
    inexact) is moved down by ``step``, up to ``_MOVES`` (3) times, before
    the eigen-solver runs (``stats.moved`` counts the moves); so is a shift
    with no LDL^T factorization (a zero pivot).

    Raises
    ------
    SliceFailure
        If S - sigma I has no LDL^T factorization (a zero pivot) and no
        ``step`` is given, or none after the moves.
    """
    n = S.shape[0]
    moves = _MOVES if step else 0
    for attempt in range(moves + 1):
        try:
            fac = shifts.factor_checked(sigma, f"S - sigma I at sigma = {sigma:.9g}")
            if shifts.probe <= _PROBE_LIMIT or attempt == moves:
                break
        except SliceFailure:        # a zero pivot: moved as a tiny one is
            if attempt == moves:
                raise
        sigma -= step
        stats.moved += 1
    v0 = rng.standard_normal(n)
    stats.lanczos_runs += 1
    got = nearest_pairs(fac.solve, sigma, n, k, v0, _STOP_TOL, int(_LANCZOS_STEPS * k))
    if got is not None:
        lam, V = got[0], got[1]
    else:
        op = spla.LinearOperator((n, n), matvec=fac.solve, dtype=np.float64)
        lam, V = spla.eigsh(S, k=k, sigma=sigma, which="LM", OPinv=op, tol=_STOP_TOL,
                            v0=v0, ncv=min(n, int(_NCV_FACTOR * k) + 1))
        stats.arpack_runs += 1
    stats.computed += lam.size
    return lam, V, sigma


def ritz_slices(S, W, k, normS, pos, stats, shifts=None, stop_above=math.inf):
    """Yield the Ritz slices (:class:`Slice`) of S from ``pos`` (a :class:`Position`) upwards.

    The eigenpairs come from *runs*: the k eigenvalues of S nearest a shift
    sigma (shift-invert Lanczos) and their Rayleigh-Ritz pairs. A slice is the
    part of one run between two edges, and the edges are proved by Sylvester
    counts (:mod:`.inertia`) in one of two ways:

    * **Counts at the shifts** (the rule). The count below a run's shift comes
      from the factorization its solves used (no factorization of its own).
      The next run's shift lies past the run's reach (the farthest of its k
      values from its shift) by ``_NEXT_STEP`` (0.8) of half the width of k
      values there, so that the two runs overlap by a few eigenvalues; the
      split point y between them lies in a gap of both runs' Ritz values in
      the overlap, farther than twice each run's Kahan radius from them.
      Between the two shifts sigma_i < sigma_j the count must be the run i
      values in (sigma_i, y) plus the run j values in (y, sigma_j): every Ritz
      value lies within its run's radius of its own eigenvalue of S, so both
      parts hold every eigenvalue of S there, and the count below y is the
      count below sigma_i plus the first part, without a factorization at y.
      A shift whose count cannot prove this (a Ritz value of its run within
      twice the radius plus the count's fuzz of it) is replaced by a counted
      edge in a gap just above it. A slice is thus proved by the run above
      it, which stays pending (:attr:`Position.pending`).
    * **Chains** (where a run's count is not at hand: its float64 count too
      fuzzy to use, its fuzz above ``shifts.fuzz_limit``, so that it would be
      made again in double-word arithmetic, as at N = 10^5; or every count a
      multifrontal factorization of its own, where ``shifts`` solves by
      SuperLU, as for large sphere packings). Up to ``CHAIN_RUNS`` - 1 (3)
      consecutive runs leave their counts out; the runs are split as above,
      and the count at the next counted run's shift (or at a counted edge)
      minus the count at the chain's lower edge must equal the number of
      Ritz values kept between them, each run's below its upper split point
      and above its lower one. The argument is the one for two runs: each
      kept value's eigenvalue lies within its run's radius, in its own part
      of the chain, so the kept values are distinct eigenvalues, and the
      counts say there are no others. The slices of a chain are yielded once
      its end is counted, each with the position a resumed scan continues
      the chain from (``Position.deferred``). A chain its counts do not
      prove is made again from its start with every run counted
      (``Position.recount_to``; ``stats.chain_failures``), so no single run
      has to be found at fault.
    * **A counted edge** (as at the top of the spectrum, and wherever the next
      run does not reach back or the counts disagree): the upper edge y lies
      in the widest gap of the slice's upper part whose distance to its Ritz
      values exceeds the Ritz radius and the inertia fuzz, and the count of
      (x, y) must equal the number of Ritz values kept. The next run then
      starts from y as the first does: its shift ``_SHIFT_FRACTION`` (0.42)
      of a slice above y so that its k nearest reach below y (checked; the
      first run's shift just below the lowest eigenvalue,
      :func:`_bottom_shift`).

    ``pos`` is advanced to the slice's upper edge before each slice is
    yielded, so that a scan saved after a slice resumes from it
    (:meth:`.scan.SlicedScan.save`) exactly as it would have gone on: the
    pending run is made again there from the same shift and start vector.
    ``stats`` (a :class:`~.stats.SlicedStats`) counts the slices and solves.
    ``shifts``: the :class:`~.inertia.Shifts` of S to factorize with (that of
    :func:`start_position`, so that its first factorization, with the
    ordering, is not made twice); default a new one, with
    :func:`~.inertia.fuzz_limit` of ``normS``. The factors at a shift do not
    depend on what was factorized before, so neither do the slices.
    ``stop_above``: no run whose shift lies above it leaves its count out
    (where the caller needs slices only up to about there, so that a chain
    closes at the first run past it, not up to ``CHAIN_RUNS`` - 1 runs later).

    Raises
    ------
    SliceFailure
        If a slice cannot be certified (no shift reaches its lower edge, a
        Ritz value within the radius of an edge, no certified upper edge).
    """
    n = S.shape[0]
    if shifts is None:
        shifts = Shifts(S, fuzz_limit(normS, n), stats)
    rng = pos.rng               # the start vectors' stream, drawn as the runs are made
    run = None
    if pos.pending is not None:
        # the run that proved the slice below pos.x, made again (not counted
        # twice in ``stats``: the saved statistics hold it)
        scratch = SlicedStats()
        kept, shifts.stats = shifts.stats, scratch
        try:
            run = _solve_run(S, W, normS, shifts, pos.pending[0], min(k, n - 2), rng,
                             scratch, pos.pending[1])
            _anchor(shifts, run, pos.x, scratch, pos.deferred > 0)
        finally:
            shifts.stats = kept
        if run.anchor is None:
            raise SliceFailure(f"the pending run at {pos.pending[0]:.9g} has no proved point")
    while pos.count < n:
        before = copy.deepcopy((pos, rng))
        try:
            got, nxt = _next_slices(S, W, k, normS, pos, shifts, stats, run, rng, stop_above)
        except _ChainFailure as exc:
            # made again from the chain's start, every run counted up to its top
            saved, rng = before
            pos.__dict__.update(saved.__dict__)
            pos.recount_to = max(pos.recount_to, exc.upto)
            stats.chain_failures += 1
            if run is not None:
                _anchor(shifts, run, pos.x, stats)
            pos.deferred = 0
            continue
        for sl, fields in got:
            pos.__dict__.update(fields)
            yield sl
        run = nxt


@dataclass
class _Run:
    """One eigen-solve about a shift and its Rayleigh-Ritz pairs (``pairs``, a
    :class:`Slice` between sigma -/+ ``reach``, ascending, not yet proved).

    ``reach``: the largest |lambda - sigma| of the eigen-solver's values (the
    eigenvalues of S within it of sigma are all sought; inf where ``whole``);
    ``top``: the largest of them; ``asked``: the (shift, step) it was asked
    for (:func:`_solve_run`); ``anchor``: the run's proved point (its
    shift, or a counted edge above it: :func:`_anchor`), with its count and
    fuzz, once set.
    """

    sigma: float
    pairs: Slice
    reach: float
    top: float
    whole: bool = False
    asked: tuple = ()
    anchor: float | None = None
    anchor_count: int = 0
    anchor_fuzz: float = 0.0


def _as_run(lam, sigma, ritz, whole):
    """The :class:`_Run` of the eigen-solver's values ``lam`` about sigma and
    their Rayleigh-Ritz ``ritz`` (:func:`rayleigh_ritz`)."""
    reach = math.inf if whole else float(np.max(np.abs(lam - sigma)))
    pairs = Slice(sigma - reach, sigma + reach, *ritz)
    return _Run(sigma, pairs, reach, math.inf if whole else float(np.max(lam)), whole)


def _solve_run(S, W, normS, shifts, sigma, kk, rng, stats, step):
    """The run about sigma (:func:`shift_invert`, moved by ``step`` from a tiny
    pivot; computed again about a lower shift where its Kahan radius exceeds
    the eigen-solver's bound, :func:`_reshifted`)."""
    asked = (sigma, step)
    lam, V, sigma = shift_invert(S, shifts, sigma, kk, rng, stats, step)
    run = _ritz_run(S, W, normS, shifts, lam, V, sigma, kk, rng, stats, False)
    run.asked = asked
    return run


def _ritz_run(S, W, normS, shifts, lam, V, sigma, kk, rng, stats, whole):
    """The :class:`_Run` of the eigen-solver's pairs (lam, V) about sigma: their
    Rayleigh-Ritz, made again about a lower shift where its Kahan radius
    exceeds the eigen-solver's bound (:func:`_reshifted`; not where
    ``whole``, LAPACK's)."""
    ritz = rayleigh_ritz(S, W, V, normS)
    if not whole and ritz[3] > _RECOMPUTE_ABOVE * stopping_bound(ritz[0].size, normS, sigma):
        lam, ritz, sigma = _reshifted(S, W, normS, shifts, sigma, kk, rng, stats, lam, ritz)
    return _as_run(lam, sigma, ritz, whole)


def _anchor(shifts, run, lo, stats, defer=False):
    """Set the run's proved point above ``lo``: its shift, whose count comes from
    the factorization of its solves where that is still held, if each of its
    Ritz values lies farther than 2 (radius + fuzz) from it; else the widest
    counted gap above max(lo, sigma) within half its reach that is as far
    from them (one of ``stats.counted_edges``); None if none.

    With ``defer``, a shift above ``lo`` whose count is not at hand
    (:meth:`~.inertia.Shifts.count_at_hand`: its float64 count too fuzzy to
    use, or each count a factorization of its own, as with SuperLU's
    solves) is left uncounted: the anchor is then the shift, its count None
    (``stats.deferred_counts``), and the chain of runs it belongs to is
    proved by the counts at its ends (:func:`_next_slices`)."""
    run.anchor = None
    run.anchor_count, run.anchor_fuzz = 0, 0.0
    theta, radius = run.pairs.theta, run.pairs.radius
    if run.sigma > lo:
        try:
            got = shifts.count_at_hand(run.sigma) if defer else None
            if defer and got is None:
                run.anchor, run.anchor_count = run.sigma, None
                stats.deferred_counts += 1
                return
            cnt, fz = got if got is not None else shifts.count_below(run.sigma)
        except (ValueError, SliceFailure):
            cnt, fz = -1, math.inf
        if cnt >= 0 and np.min(np.abs(theta - run.sigma)) > 2 * (radius + fz):
            run.anchor, run.anchor_count, run.anchor_fuzz = run.sigma, cnt, fz
            return
    base = max(lo, run.sigma)
    for _, y in _widest_gaps(theta[(theta > base) & (theta < run.sigma + 0.5 * run.reach)]):
        try:
            cnt, fz = shifts.count_below(y)
        except (ValueError, SliceFailure):
            continue
        if np.min(np.abs(theta - y)) > 2 * (radius + fz):
            run.anchor, run.anchor_count, run.anchor_fuzz = y, cnt, fz
            stats.counted_edges += 1
            return


def _split(cur, nxt):
    """A split point between two overlapping runs: in a gap of both runs' Ritz
    values between cur's anchor and nxt's shift, within both reaches, farther
    than twice each run's radius from its values (the widest first); None if none."""
    lo = max(cur.anchor, nxt.sigma - nxt.reach)
    hi = min(nxt.sigma, cur.sigma + cur.reach)
    if not lo < hi:
        return None
    both = np.concatenate([cur.pairs.theta, nxt.pairs.theta])
    t = np.sort(np.concatenate([[lo, hi], both[(both > lo) & (both < hi)]]))
    for _, y in _widest_gaps(t):
        if np.min(np.abs(cur.pairs.theta - y)) > 2 * cur.pairs.radius and \
                np.min(np.abs(nxt.pairs.theta - y)) > 2 * nxt.pairs.radius:
            return float(y)
    return None


def _next_run(S, W, normS, shifts, cur, kk, rng, stats):
    """The run above ``cur`` that overlaps it: (run, split point, the stream's
    state before its start vector, width of kk values), or None where no shift
    within ``_NEXT_TRIES`` reaches back (each try halves the step)."""
    up = cur.pairs.theta[cur.pairs.theta > cur.sigma]
    half = up[up.size // 2:]
    if half.size < 4 or not half[-1] > half[0]:
        return None
    width = kk * (half[-1] - half[0]) / (half.size - 1)
    step = _NEXT_STEP * 0.5 * width
    for _ in range(_NEXT_TRIES):
        state = copy.deepcopy(rng)
        try:
            nxt = _solve_run(S, W, normS, shifts, cur.sigma + cur.reach + step, kk, rng, stats,
                             0.01 * width)
        except SliceFailure:
            return None
        y = _split(cur, nxt)
        if y is not None:
            return nxt, y, state, width
        stats.split_misses += 1
        step *= 0.5
    return None


def _start_run(S, W, k, normS, pos, shifts, stats):
    """A run whose k nearest reach below ``pos.x`` (:func:`_pairs_reaching_below`,
    drawing from ``pos.rng``), its values below x dropped; the fuzz at x
    recounted where the nearest value above x is too close for it."""
    n = S.shape[0]
    x = pos.x
    kk = min(k, n - 2)
    lam, V, sigma, whole = _pairs_reaching_below(S, shifts, pos, kk, stats, normS)
    run = _ritz_run(S, W, normS, shifts, lam, V, sigma, kk, pos.rng, stats, whole)
    above = run.pairs.theta > x
    if not np.any(above):
        raise SliceFailure(f"no Ritz value above the slice edge {x:.6g}")
    if run.pairs.theta[above][0] - x <= 2 * (run.pairs.radius + pos.fuzz):
        _recounted_edge(shifts, pos, run.pairs.theta[above][0] - x, run.pairs.radius)
    return run


class _ChainFailure(Exception):
    """A chain of runs with counts left out whose counts at its ends disagree
    with its Ritz values (or that no counted edge closes): ``upto``, the
    highest shift of its runs."""

    def __init__(self, upto):
        super().__init__(upto)
        self.upto = upto


def _may_defer(run, deferred, pos, stop_above):
    """Whether ``run``'s count may be left out: fewer than CHAIN_RUNS - 1 runs
    left uncounted since the last count, and its shift above ``pos.recount_to``
    and not above ``stop_above``."""
    return deferred < CHAIN_RUNS - 1 and pos.recount_to < run.sigma <= stop_above


def _next_slices(S, W, k, normS, pos, shifts, stats, cur, rng, stop_above):
    """The slices above ``pos.x`` that one count proves, and the run left
    pending (None where the last upper edge was counted): :func:`ritz_slices`.

    Returns a list of (slice, the fields of ``pos`` at its upper edge) and the
    pending run; ``pos`` itself is not changed.

    Raises
    ------
    _ChainFailure
        Where a chain with counts left out is not proved.
    SliceFailure
        Where a slice cannot be certified otherwise.
    """
    n = S.shape[0]
    x, cnt_x = pos.x, pos.count
    kk = min(k, n - 2)
    deferred = pos.deferred
    if cur is None:
        cur = _start_run(S, W, k, normS, pos, shifts, stats)
        if not cur.whole and cnt_x + np.count_nonzero(cur.pairs.theta > x) < n:
            _anchor(shifts, cur, x, stats, _may_defer(cur, deferred, pos, stop_above))
            if cur.anchor is not None and cur.anchor_count is not None and \
                    cur.anchor_count - cnt_x != np.count_nonzero(
                        (cur.pairs.theta > x) & (cur.pairs.theta < cur.anchor)):
                cur.anchor = None
            deferred = deferred + 1 if cur.anchor is not None and \
                cur.anchor_count is None else 0
    # the chain: runs split at points y, each kept below the next split, up to
    # a run whose count is made (or a counted edge)
    steps = []                  # (run, lo, y, kept, rng state, width, deferred after the next)
    lo, virt = x, cnt_x         # the lower edge of cur's part and the count below it

    def uncounted():            # a run of the chain left its count out
        return any(r.anchor_count is None for r in [cur] + [st[0] for st in steps])

    while cur.anchor is not None and virt + np.count_nonzero(cur.pairs.theta > lo) < n:
        got = _next_run(S, W, normS, shifts, cur, kk, rng, stats)
        if got is None:
            break
        nxt, y, state, width = got
        _anchor(shifts, nxt, y, stats, _may_defer(nxt, deferred, pos, stop_above))
        if nxt.anchor is None:
            break
        deferred = deferred + 1 if nxt.anchor_count is None else 0
        th = cur.pairs.theta
        kept = int(np.count_nonzero((th > lo) & (th < y)))
        steps.append((cur, lo, y, kept, state, width, deferred))
        lo, virt, cur = y, virt + kept, nxt
        if nxt.anchor_count is None:
            continue
        if nxt.anchor_count - virt == np.count_nonzero((nxt.pairs.theta > y) &
                                                       (nxt.pairs.theta < nxt.anchor)):
            stats.fuzz = max([stats.fuzz, nxt.anchor_fuzz] +
                             [r.anchor_fuzz for r, *_ in steps if r.anchor_count is not None])
            return _chain_slices(steps, nxt, cnt_x, stats), nxt
        if uncounted():
            raise _ChainFailure(nxt.sigma)
        # the old pair's counts disagree: a counted edge above cur's lower part
        cur, lo, virt = steps[-1][0], steps[-1][1], virt - steps[-1][3]
        steps.pop()
        break
    # a counted upper edge of cur, which proves the chain below it too
    th = cur.pairs.theta
    above = th > lo
    theta = th[above]
    cands = _edge_candidates(theta, cur.top, cur.pairs.radius, cur.whole, virt, n)
    try:
        y, nkeep, cnt_y, fz = _certified_edge(shifts, cands, theta, cur.pairs.radius, lo, virt)
    except SliceFailure:
        if uncounted():
            raise _ChainFailure(max([cur.sigma] + [r.sigma for r, *_ in steps])) from None
        raise
    stats.fuzz = max(stats.fuzz, fz)
    stats.counted_edges += 1
    out = _chain_slices(steps, cur, cnt_x, stats)
    keep = np.flatnonzero(above)[:nkeep]
    out.append((_slice(cur, keep, lo, y, stats),
                dict(x=y, count=cnt_y, fuzz=fz, rng=rng, pending=None, deferred=0,
                     width=float(theta[nkeep - 1] - theta[0]) * k / max(nkeep - 1, 1))))
    return out, None


def _chain_slices(steps, last, cnt_x, stats):
    """The proved slices of a chain's ``steps`` (:func:`_next_slices`: each
    run with its lower edge, its split point y, the values it keeps, the
    start-vector stream's state before the next run, the width, the counts
    left out after the next run), each with the fields of the position at its
    upper edge; ``last``: the run after the last step, left pending."""
    out, count = [], cnt_x
    for j, (run, lo, y, kept, state, width, after) in enumerate(steps):
        th = run.pairs.theta
        count += kept
        pending = steps[j + 1][0] if j + 1 < len(steps) else last
        out.append((_slice(run, (th > lo) & (th < y), lo, y, stats),
                    dict(x=y, count=count, fuzz=0.0, rng=state, width=width,
                         pending=pending.asked, deferred=after)))
    return out


def _slice(run, keep, lo, hi, stats):
    """The :class:`Slice` of ``run``'s pairs ``keep`` between lo and hi."""
    stats.slices += 1
    p = run.pairs
    stats.ritz_radius = max(stats.ritz_radius, p.radius)
    return Slice(lo, hi, p.theta[keep], p.Q[:, keep], p.WQ[:, keep], p.radius, p.resid[keep],
                 p.phi)


def _pairs_reaching_below(S, shifts, pos, kk, stats, normS):
    """The kk eigenpairs of S nearest a shift sigma above ``pos.x`` that reach
    below it: (lam, V, sigma, whole); ``whole``: all of S's eigenpairs above x
    (LAPACK, where kk >= n - 2).

    The kk nearest to sigma reach below x unless (x, sigma) holds more than
    kk/2 of them: sigma 0.42 of a slice above x leaves a margin for the
    variation of the eigenvalue density (a miss costs a second eigen-solve:
    sigma is then halved towards x, and x itself after ten misses). At the
    bottom (no eigenvalue of S below x, no slice yet) x is the Gershgorin
    bound, far below the spectrum: the shift is put where
    :func:`_bottom_shift` finds it instead, among the lowest eigenvalues.
    """
    n = S.shape[0]
    x, width = pos.x, pos.width
    if kk < n - 2 and width is None and pos.count == 0:
        bottom = _bottom_shift(S, shifts, pos, kk, stats, normS)
        if bottom is not None:
            return bottom
    sigma = x if width is None else x + _SHIFT_FRACTION * width
    step = None if width is None else 0.01 * width
    for attempt in range(12):
        if kk >= n - 2:
            lam, V = np.linalg.eigh(S.toarray())
            sel = lam > x
            return lam[sel], V[:, sel], sigma, True
        lam, V, sigma = shift_invert(S, shifts, sigma, kk, pos.rng, stats, step)
        if sigma <= x or np.min(lam) < x:
            return lam, V, sigma, False
        sigma = x + 0.5 * (sigma - x) if attempt < 10 else x   # a hole above x: lower
    raise SliceFailure(f"no shift above {x:.6g} reached the slice edge")


def _bottom_shift(S, shifts, pos, kk, stats, normS):
    """The first slice's pairs, about a shift just below the spectrum of S:
    (lam, V, sigma, False), or None (then the shift at x, as before).

    Below the spectrum (x the Gershgorin bound, ``pos.count`` 0), a shift at x
    sees the kk lowest eigenvalues at nearly one distance (1 / (lambda - x)
    nearly equal), and Lanczos converges slowly: measured (ARPACK) 2255 and
    2929 solves for the first slice at N = 6400 and 10^4, against 138 for
    the next two, and 164 about this shift (docs/results/analysis.md, "The first
    slice of a scan"). Here a bisection on the float64 count between x
    (count 0) and ``normS`` + 1 (``normS`` >= ||S||_2) closes in on the
    lowest eigenvalue, two halvings past the first upper end whose count is
    kk / 4 or less (or down to an interval of 1e-6 ``normS``); the shift
    lies one final interval below its lower end, so between one and two
    intervals below the lowest eigenvalue, a fraction of the span of the
    lowest ones: the kk pairs nearest it are the kk lowest, well separated
    in 1 / (lambda - sigma). The counts steer only: the slice's own counts
    prove it complete, as for every slice.
    """
    lo, hi = pos.x, float(normS) + 1.0
    cmax, extra, floor = max(kk // 4, 1), None, 1e-6 * float(normS)
    while extra != 0 and hi - lo > floor:
        mid = 0.5 * (lo + hi)
        try:
            cnt = shifts.count(mid)[0]
        except (ValueError, SliceFailure):      # a zero pivot: the shift at x
            return None
        if cnt == 0:
            lo = mid
        else:
            hi = mid
        if extra is not None:
            extra -= 1
        elif 0 < cnt <= cmax:
            extra = 2
    try:
        lam, V, sigma = shift_invert(S, shifts, max(pos.x, lo - (hi - lo)), kk, pos.rng,
                                     stats)
    except SliceFailure:
        return None
    return lam, V, sigma, False


def _reshifted(S, W, normS, shifts, sigma, kk, rng, stats, lam, ritz):
    """The slice computed again about a shift 1 % of its span lower, kept if its
    Kahan radius is smaller: (lam, Rayleigh-Ritz of the slice kept, its shift).

    A shift where QDLDL's elimination (no pivoting) met a tiny pivot: the
    growth of D makes the solves inexact (N = 10^4: relative error 4.5e-6,
    max |d| 1.1e13, inertia fuzz 1394 at one shift) and the eigen-solver
    converges to vectors of that inexact operator whatever its tolerance
    (measured with ARPACK: residuals ~1e-3 on all 60). :func:`shift_invert`
    moves such a shift before the eigen-solver runs when its probe solve
    shows it; this catches a slice whose radius still exceeds the
    eigen-solver's own bound (:func:`stopping_bound`). The moved shift's
    window still reaches below the edge.
    """
    theta, radius = ritz[0], ritz[3]
    lam2, V, sigma2 = shift_invert(S, shifts, sigma - 0.01 * float(theta[-1] - theta[0]), kk,
                                   rng, stats)
    stats.reshifted += 1
    better = rayleigh_ritz(S, W, V, normS)
    if better[3] < radius:
        return lam2, better, sigma2
    return lam, ritz, sigma


def _edge_candidates(theta, reach, radius, whole, cnt_x, n):
    """Candidate upper edges (y, Ritz values kept below it), best first.

    The last slice: above its top Ritz value. Otherwise all eigenvalues up to
    ``reach`` (the eigen-solver's largest value) are found, and the edges lie
    in gaps of what lies below it: the widest of the top sixth first (the
    higher the edge, the fewer Ritz pairs are computed twice), then the
    widest of the rest of the upper half.
    """
    if whole or cnt_x + theta.size >= n:
        y = float(theta[-1]) + max(1.0, abs(float(theta[-1]))) * 1e-3 + 2 * radius + 1.0
        return [(y, theta.size)]
    th = theta[theta < reach]
    top = max(1, (th.size * 5) // 6)
    half = max(1, th.size // 2)
    cands = []
    for lo_i, hi_i in ((top, th.size), (half, top)):
        cands += [(y, lo_i + j) for j, y in _widest_gaps(th[lo_i - 1:hi_i])]
    return cands


def _widest_gaps(t, m=8):
    """The m widest gaps of the ascending values t, widest first: (j, midpoint
    of t[j] and t[j + 1])."""
    return [(int(j), 0.5 * (t[j] + t[j + 1])) for j in np.argsort(np.diff(t))[::-1][:m]]


def _recounted_edge(shifts, pos, d, radius):
    """The fuzz at the lower edge ``pos.x`` where its count's fuzz alone puts the
    nearest Ritz value above it (``d`` away) too close: the count made again in
    double-word arithmetic (:meth:`~.inertia.Shifts.count_below_dw`), which must
    equal ``pos.count``; ``pos.fuzz`` is set to its fuzz.

    Raises
    ------
    SliceFailure
        If the Ritz value lies within 2 x ``radius`` (or 2 (radius + the new
        fuzz)) of the edge, or the double-word count differs.
    """
    x, fz_x = pos.x, pos.fuzz
    if d > 2 * radius:
        try:
            cnt, fz = shifts.count_below_dw(x)
        except ValueError:
            cnt, fz = -1, math.inf
        if cnt != pos.count and cnt >= 0:
            raise SliceFailure(f"slice edge {x:.9g}: its double-word count {cnt} differs "
                               f"from its float64 count {pos.count}")
        if d > 2 * (radius + fz):
            pos.fuzz = fz
            return fz
    raise SliceFailure(f"slice edge {x:.9g} within {2 * (radius + fz_x):.3g} of a Ritz value")


def _certified_edge(shifts, cands, theta, radius, x, cnt_x):
    """The first candidate edge y whose Sylvester count equals the count at x
    plus the Ritz values kept, farther than 2 (radius + fuzz) from each Ritz
    value: (y, Ritz values kept, count at y, its fuzz). If none is, the
    candidates that only their count's fuzz kept too close to a Ritz value
    are counted again in double-word arithmetic, in the same order.

    Raises
    ------
    SliceFailure
        If no candidate is certified.
    """
    blurred = []
    for y, nkeep in cands:
        try:
            cnt_y, fz = shifts.count_below(y)
        except (ValueError, SliceFailure):
            continue
        d = min(abs(theta - y))
        if d > 2 * (radius + fz) and cnt_y - cnt_x == nkeep:
            return y, nkeep, cnt_y, fz
        if 2 * radius < d <= 2 * (radius + fz):
            blurred.append((y, nkeep, d))
    for y, nkeep, d in blurred:
        try:
            cnt_y, fz = shifts.count_below_dw(y)
        except ValueError:
            continue
        if d > 2 * (radius + fz) and cnt_y - cnt_x == nkeep:
            return y, nkeep, cnt_y, fz
    raise SliceFailure(f"no certified edge above {x:.9g}: inertia count and Ritz values "
                       f"differ or the edge is within the Ritz radius {radius:.3g} + "
                       f"inertia fuzz of a Ritz value")


#: Lanczos vectors of :func:`top_eigenvalue` (scipy's default for one pair is
#: 20): at the top of a tiled packing's spectrum (11 copies, a cluster of
#: eigenvalues within 2e-7 relative) 20 did not converge in 28 s of CPU (NaN),
#: 40 took 0.04 s; on random, tiled and ordered packings of 837 - 3306 dofs
#: the value is LAPACK's to 1e-14 relative either way (docs/results/analysis.md,
#: "Large clusters in pieces")
_TOP_NCV = 40


def top_eigenvalue(S):
    """ARPACK's largest eigenvalue of the symmetric S (an approximation; NaN if
    ARPACK does not converge)."""
    from scipy.sparse.linalg import ArpackError, eigsh

    if S.shape[0] < 10:
        return float(np.linalg.eigvalsh(S.toarray())[-1])
    v0 = np.random.default_rng(0).standard_normal(S.shape[0])
    try:
        return float(eigsh(S, k=1, which="LA", v0=v0, return_eigenvectors=False,
                           ncv=min(S.shape[0] - 1, _TOP_NCV))[0])
    except ArpackError:         # ArpackNoConvergence included
        return math.nan
