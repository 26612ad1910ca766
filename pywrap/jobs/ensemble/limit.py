"""The size dependence of ``ensemble.md``: what data set a fit is made on, fits by
size range with the stiff onsets apart, a test of one power law, the
weakest-link test, and whether the window survives as N grows.

The numbers come from :mod:`remote_trigger.analysis.scaling` and
:mod:`remote_trigger.analysis.weakest_link`; this module selects the rows
(the dynamics' convention only), names the data set each number is made on
and writes the lines. F_x^c is given as F_x^c / F_y: both are loads per top
particle (docs/model.md section 4), so the ratio is the shear-to-normal
stress ratio on the top line; the total tangential load is N_top F_x^c.
"""
import math

import numpy as np

__all__ = ["provenance", "limit_statistics", "limit_lines"]

#: what a row records of its packing's computation: column -> meaning
PROVENANCE = {"clearance": "clearance test of the relaxation ('all' or 'local')",
              "cpu": "CPU model", "blas": "BLAS kernel set(s)",
              "commit": "source commit"}


def _env_text(env):
    """(cpu, blas, commit) of one recorded environment."""
    cpu = env.get("cpu") or "?"
    arch = sorted({b.get("architecture") or "?" for b in env.get("blas") or []})
    blas = "/".join(arch) if arch else "?"
    if env.get("openblas_coretype"):
        blas += " (forced)"
    src = env.get("source") or {}
    commit = (src["commit"][:10] + ("+modified" if src.get("modified") else "")
              if src.get("commit") else "")
    return cpu, blas, commit


def provenance(result):
    """What a packing's result was computed with, as the table's text columns.

    Parameters
    ----------
    result : dict
        A packing's result (``tasks/<key>.json``'s ``result``).

    Returns
    -------
    dict
        ``clearance``: the relaxation's clearance test ('all' for results
        that predate the record, which were all relaxed by it); ``cpu``,
        ``blas`` (kernel sets; "(forced)" where ``OPENBLAS_CORETYPE`` chose
        them), ``commit`` (10 hex digits, "+modified" if the tree differed):
        over every environment the result records (each stage's and the
        packing's), distinct values joined by " + "; "" where none is
        recorded.
    """
    d = result.get("default") or {}
    envs = [d.get("environment")] + [(p or {}).get("environment")
                                      for p in (d.get("ramps") or {}).values()]
    envs += [(result.get("frictional") or {}).get("environment"), result.get("environment")]
    texts = [_env_text(e) for e in envs if e]
    out = {"clearance": d.get("clearance_rule") or "all"}
    for j, key in enumerate(("cpu", "blas", "commit")):
        vals = sorted({t[j] for t in texts if t[j]})
        out[key] = " + ".join(vals)
    return out


# --------------------------------------------------------------------------- statistics
def _ranges(sizes):
    """(label, sizes) of every run of three or more neighbouring sizes, longest
    first, the whole range first of all."""
    m = len(sizes)
    out = [(f"N = {sizes[0]}-{sizes[-1]}", tuple(sizes))] if m >= 2 else []
    for length in range(m - 1, 2, -1):
        for i in range(m - length + 1):
            part = tuple(sizes[i:i + length])
            out.append((f"N = {part[0]}-{part[-1]}", part))
    return out


def _try(fun, *args, **kw):
    """fun(*args, **kw), or the ValueError's message (too few values)."""
    try:
        return fun(*args, **kw)
    except ValueError as exc:
        return str(exc)


def _machine(r):
    """'cpu, blas' of a row, or 'environment not recorded'."""
    return ", ".join(x for x in (r.get("cpu", ""), r.get("blas", "")) if x) or \
        "environment not recorded"


def limit_statistics(rows, cfg):
    """The numbers of ``ensemble.md``'s size-dependence sections.

    Parameters
    ----------
    rows : list of dict
        Table rows (:func:`.report.rows_of`) of one protocol and convention
        (the report passes the default protocol under the dynamics'
        convention, rows not 'failed').
    cfg : EnsembleConfig

    Returns
    -------
    dict
        ``sets`` (per N: packings, usable ones, soft onsets, and the counts
        of each provenance value), ``fits`` (list of (data set, onsets,
        sizes, PowerLawFit or the reason there is none) of F_x^c / F_y:
        every packing over each run of three or more neighbouring sizes, and
        the packings of one clearance test or one machine where the rows
        have several), ``total`` ({onsets: fit of N_top F_x^c / F_y}),
        ``n_top`` ({N: N_top}), ``local``, ``crossover`` and ``weakest``
        ({onsets: result or the reason there is none}), ``spread`` (per N:
        standard deviation of ln F_x^c, all and stiff onsets), ``pair`` (fit
        of N PR over the stiff onsets), ``pair_soft`` (N PR of the soft
        onsets), ``soft``, ``window`` and ``window_stiff``
        (:class:`~remote_trigger.analysis.scaling.FractionBySize` of soft
        onsets, and of the window among the decided packings, all and with a
        stiff mu0 onset) and ``window_rank`` (Spearman's rho of 1 -
        F_x^c(mu_ss mu0) / F_x^c(mu0) with N over every decided packing, its
        p-value, the count). Empty with fewer than two sizes.
    """
    from scipy import stats
    from remote_trigger.analysis.scaling import (
        crossover_test, fraction_by_size, local_slopes, power_law_fit)
    from remote_trigger.analysis.weakest_link import weakest_link_test
    from remote_trigger.pywrap.stages.packing import box_width, top_count

    if len({r["n"] for r in rows}) < 2:
        return {}
    n = np.array([r["n"] for r in rows], float)
    f = np.array([r["F_x_c"] for r in rows], float) / cfg.F_y
    soft = np.array([r["soft_onset"] for r in rows])
    usable = np.isfinite(f) & (f > 0)
    stiff = usable & (soft == 0)
    sizes = sorted({int(v) for v in n[usable]})
    st = {"sets": [], "fits": [], "total": {}, "local": {}, "crossover": {}, "weakest": {},
          "spread": []}
    for s in sorted({int(v) for v in n}):
        rs = [r for r in rows if r["n"] == s]
        st["sets"].append({"n": s, "packings": len(rs),
                           "usable": int(np.sum(usable & (n == s))),
                           "soft": sum(r["soft_onset"] == 1 for r in rs),
                           "clearance": _counts(r.get("clearance", "") for r in rs),
                           "machine": _counts(_machine(r) for r in rs),
                           "commit": _counts(r.get("commit", "") for r in rs)})
        st["spread"].append((s, _sd(np.log(f[usable & (n == s)])),
                             _sd(np.log(f[stiff & (n == s)]))))
    onsets = (("all onsets", usable), ("stiff onsets", stiff))
    for label, part in _ranges(sizes):
        inside = np.isin(n, part)
        for on, mask in onsets:
            st["fits"].append(("every packing", on, label,
                               _try(power_law_fit, n[mask & inside], f[mask & inside])))
    for what, key in (("clearance '{}'", lambda r: r.get("clearance", "")),
                      ("{}", _machine)):
        values = np.array([key(r) for r in rows], dtype=object)
        if len(set(values[usable])) < 2:
            continue               # one protocol (or machine): the fits above
        for v in sorted(set(values[usable])):
            for on, mask in onsets:
                m2 = mask & (values == v)
                part = sorted({int(x) for x in n[m2]})
                if len(part) >= 2:
                    st["fits"].append((what.format(v), on, "N = " + ", ".join(map(str, part)),
                                       _try(power_law_fit, n[m2], f[m2])))
    st["n_top"] = {s: int(top_count(box_width(s, cfg.phi, dim=cfg.dim), dim=cfg.dim))
                   for s in sorted({int(v) for v in n})}
    ntop = np.array([st["n_top"][int(v)] for v in n], float)
    for on, mask in onsets:
        st["total"][on] = _try(power_law_fit, n[mask], ntop[mask] * f[mask])
        st["local"][on] = _try(local_slopes, n[mask], f[mask])
        st["crossover"][on] = _try(crossover_test, n[mask], f[mask])
        st["weakest"][on] = _try(weakest_link_test, n[mask], f[mask])
    pp = np.array([r["pair_particles"] for r in rows], float)
    st["pair"] = _try(power_law_fit, n[stiff], pp[stiff])
    st["pair_soft"] = sorted(float(v) for v in pp[(soft == 1) & np.isfinite(pp)])
    known = soft >= 0
    st["soft"] = _try(fraction_by_size, n[known], soft[known] == 1)
    order = np.array([r["order"] for r in rows])
    dec = order >= 0
    st["window"] = _try(fraction_by_size, n[dec], order[dec] == 1)
    st["window_stiff"] = _try(fraction_by_size, n[dec & (soft == 0)],
                              order[dec & (soft == 0)] == 1)
    w = 1.0 - np.array([r["ratio"] for r in rows], float)
    dec &= np.isfinite(w)
    if len(set(n[dec])) >= 2:
        rho = stats.spearmanr(n[dec], w[dec])
        st["window_rank"] = (float(rho.statistic), float(rho.pvalue), int(dec.sum()))
    return st


def _counts(values):
    """{value: count}, '' as 'not recorded'."""
    out = {}
    for v in values:
        v = v or "not recorded"
        out[v] = out.get(v, 0) + 1
    return out


def _sd(x):
    return float(np.std(x, ddof=1)) if x.size > 1 else math.nan


# --------------------------------------------------------------------------- text
def _ci(c):
    return f"[{c[0]:.3g}, {c[1]:.3g}]" if all(math.isfinite(v) for v in c) else "-"


def _fit_cells(fit):
    if isinstance(fit, str):
        return f"- | - | - | {fit} |"
    se = f"{fit.stderr:.2g}" if math.isfinite(fit.stderr) else "-"
    return (f"{fit.exponent:.3g} | {_ci(fit.ci)} | {se} | {fit.n_points} values "
            f"({', '.join(str(c) for c in fit.counts)}) |")


def limit_lines(st, per_n, cfg):
    """``ensemble.md``'s lines of :func:`limit_statistics` (a list of str; empty
    without statistics); ``per_n``: the report's statistics per N of the same
    convention (the relative window's quartiles, ``window_rel`` and
    ``window_rel_pos``)."""
    if not st:
        return []
    fy = f"F_x^c / F_y (F_y = {cfg.F_y:g})"
    L = ["", "## Data set", "",
         f"Every number below is of the default protocol's rows (I0 = {cfg.I0_dynamics:g}, "
         f"pairs = '{getattr(cfg, 'pairs', 'all')}'); the columns name what each packing was "
         f"computed with, as its result records it ('not recorded': a result of a version "
         f"that did not record it).", "",
         "| N | packings (usable) | soft-mode onsets | relaxation: clearance test | CPU, BLAS "
         "kernels | commit |", "|---|---|---|---|---|---|"]
    for s in st["sets"]:
        L.append(f"| {s['n']} | {s['packings']} ({s['usable']}) | {s['soft']} | "
                 f"{_cell(s['clearance'])} | {_cell(s['machine'])} | {_cell(s['commit'])} |")
    L += ["", "## Size dependence: fits by data set and size range", "",
          f"{fy}: the ratio of two loads per top particle, i.e. the shear-to-normal stress "
          f"ratio on the top {'line' if cfg.dim == 2 else 'layer'}. Least squares on ln y; "
          f"95 % bootstrap interval of the "
          f"exponent (packings resampled within each size). Stiff onsets: the rows whose "
          f"first pair is not a soft-mode pair.", "",
          "| data set | onsets | sizes | exponent of F_x^c / F_y | 95 % interval | s.e. | "
          "values (per size) |", "|---|---|---|---|---|---|---|"]
    for data, on, rng, fit in st["fits"]:
        L.append(f"| {data} | {on} | {rng} | " + _fit_cells(fit))
    tot = ", ".join(f"N = {k}: {v}" for k, v in st["n_top"].items())
    L += ["", f"Total tangential load N_top F_x^c / F_y (N_top: {tot}):", ""]
    for on, fit in st["total"].items():
        L.append(f"- {on}: " + (fit.describe("N_top F_x^c / F_y") if not isinstance(fit, str)
                                else fit) + ".")
    L += ["", "Local exponents, median to median (95 % bootstrap interval of the medians):", "",
          "| onsets | " + " | ".join(
              f"{s.n_low}-{s.n_high}" for s in _first_slopes(st["local"])) + " |",
          "|---|" + "---|" * len(_first_slopes(st["local"]))]
    for on, sl in st["local"].items():
        if isinstance(sl, str):
            continue
        L.append(f"| {on} | " + " | ".join(f"{s.slope:.3g} {_ci(s.ci)} ({s.counts[0]}, "
                                          f"{s.counts[1]})" for s in sl) + " |")
    L += ["", "One power law against a broken one:", ""]
    for on, t in st["crossover"].items():
        L.append(f"- {on}: " + (t if isinstance(t, str) else t.describe()) + ".")
    L += _weakest_lines(st)
    L += _window_lines(st, per_n)
    return L


def _cell(counts):
    return ", ".join(f"{k} ({v})" for k, v in sorted(counts.items()))


def _first_slopes(local):
    for sl in local.values():
        if not isinstance(sl, str):
            return sl
    return ()


def _weakest_lines(st):
    L = ["", "## Is it a weakest link? The extreme-value test", "",
         "If F_x^c were the smallest of M ~ N^a independent local thresholds with a "
         "power-law lower tail, F_x^c at each N would follow a Weibull law of one shape k at "
         "every N (its scale shrinking as its median) and F_x^c ~ N^(-a/k), with a = 1 for "
         "sites in proportion to N (analysis.weakest_link); the coalescing pair would be "
         "local, N PR independent of N.", ""]
    for on, t in st["weakest"].items():
        if isinstance(t, str):
            L.append(f"- {on}: {t}.")
            continue
        shapes = ", ".join(f"{k:.3g}" if math.isfinite(k) else "-" for k in t.shapes)
        L.append(f"- {on}: {t.describe()}. Shape at each N alone: {shapes}; normal "
                 f"(one coefficient of variation) log-likelihood {t.loglik['normal']:.4g}.")
    L += ["", "| N | sd of ln F_x^c, all onsets | stiff onsets |", "|---|---|---|"]
    L += [f"| {s} | {a:.3g} | {b:.3g} |" for s, a, b in st["spread"]]
    p = st["pair"]
    L += ["", "- The pair's size, stiff onsets: " + (p if isinstance(p, str) else
                                                     p.describe("N PR")) + "."]
    if st["pair_soft"]:
        L.append(f"- Soft-mode onsets: N PR {', '.join(f'{v:.3g}' for v in st['pair_soft'])}"
                 " (local: one or two disks).")
    L += _fraction_line("soft-mode onsets among the packings with a first pair", st["soft"])
    return L


def _fraction_line(what, fr):
    if isinstance(fr, str):
        return [f"- {what}: {fr}."]
    per = ", ".join(f"{p} of {t} {_ci(c)} (N = {s})" for s, p, t, c in
                    zip(fr.sizes, fr.present, fr.totals, fr.ci))
    z = f"{fr.trend_z:.3g}" if math.isfinite(fr.trend_z) else "-"
    return [f"- {what}: {per} (exact 95 % intervals); trend in ln N: z = {z}, p = "
            f"{fr.trend_p:.3g} ({fr.n_permutations} permutations)."]


def _window_lines(st, per_n):
    L = ["", "## Does the window survive as N grows?", "",
         "The window F_x^c(mu_ss mu0) < F_x^c(mu0), certified (disjoint brackets), among "
         "the decided packings:", ""]
    L += _fraction_line("all onsets", st["window"])
    L += _fraction_line("stiff mu0 onsets", st["window_stiff"])
    L += ["", "Its width relative to F_x^c(mu0), 1 - F_x^c(mu_ss mu0) / F_x^c(mu0) "
          "(midpoints), over every decided packing (negative where reversed), and where "
          "> 0 only (a selection: the packings with a window):", "",
          "| N | every decided packing: median [quartiles] (count) | where > 0: median "
          "(count) |", "|---|---|---|"]
    for p in per_n:
        q_all, q_pos = p["window_rel"], p["window_rel_pos"]
        if q_all[0]:
            L.append(f"| {p['n']} | {q_all[2]:.3g} [{q_all[1]:.3g}, {q_all[3]:.3g}] "
                     f"({q_all[0]}) | " + (f"{q_pos[2]:.3g} ({q_pos[0]})" if q_pos[0] else "-")
                     + " |")
    if "window_rank" in st:
        rho, p, c = st["window_rank"]
        L += ["", f"Rank correlation of the relative width with N, every decided packing: "
                  f"Spearman rho = {rho:.3g}, p = {p:.3g} ({c} packings)."]
    return L
