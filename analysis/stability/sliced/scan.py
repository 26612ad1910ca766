"""The sliced scan: one object that carries the verdict from one slice to the next.

:func:`classify_sliced` checks its options, scales K (:func:`scaled_parts`),
builds a :class:`SlicedScan` (or restores a saved one) and runs it. The scan
runs up the spectrum of the symmetric part S: it computes the next slice of
Ritz pairs (:meth:`SlicedScan.next_slice`: shift-invert Lanczos, checked by
Sylvester counts, :mod:`.slices`), tests the gaps between Ritz values whose
window lies in the slices held (:meth:`SlicedScan.gap_test`, the boundary
lemma), decides the strip between two certified boundaries
(:meth:`SlicedScan.finish_strip`, :mod:`.strips`) and, every
``checkpoint_seconds``, saves its state (:meth:`SlicedScan.save`,
:mod:`.checkpoint`). It ends at the top of the spectrum, at the first strip
certified complex (``stop_at_complex``) or at a step that cannot be
certified (its reason kept); :meth:`SlicedScan.decision` gives the verdict.
The proof: the docstring of :mod:`remote_trigger.analysis.stability.sliced`.
"""
from __future__ import annotations

import copy
import dataclasses
import functools
import math
import time

import numpy as np
import scipy.sparse as sp

from remote_trigger.analysis.errors import is_integer
from remote_trigger.analysis.stability.decision import Decision, PairDecision, SpectrumDecision
from remote_trigger.analysis.stability.enclosure import U
from remote_trigger.analysis.stability.sliced.buffer import RitzBuffer
from remote_trigger.analysis.stability.sliced.checkpoint import (
    ScanFiles, restore_ritz, scan_key)
from remote_trigger.analysis.stability.sliced.inertia import Shifts, fuzz_limit
from remote_trigger.analysis.stability.sliced.numerics import SliceFailure
from remote_trigger.analysis.stability.sliced.parts import PartsProblem, classify_parts, part_count
from remote_trigger.analysis.stability.sliced.slices import (
    ritz_slices, start_position, top_eigenvalue)
from remote_trigger.analysis.stability.sliced.stats import SlicedStats
from remote_trigger.analysis.stability.sliced.strips import (
    StripContext, arpack_hint, coupling, decide_strip, strips_decision)

__all__ = ["classify_sliced", "scaled_parts", "SlicedScan", "CHECKPOINT_SECONDS",
           ]

# largest cluster tried on the real axis (above it: the box route only); each
# real-axis evaluation of its Schur complement is a sparse LU of n + m rows,
# about m + 5 of them for a real strip (docs/results/analysis.md, "Strips of
# up to 24 on the real axis": 8 before; 4 more of 2268 points decided at
# N = 40, none contradicting the dense decision)
_MAX_STRIP = 24
# Ritz pairs per slice: the eigen-solver's work per pair grows with it
# (orthogonalization against its Lanczos vectors), the number of
# factorizations falls with it; measured at N = 6400 (n = 18 582) with ARPACK's 2k + 1
# Lanczos vectors: 40 -> 216 s, 60 -> 201 s, 85 -> 222 s, 124 -> 274 s of CPU
# (docs/results/analysis.md); with the Lanczos without restarts (.lanczos),
# 60 -> 191 s, 80 -> 186 s side by side (one profiled): kept
#: Ritz pairs per slice when ``slice_size`` is None (also the smallest
#: ``part_size``: a part holds at least one slice)
SLICE_SIZE = 60
#: seconds between two saves of a scan's state (``classify_sliced``'s
#: ``checkpoint_dir``): a save writes 2.2-16.4 MB at N = 10^4 (measured; no
#: Ritz vector: a resume computes the buffer's slices again), a scan there
#: takes 5-45 min (docs/results/analysis.md, "Checkpoint of a sliced scan")
CHECKPOINT_SECONDS = 300.0


def scaled_parts(K, mass):
    """A = M^-1/2 K M^-1/2 and its symmetric and skew parts.

    Parameters
    ----------
    K : sparse matrix or array, shape (n, n)
        Stiffness (force/length).
    mass : array_like, shape (n,)
        Diagonal of M, finite and positive.

    Returns
    -------
    A : scipy.sparse.csr_matrix
        M^-1/2 K M^-1/2, duplicates summed (1/time^2).
    S : scipy.sparse.csc_matrix
        (A + A^T) / 2.
    W : scipy.sparse.csr_matrix
        (A - A^T) / 2, explicit zeros removed.

    Raises
    ------
    ValueError
        If K is not square or not finite, or ``mass`` is not n finite
        positive values.
    """
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


class SlicedScan:
    """A scan up the spectrum of S = (A + A^T) / 2: its state and its steps.

    The state (saved at a checkpoint, :mod:`.checkpoint`): the slicing's
    position, the statistics, the buffer of Ritz pairs, the certified
    boundaries, the strips decided, the eigenvalues listed and how the scan
    ended. What a call computes from the matrix and its options (S, the
    :class:`~.strips.StripContext`, the slicing, the stop rule) is not saved:
    it is given to the constructor, or to :meth:`resumed` with a saved state.

    Parameters
    ----------
    S : scipy.sparse.csc_matrix, shape (n, n)
        The symmetric part (:func:`scaled_parts`).
    ctx : StripContext
        The boundary and strip tests' context (A, W, norms, error bounds).
    lo0 : float
        A point below the spectrum of every matrix of the set.
    slice_size : int
        Ritz pairs per slice.
    stats : SlicedStats
        Filled as the scan goes.
    stop_at_complex : bool, optional
        End at the first strip certified complex that is not soft.
    soft_below : float, optional
        A complex strip whose eigenvalue estimates all have |Re| below it is
        soft: it does not end the scan (default -inf: none is).
    t0 : float, optional
        ``time.perf_counter()`` at the start of the call (for ``timing``).

    Attributes
    ----------
    pos : Position or None
        The slicing's position (None before :meth:`start`).
    buf : RitzBuffer
        The Ritz pairs of the slices held.
    certified, cert_count : list
        The certified boundaries and the number of Ritz values below each.
    pairs : list of PairDecision
        One per strip of two or more eigenvalues.
    lam : list of complex
        The eigenvalue approximations listed so far.
    reason : str
        Why the scan failed ('' if it did not).
    scanned_below : float
        Where the scan stopped (inf: it did not stop).
    """

    # computed by each call from the matrix and the options: not saved
    _TRANSIENT = ("S", "ctx", "lo0", "k", "stop_at_complex", "soft_below", "_slices", "_t0")
    # a part of a partitioned scan (:meth:`begin_part`, :mod:`.parts`); a whole
    # scan keeps these class defaults (its saved state is unchanged)
    base = 0                    # eigenvalues of S below the scan's start
    cuts = None                 # local gap index -> a boundary certified by a part
    at_ceiling = False          # ended at the boundary of the part above
    # no run above this shift leaves its count out (a chain ends at the first
    # run past the part's ceiling or the cut's first boundary sought, so that
    # no run beyond them is made only to close a chain: ritz_slices)
    stop_above = math.inf

    def __init__(self, S, ctx, lo0, slice_size, stats, stop_at_complex=False,
                 soft_below=-math.inf, t0=None):
        n = S.shape[0]
        self._bind(S, ctx, lo0, slice_size, stop_at_complex, soft_below, t0)
        self.pos = None
        self.stats = stats
        self.buf = RitzBuffer(n)
        self.pairs, self.lam = [], []
        self.certified = []             # certified boundaries
        self.cert_count = []            # Ritz values below each
        self.n_done = 0                 # global index of the next gap to test
        self.dropped = 0                # Ritz values forgotten below the buffer
        self.margins, self.complex_margins, self.undecided_margins = [], [], []
        self.strips = {}
        self.sid = 0                    # slices added
        self.starts = {}                # slice id -> the position before it (buffered ones)
        self.t_slices = 0.0             # seconds in the slicing
        self.t_scan = 0.0               # seconds in the scan, before a resume
        self.reason = ""
        self.scanned_below = math.inf

    def _bind(self, S, ctx, lo0, slice_size, stop_at_complex, soft_below, t0):
        self.S, self.ctx, self.lo0, self.k = S, ctx, lo0, slice_size
        self.stop_at_complex, self.soft_below = stop_at_complex, soft_below
        self._t0 = time.perf_counter() if t0 is None else t0
        self._slices = None

    def __getstate__(self):
        state = self.__dict__.copy()
        for name in self._TRANSIENT:
            state.pop(name, None)
        return state

    @classmethod
    def resumed(cls, saved, S, ctx, lo0, slice_size, stats, stop_at_complex=False,
                soft_below=-math.inf, t0=None):
        """A saved scan (:meth:`.checkpoint.ScanFiles.load_scan`) made ready to go on:
        its buffer's Ritz vectors computed again (:func:`.checkpoint.restore_ritz`),
        its statistics copied into ``stats``. The other parameters as for the
        constructor, those of the call that saved it (its key). None where the
        slices computed again are not the saved ones: the scan then starts over.
        """
        t_restore = time.perf_counter()
        if not restore_ritz(saved, lambda pos: ritz_slices(S, ctx.W, slice_size, ctx.normS,
                                                           pos, SlicedStats(),
                                                           stop_above=saved.stop_above)):
            return None
        saved._bind(S, ctx, lo0, slice_size, stop_at_complex, soft_below, t0)
        saved.t_slices += time.perf_counter() - t_restore      # (slices computed again)
        for f in dataclasses.fields(saved.stats):
            setattr(stats, f.name, getattr(saved.stats, f.name))
        saved.stats = stats
        return saved

    @property
    def counted(self):
        """Eigenvalues of S below the slices computed so far (their Sylvester count)."""
        return self.base + self.dropped + self.buf.th.size

    # ----------------------------------------------------------------------- the loop
    def run(self, progress=None, files=None, checkpoint_seconds=CHECKPOINT_SECONDS):
        """Scan up to the top of the spectrum, or to the first complex strip that
        ends it (``stop_at_complex``); a step that cannot be certified ends it
        with its reason (:attr:`reason`).

        Parameters
        ----------
        progress : callable, optional
            ``progress(done, n)`` after each slice (:attr:`counted`).
        files : ScanFiles, optional
            Where to save the state, every ``checkpoint_seconds`` (after a slice).
        checkpoint_seconds : float, optional
            Seconds between two saves.
        """
        n = self.S.shape[0]
        t_saved = time.monotonic()
        try:
            shifts = None
            if self.pos is None:
                # one Shifts for the start's count and the slices: its first
                # factorization (with the ordering) made once
                shifts = Shifts(self.S, fuzz_limit(self.ctx.normS, n), self.stats)
                self.start(shifts)
            self._slices = ritz_slices(self.S, self.ctx.W, self.k, self.ctx.normS, self.pos,
                                       self.stats, shifts, self.stop_above)
            # only for n = 0 (a scan is saved before its end)
            final = self.cert_count[-1] == n - self.base
            while not final:
                final = self.next_slice()
                if progress is not None:
                    progress(self.counted, n)
                if self.test_gaps(final):
                    return                      # stopped at a complex strip
                if files is not None and not final and \
                        time.monotonic() - t_saved >= checkpoint_seconds:
                    self.save(files)
                    t_saved = time.monotonic()
            if self.cert_count[-1] != n - self.base:
                raise SliceFailure("the top of the spectrum has no certified boundary")
        except SliceFailure as exc:
            self.reason = str(exc)
            if self.complex_margins:     # the strips below the last boundary are decided
                self.scanned_below = self.certified[-1]

    def begin_part(self, pos, base, floor=None, ceiling=None):
        """Make this scan one part of a partitioned scan (:mod:`.parts`), before
        :meth:`run` or :meth:`first_boundary`.

        Parameters
        ----------
        pos : Position or None
            Where the part's slicing starts (its Sylvester count ``base``); None:
            below the spectrum (:meth:`start`, the first part).
        base : int
            Eigenvalues of S below ``pos.x`` (0 for the first part).
        floor, ceiling : (float, int), optional
            Boundaries certified by the first-boundary step of this part and of
            the part above (:meth:`first_boundary`), each with the number of
            eigenvalues of S below it. No gap at or below ``floor`` is tested
            and no strip is decided below it; the strip below ``ceiling`` ends
            there and the scan stops (:attr:`at_ceiling`). Each is checked to
            lie between the same two Ritz values of this part
            (:meth:`check_cut`).
        """
        self.pos, self.base, self.cuts = pos, base, {}
        if floor is not None:
            c, g = floor
            self.certified, self.cert_count = [c], [g - base]
            self.n_done = g - base
            self.cuts[g - base] = c
        if ceiling is not None:
            c, g = ceiling
            self.cuts[g - base] = c
            self.stop_above = c

    def check_cut(self, j, a):
        """A boundary a certified by another part, to stand as this part's boundary
        at its gap j: exactly j of this part's Ritz values lie below it (the
        eigenvalues of S below a are then base + j, and the strips on both sides
        hold as many Ritz values here as eigenvalues of A + F).

        Raises
        ------
        SliceFailure
            If a does not lie between this part's Ritz values j - 1 and j.
        """
        th, i = self.buf.th, j - self.dropped
        if not (i >= 1 and i < th.size and th[i - 1] < a < th[i]):
            raise SliceFailure(f"the boundary {a:.9g} certified by another part does not lie "
                               f"between this part's Ritz values {self.base + j - 1} and "
                               f"{self.base + j}")

    def first_boundary(self, above):
        """The first step of a part (:mod:`.parts`): scan from :attr:`pos` up to the
        first gap a >= ``above`` certified by the boundary lemma (kappa(a) < 1),
        below the top of the spectrum; no strip is decided.

        Returns
        -------
        (float, int, float) or None
            a, the eigenvalues of S below it (``base`` + its gap index) and
            kappa(a); None if the top of the spectrum comes first.

        Raises
        ------
        SliceFailure
            If a slice cannot be certified.
        """
        n = self.S.shape[0] - self.base
        self.stop_above = above
        self._slices = ritz_slices(self.S, self.ctx.W, self.k, self.ctx.normS, self.pos,
                                   self.stats, stop_above=self.stop_above)
        final = self.counted == self.S.shape[0]
        while not final:
            final = self.next_slice()
            while (gap := self.next_gap(final)) is not None:
                j, a = gap
                if j >= n or a < above:
                    continue
                kap = self.gap_test(a, final)
                if kap < 1:
                    return a, self.base + j, kap
        return None

    def start(self, shifts=None):
        """Start below the spectrum: the first boundary at ``lo0``, no eigenvalue of S
        below it (counted, by ``shifts`` if given; :class:`~.numerics.SliceFailure`
        if there is one)."""
        self.pos = start_position(self.S, self.lo0, self.stats, shifts)
        self.certified, self.cert_count = [self.pos.x], [0]

    def next_slice(self):
        """Compute the next slice of Ritz pairs (inertia counts at its edges and
        its Ritz pairs, :func:`.slices.ritz_slices`) and add it to the buffer;
        True if it is the last (every eigenvalue of S lies below it)."""
        ts = time.perf_counter()
        self.starts[self.sid] = copy.deepcopy(self.pos)
        sl = next(self._slices)
        self.t_slices += time.perf_counter() - ts
        self.buf.add(sl, self.sid)
        self.sid += 1
        return self.counted == self.S.shape[0]

    # ----------------------------------------------------------------------- gaps and strips
    def edges(self, final):
        """Below/above them the Ritz values are not in the buffer (None: no
        eigenvalue of S there)."""
        return (self.buf.lo if self.dropped or self.base else None,
                None if final else self.buf.hi)

    def next_gap(self, final):
        """The next gap to test, (j, a): a between the global Ritz values j - 1 and
        j, or above the top one for j = n; None while its window is not in the
        buffer (or every gap is tested)."""
        n, buf, Delta = self.S.shape[0] - self.base, self.buf, self.ctx.Delta
        while True:
            j = self.n_done
            if j > n:
                return None
            if j == n:
                if not final:
                    return None
                a = float(buf.th[-1]) + max(Delta, 1.0)
            else:
                if j - self.dropped >= buf.th.size:
                    return None
                if self.cuts and j in self.cuts:    # a boundary given (a part's floor or ceiling)
                    a = self.cuts[j]
                elif j == 0:             # below the first Ritz value: the start, lo0
                    self.n_done += 1
                    continue
                else:
                    a = 0.5 * (buf.th[j - 1 - self.dropped] + buf.th[j - self.dropped])
                if not final and a + Delta > buf.hi:
                    return None
            self.n_done += 1
            return j, a

    def gap_test(self, a, final):
        """kappa(a), the boundary lemma's coupling across a (inf where it cannot be
        bounded): a < 1 certifies the boundary."""
        try:
            return coupling(self.ctx, self.buf, a, a, *self.edges(final))[0]
        except SliceFailure:
            return math.inf

    def test_gaps(self, final):
        """Test every gap whose window lies in the buffer; a certified boundary
        finishes the strip below it. Then forget the slices more than two
        windows below the last boundary. True if the scan stops (at a complex
        strip)."""
        stats = self.stats
        while (gap := self.next_gap(final)) is not None:
            j, a = gap
            if self.cuts and j in self.cuts:
                self.check_cut(j, a)
                if j == self.cert_count[-1]:    # the floor: the part's first boundary
                    continue
                # the ceiling: the last strip, then the part ends
                if self.finish_strip(self.cert_count[-1], j, self.certified[-1], a, final):
                    self.scanned_below = a
                self.certified.append(a)
                self.cert_count.append(j)
                self.at_ceiling = True
                return True
            kap = self.gap_test(a, final)
            if kap < 1:
                stats.boundaries += 1
                stats.max_kappa = max(stats.max_kappa, kap)
                self.margins.append(1.0 / kap if kap > 0 else math.inf)
                if self.finish_strip(self.cert_count[-1], j, self.certified[-1], a, final):
                    self.scanned_below = a
                    return True
                self.certified.append(a)
                self.cert_count.append(j)
            if not final and len(self.certified) > 1:
                self.forget_below(self.certified[-1] - 2 * self.ctx.Delta)
        return False

    def forget_below(self, x):
        """Drop the buffer's slices whose upper edge is below x (and their start
        positions)."""
        before = self.buf.th.size
        self.buf.drop_below(x)
        self.dropped += before - self.buf.th.size
        self.starts = {e[0]: self.starts[e[0]] for e in self.buf.edges}

    def finish_strip(self, lo_idx, hi_idx, a_lo, a_hi, final):
        """Decide the strip of the global Ritz values lo_idx .. hi_idx - 1 between
        the certified boundaries a_lo and a_hi and list its eigenvalues; True if
        the scan stops at it (certified complex, not soft, ``stop_at_complex``)."""
        buf = self.buf
        m = hi_idx - lo_idx
        self.strips[m] = self.strips.get(m, 0) + 1
        I = np.arange(lo_idx, hi_idx) - self.dropped
        if m == 1:
            self.lam.append(complex(buf.th[I[0]]))
            return False
        # ARPACK's view of the strip, asked at most once: (note, complex estimates);
        # an undecided strip's reason ends with the note (decide_strip adds it)
        estimates = functools.cache(lambda: arpack_hint(self.ctx.A, a_lo, a_hi, m))
        big = m > _MAX_STRIP
        try:
            # a strip larger than a block decides: only the box route (winding)
            verdict, margin, lam_c, why = decide_strip(
                self.ctx, buf, I, a_lo, a_hi, *self.edges(final), estimates=estimates,
                real_routes=not big)
        except SliceFailure as exc:
            verdict, margin = Decision.UNDECIDED, 0.0
            why = "; ".join(w for w in (str(exc), estimates()[0]) if w)
            lam_c = buf.th[I].astype(complex)
        if big and verdict is Decision.UNDECIDED:
            lam_c = buf.th[I].astype(complex)
            why = "; ".join(w for w in (f"strip of {m} eigenvalues (> {_MAX_STRIP})", why) if w)
        self.lam.extend(lam_c)
        ok = verdict is not Decision.UNDECIDED
        self.pairs.append(PairDecision(np.sort_complex(lam_c), verdict is Decision.COMPLEX, ok,
                                       float(margin), method="sliced-strip", reason=why))
        (self.complex_margins if verdict is Decision.COMPLEX else self.margins if ok
         else self.undecided_margins).append(float(margin))
        return verdict is Decision.COMPLEX and self.stop_at_complex and not (
            np.max(np.abs(np.real(lam_c))) < self.soft_below)

    # ----------------------------------------------------------------------- checkpoint
    def save(self, files):
        """Save the state (:meth:`.checkpoint.ScanFiles.save_scan`), the seconds
        scanned so far with it."""
        t_now = time.perf_counter()
        self.t_scan += t_now - self._t0
        self._t0 = t_now
        files.save_scan(self)

    # ----------------------------------------------------------------------- the verdict
    def decision(self):
        """The SpectrumDecision of the finished (stopped, or failed) scan."""
        n = self.S.shape[0]
        timing = {"eigen": self.t_slices,
                  "decision": self.t_scan + time.perf_counter() - self._t0 - self.t_slices}
        if self.pos is None:            # no start: no count below the spectrum
            return SpectrumDecision(None, 0.0, [], 0.0, np.zeros(0, complex), timing,
                                    self.reason, start="sliced", n_total=n)
        self.stats.strips = dict(sorted(self.strips.items()))
        return strips_decision(self.S, self.ctx.eps, self.pairs, self.lam, self.margins,
                                 self.complex_margins, self.undecided_margins, self.reason,
                                 self.scanned_below, timing)


def _checked_options(rel_error, window, slice_size, checkpoint_seconds, soft_rel):
    """The options of :func:`classify_sliced`, checked; (slice_size,
    checkpoint_seconds) with their defaults."""
    # (rel_error = -1 gave a verdict with a negative backward error)
    if not (isinstance(rel_error, (int, float, np.floating)) and 0 <= rel_error < 0.01):
        raise ValueError(f"rel_error must be in [0, 0.01), got rel_error = {rel_error!r}")
    if not (isinstance(window, (int, float, np.floating)) and window > 0
            and np.isfinite(window)):
        raise ValueError(f"window must be a finite number > 0, got window = {window!r}")
    if slice_size is None:
        slice_size = SLICE_SIZE
    if not is_integer(slice_size) or \
            slice_size < 2:
        raise ValueError(f"slice_size must be an integer >= 2, got slice_size = {slice_size!r}")
    checkpoint_seconds = (CHECKPOINT_SECONDS if checkpoint_seconds is None
                          else checkpoint_seconds)
    if not (isinstance(checkpoint_seconds, (int, float, np.floating))
            and checkpoint_seconds >= 0):
        raise ValueError(f"checkpoint_seconds must be a number >= 0, got "
                         f"{checkpoint_seconds!r}")
    if soft_rel is not None and not (isinstance(soft_rel, (int, float, np.floating))
                                     and not isinstance(soft_rel, bool) and 0 <= soft_rel < 1):
        raise ValueError(f"soft_rel must be a number in [0, 1) or None, got "
                         f"soft_rel = {soft_rel!r}")
    return slice_size, float(checkpoint_seconds)


def _bottom(S, ctx, rel_error):
    """A point lo0 below the real part of every eigenvalue of every matrix of the
    set: Re <x, (S + W + F) x> >= lambda_min(S) - eps >= (Gershgorin) - eps."""
    absS = abs(S)
    gersh = float(np.min(S.diagonal() - (np.asarray(absS.sum(axis=1)).ravel()
                                         - np.abs(S.diagonal()))))
    lo0 = gersh - 1e-3 * max(ctx.normS, 1.0) - 1.0
    if not ctx.eps < gersh - lo0:
        raise ValueError(f"rel_error {rel_error!r} is too large for this matrix")
    return lo0


def _top(S, ctx):
    """A point above every eigenvalue of S (Gershgorin)."""
    absS = abs(S)
    gersh = float(np.max(S.diagonal() + (np.asarray(absS.sum(axis=1)).ravel()
                                         - np.abs(S.diagonal()))))
    return gersh + 1e-3 * max(ctx.normS, 1.0) + 1.0


def classify_sliced(K, mass, rel_error=U, window=10.0, slice_size=None, stats=None,
                    stop_at_complex=False, progress=None, checkpoint_dir=None,
                    checkpoint_seconds=None, soft_rel=None, part_size=None, map_tasks=None):
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
        last bits and the scan starts over. A file of other code (another
        :data:`~.checkpoint.CHECKPOINT_FORMAT`) or unreadable is scanned over.
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
    part_size : int, optional
        Scan in P = ceil(n / ``part_size``) parts of about ``part_size``
        eigenvalues of the symmetric part, run by ``map_tasks``
        (:mod:`.parts`; at least ``slice_size``). The partition depends on the
        matrix and ``part_size`` only, so the answer is the same, bit for bit,
        whatever runs the tasks; it is the verdict of the whole scan, its
        eigenvalues the same to within the Ritz radii, its strips cut at
        other boundaries. Default None (or P = 1): one part, the whole scan.
        With ``checkpoint_dir`` each finished task is saved
        (``sliced-<key>.task-*.pkl``, the key including ``part_size``) and a
        call again runs only the tasks not saved (:func:`.parts.classify_parts`).
    map_tasks : callable, optional
        ``map_tasks(fn, tasks)`` returning ``fn``'s results in the order of
        ``tasks`` (an iterable, read in order, perhaps not to its end:
        ``stop_at_complex``); ``fn``, the tasks and the results are picklable
        (an MPI executor sends them). Default: the builtin :func:`map` (one
        task after the other). Used with ``part_size`` only.

    Returns
    -------
    SpectrumDecision
        ``decision`` COMPLEX / REAL / UNDECIDED as the dense decision
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
        negative or not a number, ``soft_rel`` is not a number in [0, 1), or
        ``part_size`` is not an integer >= ``slice_size``.

    Notes
    -----
    Package docstring (:mod:`remote_trigger.analysis.stability.sliced`): what
    is certified and how.
    """
    t0 = time.perf_counter()
    stats = stats if stats is not None else SlicedStats()
    slice_size, checkpoint_seconds = _checked_options(rel_error, window, slice_size,
                                                      checkpoint_seconds, soft_rel)
    if part_size is not None:
        if not is_integer(part_size) or part_size < slice_size:
            raise ValueError(f"part_size must be an integer >= slice_size ({slice_size}), "
                             f"got part_size = {part_size!r}")
    if map_tasks is not None and not callable(map_tasks):
        raise ValueError(f"map_tasks must be callable, got map_tasks = {map_tasks!r}")
    if K.shape[0] == 0:
        raise ValueError("K is empty (0 x 0): no degree of freedom to decide")
    A, S, W = scaled_parts(K, mass)
    files = saved = None
    in_parts = part_size is not None and part_count(A.shape[0], part_size) > 1
    if checkpoint_dir is not None:
        files = ScanFiles(checkpoint_dir, scan_key(
            A, rel_error, window, slice_size, stop_at_complex, _MAX_STRIP,
            soft_rel if stop_at_complex else None, part_size if in_parts else None))
        done = files.load_verdict()
        if done is not None:
            dec, st = done
            for f in dataclasses.fields(st):
                setattr(stats, f.name, getattr(st, f.name))
            return dec
        saved = None if in_parts else files.load_scan()
    stats.n = A.shape[0]
    ctx = StripContext.of(A, S, W, rel_error, window)
    stats.norm_W, stats.window = ctx.normW, ctx.Delta
    lo0 = _bottom(S, ctx, rel_error)
    # the real part below which a complex strip is soft (it does not stop the scan)
    soft_below = (soft_rel * top_eigenvalue(S) if stop_at_complex and soft_rel is not None
                  else -math.inf)
    if in_parts:
        new_scan = functools.partial(SlicedScan, S, ctx, lo0, slice_size,
                                     stop_at_complex=stop_at_complex, soft_below=soft_below)
        pb = PartsProblem(S, ctx, lo0, _top(S, ctx), int(part_size), new_scan)
        dec = classify_parts(pb, stats, map_tasks, progress, files)
        if files is not None:
            files.save_verdict(dec, dataclasses.replace(stats))
        return dec
    setup = dict(S=S, ctx=ctx, lo0=lo0, slice_size=slice_size, stats=stats,
                 stop_at_complex=stop_at_complex, soft_below=soft_below, t0=t0)
    scan = SlicedScan.resumed(saved, **setup) if saved is not None else None
    if scan is None:
        scan = SlicedScan(**setup)
    scan.run(progress, files, checkpoint_seconds)
    dec = scan.decision()
    if files is not None:
        files.save_verdict(dec, dataclasses.replace(stats))
    return dec
