"""Time series of undamped runs: noise level, exponential growth, boundedness, triggering.

LAMMPS-free: every function takes plain arrays (the records of a run, as
written by the driver in ``perturb_*.h5`` / ``instability.h5``: time ``t``,
MSD ``D`` (paper Eq. 8), mean x-velocity of the top line ``v_top`` and the
friction coefficient in force ``mu``). The definitions are those of
docs/paper.md ("Fig. 5: criteria") and are used by the paper report, the
trigger map and the driver alike (one implementation).
"""
import math

import numpy as np

from remote_trigger.analysis.errors import is_real

#: default runaway level of D (sigma^2): the disks have moved by ~0.03 sigma rms,
#: ~50x the typical contact overlap (F_y / k_n)^(2/3) ~ 6e-4 of the default
#: model: the linear regime is left (docs/paper.md)
D_RUNAWAY = 1e-3


def noise_level(t, D, frac=0.05):
    """Median of D over the first ``frac`` of the records with t > 0 and D > 0.

    Parameters
    ----------
    t, D : array_like, shape (n,)
    frac : float
        Fraction of the records (at least 3) used, in (0, 1].

    Returns
    -------
    float
        NaN when no record has D > 0.

    Raises
    ------
    ValueError
        t and D not 1-D arrays of one length, not finite, or t not
        increasing; ``frac`` not in (0, 1].
    """
    _check_series("noise_level", t, D=D)
    if not is_real(frac) or not 0.0 < frac <= 1.0:
        raise ValueError(f"noise_level: frac must be a number in (0, 1], got frac = {frac!r}")
    sel = (np.asarray(t) > 0) & (np.asarray(D) > 0)
    d = np.asarray(D)[sel]
    if d.size == 0:
        return float("nan")
    return float(np.median(d[:max(3, int(frac * d.size))]))


def exp_rate(t, D, mask=None, min_records=5):
    """Growth rate g of D ~ e^{2 g t}: least-squares slope of ln D over t, halved.

    The one fit of a growth rate in the project (:func:`growth_window`, the
    saturation test of the report and the accuracy study's time-step sweep
    use it).

    Parameters
    ----------
    t, D : array_like, shape (n,)
        Times and MSD (Eq. 8).
    mask : array_like of bool, shape (n,), optional
        Records to fit (default all); records with D <= 0 are left out.
    min_records : int
        Fewer records give NaN.

    Returns
    -------
    float
        g (1/time), or NaN.

    Raises
    ------
    ValueError
        t, D and mask not 1-D arrays of one length, not finite; t not increasing; mask not bool.
    """
    if mask is not None and np.asarray(mask).dtype != bool:
        raise ValueError(f"exp_rate: mask must be an array of bool (the records to fit), got "
                         f"dtype {np.asarray(mask).dtype}")
    t, D = _check_series("exp_rate", t, D=D, **({} if mask is None else {"mask": mask}))[:2]
    sel = D > 0 if mask is None else np.asarray(mask, bool) & (D > 0)
    if np.count_nonzero(sel) < min_records:
        return float("nan")
    return float(np.polyfit(t[sel], np.log(D[sel]), 1)[0] / 2.0)


def growth_window(t, D, noise, lo=1e3, hi=1e-3, start=0, chunks=8, rtol=0.05):
    """Exponential stretch of an MSD series and its growth rate g (D ~ e^{2 g t}).

    The window runs from the first record (at or after index ``start``) with
    D > lo x noise to the first later record with D > hi x max D (the growth
    before the final saturation; later records can fall and rise again), and
    ends earlier at the first departure from a constant rate: the window is
    cut into ``chunks`` pieces of equal duration, each piece's rate is
    fitted, and the window ends before the first piece whose rate differs by
    more than ``rtol`` from the median rate of the pieces before it (an
    earlier, weaker nonlinearity -- e.g. a contact reaching its Coulomb limit
    -- bends the growth long before the final saturation: measured on the
    default job's Fig. 4 run, rate 0.0162 over t = 450-1200, then 0.011 and
    0.005 from D ~ 1e-12 on, while max D / 10^3 = 4e-8). The cut uses the
    data only, never a predicted rate. g is the least-squares slope of
    ln D / 2 over the (cut) window. No cut is made when a piece would span
    less than a decade of D on average (the rate of a short piece is
    dominated by the oscillation of D at the pair's frequency: on the
    default job's Fig. 5 (c) window, 3 decades in 64 time units, pieces of
    8 records scatter by 50 %) or holds fewer than 3 records.

    Parameters
    ----------
    t, D : array_like, shape (n,)
    noise : float
        Reference level (e.g. :func:`noise_level`).
    lo, hi : float
        Relative levels of the window's ends.
    start : int
        First record allowed in the window.

    Returns
    -------
    ((i0, i1), g) or (None, nan)
        With fewer than 5 records in the window: ``(None, nan)``.

    Raises
    ------
    ValueError
        t and D not 1-D arrays of one length, not finite, or t not increasing.
    """
    t, D = _check_series("growth_window", t, D=D)
    if not (noise > 0) or D.size == 0:
        return None, float("nan")
    idx = np.arange(D.size)
    above = np.flatnonzero((D > lo * noise) & (idx >= start))
    top = np.flatnonzero((D > hi * np.max(D)) & (idx >= start))
    if above.size == 0 or top.size == 0:
        return None, float("nan")
    i0 = int(above[0])
    later = top[top >= i0]
    if later.size == 0:
        return None, float("nan")
    i1 = int(later[0])
    if i1 - i0 < 4:
        return None, float("nan")
    i1 = _constant_rate_end(t, D, i0, i1, chunks, rtol)
    if i1 - i0 < 4:
        return None, float("nan")
    g = exp_rate(t, D, (idx >= i0) & (idx <= i1))
    return (i0, i1), g


def below_exponential(t, D, window, g, tail=0.1):
    """Decades by which D over the end of a run stays below the window's exponential.

    The exponential of the growth window (:func:`growth_window`), D[i1]
    e^{2 g (t - t[i1])} from its last record i1, extrapolated to the last
    record, over the largest D in the last ``tail`` fraction of the records:
    ~0 while D still grows at the rate g, large once the growth has
    saturated, whatever D does inside the tail (a late slip event).

    Parameters
    ----------
    t, D : array_like, shape (n,)
    window : tuple (i0, i1) or None
    g : float
        Growth rate of the window (D ~ e^{2 g t}).
    tail : float

    Returns
    -------
    float
        log10(extrapolated D / max D of the tail); NaN without a window.

    Raises
    ------
    ValueError
        t and D not 1-D arrays of one length, not finite, or t not increasing.
    """
    t, D = _check_series("below_exponential", t, D=D)
    if window is None or not np.isfinite(g) or D.size == 0:
        return float("nan")
    i1 = window[1]
    ext = np.log10(D[i1]) + 2.0 * g * (t[-1] - t[i1]) / np.log(10.0)
    last = D[int((1.0 - tail) * D.size):]
    return float(ext - np.log10(np.max(last)))


def first_crossing(t, x, level):
    """Time of the first record with x > level (NaN if none).

    Parameters
    ----------
    t, x : array_like, shape (n,)
    level : float

    Raises
    ------
    ValueError
        t and x not 1-D arrays of one length, not finite, or t not increasing.
    """
    _check_series("first_crossing", t, x=x)
    i = np.flatnonzero(np.asarray(x) > level)
    return float(np.asarray(t)[i[0]]) if i.size else float("nan")


def friction_switch_time(t, mu, mu0):
    """First record time with mu < mu0 (mu(v) switched on), NaN if never.

    A relative tolerance of 1e-12 separates a switched-on law from mu0.

    Raises
    ------
    ValueError
        t and mu not 1-D arrays of one length, not finite, or t not increasing.
    """
    _check_series("friction_switch_time", t, mu=mu)
    i = np.flatnonzero(np.asarray(mu) < mu0 * (1 - 1e-12))
    return float(np.asarray(t)[i[0]]) if i.size else float("nan")


def settle_index(t, mu, target, tol=0.01, span=50.0):
    """First record from which the friction has settled at ``target``.

    mu(v) is evaluated at the instantaneous top-line velocity, which crosses
    zero twice per oscillation, so single records scatter up to mu0; the
    friction counts as settled from the first record i such that the median
    of mu over the records in [t_i, t_i + span] is within ``tol`` of
    ``target`` (absolute).

    Parameters
    ----------
    t, mu : array_like, shape (n,)
    target : float
        e.g. mu_ss mu0.
    tol : float
    span : float
        Length of the median window (time).

    Returns
    -------
    int or None
        None if the friction never settles.

    Raises
    ------
    ValueError
        t and mu not 1-D arrays of one length, not finite, or t not increasing.
    """
    t, mu = _check_series("settle_index", t, mu=mu)
    j = np.searchsorted(t, t + span, side="right")
    for i in range(t.size):
        if j[i] - i < 3:
            break
        if abs(float(np.median(mu[i:j[i]])) - target) <= tol:
            return i
    return None


def growth_over(t, D, t0, t1):
    """Decades of growth of the running maximum of D from [t0, t0 + w] to [t1 - w, t1].

    ``w = (t1 - t0) / 4``. D oscillates, so the maxima over the first and
    last quarter of the interval are compared: log10(max D late / max D
    early). A bounded (forced or free) oscillation gives ~0; an exponential
    instability at rate g gives ~ 2 g (t1 - t0) (3/4) / ln 10.

    Returns
    -------
    float
        NaN if a quarter holds no positive D.

    Raises
    ------
    ValueError
        t and D not 1-D arrays of one length, not finite, or t not increasing.
    """
    t, D = _check_series("growth_over", t, D=D)
    w = (t1 - t0) / 4.0
    early = D[(t >= t0) & (t <= t0 + w) & (D > 0)]
    late = D[(t >= t1 - w) & (t <= t1) & (D > 0)]
    if early.size == 0 or late.size == 0:
        return float("nan")
    return float(math.log10(late.max() / early.max()))


def decades_above(x, level):
    """log10(max |x| / level); NaN if level is not positive."""
    x = np.abs(np.asarray(x, float))
    if not (level > 0) or x.size == 0:
        return float("nan")
    return float(math.log10(max(float(x.max()), 1e-300) / level))


def quasi_static_velocity(t, a, omega_p, C, t_on=0.0):
    """Velocity of the top line following f(t) quasi-statically: d/dt [C f(t)].

    f(t) = a e(t) cos(omega_p t) with e the onset envelope (1 for a step,
    the raised cosine (1 - cos(pi t/t_on))/2 for t < t_on). C = d<x_top>/dF_x
    is the static compliance of the top line (length/force). Valid for
    omega_p far below the packing's natural frequencies (off resonance).

    Parameters
    ----------
    t : array_like
    a, omega_p, C, t_on : float

    Returns
    -------
    ndarray
        Same shape as t (length/time).
    """
    t = np.asarray(t, float)
    if t_on > 0:
        e = np.where(t < t_on, 0.5 * (1 - np.cos(np.pi * t / t_on)), 1.0)
        de = np.where(t < t_on, 0.5 * np.pi / t_on * np.sin(np.pi * t / t_on), 0.0)
    else:
        e, de = np.ones_like(t), np.zeros_like(t)
    return C * a * (de * np.cos(omega_p * t) - e * omega_p * np.sin(omega_p * t))


def post_switch_level(t, D, mu, mu0, span=100.0):
    """Level of D right after mu(v) switched on: median D over [t_s, t_s + span].

    When the friction drops the equilibrium moves, and D jumps to the square
    of that shift (the re-equilibration jump); growth is measured from there.

    Returns
    -------
    float
        NaN if mu never switched on or no record lies in the interval.

    Raises
    ------
    ValueError
        t, D and mu not 1-D arrays of one length, not finite, or t not increasing.
    """
    t, D, mu = _check_series("post_switch_level", t, D=D, mu=mu)
    ts = friction_switch_time(t, mu, mu0)
    if not math.isfinite(ts):
        return float("nan")
    sel = (t >= ts) & (t <= ts + span) & (D > 0)
    return float(np.median(D[sel])) if np.any(sel) else float("nan")


#: growth of an exponential over the saturation span that :func:`saturation_span`
#: asks for: 4 x the factor 2 of :func:`saturated`
SPAN_GROWTH = 8.0


def saturation_span(growth_rate, span=100.0):
    """Span of :func:`saturated` for a run expected to grow at ``growth_rate``.

    :func:`saturated` calls D saturated when it grew less than 2x over the
    last span; an exponential e^{2 g t} must therefore grow well above 2
    over it. The span returned is ``span``, lengthened where needed so that
    e^{2 g span} >= :data:`SPAN_GROWTH` = 8 (ln 8 / (2 g) = 1.04 / g: 196 at
    g = 0.0053); the span is unchanged for g >= ln 8 / (2 span) (0.0104 at
    span = 100).

    Parameters
    ----------
    growth_rate : float
        Amplitude growth rate g (1/time; D grows as e^{2 g t}), e.g. the
        certified max Im sqrt(lambda) after the friction drop.
    span : float
        Shortest span (time), > 0.

    Returns
    -------
    float
        ``span`` if g is not positive or not finite, else
        max(span, ln(SPAN_GROWTH) / (2 g)).
    """
    g = float(growth_rate)
    if not (math.isfinite(g) and g > 0.0):
        return float(span)
    return max(float(span), math.log(SPAN_GROWTH) / (2.0 * g))


def saturated(t, D, mu, mu0, span=100.0, rise=1e3):
    """Has a triggered run's D stopped growing (nonlinear saturation)?

    True once mu(v) has switched on, max D exceeds ``rise`` x the level right
    after the switch (:func:`post_switch_level`), and the maximum of D over
    the last ``span`` is below twice the maximum before it (an exponential
    growing at rate g multiplies it by e^{2 g span}: 13.5 for g = 0.013,
    span = 100).

    Parameters
    ----------
    t, D, mu : array_like, shape (n,)
    mu0 : float
    span : float
    rise : float

    Returns
    -------
    bool

    Raises
    ------
    ValueError
        t, D and mu not 1-D arrays of one length, not finite, or t not increasing.
    """
    t, D, mu = _check_series("saturated", t, D=D, mu=mu)    # (arrays once: every record)
    if t.size < 3 or t[-1] - t[0] < 2 * span:
        return False
    lvl = post_switch_level(t, D, mu, mu0)
    if not (lvl > 0) or D.max() < rise * lvl:
        return False
    last = t >= t[-1] - span
    return bool(D[last].max() < 2.0 * D[~last].max())


def settled_growth(t, D, mu, mu0, mu_target, settle_tol, lo=3.0, hi=1e-1):
    """Exponential window of a triggered run, after mu(v) has settled.

    The window (:func:`growth_window`) ends at the first record above ``hi``
    x max D (then earlier at the first departure from a constant rate) and
    starts at the first record after the friction has settled at
    ``mu_target`` (:func:`settle_index`) with D above ``lo`` x the largest D
    between the switch and half-way (in time) to that end. That largest D
    is the top of the undamped oscillation about the equilibrium shifted by
    the friction drop (the re-equilibration jump), whose amplitude beats
    slowly over hundreds of time units (the default 3D job's (c): block
    maxima 3e-14 - 1.1e-13 before the growth, top 9.3e-14). Below ~3 x
    that top the growing pair is mixed with the oscillation, which bends
    ln D (local rates over 150 time units, in that run: 0.0027 at 1.2 x the
    top, 0.0041 at 1.8 x, 0.0044-0.0050 from 2.6 x on); the
    upper end 0.1 x max D lies on the constant-rate stretch before the
    saturation (0.0044-0.0050 up to 0.14 x max D there). With the former
    ends, 10 x the *median* D of the first 100 time units after the switch
    and 1e-2 x max D, the window of that run spanned half a decade and its
    rate followed the noise realisation (-21 %, -25 % and -54 % in three
    runs; docs/results/paper.md).

    Parameters
    ----------
    t, D, mu : array_like, shape (n,)
    mu0, mu_target, settle_tol, lo, hi : float

    Returns
    -------
    dict or None
        ``settle_index``, ``t_settle``, ``level`` (:func:`post_switch_level`,
        the median D after the switch), ``peak`` (the largest D before the
        window, which sets its start), ``window`` ([i0, i1] or None),
        ``t_window``, ``growth_rate`` (g of D ~ e^{2gt}), ``mu_fit``
        (median mu over the window); None if mu never settled.

    Raises
    ------
    ValueError
        t, D and mu not 1-D arrays of one length, not finite, or t not increasing.
    """
    t, D, mu = _check_series("settled_growth", t, D=D, mu=mu)
    i = settle_index(t, mu, mu_target, tol=settle_tol)
    if i is None:
        return None
    level = post_switch_level(t, D, mu, mu0)
    peak, win, g = float("nan"), None, float("nan")
    ts = friction_switch_time(t, mu, mu0)
    top = np.flatnonzero(D > hi * np.max(D)) if D.size else np.zeros(0, int)
    top = top[t[top] > ts] if math.isfinite(ts) else top[:0]
    if top.size:
        before = (t >= ts) & (t <= ts + 0.5 * (t[top[0]] - ts)) & (D > 0)
        if np.any(before):
            peak = float(np.max(D[before]))
            win, g = growth_window(t, D, peak, lo=lo, hi=hi, start=i)
    return {"settle_index": int(i), "t_settle": float(t[i]), "level": level, "peak": peak,
            "window": list(win) if win else None,
            "t_window": [float(t[win[0]]), float(t[win[1]])] if win else None,
            "growth_rate": g,
            "mu_fit": float(np.median(mu[win[0]:win[1] + 1])) if win else float("nan")}


def growth_fit(t, D, lo_decades=3.0, hi=None):
    """Fit D ~ exp(2 g t) on the exponential stretch of an MSD series.

    The stretch is the one the paper report uses (:func:`growth_window`):
    contiguous, from the
    first record with D above 10^lo_decades times the initial noise level
    (median of the first 5 % of positive D) to the first record above
    min(``hi``, max(D)/1e3) -- the growth before the first nonlinear
    saturation. (Before, every record between the two levels was used, which
    let a saturated plateau below ``hi`` into the fit: 0.0117 instead of
    0.0159 for a predicted 0.0162.)

    Parameters
    ----------
    t, D : array_like, shape (n,)
        Times and MSD (Eq. 8).
    lo_decades : float
        Start of the window above the noise level, in decades.
    hi : float, optional
        Absolute upper bound of the window (e.g. the stop level / 100).

    Returns
    -------
    float
        g (1/time); NaN with fewer than 5 records in the window or no noise
        level (no positive D).

    Raises
    ------
    ValueError
        t and D not 1-D arrays of one length, not finite, or t not increasing.
    """
    t, D = _check_series("growth_fit", t, D=D)
    Dmax = float(np.max(D)) if D.size else 0.0
    if not Dmax > 0:
        return float("nan")
    top = 1e-3 if hi is None else min(1e-3, float(hi) / Dmax)
    _, g = growth_window(t, D, noise_level(t, D), lo=10.0 ** lo_decades, hi=top)
    return g


#: a triggered run's rise to the runaway level must match the predicted growth
#: rate within this factor (docs/trigger_map.md, "Growth check")
RUNAWAY_RATE_TOL = 2.0
#: and be fitted on at least this many records
RUNAWAY_MIN_RECORDS = 5


def runaway_rate(t, D, d_run, decades=1.0):
    """Growth rate of a run's last rise to the runaway level D_run.

    The records from the first one after the last record below
    D_run x 10^-``decades`` (before D first passes D_run) up to that first
    passage are fitted by :func:`exp_rate` (least squares of ln D / 2 over
    t). One decade of D is 1.15 e-foldings of the amplitude; fitted by least
    squares over all its records, not from two crossing times (D of a
    complex pair oscillates at the pair's frequency, far faster than the
    records: the time between two single crossings is biased short).

    Parameters
    ----------
    t, D : array_like, shape (n,)
        Times and MSD (Eq. 8) of one run.
    d_run : float
        Runaway level (> 0).
    decades : float
        Depth of the fitted rise below D_run.

    Returns
    -------
    (float, int)
        g (1/time, D ~ e^{2 g t}) and the number of records fitted; (NaN, 0)
        if D never passes D_run, (NaN, n) with n < 5 records.

    Raises
    ------
    ValueError
        t and D not 1-D arrays of one length, not finite, or t not increasing.
    """
    t, D = _check_series("runaway_rate", t, D=D)
    hit = np.flatnonzero(D > d_run)
    if hit.size == 0:
        return float("nan"), 0
    i1 = int(hit[0])
    low = np.flatnonzero(D[:i1] < d_run * 10.0 ** -decades)
    i0 = int(low[-1]) + 1 if low.size else 0
    idx = np.arange(D.size)
    n = i1 - i0 + 1
    return exp_rate(t, D, (idx >= i0) & (idx <= i1)), n


def runaway_consistent(rate, n_records, predicted, tol=RUNAWAY_RATE_TOL,
                       min_records=RUNAWAY_MIN_RECORDS):
    """Is a measured rise to D_run the predicted instability?

    True when the predicted growth rate is positive, the rise was fitted on
    at least ``min_records`` records (a rise in fewer records is a forced
    jump, not an exponential), and the measured rate lies within a factor
    ``tol`` of the prediction. A response that passes D_run while no growth
    is predicted (a resonance enlarged by the lower friction, measured below
    the window) or far faster than predicted (a resonance building up over a
    few periods) is not the instability.

    Parameters
    ----------
    rate : float
        Measured rate (:func:`runaway_rate`).
    n_records : int
        Records of its fit.
    predicted : float
        Growth rate after the friction drop from the eigenvalues (with the
        run's damping), 1/time.
    tol : float
        Allowed factor (> 1).
    min_records : int

    Returns
    -------
    bool
    """
    if not (predicted > 0 and n_records >= min_records and math.isfinite(rate)):
        return False
    return bool(predicted / tol <= rate <= tol * predicted)


# ----------------------------------------------------------------------- helpers
def _check_series(func, t, **series):
    """``t`` and each named series: 1-D arrays of one length, every value
    finite, ``t`` increasing (the records of one run, in time order).

    Returns the float64 arrays, ``t`` first, then the series in their order.

    Raises
    ------
    ValueError
        Naming ``func``, the arguments and their shapes, the first
        non-finite value, or the first time not after its predecessor.
    """
    arrays = {}
    for name, a in dict(t=t, **series).items():
        try:
            arrays[name] = np.asarray(a, np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"{func}: {name} must be a 1-D array of numbers, got "
                             f"{type(a).__name__} {str(a)[:40]}") from None
    shapes = [a.shape for a in arrays.values()]
    if any(len(sh) != 1 for sh in shapes) or len(set(shapes)) != 1:
        # (growth_window(t, D[:10], ...) returned (None, nan); growth_fit and
        # exp_rate were raw broadcasting / indexing errors)
        names = list(arrays)
        raise ValueError(f"{func}: {', '.join(names[:-1])} and {names[-1]} must be 1-D arrays "
                         f"of one length, got shapes "
                         f"{', '.join(str(sh) for sh in shapes[:-1])} and {shapes[-1]}")
    for name, a in arrays.items():
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            raise ValueError(f"{func}: {name} must be finite, got {bad.size} non-finite "
                             f"value(s), the first {float(a[bad[0]])!r} at index {int(bad[0])}")
    t = arrays["t"]
    # (a reversed or shuffled t gave a growth rate of the wrong sign, or NaN)
    back = np.flatnonzero(np.diff(t) <= 0)
    if back.size:
        i = int(back[0]) + 1
        raise ValueError(f"{func}: t must be increasing (records in time order), got "
                         f"t[{i}] = {float(t[i])!r} after t[{i - 1}] = {float(t[i - 1])!r}")
    return tuple(arrays.values())


def _constant_rate_end(t, D, i0, i1, chunks, rtol):
    """Last index of the constant-rate part of [i0, i1] (see :func:`growth_window`)."""
    if not (D[i0] > 0 and np.log10(D[i1] / D[i0]) >= chunks):
        return i1                     # pieces of less than a decade: rates too noisy
    edges = np.linspace(t[i0], t[i1], chunks + 1)
    rates, ends = [], []
    for k in range(chunks):
        sel = (t >= edges[k]) & (t <= edges[k + 1]) & (D > 0)
        sel[:i0] = False
        sel[i1 + 1:] = False
        if np.count_nonzero(sel) < 3:
            return i1
        rates.append(float(np.polyfit(t[sel], np.log(D[sel]), 1)[0] / 2.0))
        ends.append(int(np.flatnonzero(sel)[0]))
    for k in range(1, chunks):
        ref = float(np.median(rates[:k]))
        if ref > 0 and abs(rates[k] - ref) > rtol * ref:
            return max(i0, ends[k] - 1)
    return i1
