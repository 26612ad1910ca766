"""The onset of one ramp, measured from its points: certified bracket, position
of the coalescing pair, growth-rate slope, and the re-analysis of the same
equilibria under another moment of inertia (``remote-trigger ensemble``,
docs/ensemble.md "What is measured"). Reads ``ramp.h5`` and equilibrium
dumps; no LAMMPS.
"""
import math
import os

import numpy as np
from remote_trigger.analysis.stability.decision import Decision


def spectrum(state, basis=None, pairs="all"):
    """The engine's dense verdict on one state, as the ensemble's records hold it.

    :func:`~remote_trigger.analysis.stability.verdict.decide` on the state's
    reduced system with ``method='dense'`` (the ramp's dense path).

    Parameters
    ----------
    state : remote_trigger.analysis.state.state.State
        Its ``inertia`` sets the mass matrix M = diag(m, m, I / R^2).
    basis : remote_trigger.analysis.stability.decision.SpectrumBasis, optional
        The previous point's ``basis``: the decision starts from it where it
        certifies (``classify_spectrum(basis=)``, the same answer as from
        dgeev), carried over to this state's kept dofs.
    pairs : {'all', 'collective'}
        The soft-pair policy (``VerdictOptions.pairs``): with 'collective'
        (a ramp with ``pairs`` = 'collective') ``decision`` is that on the
        pairs that are not soft
        (:func:`~remote_trigger.analysis.stability.verdict.collective_decision`;
        from dgeev again where the basis leaves it undecided).

    Returns
    -------
    dict
        ``decision`` (the :class:`Decision`; its code 1 complex, 0 real, -1
        undecided is what the task files store), ``confidence``,
        ``eigenvalues`` (complex, shape (M,), eigenvalues of M^-1 K after
        rattler removal, 1/time^2, sorted by real part), ``n_pairs`` (units
        certified complex), ``growth`` (max |Im sqrt(lambda)|, 1/time),
        ``basis`` (the decision's verified basis, for the next point; None
        if there is none), ``reason`` (why, when undecided; else '').
    """
    from remote_trigger.analysis.stability.verdict import VerdictOptions, stability_of

    res = stability_of(state, VerdictOptions(method="dense", pairs=pairs), basis)
    decision = res.policy_decision
    return {"decision": decision, "confidence": float(res.confidence),
            "eigenvalues": res.eigenvalues, "n_pairs": int(res.complex_units),
            "growth": float(res.growth_rate), "basis": res.basis,
            "reason": res.reason if decision is Decision.UNDECIDED else ""}


def read_ramp(h5):
    """Every equilibrium of a ramp, in increasing F_x.

    Parameters
    ----------
    h5 : str
        ``ramp.h5`` of :func:`.stages.ramp`.

    Returns
    -------
    list of dict
        ``F_x``, ``decision`` (1, 0, -1), ``growth`` (1/time), ``dump``
        (equilibrium dump), ``eigenvalues`` (complex, sorted by real part,
        the dynamics' I0: 1/2 disks, 2/5 spheres; all of them, or those below
        the column ``scanned_below`` where a sliced scan stopped at its first
        complex strip), ``lambda_max`` and ``n_dof`` (the spectrum's top and
        size; NaN and -1 in files that predate these columns),
        ``saddle_escaped`` (escapes from a saddle made; 0 in older files),
        ``n_negative`` (the ramp's count of negative eigenvalues; NaN in
        older files), ``soft_pairs`` (certified complex pairs that are soft,
        with ``pairs`` = 'collective'; NaN otherwise), ``reason``
        (why an undecided point is undecided, from the file's
        ``undecided_reasons``; '' otherwise or where the file has none).
        Bisection points without an equilibrium are left out.
    """
    import h5py

    from remote_trigger.pywrap.stages.ramp_file import point_file, undecided_reasons

    pts = []
    with h5py.File(h5, "r") as fh:
        why = undecided_reasons(fh.attrs)
        for kind, stem in (("steps", "step_{:05d}"), ("bisection", "bisect_{:03d}")):
            if kind not in fh:
                continue
            F = fh[f"{kind}/F_x"][()]
            dec = fh[f"{kind}/decision"][()]
            g = fh[f"{kind}/growth_rate"][()]
            nan = np.full(len(F), np.nan)
            top = fh[f"{kind}/lambda_max"][()] if f"{kind}/lambda_max" in fh else nan
            ndof = fh[f"{kind}/n_dof"][()] if f"{kind}/n_dof" in fh else nan
            esc = (fh[f"{kind}/saddle_escaped"][()] if f"{kind}/saddle_escaped" in fh
                   else np.zeros(len(F)))
            nneg = fh[f"{kind}/n_negative"][()] if f"{kind}/n_negative" in fh else nan
            soft = fh[f"{kind}/soft_pairs"][()] if f"{kind}/soft_pairs" in fh else nan
            files = [point_file(h5, x, fh.attrs) for x in fh[f"{kind}/datafile"][()]]
            for k in range(len(F)):
                if not np.isfinite(dec[k]):
                    continue
                name = f"eigenvalues/{kind}/{stem.format(k)}"
                lam = np.asarray(fh[name][()], complex) if name in fh else np.zeros(0, complex)
                lam = lam[np.lexsort((lam.imag, lam.real))]
                pts.append({"F_x": float(F[k]), "decision": int(dec[k]), "growth": float(g[k]),
                            "dump": files[k][:-len(".data")] + ".dump", "eigenvalues": lam,
                            "lambda_max": float(top[k]),
                            "n_dof": int(ndof[k]) if np.isfinite(ndof[k]) else -1,
                            "saddle_escaped": float(esc[k]), "n_negative": float(nneg[k]),
                            "soft_pairs": float(soft[k]),
                            "reason": str(why.get(stem.format(k), ""))})
    pts.sort(key=lambda p: p["F_x"])
    return pts


def bracket(points):
    """Certified bracket of F_x^c from points with decisions (the ramp's rule).

    ``hi`` is the smallest F_x certified complex, ``lo`` the largest F_x
    certified real below it; undecided points are neither.

    Parameters
    ----------
    points : list of dict
        Each with ``F_x`` and ``decision`` (1, 0, -1).

    Returns
    -------
    lo, hi : float
        ``hi`` = inf when no point is certified complex (``lo`` is then the
        largest certified real F_x: a lower bound of F_x^c); NaN when there is
        no such point.
    """
    cx = [p["F_x"] for p in points if p["decision"] == Decision.COMPLEX]
    hi = min(cx) if cx else math.inf
    real = [p["F_x"] for p in points if p["decision"] == Decision.REAL and p["F_x"] < hi]
    lo = max(real) if real else math.nan
    return float(lo), float(hi)


def bracket_words(lo, hi, name="F_x^c"):
    """A bracket of :func:`bracket` as a status line says it.

    Parameters
    ----------
    lo, hi : float
        As :func:`bracket` returns them.
    name : str
        What the bracket brackets (``'F_x^c'``, ``'F_x^c(mu0)'``).

    Returns
    -------
    str
        ``'<name> in [lo, hi]'`` where both ends are certified; ``'complex
        at F_x = 0 (no <name>)'`` where the ramp's first point, at F_x = 0,
        is certified complex; ``'complex at F_x = hi, no real point below
        (<name> <= hi)'`` where it starts higher; ``'real up to F_x = lo'``
        where no point is certified complex; ``'no certified point'``.
    """
    from remote_trigger.analysis.output import bracket_text

    if math.isfinite(hi):
        if math.isfinite(lo):
            return f"{name} in {bracket_text(lo, hi)}"
        if hi == 0.0:
            return f"complex at F_x = 0 (no {name})"
        return f"complex at F_x = {hi:.6g}, no real point below ({name} <= {hi:.6g})"
    if math.isfinite(lo):
        return f"real up to F_x = {lo:.6g}"
    return "no certified point"


def pair_position(eigenvalues, lambda_max=math.nan, n_dof=-1, soft_rel=None):
    """Where the coalesced pair sits in the spectrum.

    Parameters
    ----------
    eigenvalues : ndarray of complex, shape (M,)
        Spectrum of M^-1 K with a complex pair: all of it, or every
        eigenvalue below some real part (a sliced scan stopped at its first
        complex strip; then give ``lambda_max`` and ``n_dof``).
    lambda_max : float, optional
        The spectrum's largest real part (default: that of ``eigenvalues``).
    n_dof : int, optional
        The spectrum's size (default: M).
    soft_rel : float, optional
        Leave out the eigenvalues off the real axis with |Re lambda| <
        ``soft_rel`` lambda_max (soft pairs; the ramp's ``pairs`` =
        'collective'). Default None: none left out.

    Returns
    -------
    dict
        ``lambda_c`` (of the eigenvalues off the real axis, the one of largest
        |Im sqrt(lambda)|, [Re, |Im|]; a negative *real* eigenvalue, a static
        instability, is not a pair), ``pair_re_rel`` = Re lambda_c /
        lambda_max, ``pair_index`` (1-based index of the pair counted from
        the softest mode: 1 + the number of eigenvalues with smaller real
        part), ``n_dof``. NaN / -1 when no eigenvalue is off the real axis.
    """
    lam = np.asarray(eigenvalues, complex)
    n_dof = int(lam.size) if n_dof < 0 else int(n_dof)
    top = float(lambda_max) if not math.isnan(lambda_max) else (
        float(np.max(lam.real)) if lam.size else math.nan)
    off = np.nonzero((lam.imag != 0) & ~(np.abs(lam.real) < (soft_rel or 0.0) * top))[0]
    if off.size == 0:
        return {"lambda_c": [math.nan, math.nan], "pair_re_rel": math.nan,
                "pair_index": -1, "n_dof": n_dof}
    g = np.abs(np.sqrt(lam[off]).imag)
    c = lam[off[int(np.argmax(g))]]
    below = int(np.count_nonzero(lam.real < c.real - 1e-12 * abs(c.real)))
    return {"lambda_c": [float(c.real), float(abs(c.imag))],
            "pair_re_rel": float(c.real / top), "pair_index": below + 1, "n_dof": n_dof}


#: a pair whose mode moves fewer particles than this (N PR) is a local onset
LOCAL_PAIR_PARTICLES = 10.0


def pair_shape(points, numbers, inertia_factor=None):
    """Participation ratio of the pair's mode at the first load certified complex.

    Parameters
    ----------
    points : list of dict
        From :func:`read_ramp` (or :func:`reanalyse`), with ``dump``.
    numbers : dict
        :func:`onset_numbers` of the same points (``F_x_c_high``, ``lambda_c``).
    inertia_factor : float, optional
        I0 of the analysis convention (None: the dump's own).

    Returns
    -------
    dict
        ``pair_pr`` (participation ratio of the translations,
        :func:`~remote_trigger.analysis.stability.modeshape.pair_mode`) and
        ``pair_particles`` (N PR) and ``pair_longwave`` (the long-wave
        fraction of the translations,
        :func:`~remote_trigger.analysis.stability.modeshape.long_wave_fraction`);
        NaN without a complex point, when its
        dump is gone (a ramp finished by an older version) or when the
        eigenvector cannot be computed.
    """
    from remote_trigger.analysis.state.dumpfile import read_dump, read_equilibrium
    from remote_trigger.analysis.stability.modeshape import pair_mode

    out = {"pair_pr": math.nan, "pair_particles": math.nan, "pair_longwave": math.nan}
    hi, lam = numbers.get("F_x_c_high", math.nan), numbers.get("lambda_c", [math.nan] * 2)
    if not (math.isfinite(hi) and math.isfinite(lam[0])):
        return out
    top = next((p for p in points if p["F_x"] == hi and p["decision"] == Decision.COMPLEX),
               None)
    if top is None or not os.path.isfile(top["dump"]):
        return out
    state = (read_equilibrium(top["dump"]) if inertia_factor is None else
             read_dump(top["dump"], require_contacts=False, inertia_factor=inertia_factor))
    try:
        m = pair_mode(state, complex(lam[0], lam[1]))
    except (ValueError, RuntimeError, np.linalg.LinAlgError):
        # a description, not a result: ARPACK's failure (it is a RuntimeError)
        # or a singular shift leaves it unmeasured, never the packing failed
        return out
    return {"pair_pr": m.participation_ratio, "pair_particles": m.n_particles,
            "pair_longwave": m.long_wave}


def growth_slope(F, g, lo, hi):
    """Slope s of the growth rate g = s sqrt(F_x - F_x^c) just above onset.

    Parameters
    ----------
    F, g : array_like, shape (P,)
        Loads certified complex near onset and their growth rates
        max |Im sqrt(lambda)| (1/time).
    lo, hi : float
        Certified bracket of F_x^c.

    Returns
    -------
    dict
        ``slope`` (1/(time sqrt(force))), ``F_x_onset_fit`` (onset F_x0 of
        the line g^2 = s^2 (F_x - F_x0); NaN with one point), ``n_points``.
        With two or more distinct loads, least squares on g^2; with one,
        s = g / sqrt(F_x - (lo + hi) / 2). NaN where undefined.
    """
    F, g = np.asarray(F, float), np.asarray(g, float)
    out = {"slope": math.nan, "F_x_onset_fit": math.nan, "n_points": int(F.size)}
    if F.size >= 2 and np.ptp(F) > 0:
        a, b = np.polyfit(F, g * g, 1)
        if a > 0:
            out.update(slope=float(math.sqrt(a)), F_x_onset_fit=float(-b / a))
    elif F.size == 1 and math.isfinite(lo) and math.isfinite(hi):
        d = F[0] - 0.5 * (lo + hi)
        if d > 0:
            out["slope"] = float(g[0] / math.sqrt(d))
    return out


def onset_numbers(points, dF_x, pairs="all"):
    """Bracket, pair position and growth-rate slope of a ramp's points.

    Parameters
    ----------
    points : list of dict
        As from :func:`read_ramp` (decisions and eigenvalues of one
        convention).
    dF_x : float
        Ramp step: the slope uses the certified complex points within one
        step above F_x_c_high.
    pairs : {'all', 'collective'}
        The ramp's soft-pair policy: with 'collective' :func:`pair_position`
        leaves the soft pairs out (its ``soft_rel``, ``VerdictOptions.soft_rel``).

    Returns
    -------
    dict
        ``F_x_c_low``, ``F_x_c_high`` (see :func:`bracket`), ``n_undecided``,
        ``undecided`` (a list of [F_x, reason] of the undecided points; the
        reason '' where none was recorded), ``F_x_last`` (largest F_x
        analysed), the keys of :func:`pair_position` (NaN without a complex
        point) and of :func:`growth_slope`; ``n_saddle`` (points whose
        equilibrium has an eigenvalue below -NEGATIVE_REL lambda_max: a
        saddle), ``n_escaped`` (points whose Newton equilibrium was a saddle
        and was replaced, ``RampConfig.saddle_escape``), ``saddle_ends``
        (the bracket's ends that are saddles, their F_x) and ``F_x_soft``
        (the smallest F_x with a soft pair certified, a ramp with ``pairs`` =
        'collective'; NaN if none).
    """
    from remote_trigger.analysis.stability.verdict import VerdictOptions

    soft_rel = VerdictOptions(pairs=pairs).soft_rel
    lo, hi = bracket(points)
    out = {"F_x_c_low": lo, "F_x_c_high": hi,
           "n_undecided": sum(1 for p in points if p["decision"] == Decision.UNDECIDED),
           "undecided": [[p["F_x"], p.get("reason", "")] for p in points
                         if p["decision"] == Decision.UNDECIDED],
           "F_x_last": max((p["F_x"] for p in points), default=math.nan),
           "lambda_c": [math.nan, math.nan], "pair_re_rel": math.nan, "pair_index": -1,
           "n_dof": -1, "slope": math.nan, "F_x_onset_fit": math.nan, "n_points": 0}
    saddles = [p["F_x"] for p in points if is_saddle(p)]
    out.update(n_saddle=len(saddles),
               n_escaped=sum(1 for p in points if p.get("saddle_escaped", 0) > 0),
               saddle_ends=[F for F in (lo, hi) if F in saddles],
               F_x_soft=min((p["F_x"] for p in points if p.get("soft_pairs", 0) > 0),
                            default=math.nan))
    if math.isfinite(hi):
        top = next(p for p in points if p["F_x"] == hi and p["decision"] == Decision.COMPLEX)
        out.update(pair_position(top["eigenvalues"], top.get("lambda_max", math.nan),
                                 top.get("n_dof", -1), soft_rel))
        near = [p for p in points
                if p["decision"] == Decision.COMPLEX and p["F_x"] <= hi + dF_x * (1 + 1e-9)]
        out.update(growth_slope([p["F_x"] for p in near], [p["growth"] for p in near], lo, hi))
    return out


def is_saddle(point):
    """Has the equilibrium of ``point`` (from :func:`read_ramp`) an eigenvalue
    with Re lambda < -NEGATIVE_REL lambda_max (a saddle)? The ramp's
    ``n_negative`` where recorded; in older files the stored eigenvalues
    (the bottom of the spectrum is listed even where a sliced scan stopped
    early; but a sliced list holds the symmetric part's Ritz values, so
    there a free rotation can count too)."""
    from remote_trigger.analysis.stability.analyze import NEGATIVE_REL

    n = point.get("n_negative", math.nan)
    if math.isfinite(n) and n >= 0:
        return n > 0
    lam = np.asarray(point["eigenvalues"])
    if lam.size == 0:
        return False
    top = point.get("lambda_max", math.nan)
    top = float(np.max(lam.real)) if not math.isfinite(top) else top
    return bool(np.min(lam.real) < -NEGATIVE_REL * top)


def reanalyse(points, I0, pairs="all"):
    """The same equilibria with the moment of inertia I = I0 m R^2 in M.

    Only the mass matrix changes (K does not depend on the inertia); the
    certified decision is recomputed at every point, in the order given
    (increasing F_x), each starting from the previous point's basis.

    Parameters
    ----------
    points : list of dict
        From :func:`read_ramp` (their ``dump`` files must exist).
    I0 : float
    pairs : {'all', 'collective'}
        :func:`spectrum`'s soft-pair policy (the ramp's ``pairs``).

    Returns
    -------
    list of dict
        Same keys, with ``decision``, ``growth``, ``eigenvalues`` and
        ``reason`` of the new convention.
    """
    from remote_trigger.analysis.state.dumpfile import read_dump

    out, basis = [], None
    for p in points:
        s = spectrum(read_dump(p["dump"], require_contacts=False, inertia_factor=I0), basis,
                     pairs)
        basis = s.pop("basis")
        # a whole dense spectrum: its own top and size (M changed with I0)
        out.append(dict(p, decision=s["decision"], growth=s["growth"],
                        eigenvalues=s["eigenvalues"], reason=s["reason"],
                        lambda_max=math.nan, n_dof=-1))
    return out
