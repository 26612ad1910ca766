"""The certified bracket of F_x^c and where a ramp decides next inside it.

Part of :mod:`remote_trigger.pywrap.stages`; used by the ramp
(:mod:`remote_trigger.pywrap.stages.ramp`) and the ensemble's I0 = 1
continuation. Only certified answers bound the bracket (docs/driver.md,
"Bisection").

**Where to decide next** (``RampConfig.bisection``). ``'midpoint'`` (the
default) halves the bracket. ``'onset'`` uses what the complex points
already say: near an exceptional point the growth rate g = max Im sqrt(lambda)
opens like g^2 = s^2 (F_x - F*) (the square-root law of the coalescence,
docs/model.md), so the two lowest certified complex loads F1 < F2 with
growth rates 0 < g1 < g2 predict the onset F* = F1 - g1^2 (F2 - F1) /
(g2^2 - g1^2). The next load is F* - tol/3 (if it lies above lo), else
F* + tol/3: when the prediction is right to tol/3 the bracket is closed
in two points, one real and one complex, where halving takes log2(width /
tol) points of which about half are real. At large N a real point costs
the whole spectrum and a complex one only the part below its pair
(docs/analysis.md), so fewer real points is what counts. The load is kept
at least min(width/16, tol/8) inside the bracket, and the midpoint is used
whenever the prediction is not inside it, g1 or g2 is not positive, or
g2 <= g1 (two different pairs, or not yet the square-root regime). Every
answer is certified either way: the rule only chooses which loads are
decided, so the bracket it ends with is as certified as the midpoint's,
and both contain the same onset when the ramp interval holds one
(measured: docs/results/driver.md).
"""
import numpy as np

from remote_trigger.analysis.stability.verdict import Decision

__all__ = ["ramp_bracket", "next_bisection_point", "complex_growth", "BISECTION_RULES"]

#: the rules of :func:`next_bisection_point` (``RampConfig.bisection``)
BISECTION_RULES = ("midpoint", "onset")


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
    F, dec, files = [], [], []
    for kind in ("steps", "bisection"):
        rows = rlog.rows[kind]
        F.extend(rows["F_x"])
        dec.extend(rows["decision"])
        files.extend(rlog.files[kind])
    F, dec = np.asarray(F, float), np.asarray(dec, float)
    cx = F[dec == Decision.COMPLEX]
    hi = float(cx.min()) if cx.size else float("nan")
    real = np.flatnonzero((dec == 0) & (F < hi)) if cx.size else np.flatnonzero(dec == 0)
    if real.size:
        k = int(real[np.argmax(F[real])])
        lo, lo_file = float(F[k]), files[k]
    else:
        lo, lo_file = float("nan"), None
    unknown = sorted(float(f) for f, d in zip(F, dec)
                     if not (d == Decision.REAL or d == Decision.COMPLEX) and lo < f < hi)
    return lo, hi, lo_file, unknown


def complex_growth(rlog):
    """The certified complex points of a ramp log as (F_x, growth rate), by F_x."""
    pts = []
    for kind in ("steps", "bisection"):
        rows = rlog.rows[kind]
        pts += [(float(F), float(g)) for F, d, g in
                zip(rows["F_x"], rows["decision"], rows["growth_rate"])
                if d == Decision.COMPLEX]
    return sorted(pts)


def onset_prediction(complex_points):
    """F* from the two lowest complex points by g^2 = s^2 (F_x - F*), or None
    (fewer than two, a growth rate not positive, or not increasing)."""
    if len(complex_points) < 2:
        return None
    (F1, g1), (F2, g2) = complex_points[0], complex_points[1]
    if not (0.0 < g1 < g2 and F1 < F2):
        return None
    return F1 - g1 * g1 * (F2 - F1) / (g2 * g2 - g1 * g1)


def next_bisection_point(lo, hi, unknown, tol, rule="midpoint", complex_points=()):
    """Next load to decide inside the certified bracket, or why there is none.

    Without undecided points inside: the midpoint, or with ``rule``
    'onset' the load next to the predicted onset (module docstring). With
    undecided points inside, they are taken to mark the exceptional point's
    neighbourhood: the larger of the two uncertified gaps [lo, min(unknown)]
    and [max(unknown), hi] is halved, until both are at most tol/2 (either
    rule).

    Parameters
    ----------
    lo, hi : float
        The certified bracket (:func:`ramp_bracket`).
    unknown : list of float
        Loads inside it without a certified answer.
    tol : float
        The width to reach (force).
    rule : {'midpoint', 'onset'}
    complex_points : sequence of (float, float)
        (F_x, growth rate) of the certified complex points, by F_x
        (:func:`complex_growth`); used by 'onset' only.

    Returns
    -------
    F : float or None
    why : str
        ``''`` (F given), ``'tol'`` (hi - lo <= tol), ``'undecided'`` (no
        gap wider than tol/2 is left beside the undecided points) or
        ``'resolution'`` (no float64 number strictly inside the gap).

    Raises
    ------
    ValueError
        If ``rule`` is not one of :data:`BISECTION_RULES`.
    """
    if rule not in BISECTION_RULES:
        raise ValueError(f"rule must be one of {BISECTION_RULES}, got {rule!r}")
    if hi - lo <= tol:
        return None, "tol"
    if rule == "onset" and not unknown:
        F = onset_prediction(list(complex_points))
        if F is not None and lo < F < hi:
            x = F - tol / 3.0 if F - tol / 3.0 > lo else F + tol / 3.0
            m = min((hi - lo) / 16.0, tol / 8.0)
            x = min(max(x, lo + m), hi - m)
            if lo < x < hi:
                return x, ""
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


