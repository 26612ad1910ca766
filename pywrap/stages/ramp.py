"""The ramp stage: F_x steps, the certified bracket of F_x^c and its bisection.

Part of :mod:`remote_trigger.pywrap.stages`; file layout in :mod:`.ramp_file`."""
from dataclasses import dataclass, field
import os

import numpy as np

from remote_trigger.analysis.output import bracket_text
from remote_trigger.analysis.stability.decision import Decision
from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.stages.config import RampConfig
from remote_trigger.pywrap.bindings.engine import Engine
from remote_trigger.pywrap.stages import equilibrium as eq
from remote_trigger.pywrap.stages import ramp_file
from remote_trigger.pywrap.stages.common import (
    EQUILIBRIUM_EXTS, ensure_dir, progress_bar, start_timestep)
from remote_trigger.pywrap.stages.point import ramp_point, verdict_progress


@dataclass
class RampResult:
    """Outcome of :func:`ramp`.

    Attributes
    ----------
    F_x : ndarray
        Loads of the ramp steps.
    residual : ndarray
        Residual reached at each step.
    complex_pair : ndarray of bool
        Certified complex pair (analyzer decision ``'complex'``).
    growth_rate : ndarray
        max Im sqrt(lambda) at each step (0 when stable).
    bisection_F_x, bisection_complex : ndarray
    F_x_c_low, F_x_c_high : float
        Certified bracket of F_x^c: the largest F_x certified real below the
        smallest F_x certified complex (undecided: neither); NaN if none.
    status : str
        ``'complete'``, ``'no_complex_pair'``, ``'no_equilibrium'``,
        ``'complex_at_start'`` or (``stop_after`` reached) ``'interrupted'``.
    h5 : str
    message : str
        Set when the bracket stayed wider than ``tol`` (the points next to
        F_x^c could not be certified) and for the other statuses.
    decision, confidence : ndarray
        Analyzer decision per ramp step, as the stored codes (float; the
        values of :class:`~remote_trigger.analysis.stability.decision.Decision`:
        1 complex, 0 real, -1 undecided; :attr:`decisions` gives them as
        ``Decision`` members) and its margin (> 1 certified).
    bisection_decision : ndarray
        Same for the bisection points (NaN where no equilibrium was found).
    tol_reached : bool
        The bracket is at most ``tol`` wide.
    n_undecided : int
        Equilibria (steps and bisection) the analyzer left undecided.
    n_escaped, n_saddle : int
        Points whose Newton equilibrium was a saddle and was replaced
        (``RampConfig.saddle_escape``), and points left on a saddle
        (``n_negative`` > 0); NaN rows (older files) count as 0.
    start_damped_time : float
        Damped-dynamics time the first step needed to come to rest: > 0 when
        the start file was not an equilibrium at the start load (e.g. a
        loose ``generate`` packing, settled with friction on); NaN if none.
    timestep : dict
        The time-step decision at the start (``dt_used``, ``dt_max``,
        ``dt_fraction``, ``dt_limit_source``, ``dt_auto``; also in ramp.h5).
    """

    F_x: np.ndarray
    residual: np.ndarray
    complex_pair: np.ndarray
    growth_rate: np.ndarray
    bisection_F_x: np.ndarray
    bisection_complex: np.ndarray
    F_x_c_low: float
    F_x_c_high: float
    status: str
    h5: str
    message: str = ""
    decision: np.ndarray = None
    confidence: np.ndarray = None
    bisection_decision: np.ndarray = None
    timestep: dict = field(default_factory=dict)
    tol_reached: bool = False
    n_undecided: int = 0
    n_escaped: int = 0
    n_saddle: int = 0
    start_damped_time: float = float("nan")

    @property
    def F_x_c(self):
        """Midpoint of the bracket."""
        return 0.5 * (self.F_x_c_low + self.F_x_c_high)

    @property
    def F_x_c_width(self):
        """Width of the certified bracket, F_x_c_high - F_x_c_low (NaN if none)."""
        return self.F_x_c_high - self.F_x_c_low

    @property
    def decisions(self):
        """The ramp steps' decisions as :class:`Decision` members (list, one per step)."""
        return [Decision.of(d) for d in (() if self.decision is None else self.decision)]


#: the ramp's own folder of sliced verdicts, under ``<out>/ramp`` (removed when
#: the ramp ends; ``ramp(..., verdict_dir=D)`` uses D instead)
VERDICTS = "verdicts"


def ramp_bracket(rlog):
    """The certified bracket of F_x^c from every row of a ramp (steps and bisection).

    Only certified answers count: ``hi`` is the smallest F_x certified
    complex (decision 1), ``lo`` the largest F_x certified real (decision 0)
    below it. Undecided points (decision -1) and points without an
    equilibrium (``complex`` = 2) are neither stable nor unstable.

    Returns
    -------
    lo, hi : float
        NaN where there is no such point.
    lo_file : str or None
        Data file of the ``lo`` equilibrium (start of the next bisection point).
    unknown : list of float
        Loads strictly inside (lo, hi) without a certified answer.
    """
    F, dec, files = _all_rows(rlog)
    cx = F[dec == Decision.COMPLEX]
    hi = float(cx.min()) if cx.size else float("nan")
    lo, lo_file = _highest_real_below(rlog, hi if cx.size else np.inf)
    unknown = sorted(float(f) for f, d in zip(F, dec)
                     if not (d == Decision.REAL or d == Decision.COMPLEX) and lo < f < hi)
    return lo, hi, lo_file, unknown


def _all_rows(rlog):
    """(F_x, decision, data file) of every row, steps then bisection."""
    F, dec, files = [], [], []
    for kind in ("steps", "bisection"):
        rows = rlog.rows[kind]
        F.extend(rows["F_x"])
        dec.extend(rows["decision"])
        files.extend(rlog.files[kind])
    return np.asarray(F, float), np.asarray(dec, float), files


def _highest_real_below(rlog, limit):
    """(F_x, data file) of the highest row certified real below ``limit``
    (NaN, None if none): the bracket's lower end were ``limit`` its upper."""
    F, dec, files = _all_rows(rlog)
    real = np.flatnonzero((dec == Decision.REAL) & (F < limit))
    if not real.size:
        return float("nan"), None
    k = int(real[np.argmax(F[real])])
    return float(F[k]), files[k]


def next_bisection_point(lo, hi, unknown, tol):
    """Next load to decide inside the certified bracket, or why there is none.

    Without undecided points inside, the midpoint. With some, they are
    taken to mark the exceptional point's neighbourhood: the larger of the
    two uncertified gaps [lo, min(unknown)] and [max(unknown), hi] is
    halved, until both are at most tol/2.

    Returns
    -------
    F : float or None
    why : str
        ``''`` (F given), ``'tol'`` (hi - lo <= tol), ``'undecided'`` (no
        gap wider than tol/2 is left beside the undecided points) or
        ``'resolution'`` (no float64 number strictly inside the gap).
    """
    if hi - lo <= tol:
        return None, "tol"
    if unknown:
        g_lo, g_hi = unknown[0] - lo, hi - unknown[-1]
        if max(g_lo, g_hi) <= 0.5 * tol:
            return None, "undecided"
        a, b = (lo, unknown[0]) if g_lo >= g_hi else (unknown[-1], hi)
    else:
        a, b = lo, hi
    mid = 0.5 * (a + b)
    if not a < mid < b:
        return None, "resolution"
    return mid, ""


def _n_undecided(rlog):
    return int(sum(np.count_nonzero(np.asarray(rlog.rows[k]["decision"], float)
                                    == Decision.UNDECIDED) for k in ("steps", "bisection")))


def _open_bracket_attrs(rlog):
    """ramp.h5 attributes of a ramp that ends without a bracket (no complex
    point, no equilibrium, complex at the start): the same keys as a complete
    ramp's, NaN for an end it has not got, ``tol_reached`` False."""
    lo, hi, _, _ = ramp_bracket(rlog)
    return dict(F_x_c_low=lo, F_x_c_high=hi, F_x_c_width=hi - lo, tol_reached=False,
                n_undecided=_n_undecided(rlog))


def _bracket_attrs(rlog, lo, hi, tol, why=""):
    """ramp.h5 attributes of the certified bracket; a message when it is wider than tol."""
    n_und = _n_undecided(rlog)
    width = hi - lo
    attrs = dict(F_x_c_low=lo, F_x_c_high=hi, F_x_c_width=width,
                 tol_reached=bool(width <= tol), n_undecided=n_und)
    if why in ("undecided", "resolution"):
        _, _, _, unknown = ramp_bracket(rlog)
        said = list(ramp_file.undecided_reasons(rlog.attrs).values())
        cause = (f"{n_und} undecided point(s), the last reason given: {said[-1]}; each in "
                 "ramp.h5 undecided_reasons" if said else "closer to the exceptional point "
                 "than the float64 matrix resolves, or no equilibrium")
        zone = (f"the loads in [{unknown[0]:.10g}, {unknown[-1]:.10g}] could not be "
                f"certified ({cause})" if unknown else
                "no float64 load is left strictly inside the bracket")
        attrs["message"] = (f"bisection stopped at width {width:.3g} > tol = {tol:.3g}: "
                            f"{zone}; F_x^c is certified only to [{lo:.10g}, {hi:.10g}]")
    return attrs


def ramp(cfg, out, comm=None, quiet=False, resume=False, log="none", stop_after=None,
         verdict_dir=None):
    """Ramp F_x until a complex eigenvalue pair appears, then bisect F_x^c.

    Step k has F_x = cfg.F_x + k dF_x (k = 0 re-equilibrates the data file at
    cfg.F_x), or, with ``cfg.dF_x_max`` set, an adaptive step
    (:func:`next_step`). Each step starts from the previous equilibrium's data file,
    equilibrates (Newton first, damped dynamics if needed), writes
    ``ramp/step_NNNNN.*`` and is analysed (:mod:`remote_trigger.analysis.stability.verdict`) until a step is
    certified complex.

    "Complex" and "real" are the analyzer's certified decisions; an
    ``'undecided'`` point is neither (recorded with ``decision`` = -1 and its
    margin). The bracket of F_x^c is [largest load certified real, smallest
    load certified complex] (:func:`ramp_bracket`); bisection works inside
    it, each point starting from the ``lo`` equilibrium
    (:func:`next_bisection_point`), until it is at most ``cfg.tol`` wide or
    no further point can be certified next to the undecided ones. Then the
    ramp is ``'complete'`` with ``tol_reached`` False and a message giving the
    width reached; nothing narrower than what was certified is reported.
    A bisection point without an equilibrium is no answer either.

    With ``cfg.between`` = m > 1, before the bisection, m - 1 loads evenly
    spaced between every two consecutive steps below the first certified
    complex step, the lower one certified real, are decided too
    (:func:`between_loads`; recorded as bisection points, each from the
    lower step's equilibrium, lowest first): a complex window narrower than
    a step is then looked for at the resolution dF_x / m. The first
    complex one ends the check, and the bracket and the bisection move to it.

    Parameters
    ----------
    cfg : RampConfig
    out : str
        Output folder (``ramp.h5``, ``ramp/``).
    comm : mpi4py communicator, optional
    quiet : bool
    resume : bool
        Continue an interrupted ramp from its last completed equilibrium; the
        configuration must be the same. Without ``resume`` an existing
        ``ramp.h5`` is an error (nothing is overwritten).
    log : str
        LAMMPS log file.
    stop_after : int, optional
        Testing aid: return (status ``'interrupted'``) after this many new
        equilibria, as if killed.
    verdict_dir : str, optional
        Where a sliced verdict saves its scan (every 5 min) and its verdict
        (``ramp_point``'s ``checkpoint_dir``). Default ``<out>/ramp/verdicts``,
        removed when the ramp ends; a folder given is left to the caller.

    Returns
    -------
    RampResult

    Raises
    ------
    ConfigError
        Bad configuration, ``ramp.h5`` exists without ``resume``, or the file
        to resume is unreadable or from another configuration.
    """
    if not isinstance(cfg, RampConfig):
        raise ConfigError(f"ramp needs a RampConfig, got {type(cfg).__name__}")
    h5 = os.path.join(out, "ramp.h5")
    folder = os.path.join(out, "ramp")
    with Engine(comm=comm, log=log) as eng:
        rlog = ramp_file.open_ramp_log(eng, cfg, out, h5, resume)
        _BASES.clear()
        rcfg, dtinfo = start_timestep(eng, cfg, cfg.datafile, cfg.F_x, "ramp")
        ensure_dir(eng, folder)        # after the refusals of the start (dt)
        dim = eng.dimension             # of the start file, whose scene is loaded
        if "dt_used" in rlog.attrs and cfg.dt == "auto":   # resume: the same step
            rcfg = cfg.replace(dt=float(rlog.attrs["dt_used"]))
            dtinfo.update(dt_used=rcfg.dt, dt_fraction=rcfg.dt / dtinfo["dt_max"])
        rlog.attrs.update(dtinfo)
        status = getattr(rlog, "status", "running")
        if status in ("complete", "no_complex_pair", "no_equilibrium", "complex_at_start"):
            return _ramp_result(rlog, status)
        budget = _Budget(stop_after)
        bar = progress_bar(None, "ramp", quiet, eng.rank, unit=" points")
        vdir = verdict_dir or os.path.join(folder, VERDICTS)
        try:
            ended = _ramp_steps(eng, cfg, rcfg, rlog, folder, bar, budget, dim, vdir)
            if ended is None and cfg.between > 1:
                ended = _between(eng, cfg, rcfg, rlog, folder, bar, budget, dim, vdir)
            if ended is not None:
                return ended
            return _bisect(eng, cfg, rcfg, rlog, folder, bar, budget, dim, vdir)
        finally:
            bar.close()
            if rlog.dirty:
                # rows since the last checkpoint (interrupted, or an error)
                _checkpoint(eng, rlog, folder, "running", force=True)


class _Budget:
    """New equilibria of this call, against ``stop_after`` (testing aid)."""

    def __init__(self, stop_after):
        self.stop_after, self.new = stop_after, 0

    def spend(self):
        """Count one equilibrium; True when the budget is used up."""
        self.new += 1
        return self.stop_after is not None and self.new >= self.stop_after


#: the adaptive ramp steps by this fraction of the predicted distance to the
#: nearest coalescence (the prediction is exact for the square-root law and
#: an underestimate for gaps closing faster, see analysis.eigtrack)
ADAPTIVE_SAFETY = 0.5


def next_step(cfg, rlog):
    """Load of the next ramp step, from the steps recorded so far.

    Fixed steps (``cfg.dF_x_max`` None): F_x + k dF_x for step k. Adaptive
    ramp: steps 0 and 1 as fixed, then :func:`adaptive_step` from the last
    two steps. The choice depends only on recorded rows, so a resumed ramp
    takes the same loads.

    Parameters
    ----------
    cfg : RampConfig
    rlog : ramp_file.RampLog

    Returns
    -------
    float
    """
    steps = rlog.rows[ramp_file.STEPS]
    k = len(steps["F_x"])
    if cfg.dF_x_max is None or k < 2:
        return cfg.F_x + k * cfg.dF_x
    prev, last = ((steps["F_x"][j], steps["decision"][j],
                   rlog.eig[f"{ramp_file.STEPS}/{ramp_file.point_name(ramp_file.STEPS, j)}"])
                  for j in (k - 2, k - 1))
    return last[0] + adaptive_step(cfg.dF_x, cfg.dF_x_max, prev, last)


def adaptive_step(dF_x, dF_x_max, prev, last):
    """Step of the adaptive ramp after two analysed loads.

    If both loads were certified real (decision 0), with real spectra (not so
    with a soft pair, ``pairs`` = 'collective') of the same size, ``ADAPTIVE_SAFETY`` x the distance to the nearest coalescence
    predicted from them
    (:func:`remote_trigger.analysis.stability.eigtrack.predict_coalescence`), clipped
    to [dF_x, dF_x_max]; otherwise dF_x.

    Parameters
    ----------
    dF_x, dF_x_max : float
        Smallest and largest step.
    prev, last : tuple (F_x, decision, eigenvalues)
        The two loads, ``prev[0] < last[0]``.

    Returns
    -------
    float
    """
    from remote_trigger.analysis.stability.eigtrack import predict_coalescence

    if not (prev[1] == 0 and last[1] == 0) or np.any(np.imag(prev[2])) or \
            np.any(np.imag(last[2])):
        return dF_x
    try:
        d, _ = predict_coalescence(prev[0], prev[2], last[0], last[2])
    except ValueError:          # rattlers changed: no matching of neighbours
        return dF_x
    return min(max(ADAPTIVE_SAFETY * d, dF_x), dF_x_max)


def _ramp_steps(eng, cfg, rcfg, rlog, folder, bar, budget, dim=2, vdir=None):
    """The ramp: steps of dF_x until one is certified complex.

    Returns the :class:`RampResult` of a ramp that ends here (no complex pair up to
    F_x_max, no equilibrium, complex at the start, interrupted), or None: bisection."""
    steps = rlog.rows["steps"]
    k0 = len(steps["F_x"]) - 1
    basis = _load_basis(eng, rlog.files["steps"][k0] if k0 >= 0 else None)
    while not (steps["complex"] and steps["complex"][-1] > 0):
        k = len(steps["F_x"])
        F = next_step(cfg, rlog)
        if F > cfg.F_x_max:
            n_und = int(np.count_nonzero(np.asarray(steps["decision"], float) == Decision.UNDECIDED))
            und = f" ({n_und} undecided)" if n_und else ""
            rlog.attrs["message"] = (
                f"no complex pair certified at the {k} ramp point(s) from F_x = {steps['F_x'][0]:.10g}"
                f" to {steps['F_x'][-1]:.10g}{und}; the next step, {F:.10g}, passes F_x_max = "
                f"{cfg.F_x_max}")
            rlog.attrs.update(_open_bracket_attrs(rlog))
            _checkpoint(eng, rlog, folder, "no_complex_pair")
            return _ramp_result(rlog, "no_complex_pair")
        start = cfg.datafile if k == 0 else rlog.files["steps"][-1]
        name = ramp_file.point_name(ramp_file.STEPS, k)
        prefix = os.path.join(folder, name)
        try:
            vals, res = ramp_point(eng, rcfg, start, F, prefix, basis, dim,
                                   verdict_progress(bar, F), vdir)
        except eq.NoEquilibriumError as exc:
            rlog.attrs["message"] = str(exc)
            rlog.attrs.update(_open_bracket_attrs(rlog))
            _checkpoint(eng, rlog, folder, "no_equilibrium")
            return _ramp_result(rlog, "no_equilibrium")
        basis = res.basis
        rlog.add(ramp_file.STEPS, name, prefix + ".data", vals, res.eigenvalues, res.reason)
        _remember(eng, rlog, prefix + ".data", basis)
        _checkpoint(eng, rlog, folder, "running")
        bar.update(1)
        bar.set_postfix_str(f"F_x {F:.6g} r {vals['residual']:.1e} "
                            f"complex {bool(vals['complex'])}")
        if budget.spend():
            return _ramp_result(rlog, "interrupted")
    lo, hi, lo_file, unknown = ramp_bracket(rlog)
    if lo_file is None:
        rlog.attrs["message"] = (
            "complex pair already at the start value of F_x" if len(steps["F_x"]) == 1
            else f"no equilibrium certified real below the first certified complex "
                 f"one (F_x = {hi:.10g}); the steps before it are undecided")
        rlog.attrs.update(_open_bracket_attrs(rlog))
        _checkpoint(eng, rlog, folder, "complex_at_start")
        return _ramp_result(rlog, "complex_at_start")
    return None


def between_loads(rlog, m):
    """The loads the check between steps decides (``RampConfig.between`` = m), in order.

    For every two consecutive steps F_k < F_{k+1} whose lower one is certified
    real and whose upper one is at or below the first step certified complex
    (every step so far while there is none), the m - 1 loads F_k + j (F_{k+1}
    - F_k) / m, j = 1 .. m - 1, each with the data file of step k (its
    start), lowest first. The list depends only on the recorded steps, so a
    resumed ramp takes the same loads.

    Parameters
    ----------
    rlog : ramp_file.RampLog
    m : int
        Subintervals per step, >= 1 (1: none).

    Returns
    -------
    list of (float, str)
        (F_x, start data file).
    """
    steps = rlog.rows[ramp_file.STEPS]
    F, dec, files = steps["F_x"], steps["decision"], rlog.files[ramp_file.STEPS]
    out = []
    for k in range(len(F) - 1):
        if dec[k] != Decision.REAL:
            continue
        a, b = float(F[k]), float(F[k + 1])
        out += [(a + j * (b - a) / m, files[k]) for j in range(1, m)]
        if dec[k + 1] == Decision.COMPLEX:
            break
    return out


def _between_pending(rlog, m):
    """(F_x, start) of :func:`between_loads` not yet recorded and below the
    bracket's upper end (all of them before a complex load is recorded)."""
    hi = ramp_bracket(rlog)[1]
    done = set(float(f) for f in rlog.rows[ramp_file.BISECTION]["F_x"])
    return [(F, f) for F, f in between_loads(rlog, m)
            if F not in done and not F >= hi]


def _between(eng, cfg, rcfg, rlog, folder, bar, budget, dim=2, vdir=None):
    """The check between steps (``cfg.between`` > 1): the loads of
    :func:`between_loads` below the bracket's upper end, lowest first, until
    one is certified complex. Returns a :class:`RampResult` where the ramp
    ends here (interrupted), else None: the bisection follows."""
    while True:
        todo = _between_pending(rlog, cfg.between)
        if not todo:
            return None
        F, start = todo[0]
        # (no start basis: the same numbers whether or not the ramp was resumed)
        vals, _, _ = _bisection_point(eng, cfg, rcfg, rlog, folder, bar, dim, vdir, start, F,
                                      None)
        bar.set_postfix_str(f"between steps: F_x {F:.6g} complex {bool(vals['complex'] == 1)}")
        if budget.spend():
            return _ramp_result(rlog, "interrupted")


def _bisection_point(eng, cfg, rcfg, rlog, folder, bar, dim, vdir, start, F, basis):
    """One point of the bisection table (a bisection point, or a load between
    steps): equilibrium at F from ``start``, decision from ``basis``, the row
    recorded and checkpointed; a point without an equilibrium is no answer.
    Returns (the row's values, the bracket's lo, hi)."""
    name = ramp_file.point_name(ramp_file.BISECTION, len(rlog.rows[ramp_file.BISECTION]["F_x"]))
    prefix = os.path.join(folder, name)
    try:
        vals, res = ramp_point(eng, rcfg, start, F, prefix, basis, dim,
                               verdict_progress(bar, F), vdir)
    except eq.NoEquilibriumError:
        vals = {c: np.nan for c in ramp_file.COLUMNS}
        vals.update(F_x=F, complex=2.0)         # no equilibrium: no answer
        res = None
    rlog.add(ramp_file.BISECTION, name, prefix + ".data", vals,
             [] if res is None else res.eigenvalues, "" if res is None else res.reason)
    _remember(eng, rlog, prefix + ".data", None if res is None else res.basis)
    lo, hi, _, _ = ramp_bracket(rlog)
    rlog.attrs.update(_bracket_attrs(rlog, lo, hi, cfg.tol))
    _checkpoint(eng, rlog, folder, "running")
    bar.update(1)
    return vals, lo, hi


def _bisect(eng, cfg, rcfg, rlog, folder, bar, budget, dim=2, vdir=None):
    """Bisection of F_x^c on certified answers only (docs/driver.md); returns the
    :class:`RampResult` (``'complete'``, or ``'interrupted'``)."""
    while True:
        lo, hi, lo_file, unknown = ramp_bracket(rlog)
        mid, why = next_bisection_point(lo, hi, unknown, cfg.tol)
        if mid is None:
            break
        _, lo, hi = _bisection_point(eng, cfg, rcfg, rlog, folder, bar, dim, vdir, lo_file, mid,
                                     _load_basis(eng, lo_file))
        bar.set_postfix_str(f"F_x^c in {bracket_text(lo, hi, 9)}")
        if budget.spend():
            return _ramp_result(rlog, "interrupted")
    rlog.attrs.update(_bracket_attrs(rlog, lo, hi, cfg.tol, why))
    _checkpoint(eng, rlog, folder, "complete")
    return _ramp_result(rlog, "complete")


# --------------------------------------------------------------------------- spectrum bases
# Each ramp step's certified decision starts from the previous step's
# verified basis, each bisection point's from the basis of its start (the
# bracket's lower end) (analysis.exceptional.classify_spectrum(basis=));
# which basis it started from changes its margins and the last bits of its
# eigenvalues (which the adaptive ramp's next load depends on). Rank 0 keeps
# in memory the bases of the points a later point can start from (the last
# step's and the lower end's). So that a resumed ramp takes the same loads
# and stores the same numbers, at each checkpoint the bases of the starts of
# the rows about to be written are saved beside their equilibria
# (``<point>.basis.npz``, atomically) before ramp.h5 is, and every other
# saved basis is removed after it; all are removed when the ramp ends.
# --resume reads its starts' bases from those files: X as saved and R
# recomputed by the same inversion the verification made, so the numbers
# are those of the uninterrupted run (a missing file -- a ramp.h5 of an
# older version -- only means that decision starts from dgeev). Between
# checkpoints nothing is written: a basis at N = 100 is 0.6 MB, one per
# point would be ~20 MB/s.
#: rank 0: datafile -> verified basis of the points that can start a later one
_BASES = {}


def _basis_path(datafile):
    return datafile[:-len(".data")] + ".basis.npz"


def _starts(rlog):
    """Data files of the recorded points a later point can start from with its
    basis (the checks between steps start from theirs without one)."""
    files = rlog.files[ramp_file.STEPS]
    lo_file = ramp_bracket(rlog)[2]
    return {f for f in ([files[-1]] if files else []) + [lo_file] if f}


def _prune_equilibria(rlog):
    """Remove the equilibrium files of the recorded points except the starts
    (:func:`_starts`; with ``between`` > 1 also those of the loads between
    steps still to decide, and the highest point certified real below the
    next of them, the bracket's lower end should that one be complex) and
    the bracket's upper end (the smallest load certified complex); files
    already gone are skipped."""
    keep, hi = _starts(rlog), ramp_bracket(rlog)[1]
    if rlog.cfg.between > 1:          # the starts of the loads between steps still to decide
        pending = _between_pending(rlog, rlog.cfg.between)
        keep |= {f for _, f in pending}
        if pending:
            # should the next one be complex, the bracket's lower end is the
            # highest load certified real below it, which may be a load between
            keep.add(_highest_real_below(rlog, pending[0][0])[1])
    for kind in (ramp_file.STEPS, ramp_file.BISECTION):
        rows = rlog.rows[kind]
        for F, d, f in zip(rows["F_x"], rows["decision"], rlog.files[kind]):
            if f in keep or (d == Decision.COMPLEX and F == hi):
                continue
            for ext in EQUILIBRIUM_EXTS:
                try:
                    os.remove(f[:-len(".data")] + ext)
                except FileNotFoundError:
                    pass


def _remember(eng, rlog, datafile, basis):
    """Rank 0, once the point of ``datafile`` is recorded: keep its basis if it
    can start a later point, forget those that no longer can."""
    if eng.rank != 0:
        return
    if basis is not None:
        _BASES[datafile] = basis
    keep = _starts(rlog)
    for f in [f for f in _BASES if f not in keep]:
        del _BASES[f]


def _checkpoint(eng, rlog, folder, status, force=False):
    """Rank 0: ramp.h5 brought up to date (``rlog.write``: at a checkpoint, or
    ``force``), the bases of its start points saved just before it, the other
    saved bases removed after it (all of them for a final status), and, with
    ``keep_equilibria`` False, the equilibria no longer needed
    (:func:`_prune_equilibria`), also only once ramp.h5 names every row; at a
    final status the ramp's own saved verdicts (``ramp/verdicts``) go too."""
    import glob
    import shutil
    from remote_trigger.analysis.output import atomic_path

    if eng.rank != 0:
        return
    final = status != "running"
    keep = set() if final else {_basis_path(f) for f in _starts(rlog)}

    def save():
        for f in _starts(rlog):
            if f in _BASES:
                with atomic_path(_basis_path(f)) as tmp:
                    _BASES[f].save(tmp)

    rlog.write(status, force=force, before=None if final else save)
    if final:
        shutil.rmtree(os.path.join(folder, VERDICTS), ignore_errors=True)
    if final or not rlog.dirty:         # the file on disk names only these starts
        for path in glob.glob(os.path.join(folder, "*.basis.npz")):
            if path not in keep:
                os.remove(path)
        if not rlog.cfg.keep_equilibria:
            _prune_equilibria(rlog)


def _load_basis(eng, datafile):
    """Rank 0: the basis of the point of ``datafile`` -- from memory, or (after
    --resume) from its saved file; None if neither has it, the file is
    unreadable, or on the other ranks."""
    from remote_trigger.analysis.stability.decision import SpectrumBasis

    if eng.rank != 0 or datafile is None:
        return None
    if datafile not in _BASES:
        try:
            _BASES[datafile] = SpectrumBasis.load(_basis_path(datafile))
        except ValueError:          # absent or unreadable (named in the message)
            return None
    return _BASES[datafile]


def _ramp_result(rlog, status):
    s, b = rlog.rows["steps"], rlog.rows["bisection"]

    def count(col, test):
        return int(sum(np.count_nonzero(test(np.asarray(rlog.rows[k][col], float)))
                       for k in ("steps", "bisection")))

    return RampResult(
        F_x=np.asarray(s["F_x"]), residual=np.asarray(s["residual"]),
        complex_pair=np.asarray(s["complex"]) > 0, growth_rate=np.asarray(s["growth_rate"]),
        bisection_F_x=np.asarray(b["F_x"]), bisection_complex=np.asarray(b["complex"]) == 1,
        F_x_c_low=float(rlog.attrs.get("F_x_c_low", np.nan)),
        F_x_c_high=float(rlog.attrs.get("F_x_c_high", np.nan)), status=status,
        h5=rlog.path, message=str(rlog.attrs.get("message", "")),
        decision=np.asarray(s["decision"]), confidence=np.asarray(s["confidence"]),
        bisection_decision=np.asarray(b["decision"]),
        timestep={k: v for k, v in rlog.attrs.items() if k.startswith("dt_")},
        tol_reached=bool(rlog.attrs.get("tol_reached", False)),
        n_undecided=count("decision", lambda d: d == Decision.UNDECIDED),
        n_escaped=count("saddle_escaped", lambda e: e > 0),
        n_saddle=count("n_negative", lambda m: m > 0),
        start_damped_time=float(s["damped_time"][0]) if len(s["damped_time"]) else np.nan)


# --------------------------------------------------------------------------- undamped
