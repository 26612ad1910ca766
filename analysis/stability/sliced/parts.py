r"""A sliced scan in parts that an executor runs side by side.

``classify_sliced(..., part_size=p, map_tasks=m)`` cuts the spectrum of the
symmetric part S into P = ceil(n / p) parts of about p eigenvalues each and
scans them in two rounds of independent tasks, each round one call
``m(fn, tasks)`` (default: the builtin :func:`map`, one after the other; an
MPI or process-pool executor runs them side by side). The partition depends
on S and p only, never on how many workers run it, and each task is
deterministic, so the verdict, the eigenvalues and the statistics are the
same, bit for bit, whatever the executor (on machines and BLAS thread counts
that give the same bits; :mod:`.checkpoint` relies on the same).

1. **Cuts** (:func:`find_cut`, one task per part j >= 1). The split point
   x_j: a point whose Sylvester count (:class:`~.inertia.Shifts`) is within
   p / 10 of round(j n / P), by bisection on the count between the bottom
   lo0 and a Gershgorin bound above the spectrum. From the position (x_j,
   its count, its fuzz, a random stream seeded from j) the task scans up
   (:meth:`~.scan.SlicedScan.first_boundary`) to the first gap c_j >= x_j +
   2 Delta certified by the boundary lemma (2 Delta: the window the whole
   scan keeps below its last boundary, :meth:`~.scan.SlicedScan.forget_below`,
   so the strips above c_j see at least what they would see there), and
   returns c_j with the number of eigenvalues of S below it. A cut whose task
   fails, or that does not lie above the cut kept below it, is dropped: the
   part below then scans through it.
2. **Parts** (:func:`scan_part`, one task per part). Part j scans from x_j
   again (the same position and random stream: the same slices), takes c_j
   as its first certified boundary (no gap at or below it is tested, no strip
   below it is decided), certifies its own boundaries and decides its strips
   as the whole scan does (:class:`~.scan.SlicedScan`), and ends at
   c_{j+1}, the cut of the part above: the strip below c_{j+1} is decided with
   c_{j+1} as its upper boundary. Part 0 starts at the bottom, the last part
   ends at the top of the spectrum.
3. **Merge** (:func:`merged_decision`, sequential). The parts' strips in
   order: *complex* if one is certified complex, *real* if all are certified
   real, else *undecided* with the reasons, as
   :func:`~.strips.strips_decision` decides a whole scan; the eigenvalues
   are the parts' lists together. The parts are read in order and the merge
   stops at the first part that stops at a complex strip
   (``stop_at_complex``) or fails: the parts above are not read (not run by
   a lazy ``map``; an executor's ``map`` whose iterator has ``close`` is
   closed, which cancels the tasks not started), so the answer is that of a
   scan that went up the parts in order.

**Why a cut is a boundary of both parts.** A strip's decision (package
docstring, *Strips*) needs of its two edges: (i) each is a certified
boundary, i.e. A + F has as many eigenvalues with real part below it as S
has below it (the boundary lemma: a statement about the matrix, whichever
task proves it); (ii) the number of eigenvalues of S between them equals the
number of Ritz values of the strip's block I, so that the strip holds
exactly m = |I| eigenvalues of A + F (the real route needs m sign changes);
(iii) the rest, every Ritz vector but I and the eigenvectors of S not held,
is coupled weakly across the strip: :func:`~.strips.coupling` with ``exclude
= I``, computed from the deciding part's own buffer, its edges (the region
below x_j counts as not held, as slices forgotten do) and its Ritz radii, and
checked there. c_{j+1} satisfies (i) by part j+1's gap test; (ii) because part
j checks that c_{j+1} lies between its Ritz values g - 1 and g (g: part j+1's
count of eigenvalues of S below c_{j+1}, less part j's base;
:meth:`~.scan.SlicedScan.check_cut`): every eigenvalue of S in a slice of
part j is within the slice's Kahan radius of its own Ritz value, and part
j+1's test put c_{j+1} more than twice its radii from its Ritz values, so a
failure of the check means a Ritz value of part j is far from part j+1's
and the strip is left undecided with the reason (a step that cannot be
certified); (iii) is checked by part j itself as for any strip, with the
window above c_{j+1} in its buffer (part j ends only once its slices reach
Delta above c_{j+1}, as the whole scan requires of a gap). The same holds of
c_j for part j (its own cut, computed again in the same bits, and checked
again).

**Cost.** Each cut's region [x_j, c_j + Delta + a slice] is computed three
times (the cut's task, part j and part j-1), the bisection costs about
log2(n / tol) factorizations per cut: measured, docs/results/analysis.md
("A scan in parts").
"""
from __future__ import annotations

from dataclasses import dataclass, field
import math
import time

import numpy as np

from remote_trigger.analysis.stability.sliced.inertia import Shifts, fuzz_limit
from remote_trigger.analysis.stability.sliced.numerics import SliceFailure
from remote_trigger.analysis.stability.sliced.slices import Position
from remote_trigger.analysis.stability.sliced.stats import SlicedStats
from remote_trigger.analysis.stability.sliced.strips import strips_decision

__all__ = ["PartsProblem", "CutTask", "Cut", "PartTask", "PartResult", "find_cut",
           "scan_part", "split_point", "merged_decision", "classify_parts", "part_count"]

# the first boundary of a part lies this many windows Delta above its split
# point: the window the whole scan keeps below its last boundary
_CUT_WINDOWS = 2.0
# a split point's count may miss its target by part_size / _CUT_TOL
_CUT_TOL = 10


@dataclass(frozen=True)
class PartsProblem:
    """What every task of a partitioned scan needs (pickled with each task).

    Attributes
    ----------
    S : scipy.sparse.csc_matrix, shape (n, n)
        The symmetric part.
    ctx : StripContext
        The boundary and strip tests' context.
    lo0 : float
        Below the spectrum of every matrix of the set.
    hi0 : float
        Above the spectrum of S (a Gershgorin bound).
    part_size : int
        Eigenvalues per part (about).
    new_scan : callable
        ``new_scan(stats)``: a new :class:`~.scan.SlicedScan` of S with the
        call's options (slice size, stop rule; picklable: a
        :func:`functools.partial` of the class).
    """

    S: object
    ctx: object
    lo0: float
    hi0: float
    part_size: int
    new_scan: object

    def scan(self, stats):
        """A new :class:`~.scan.SlicedScan` of S with the call's options."""
        return self.new_scan(stats)


def part_count(n, part_size):
    """Number of parts P = ceil(n / part_size) of a scan in parts of n eigenvalues."""
    return max(1, -(-n // int(part_size)))


def _rng(j):
    """The random stream of part j's start vectors (part 0: that of a whole scan)."""
    return np.random.default_rng(12345 if j == 0 else [12345, j])


@dataclass(frozen=True)
class CutTask:
    """Find cut j (:func:`find_cut`): split point near ``target`` eigenvalues of S."""

    problem: PartsProblem
    j: int
    target: int


@dataclass
class Cut:
    """What :func:`find_cut` found: the split point x (its count and fuzz), the
    first certified boundary c above it (None: none found, ``reason``), the
    eigenvalues of S below c, kappa(c), the statistics and seconds of the task."""

    j: int
    x: float
    count: int
    fuzz: float
    c: float | None
    below: int = 0
    kappa: float = math.inf
    reason: str = ""
    stats: SlicedStats = field(default_factory=SlicedStats)
    seconds: float = 0.0
    t_slices: float = 0.0


def split_point(shifts, lo, hi, target, tol):
    """A point x in (lo, hi) whose Sylvester count of S is within ``tol`` of
    ``target``, by bisection on the count (``shifts``: a :class:`~.inertia.Shifts`
    of S): (x, count, fuzz). The bisection steers by float64 counts; the
    count returned is double-word where their fuzz exceeds ``shifts.fuzz_limit``.

    Raises
    ------
    SliceFailure
        If 200 halvings do not reach such a count.
    """
    def steer(x):                # float64 counts: they only steer the bisection
        return shifts.count(x)

    for _ in range(200):
        x = 0.5 * (lo + hi)
        try:
            cnt, fz = steer(x)
        except (ValueError, SliceFailure):      # a zero pivot: a point beside it
            x = lo + 0.5000001 * (hi - lo)
            cnt, fz = steer(x)
        if abs(cnt - target) <= tol:
            if fz > shifts.fuzz_limit:
                cnt, fz = shifts.count_below_dw(x)
            return x, cnt, fz
        if cnt < target:
            lo = x
        else:
            hi = x
    raise SliceFailure(f"no split point with {target} +- {tol} eigenvalues of S below it")


def find_cut(task):
    """Cut j (module docstring, step 1): its split point and the first boundary
    certified at least 2 Delta above it. A :class:`Cut`; ``c`` is None where
    the scan fails or reaches the top first (its ``reason``)."""
    t0 = time.perf_counter()
    pb = task.problem
    stats = SlicedStats()
    tol = pb.part_size // _CUT_TOL
    shifts = Shifts(pb.S, fuzz_limit(pb.ctx.normS, pb.S.shape[0]), stats)
    x, cnt, fz = split_point(shifts, pb.lo0, pb.hi0, task.target, tol)
    cut = Cut(task.j, x, cnt, fz, None, stats=stats)
    scan = pb.scan(stats)
    scan.begin_part(Position(x, cnt, fz, _rng(task.j)), cnt)
    try:
        found = scan.first_boundary(x + _CUT_WINDOWS * pb.ctx.Delta)
        if found is None:
            cut.reason = "no certified boundary below the top of the spectrum"
        else:
            cut.c, cut.below, cut.kappa = float(found[0]), int(found[1]), float(found[2])
    except SliceFailure as exc:
        cut.reason = str(exc)
    cut.seconds, cut.t_slices = time.perf_counter() - t0, scan.t_slices
    return cut


@dataclass(frozen=True)
class PartTask:
    """Scan part j (:func:`scan_part`) from ``start`` (None: the bottom) with the
    boundaries ``floor`` and ``ceiling`` ((c, eigenvalues of S below c) or None)."""

    problem: PartsProblem
    j: int
    start: tuple | None
    floor: tuple | None
    ceiling: tuple | None


@dataclass
class PartResult:
    """What one part found: its strips (``pairs``), eigenvalues, margins, strip
    sizes, how it ended (``reason`` of a failure, ``scanned_below`` of a stop
    at a complex strip, its last certified boundary), the eigenvalues of S
    below its top (``counted``), its statistics and seconds."""

    j: int
    pairs: list
    lam: list
    margins: list
    complex_margins: list
    undecided_margins: list
    strips: dict
    reason: str
    scanned_below: float
    last_boundary: float
    counted: int
    stats: SlicedStats
    seconds: float
    t_slices: float


def scan_part(task):
    """Part j (module docstring, step 2): a :class:`PartResult`."""
    t0 = time.perf_counter()
    pb = task.problem
    stats = SlicedStats()
    stats.n = pb.S.shape[0]         # (the order, for progress reports: saved_scans)
    scan = pb.scan(stats)
    pos = None if task.start is None else Position(*task.start, _rng(task.j))
    scan.begin_part(pos, 0 if task.start is None else task.start[1], task.floor,
                    task.ceiling)
    scan.run()
    return PartResult(task.j, scan.pairs, scan.lam, scan.margins, scan.complex_margins,
                      scan.undecided_margins, dict(scan.strips), scan.reason,
                      scan.scanned_below, scan.certified[-1] if scan.certified else pb.lo0,
                      scan.counted, stats, time.perf_counter() - t0, scan.t_slices)


def _add_stats(total, st):
    """Add the work of a task's statistics to ``total``."""
    for name in ("slices", "boundaries", "lanczos_runs", "arpack_runs", "computed", "moved",
                 "reshifted", "split_misses", "counted_edges", "dw_counts", "deferred_counts",
                 "chain_failures"):
        setattr(total, name, getattr(total, name) + getattr(st, name))
    for name in ("max_kappa", "fuzz", "ritz_radius"):
        setattr(total, name, max(getattr(total, name), getattr(st, name)))


def merged_decision(pb, cuts, results, stats, timing, progress=None):
    """The SpectrumDecision of the parts (module docstring, step 3).

    ``cuts``: the :class:`Cut` s kept (their boundaries count as certified
    boundaries: kappa, margin); ``results``: an iterable of
    :class:`PartResult` in part order, read only as far as needed (closed
    after, if it has ``close``). ``stats`` and ``timing`` ('eigen',
    'decision': seconds) receive the sums of the parts' work.
    """
    n = pb.S.shape[0]
    pairs, lam, margins, cm, um, strips = [], [], [], [], [], {}
    reason, scanned_below = "", math.inf
    for cut in cuts:
        margins.append(1.0 / cut.kappa if cut.kappa > 0 else math.inf)
        stats.boundaries += 1
        stats.max_kappa = max(stats.max_kappa, cut.kappa)
    try:
        for r in results:
            pairs += r.pairs
            lam += r.lam
            margins += r.margins
            cm += r.complex_margins
            um += r.undecided_margins
            for m, c in r.strips.items():
                strips[m] = strips.get(m, 0) + c
            _add_stats(stats, r.stats)
            timing["eigen"] += r.t_slices
            timing["decision"] += r.seconds - r.t_slices
            if progress is not None:
                progress(r.counted, n)
            if r.reason:
                reason = r.reason
                if cm:              # the strips below the part's last boundary are decided
                    scanned_below = r.last_boundary
                break
            if math.isfinite(r.scanned_below):
                scanned_below = r.scanned_below
                break
    finally:
        close = getattr(results, "close", None)
        if close is not None:
            close()
    stats.strips = dict(sorted(strips.items()))
    return strips_decision(pb.S, pb.ctx.eps, pairs, lam, margins, cm, um, reason,
                             scanned_below, timing)


def _saved_map(map_tasks, fn, tasks, files, kind):
    """``map_tasks(fn, tasks)`` with the results saved in ``files`` reused and each
    new result saved as it is read (:meth:`~.checkpoint.ScanFiles.save_task`;
    ``files`` None: the plain map). A generator of the results in task order;
    closing it closes the map's iterator."""
    if files is None:
        it = iter(map_tasks(fn, tasks))
        try:
            yield from it
        finally:
            close = getattr(it, "close", None)
            if close is not None:
                close()
        return
    saved = [files.load_task(kind, t.j) for t in tasks]
    todo = [t for t, r in zip(tasks, saved) if r is None]
    it = iter(map_tasks(fn, todo)) if todo else iter(())
    try:
        for task, r in zip(tasks, saved):
            if r is None:
                r = next(it)
                files.save_task(kind, task.j, r)
            yield r
    finally:
        close = getattr(it, "close", None)
        if close is not None:
            close()


def classify_parts(pb, stats, map_tasks=None, progress=None, files=None):
    """The verdict of a partitioned scan (module docstring): cuts, parts, merge.

    Parameters
    ----------
    pb : PartsProblem
        S, the options and the part size.
    stats : SlicedStats
        Filled: the sums over every task (both rounds), ``parts`` and ``cuts``.
    map_tasks : callable, optional
        ``map_tasks(fn, tasks)`` -> the results in the order of ``tasks`` (an
        iterable, read in order and possibly not to its end); ``fn`` and the
        tasks and results are picklable. Default: the builtin :func:`map`.
    progress : callable, optional
        ``progress(done, n)`` after each part is merged.
    files : ScanFiles, optional
        Where each finished task's result is saved (atomically, by this
        process, as the merge reads it: in task order) and found again: a
        scan killed and called again runs only the tasks not saved, and its
        answer is that of an uninterrupted scan, bit for bit (a saved result
        is the one the task computes; ``timing`` adds the saved tasks'
        seconds, as a resumed whole scan adds its seconds before the resume).

    Returns
    -------
    SpectrumDecision
        ``timing``: the seconds (wall, ``time.perf_counter``) summed over the
        tasks ('eigen': the slices; 'decision': the rest, the bisections
        included), and 'parts': the longest task of each round, added (what
        as many workers as parts would take, the merge aside).
    """
    map_tasks = map if map_tasks is None else map_tasks
    n = pb.S.shape[0]
    P = part_count(n, pb.part_size)
    tasks = [CutTask(pb, j, round(j * n / P)) for j in range(1, P)]
    found = list(_saved_map(map_tasks, find_cut, tasks, files, "cut"))
    kept, prev = [], pb.lo0
    for cut in found:
        _add_stats(stats, cut.stats)
        if cut.c is not None and cut.c > prev:
            kept.append(cut)
            prev = cut.c
    stats.parts = len(kept) + 1
    stats.cuts = tuple((cut.x, cut.c) for cut in kept)
    bounds = [None] + [(cut.c, cut.below) for cut in kept] + [None]
    starts = [None] + [(cut.x, cut.count, cut.fuzz) for cut in kept]
    ids = [0] + [cut.j for cut in kept]
    ptasks = [PartTask(pb, ids[i], starts[i], bounds[i], bounds[i + 1])
              for i in range(len(ids))]
    done = []

    def results():
        it = _saved_map(map_tasks, scan_part, ptasks, files, "part")
        try:
            for r in it:
                done.append(r)
                yield r
        finally:                # an executor's map: the tasks not started are cancelled
            it.close()

    eigen = sum(c.t_slices for c in found)
    timing = {"eigen": eigen, "decision": sum(c.seconds for c in found) - eigen}
    dec = merged_decision(pb, kept, results(), stats, timing, progress)
    timing["parts"] = (max((c.seconds for c in found), default=0.0)
                       + max((r.seconds for r in done), default=0.0))
    return dec
