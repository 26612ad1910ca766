"""Rows, statistics and outputs of ``remote-trigger ensemble``: one table row
per packing and protocol (``ensemble.h5``), the statistics, the figure and
``ensemble.md``, made on rank 0 (:mod:`remote_trigger.pywrap.jobs.ensemble.job`)."""
import json
import math

import numpy as np

from remote_trigger.analysis.output import write_text_atomic
from remote_trigger.pywrap.jobs.paper.config import PAPER
from remote_trigger.pywrap.jobs.ensemble.config import ONLY_2D
from remote_trigger.analysis.stability.decision import Decision
from remote_trigger.analysis.stability.verdict import SOFT_MODE_REL
from remote_trigger.analysis.stability.modeshape import LONG_WAVE_M
from remote_trigger.pywrap.jobs.ensemble.onset import LOCAL_PAIR_PARTICLES
from remote_trigger.pywrap.jobs.ensemble.limit import (
    PROVENANCE, limit_lines, limit_statistics, provenance)

#: the paper's bracket of F_x^c(mu = 1) for its N = 100 packing
PAPER_BRACKET = (PAPER["F_x_c_mu1_low"], PAPER["F_x_c_mu1_high"])


# --------------------------------------------------------------------------- rows
#: string columns of the table
STR_COLS = ("key", "protocol", "status", "reason", "ramp_status_mu0", "ramp_status_mu_ss",
            *PROVENANCE)
#: columns of the table, in order (numbers are float64; -1 / NaN = not measured)
COLUMNS = ("key", "n", "seed", "protocol", "I0", "dynamics_consistent", "status", "reason",
           "phi", "residual", "antisymmetry",
           "F_x_c_low", "F_x_c_high", "F_x_c", "F_x_c_ss_low", "F_x_c_ss_high", "F_x_c_ss",
           "ratio", "ratio_low", "ratio_high", "order", "pair_re_rel", "pair_index", "n_dof",
           "lambda_c_re", "lambda_c_im", "growth_slope", "F_x_onset_fit", "slope_points",
           "n_undecided", "n_steps", "n_bisection", "n_extra", "ramp_status_mu0", "ramp_status_mu_ss",
           "decision_at_zero", "n_pairs_at_zero", "growth_at_zero", "soft_onset", "wall",
           "pair_pr", "pair_particles", "n_saddle", "n_escaped", "pair_longwave",
           "F_x_soft", "F_x_soft_ss", *PROVENANCE)


def _mid(lo, hi):
    return 0.5 * (lo + hi) if math.isfinite(lo) and math.isfinite(hi) else math.nan


def order_code(lo0, hi0, lo1, hi1):
    """Is F_x^c(mu_ss mu0) < F_x^c(mu0)? From the two certified brackets.

    Returns
    -------
    int
        1 certified (hi1 < lo0), 0 certified reversed (lo1 > hi0), -1 not
        decided (brackets overlap or missing).
    """
    if math.isfinite(hi1) and math.isfinite(lo0) and hi1 < lo0:
        return 1
    if math.isfinite(lo1) and math.isfinite(hi0) and lo1 > hi0:
        return 0
    return -1


def _empty_row(task, protocol, I0, i0_dyn):
    row = {c: math.nan for c in COLUMNS}
    row.update(key=task["key"], n=task["n"], seed=task["seed"], protocol=protocol, I0=I0,
               dynamics_consistent=float(I0 == i0_dyn), status="failed", reason="",
               ramp_status_mu0="", ramp_status_mu_ss="", pair_index=-1, n_dof=-1,
               slope_points=0, order=-1, decision_at_zero=math.nan, n_extra=0,
               soft_onset=-1, **{k: "" for k in PROVENANCE})
    return row


def soft_onset(pair_re_rel):
    """1 if the coalescing pair is a soft-mode pair (|Re lambda_c| < SOFT_MODE_REL
    lambda_max), 0 if two stiff modes, -1 if unknown (no complex point)."""
    if not math.isfinite(pair_re_rel):
        return -1
    return int(abs(pair_re_rel) < SOFT_MODE_REL)


def rows_of(task, result, cfg):
    """Table rows of one packing (see the module docstring).

    Returns
    -------
    list of dict
        Keys :data:`COLUMNS`. ``status``: ``'ok'`` (every bracket certified
        to ``tol``), ``'incomplete'`` (a bracket wider than tol, only a lower
        bound, or the second ramp missing: ``reason`` says which) or
        ``'failed'`` (``reason``).
    """
    i0_dyn = cfg.I0_dynamics
    rows = [_default_row(task, result, I0, i0_dyn) for I0 in cfg.conventions()]
    f = result.get("frictional")
    if f is not None:
        rows.append(_frictional_row(task, result, f, i0_dyn))
    made = provenance(result)
    for row in rows:
        row.update(made)
    return rows


def _default_row(task, result, I0, i0_dyn):
    """The row of the default protocol's ramps analysed with inertia I0 (``i0_dyn``:
    that of the dynamics)."""
    d = result["default"]
    row = _empty_row(task, "frictionless-then-friction", I0, i0_dyn)
    row["wall"] = result["wall"]
    for k in ("phi", "residual", "antisymmetry"):
        row[k] = d.get(k, math.nan)
    ck = f"I0_{I0:g}"
    r0, r1 = d["ramps"].get("mu0"), d["ramps"].get("mu_ss")
    why = []
    if d.get("error"):
        why.append(d["error"])
    for name, r in (("mu0", r0), ("mu_ss", r1)):
        if r is None:
            continue
        row[f"ramp_status_{name}"] = r["ramp_status"]
        if r["ramp_status"] != "complete":
            why.append(f"ramp {name} (mu = {r['mu']:g}): {r['ramp_status']}"
                       + (f" ({r['message']})" if r["message"] else ""))
        elif not r["tol_reached"]:
            why.append(f"ramp {name}: {r['message']}")
        und = r.get(ck, {}).get("undecided") or []
        if und:
            F, what = und[0]
            why.append(f"{len(und)} undecided point(s) at {name}, the first at F_x = {F:.6g}"
                       + (f": {what}" if what else ""))
        ends = r.get(ck, {}).get("saddle_ends") or []
        if ends:
            why.append(f"bracket end(s) on a saddle at {name}: F_x = "
                       + ", ".join(f"{F:.6g}" for F in ends))
    for c in ("n_saddle", "n_escaped"):      # both ramps; NaN where not recorded
        got = [r.get(ck, {}).get(c, math.nan) for r in (r0, r1) if r is not None]
        row[c] = sum(got) if got else math.nan
    if r0 is not None and ck in r0:
        o = r0[ck]
        row.update(F_x_c_low=o["F_x_c_low"], F_x_c_high=o["F_x_c_high"],
                   F_x_c=_mid(o["F_x_c_low"], o["F_x_c_high"]),
                   pair_re_rel=o["pair_re_rel"], pair_index=o["pair_index"],
                   n_dof=o["n_dof"], lambda_c_re=o["lambda_c"][0],
                   lambda_c_im=o["lambda_c"][1], growth_slope=o["slope"],
                   F_x_onset_fit=o["F_x_onset_fit"], slope_points=o["n_points"],
                   n_undecided=o["n_undecided"], n_steps=r0["n_steps"],
                   n_bisection=r0["n_bisection"], pair_pr=o.get("pair_pr", math.nan),
                   pair_particles=o.get("pair_particles", math.nan),
                   pair_longwave=o.get("pair_longwave", math.nan),
                   F_x_soft=o.get("F_x_soft", math.nan))
        if r0.get("at_zero") and I0 == i0_dyn:
            row.update(decision_at_zero=r0["at_zero"]["decision"], n_pairs_at_zero=math.nan,
                       growth_at_zero=r0["at_zero"]["growth"])
        if I0 != i0_dyn:
            row["n_extra"] = o["n_new"] + r1.get(ck, {}).get("n_new", 0) if r1 else \
                o["n_new"]
            if r0["ramp_status"] == "complete" and not math.isfinite(o["F_x_c_high"]):
                why.append(f"I0 = {I0:g}: no pair certified complex up to F_x = "
                           f"{o['F_x_last']:.6g} at mu0 (F_x^c above it)")
            elif not o["tol_reached"] and r0["tol_reached"]:
                why.append(f"I0 = {I0:g}: mu0 bracket wider than tol")
    if r1 is not None and ck in r1:
        o1 = r1[ck]
        row.update(F_x_c_ss_low=o1["F_x_c_low"], F_x_c_ss_high=o1["F_x_c_high"],
                   F_x_c_ss=_mid(o1["F_x_c_low"], o1["F_x_c_high"]),
                   F_x_soft_ss=o1.get("F_x_soft", math.nan))
        if I0 != i0_dyn and r1["ramp_status"] == "complete":
            if not math.isfinite(o1["F_x_c_high"]):
                why.append(f"I0 = {I0:g}: no pair certified complex up to F_x = "
                           f"{o1['F_x_last']:.6g} at mu_ss mu0 (F_x^c above it)")
            elif not o1["tol_reached"] and r1["tol_reached"]:
                why.append(f"I0 = {I0:g}: mu_ss mu0 bracket wider than tol")
    row["soft_onset"] = soft_onset(row["pair_re_rel"])
    row["ratio"] = row["F_x_c_ss"] / row["F_x_c"] if row["F_x_c"] else math.nan
    if row["F_x_c_low"] > 0 and row["F_x_c_high"] > 0:
        row["ratio_low"] = row["F_x_c_ss_low"] / row["F_x_c_high"]
        row["ratio_high"] = row["F_x_c_ss_high"] / row["F_x_c_low"]
    row["order"] = order_code(row["F_x_c_low"], row["F_x_c_high"], row["F_x_c_ss_low"],
                              row["F_x_c_ss_high"])
    if I0 != i0_dyn:
        why.append(f"analysis only: I0 = {I0:g} is inconsistent with the dynamics "
                   f"(I0 = {i0_dyn})")
    if not (math.isfinite(row["F_x_c_low"]) or math.isfinite(row["F_x_c_high"])):
        row["status"] = "failed"
    elif math.isfinite(row["F_x_c"]) and math.isfinite(row["F_x_c_ss"]) and \
            not d.get("error") and all(r is not None and r["tol_reached"]
                                       and r.get(ck, {}).get("tol_reached", False)
                                       for r in (r0, r1)):
        row["status"] = "ok"
    else:
        row["status"] = "incomplete"
    row["reason"] = "; ".join(why)
    return row


def _frictional_row(task, result, f, i0_dyn):
    """The row of the frictional protocol at F_x = 0."""
    row = _empty_row(task, "frictional", i0_dyn, i0_dyn)
    row["wall"] = result["wall"]
    if f.get("error"):
        row["reason"] = f["error"]
    else:
        row.update(status="ok", phi=f["phi"], residual=f["residual"],
                   antisymmetry=f["antisymmetry"], decision_at_zero=f["decision"],
                   n_pairs_at_zero=f["n_pairs"], growth_at_zero=f["growth"])
    return row


# --------------------------------------------------------------------------- statistics
def quartiles(x):
    """(count, q25, median, q75) of the finite values of x (NaN if none)."""
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    if not x.size:
        return 0, math.nan, math.nan, math.nan
    q = np.percentile(x, [25, 50, 75])
    return int(x.size), float(q[0]), float(q[1]), float(q[2])


def percentile_of(value, x):
    """Percentage of the finite values of x below ``value`` (NaN if none)."""
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    return float(100.0 * np.mean(x < value)) if x.size else math.nan


def select(rows, protocol, I0, n=None, usable=True):
    """Rows of one protocol/convention (and size); ``usable``: status not 'failed'."""
    return [r for r in rows if r["protocol"] == protocol and r["I0"] == I0
            and (n is None or r["n"] == n) and (not usable or r["status"] != "failed")]


def statistics(rows, cfg):
    """The numbers of ``ensemble.md``.

    Returns
    -------
    dict
        ``per_n`` (per N and convention: quartiles of F_x^c(mu0), of the
        ratio, of phi, of the slope), ``order`` (per convention: counts of
        certified holds / reversed / undecided), ``frictional`` (per N:
        unstable fraction at F_x = 0), ``paper_percentile`` (per
        convention: percentiles of 0.0091 and 0.012 among F_x^c(mu0) at
        N = 100, or at every N if 100 is not in the ensemble; empty for
        spheres, whose F_x^c the paper's disks do not bracket),
        ``n_exponent`` (per convention: d ln median F_x^c / d ln N between
        the smallest and largest N), ``n_fit`` (per convention, with two
        sizes or more: :func:`~remote_trigger.analysis.scaling.power_law_fit`
        of F_x^c(mu0), F_x^c(mu_ss mu0) and the window width F_x^c(mu0) -
        F_x^c(mu_ss mu0) over every usable packing, keys ``'F_x_c'``,
        ``'F_x_c_ss'``, ``'width'``; a quantity with fewer than two sizes is
        left out), ``limit`` (the size-dependence numbers of the default
        protocol under the dynamics' convention,
        :func:`~remote_trigger.pywrap.jobs.ensemble.limit.limit_statistics`).
        ``per_n`` also holds ``window_rel`` (quartiles of 1 - ratio over the
        packings whose order is decided, negative where reversed) and
        ``window_rel_pos`` (the same where the order holds).
    """
    ft = "frictionless-then-friction"
    convs = cfg.conventions()
    st = {"per_n": [], "order": {}, "frictional": [], "paper_percentile": {},
          "n_exponent": {}, "n_fit": {}}
    for I0 in convs:
        for n in cfg.n:
            sel = select(rows, ft, I0, n)
            st["per_n"].append({
                "n": n, "I0": I0, "n_packings": len(select(rows, ft, I0, n, usable=False)),
                "n_usable": len(sel),
                "F_x_c": quartiles([r["F_x_c"] for r in sel]),
                "F_x_c_ss": quartiles([r["F_x_c_ss"] for r in sel]),
                "ratio": quartiles([r["ratio"] for r in sel]),
                "phi": quartiles([r["phi"] for r in sel]),
                "slope": quartiles([r["growth_slope"] for r in sel]),
                "pair_re_rel": quartiles([r["pair_re_rel"] for r in sel]),
                "pair_index": quartiles([r["pair_index"] for r in sel if r["pair_index"] > 0]),
                "n_soft": sum(1 for r in sel if r["soft_onset"] == 1),
                "pair_particles": quartiles([r["pair_particles"] for r in sel]),
                "n_local": sum(1 for r in sel if r["pair_particles"] < LOCAL_PAIR_PARTICLES),
                "pair_longwave": quartiles([r["pair_longwave"] for r in sel]),
                "F_x_c_stiff": quartiles([r["F_x_c"] for r in sel if r["soft_onset"] == 0]),
                "window_rel": quartiles([1.0 - r["ratio"] for r in sel if r["order"] >= 0]),
                "window_rel_pos": quartiles([1.0 - r["ratio"] for r in sel
                                             if r["order"] == 1])})
        codes = [r["order"] for r in select(rows, ft, I0, usable=False)]
        st["order"][I0] = {"holds": codes.count(1), "reversed": codes.count(0),
                           "undecided": codes.count(-1), "total": len(codes)}
        ref = [100] if 100 in cfg.n else list(cfg.n)
        x = [r["F_x_c"] for r in select(rows, ft, I0) if r["n"] in ref]
        if cfg.dim == 2:
            st["paper_percentile"][I0] = {"n": ref, "count": int(np.sum(np.isfinite(x))),
                                          "low": percentile_of(PAPER_BRACKET[0], x),
                                          "high": percentile_of(PAPER_BRACKET[1], x)}
        meds = [(p["n"], p["F_x_c"][2]) for p in st["per_n"] if p["I0"] == I0
                and math.isfinite(p["F_x_c"][2]) and p["F_x_c"][2] > 0]
        if len(meds) >= 2 and meds[0][0] != meds[-1][0]:
            (n1, m1), (n2, m2) = meds[0], meds[-1]
            st["n_exponent"][I0] = math.log(m2 / m1) / math.log(n2 / n1)
        meds = [(p["n"], p["F_x_c_stiff"][2]) for p in st["per_n"] if p["I0"] == I0
                and math.isfinite(p["F_x_c_stiff"][2]) and p["F_x_c_stiff"][2] > 0]
        if len(meds) >= 2 and meds[0][0] != meds[-1][0]:
            (n1, m1), (n2, m2) = meds[0], meds[-1]
            st.setdefault("n_exponent_stiff", {})[I0] = math.log(m2 / m1) / math.log(n2 / n1)
        st["n_fit"][I0] = size_fits(select(rows, ft, I0))
    st["limit"] = limit_statistics(select(rows, ft, cfg.I0_dynamics), cfg)
    for n in cfg.n:
        fr = [r for r in rows if r["protocol"] == "frictional" and r["n"] == n]
        ok = [r for r in fr if r["status"] == "ok"]
        st["frictional"].append({
            "n": n, "n_packings": len(fr), "n_relaxed": len(ok),
            "unstable": sum(1 for r in ok if r["decision_at_zero"] == Decision.COMPLEX),
            "undecided": sum(1 for r in ok if r["decision_at_zero"] == Decision.UNDECIDED),
            "pairs": quartiles([r["n_pairs_at_zero"] for r in ok]),
            "growth": quartiles([r["growth_at_zero"] for r in ok
                                 if r["decision_at_zero"] == Decision.COMPLEX])})
    return st


def size_fits(rows):
    """Power laws in N over the packings of ``rows`` (one convention).

    Returns
    -------
    dict
        ``'F_x_c'``, ``'F_x_c_ss'``, ``'width'`` (F_x^c(mu0) - F_x^c(mu_ss mu0),
        where positive) -> :class:`~remote_trigger.analysis.scaling.PowerLawFit`;
        a quantity whose usable values span fewer than two sizes is absent.
    """
    from remote_trigger.analysis.scaling import power_law_fit

    n = np.array([r["n"] for r in rows], float)
    a = np.array([r["F_x_c"] for r in rows], float)
    b = np.array([r["F_x_c_ss"] for r in rows], float)
    fits = {}
    for key, y in (("F_x_c", a), ("F_x_c_ss", b), ("width", a - b)):
        ok = np.isfinite(y) & (y > 0)
        if np.unique(n[ok]).size >= 2:
            fits[key] = power_law_fit(n, y)
    return fits


# --------------------------------------------------------------------------- outputs
def write_table(path, rows, cfg):
    """``ensemble.h5``: one dataset per column under ``rows/`` (docs/ensemble.md)."""
    from remote_trigger.pywrap.runtime.results import write_atomic

    ds = {}
    for c in COLUMNS:
        vals = [r[c] for r in rows]
        ds[f"rows/{c}"] = (np.array([str(v) for v in vals], dtype=object) if c in STR_COLS
                           else np.asarray(vals, dtype=float))
    attrs = {"stage": "ensemble", "config": json.dumps(cfg.to_dict(), sort_keys=True),
             "I0_dynamics": cfg.I0_dynamics,
             "note": "rows with dynamics_consistent = 0 analyse the equilibria with "
                     "another moment of inertia than the dynamics used (analysis only)",
             "paper_bracket": list(PAPER_BRACKET)}
    if cfg.dim == 3:
        attrs["note"] = "spheres (dim = 3): " + skipped_in_3d()
    write_atomic(path, attrs, ds)


def read_table(path):
    """Rows of ``ensemble.h5`` as a dict of column arrays (strings decoded)."""
    import h5py

    with h5py.File(path, "r") as fh:
        cols = {c: fh["rows/" + c][()] for c in fh["rows"]}
    for c in STR_COLS:
        if c in cols:
            cols[c] = np.array([x.decode() if isinstance(x, bytes) else str(x)
                                for x in cols[c]])
    return cols


def skipped_in_3d():
    """What the ensemble of spheres leaves out, and why (one line, from
    :data:`~remote_trigger.pywrap.jobs.ensemble.config.ONLY_2D`)."""
    return ("the frictional relaxation protocol (" + ONLY_2D["frictional"][1] + ") and the "
            "I0 = 1 re-analysis rows (" + ONLY_2D["inertia_I0"][1] + ")")


def _f(x, f=".4g"):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return format(x, f)


def _q(q, f=".4g", of=None):
    """``median [q25, q75]``, ``-`` if no value; with ``of`` (the packings the
    value is asked of), ``(count of of)`` added where fewer had one (e.g. a
    ramp complex at its start has no F_x^c)."""
    c, a, m, b = q
    if not c:
        return "-"
    more = f" ({c} of {of})" if of is not None and c < of else ""
    return f"{_f(m, f)} [{_f(a, f)}, {_f(b, f)}]{more}"


def _per_size(cfg, name):
    """``cfg.<name>`` as text: one number, or one per N (``0.00025 (N = 100), ...``)."""
    val = getattr(cfg, name)
    if isinstance(val, tuple):
        return ", ".join(f"{v:g} (N = {n})" for v, n in zip(val, cfg.n))
    return f"{val:g}"


def write_summary(path, rows, cfg, st, wall, size, computed):
    """``ensemble.md``: the distributions, the checks and every failure."""
    ft = "frictionless-then-friction"
    n_pk = len(cfg.packings())
    L = ["# Ensemble of packings" + (" of spheres (dim = 3)" if cfg.dim == 3 else ""), "",
         f"{n_pk} packings: " + ", ".join(f"N = {n}: seeds {list(s)}"
                                          for n, s in zip(cfg.n, cfg.seeds))
         + f". mu0 = {cfg.mu:g}, mu_ss mu0 = {cfg.mu * cfg.mu_ss:g}; ramp dF_x = "
         f"{_per_size(cfg, 'dF_x')}"
         + ("" if cfg.between == 1 else
            f", loads between the steps checked: {_per_size(cfg, 'between')} sub-steps per "
            f"step")
         + f", bisection to tol = {_per_size(cfg, 'tol')}, "
         f"F_x_max = {cfg.F_x_max:g}. F_x^c is the midpoint "
         f"of the certified bracket. Values: median [first quartile, third quartile] over the"
         f" packings whose row is not 'failed'.", ""]
    if cfg.dim == 3:
        layer = (cfg.relax or {}).get("top_layer", "free")
        L += [f"Spheres: I0 = {cfg.I0_dynamics:g} (I = 2/5 m R^2, the dynamics' own). "
              + ("The top layer is a rigid plate (top_layer = 'rigid': it translates as one "
                 "body, every sphere with its loads; docs/model.md section 9.1). "
                 if layer == "rigid" else "")
              + f"Skipped in 3D: {skipped_in_3d()}.", ""]
    if cfg.inertia_I0 is not None:
        L += [f"**I0 = {cfg.inertia_I0:g} rows are an analysis convention only**: the same "
              f"equilibria (made by dynamics with I0 = {cfg.I0_dynamics}) analysed with "
              f"I = {cfg.inertia_I0:g} m R^2 in M; their eigenvalues do not predict the "
              f"simulated motion.", ""]
    L += ["## F_x^c by size and convention", "",
          "| N | I0 | packings (usable) | F_x^c(mu0) | F_x^c(mu_ss mu0) | ratio | phi | "
          "slope s | Re lambda_c / lambda_max | pair index | soft-mode onsets | "
          "F_x^c(mu0), stiff onsets only (count) |",
          "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for p in st["per_n"]:
        L.append(f"| {p['n']} | {p['I0']:g} | {p['n_packings']} ({p['n_usable']}) | "
                 f"{_q(p['F_x_c'], of=p['n_usable'])} | {_q(p['F_x_c_ss'], of=p['n_usable'])} | "
                 f"{_q(p['ratio'], of=p['n_usable'])} | "
                 f"{_q(p['phi'])} | {_q(p['slope'])} | {_q(p['pair_re_rel'], '.3g')} | "
                 f"{_q(p['pair_index'], '.3g')} | {p['n_soft']} | "
                 f"{_q(p['F_x_c_stiff'])} ({p['F_x_c_stiff'][0]}) |")
    L.append("")
    if any(0 < p[k][0] < p["n_usable"] for p in st["per_n"] for k in ("F_x_c", "F_x_c_ss")):
        L.append("(k of m): only k of the m usable packings have the value (a ramp complex "
                 "at its first point or undecided throughout has a bracket with one end "
                 "only, and no F_x^c).")
    L += ["slope s: g = s sqrt(F_x - F_x^c) just above onset (g = max Im sqrt(lambda))."]
    if getattr(cfg, "pairs", "all") == "collective":
        L += [f"pairs = 'collective': a soft pair (every eigenvalue of the pair at |Re lambda| "
              f"< {SOFT_MODE_REL:g} lambda_max, two near-floppy modes) does not end a ramp; "
              f"F_x^c is the onset of the first pair that is not soft, and the table has no "
              f"soft-mode onsets."]
        for n in cfg.n:
            rs = select(rows, ft, cfg.I0_dynamics, n, usable=False)
            L.append(f"- N = {n}: a soft pair certified at a load up to F_x^c in "
                     f"{sum(1 for r in rs if math.isfinite(r.get('F_x_soft', math.nan)))} of "
                     f"{len(rs)} mu0 ramps and "
                     f"{sum(1 for r in rs if math.isfinite(r.get('F_x_soft_ss', math.nan)))} of "
                     f"{len(rs)} mu_ss mu0 ramps (columns F_x_soft, F_x_soft_ss: the first "
                     f"load with one).")
    else:
        # (the words of the tables written before pairs = 'collective'; docs/ensemble.md
        # names the option that measures the stiff pairs' onset)
        L += [f"Soft-mode onset: the first certified complex pair has |Re lambda_c| < "
              f"{SOFT_MODE_REL:g} lambda_max -- two near-floppy modes, not two stiff ones (its "
              f"F_x^c is that of the soft pair; the ramp stops there, so the stiff pairs' onset "
              f"is not measured for that packing)."]
    shaped = [p for p in st["per_n"] if p["pair_particles"][0]]
    if shaped:
        # measured since the pair's mode shape exists (tables of older runs: none)
        waves = 2 * LONG_WAVE_M + 1
        L += ["", "## The pair's mode: collective or local", "",
              "| N | I0 | packings measured | particles that move, N PR | local onsets "
              f"| long-wave fraction, abs(m) <= {LONG_WAVE_M} | a random vector's, {waves}/N |",
              "|---|---|---|---|---|---|---|"]
        L += [f"| {p['n']} | {p['I0']:g} | {p['pair_particles'][0]} | "
              f"{_q(p['pair_particles'], '.3g')} | {p['n_local']} | "
              f"{_q(p['pair_longwave'], '.3g')} | {waves / p['n']:.3g} |" for p in shaped]
        L += ["", f"N PR: the participation ratio PR of the translations of the pair's right "
              f"eigenvector at the first load certified complex of the mu0 ramp, times N. "
              f"Local onset: N PR < {LOCAL_PAIR_PARTICLES:g}, a pair carried by a few weakly "
              f"held particles rather than the collective mechanism. Long-wave fraction: the "
              f"part of the same translations in the span of the plane waves exp(i k x), "
              f"k = 2 pi m / L_x, abs(m) <= {LONG_WAVE_M}; 1 for a long plane wave, "
              f"{waves}/N on average for a random vector ('-': not measured, e.g. a run "
              f"whose equilibria are gone)."]
    sad = [(n, [r for r in select(rows, ft, cfg.I0_dynamics, n, usable=False)
                if math.isfinite(r["n_saddle"])]) for n in cfg.n]
    if any(rs for _, rs in sad):
        # recorded since the saddle screen exists (tables of older runs: none)
        L += ["", "## Saddles", "", "| N | packings | points escaped | points left on a saddle "
              "| packings with a bracket end on one |", "|---|---|---|---|---|"]
        L += [f"| {n} | {len(rs)} | {sum(r['n_escaped'] for r in rs):.0f} | "
              f"{sum(r['n_saddle'] for r in rs):.0f} | "
              f"{sum('on a saddle' in r['reason'] for r in rs)} |" for n, rs in sad if rs]
        L += ["", "Both ramps of each packing. A saddle: an equilibrium with a negative "
              "eigenvalue; escaped: Newton's equilibrium was one and damped dynamics replaced "
              "it (docs/driver.md, \"Saddles\")."]
    L += ["", "## N dependence", ""]
    for I0, e in st["n_exponent"].items():
        L.append(f"- I0 = {I0:g}: median F_x^c(mu0) ~ N^{e:.3g} between N = {min(cfg.n)} "
                 f"and N = {max(cfg.n)} (two medians).")
    for I0, e in st.get("n_exponent_stiff", {}).items():
        L.append(f"- I0 = {I0:g}, stiff onsets only: median F_x^c(mu0) ~ N^{e:.3g}.")
    names = {"F_x_c": "F_x^c(mu0)", "F_x_c_ss": f"F_x^c({cfg.mu_ss:g} mu0)",
             "width": "window F_x^c(mu0) - F_x^c(mu_ss mu0) (where > 0)"}
    for I0, fits in st.get("n_fit", {}).items():
        for key, fit in fits.items():
            L.append(f"- I0 = {I0:g}, fit over every packing: {fit.describe(names[key])}.")
    if not st["n_exponent"]:
        L.append("- one size only (or no usable median): no N dependence measured.")
    L += limit_lines(st.get("limit") or {}, [p for p in st["per_n"]
                                             if p["I0"] == cfg.I0_dynamics], cfg)
    L += ["", "## Does F_x^c(mu_ss mu0) < F_x^c(mu0) hold for every packing?", "",
          "Certified: the two brackets do not overlap.", "",
          "| I0 | holds | reversed | not decided | packings | every packing? |",
          "|---|---|---|---|---|---|"]
    for I0, o in st["order"].items():
        every = "yes" if o["holds"] == o["total"] and o["total"] else "no"
        L.append(f"| {I0:g} | {o['holds']} | {o['reversed']} | {o['undecided']} | "
                 f"{o['total']} | {every} |")
    L += ["", "## The paper's bracket in our distribution", ""]
    if cfg.dim == 3:
        L.append("- not compared: the paper's bracket 0.0091-0.012 is of N = 100 disks.")
    for I0, p in st["paper_percentile"].items():
        L.append(f"- I0 = {I0:g}, N = {p['n']} ({p['count']} packings): F_x^c = "
                 f"{PAPER_BRACKET[0]:g} is at the {_f(p['low'], '.3g')}th percentile, "
                 f"{PAPER_BRACKET[1]:g} at the {_f(p['high'], '.3g')}th.")
    if cfg.frictional:
        L += ["", "## Frictional relaxation (friction on during settling)", "",
              "| N | packings | relaxed | unstable at F_x = 0 | undecided | fraction unstable "
              "| certified complex pairs | max Im sqrt(lambda) (unstable ones) |",
              "|---|---|---|---|---|---|---|---|"]
        for f in st["frictional"]:
            frac = f["unstable"] / f["n_relaxed"] if f["n_relaxed"] else math.nan
            L.append(f"| {f['n']} | {f['n_packings']} | {f['n_relaxed']} | {f['unstable']} |"
                     f" {f['undecided']} | {_f(frac, '.3g')} | {_q(f['pairs'], '.3g')} | "
                     f"{_q(f['growth'], '.3g')} |")
        dz = [r for r in select(rows, ft, cfg.I0_dynamics)
              if r["decision_at_zero"] == Decision.COMPLEX]
        L += ["", f"Default protocol: {len(dz)} packing(s) certified complex at F_x = 0."]
    L += ["", "## Packings", "",
          "| key | protocol | I0 | status | phi | F_x^c(mu0) bracket | F_x^c(mu_ss mu0) "
          "bracket | order | at F_x = 0 | reason |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        az = r["decision_at_zero"]
        L.append(f"| {r['key']} | {r['protocol']} | {r['I0']:g} | {r['status']} | "
                 f"{_f(r['phi'])} | [{_f(r['F_x_c_low'], '.6g')}, {_f(r['F_x_c_high'], '.6g')}]"
                 f" | [{_f(r['F_x_c_ss_low'], '.6g')}, {_f(r['F_x_c_ss_high'], '.6g')}] | "
                 f"{ {1: 'holds', 0: 'reversed', -1: '-'}[int(r['order'])] } | "
                 f"{Decision.of(az).label if math.isfinite(az) else '-'} | "
                 f"{r['reason'] or ''} |")
    cpu = sum({r["key"]: r["wall"] for r in rows}.values())
    L += ["", "## Cost", "",
          f"{n_pk} packings; {cpu:.0f} s of packing time in total; this run computed {len(computed)} packing(s) on {size} "
          f"rank(s) in {wall:.0f} s of wall time."]
    write_text_atomic(path, "\n".join(L) + "\n")
