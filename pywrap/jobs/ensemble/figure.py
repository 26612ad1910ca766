"""``ensemble.png``: the figure of the ensemble job (docs/ensemble.md).

Part of :mod:`remote_trigger.pywrap.jobs.ensemble`; the table, statistics
and fits it draws are those of
:mod:`remote_trigger.pywrap.jobs.ensemble.report` and
:mod:`remote_trigger.pywrap.jobs.ensemble.limit`. Loads are drawn as
F_x^c / F_y, the shear-to-normal stress ratio on the top line (both are
loads per top particle).
"""
import math

import numpy as np

from remote_trigger.analysis.output import savefig_atomic
from remote_trigger.pywrap.jobs.ensemble.report import (PAPER_BRACKET, quartiles, select,
                                                        size_fits)
from remote_trigger.pywrap.jobs.ensemble.limit import limit_statistics

__all__ = ["plot"]

#: the axis label of a critical load
STRESS = "F_x^c / F_y (shear / normal stress on the top line)"


def plot(path, rows, cfg, fits=None, limit=None):
    """``ensemble.png``: (top row) F_x^c(mu0) / F_y histograms per N, the ratio,
    F_x^c / F_y vs N, and F_x^c(mu0), F_x^c(mu_ss mu0) and the window width vs N
    with their fits (``fits``: :func:`~remote_trigger.pywrap.jobs.ensemble.report.size_fits`
    of the dynamics' convention, as in
    :func:`~remote_trigger.pywrap.jobs.ensemble.report.statistics`); (bottom row,
    with two sizes or more) the fits by size range and the broken law, the
    local exponents, the distribution at each N against the weakest-link
    picture's, and the pair's size N PR vs N (``limit``:
    :func:`~remote_trigger.pywrap.jobs.ensemble.limit.limit_statistics`). Both
    computed here if not given."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ft = "frictionless-then-friction"
    convs = cfg.conventions()
    i0_dyn = cfg.I0_dynamics
    fy = cfg.F_y
    paper = cfg.dim == 2          # the paper's bracket is of disks
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    limit = limit_statistics(select(rows, ft, i0_dyn), cfg) if limit is None else limit
    fig, axes = plt.subplots(2 if limit else 1, 4, figsize=(18.5, 8.6 if limit else 4.2),
                             squeeze=False)
    ax = axes[0]
    allx = [r["F_x_c"] / fy for r in rows if math.isfinite(r["F_x_c"]) and r["F_x_c"] > 0
            and r["status"] != "failed"]
    ref = [b / fy for b in PAPER_BRACKET] if paper else []
    lo_b = min(allx + ref[:1] or [1e-3]) / 1.3
    hi_b = max(allx + ref[1:] or [1e-3]) * 1.3
    bins = np.geomspace(lo_b, hi_b, 25)
    allr = [r["ratio"] for r in rows if math.isfinite(r["ratio"]) and r["status"] != "failed"]
    rbins = np.linspace(min(allr + [1.0]) - 0.05, max(allr + [1.0]) + 0.05, 25)
    for k, n in enumerate(cfg.n):
        for I0, ls, fill in ((i0_dyn, "-", True), (cfg.inertia_I0, "--", False)):
            if I0 is None:
                continue
            sel = select(rows, ft, float(I0), n)
            for a_, col, b_, scale in ((ax[0], "F_x_c", bins, fy), (ax[1], "ratio", rbins, 1)):
                x = [r[col] / scale for r in sel if math.isfinite(r[col])]
                if x:
                    a_.hist(x, bins=b_, histtype="stepfilled" if fill else "step",
                            alpha=0.35 if fill else 1.0, ls=ls, color=colors[k % len(colors)],
                            label=f"N = {n}, I0 = {I0:g}")
    if paper:
        ax[0].axvspan(*ref, color="k", alpha=0.15, label="paper (N = 100)")
    ax[0].set_xscale("log")
    ax[0].set_xlabel("F_x^c(mu0) / F_y (bracket midpoint)" + ("" if paper else ", spheres"))
    ax[0].set_ylabel("packings")
    ax[0].legend(fontsize=7)
    ax[1].axvline(1.0, color="k", lw=0.8)
    ax[1].set_xlabel(f"F_x^c(mu_ss mu0) / F_x^c(mu0), mu_ss = {cfg.mu_ss:g}")
    if ax[1].get_legend_handles_labels()[0]:     # no usable packing: no legend
        ax[1].legend(fontsize=7)
    soft_label = "soft-mode onset"      # in the legend once, not once a size
    for j, I0 in enumerate(convs):
        for n in cfg.n:
            x = [r["F_x_c"] / fy for r in select(rows, ft, I0, n) if math.isfinite(r["F_x_c"])]
            if not x:
                continue
            shift = 1.0 + 0.04 * j
            ax[2].plot([n * shift] * len(x), x, ".", color=colors[j], alpha=0.5)
            soft = [r["F_x_c"] / fy for r in select(rows, ft, I0, n)
                    if math.isfinite(r["F_x_c"]) and r["soft_onset"] == 1]
            if soft:
                ax[2].plot([n * shift] * len(soft), soft, "x", color=colors[j], ms=7,
                           label=soft_label if j == 0 else None)
                if j == 0:
                    soft_label = None
            c, q1, m, q3 = quartiles(x)
            ax[2].errorbar([n * shift], [m], yerr=[[m - q1], [q3 - m]], fmt="o",
                           color=colors[j], capsize=4,
                           label=f"I0 = {I0:g}" + (" (analysis only)" if I0 != i0_dyn
                                                   else "") if n == cfg.n[0] else None)
    if paper:
        ax[2].fill_between([90, 110], *ref, color="k", alpha=0.15, label="paper")
    ax[2].set_xscale("log")
    ax[2].set_yscale("log")
    ax[2].set_xlabel("N")
    ax[2].set_ylabel("F_x^c(mu0) / F_y: packings, median, quartiles")
    if ax[2].get_legend_handles_labels()[0]:
        ax[2].legend(fontsize=7)
    _plot_window(ax[3], select(rows, ft, float(i0_dyn)), cfg, colors, fits)
    if limit:
        _plot_limit(axes[1], select(rows, ft, float(i0_dyn)), cfg, colors, limit)
    fig.tight_layout()
    savefig_atomic(fig, path, dpi=110)
    plt.close(fig)


def _plot_window(ax, rows, cfg, colors, fits=None):
    """F_x^c(mu0), F_x^c(mu_ss mu0) and the window width vs N (the dynamics'
    convention): median and quartiles per N, the power-law fit over every
    packing (:func:`~remote_trigger.pywrap.jobs.ensemble.report.size_fits`) as a line
    where there are two sizes or more."""
    fits = size_fits(rows) if fits is None else fits
    n = np.array([r["n"] for r in rows], float)
    a = np.array([r["F_x_c"] for r in rows], float) / cfg.F_y
    b = np.array([r["F_x_c_ss"] for r in rows], float) / cfg.F_y
    for j, (key, y, label) in enumerate((("F_x_c", a, "F_x^c(mu0)"),
                                         ("F_x_c_ss", b, f"F_x^c({cfg.mu_ss:g} mu0)"),
                                         ("width", a - b, "window F_x^c(mu0) - "
                                                          f"F_x^c({cfg.mu_ss:g} mu0), where "
                                                          "> 0 (a selection)"))):
        ok = np.isfinite(y) & (y > 0)
        for k, size in enumerate(sorted(set(n[ok].tolist()))):
            c, q1, m, q3 = quartiles(y[ok & (n == size)])
            ax.errorbar([size * (1.0 + 0.04 * j)], [m], yerr=[[m - q1], [q3 - m]], fmt="os^"[j],
                        color=colors[j], capsize=4, label=label if k == 0 else None)
        fit = fits.get(key)
        if fit is not None:
            x = np.geomspace(fit.sizes[0], fit.sizes[-1], 20)
            ax.plot(x, fit.prefactor / cfg.F_y * x ** fit.exponent, "-", lw=0.8, color=colors[j],
                    label=f"fit: N^{fit.exponent:.2f}" + (f" +- {fit.stderr:.2f}" if
                                                         np.isfinite(fit.stderr) else ""))
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("N")
    ax.set_ylabel(f"F_x^c / F_y: median and quartiles (I0 = {cfg.I0_dynamics:g})")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7)


def _plot_limit(ax, rows, cfg, colors, st):
    """The bottom row: fits by range and the broken law, local exponents, the
    distribution at each N against the weakest-link picture, N PR vs N."""
    from scipy import stats

    n = np.array([r["n"] for r in rows], float)
    f = np.array([r["F_x_c"] for r in rows], float) / cfg.F_y
    soft = np.array([r["soft_onset"] for r in rows])
    ok = np.isfinite(f) & (f > 0)
    sizes = sorted({int(v) for v in n[ok]})
    # (e) every packing, stiff and soft, with the fits of the two ends' ranges
    a = ax[0]
    a.plot(n[ok & (soft == 0)], f[ok & (soft == 0)], ".", color="0.5", alpha=0.6,
           label="stiff onsets")
    if np.any(ok & (soft == 1)):
        a.plot(n[ok & (soft == 1)], f[ok & (soft == 1)], "x", color="k", label="soft-mode onsets")
    fits = {(on, r): v for d, on, r, v in st["fits"] if d == "every packing"}
    ranges = [(f"N = {sizes[0]}-{sizes[-1]}", "--")]
    if len(sizes) >= 4:          # the first three sizes, and all but the first
        ranges += [(f"N = {sizes[0]}-{sizes[2]}", "-"), (f"N = {sizes[1]}-{sizes[-1]}", "-")]
    for j, (key, ls) in enumerate(ranges):
        fit = fits.get(("all onsets", key))
        if fit is None or isinstance(fit, str):
            continue
        x = np.geomspace(fit.sizes[0], fit.sizes[-1], 20)
        a.plot(x, fit.prefactor * x ** fit.exponent, ls, color=colors[j], lw=1.2,
               label=f"{key}: N^{fit.exponent:.2f} [{fit.ci[0]:.2f}, {fit.ci[1]:.2f}]")
    t = st["crossover"].get("all onsets")
    if t is not None and not isinstance(t, str):
        x = np.geomspace(sizes[0], sizes[-1], 60)
        y = t.break_value * (x / t.break_n) ** np.where(x < t.break_n, t.exponent_below,
                                                        t.exponent_above)
        a.plot(x, y, ":", color="k", lw=1.2,
               label=f"broken law ({t.exponent_below:.2f} / {t.exponent_above:.2f}), "
                     f"p = {t.p_value:.2g}")
    _finish(a, "N", STRESS if cfg.dim == 2 else STRESS.replace("top line", "top layer"),
            bool(np.any(ok)), logy=True)
    # (f) local exponents with their intervals, and the single law's band
    a = ax[1]
    for j, (on, sl) in enumerate(st["local"].items()):
        if isinstance(sl, str):
            continue
        x = np.array([math.sqrt(s.n_low * s.n_high) for s in sl]) * (1.0 + 0.05 * j)
        y = np.array([s.slope for s in sl])
        err = np.array([[s.slope - s.ci[0] for s in sl], [s.ci[1] - s.slope for s in sl]])
        a.errorbar(x, y, yerr=err, fmt="os"[j % 2], color=colors[j], capsize=3,
                   label=f"median to median, {on}")
    whole = fits.get(("all onsets", f"N = {sizes[0]}-{sizes[-1]}"))
    if whole is not None and not isinstance(whole, str):
        a.axhspan(*whole.ci, color=colors[0], alpha=0.15,
                  label=f"one law over all N, all onsets: {whole.exponent:.2f}")
    a.axhline(-1.0, color="k", lw=0.6, ls="--", label="1/N")
    _finish(a, "N (geometric mean of the pair of sizes)", "local exponent d ln F_x^c / d ln N",
            any(not isinstance(sl, str) and sl for sl in st["local"].values()))
    # (g) the distribution at each N, scaled by its median, against Weibull laws
    a = ax[2]
    w = st["weakest"].get("stiff onsets")
    drawn = False
    for j, s in enumerate(sizes):
        x = np.sort(f[ok & (soft == 0) & (n == s)])
        if x.size >= 3:
            drawn = True
            x = x / np.median(x)
            a.step(x, (np.arange(x.size) + 0.5) / x.size, where="mid", color=colors[j % 10],
                   label=f"N = {s} ({x.size}), stiff onsets")
    if w is not None and not isinstance(w, str):
        grid = np.geomspace(0.02, 5.0, 200)
        for k, ls, what in ((w.shape, "-", f"Weibull k = {w.shape:.2f} (fitted, one shape)"),
                            (-1.0 / w.exponent, "--",
                             f"Weibull k = {-1 / w.exponent:.2f}: sites ~ N with the "
                             f"exponent {w.exponent:.2f}")):
            lam = math.log(2.0) ** (-1.0 / k)       # median 1
            a.plot(grid, stats.weibull_min.cdf(grid, k, scale=lam), ls, color="k", lw=1.0,
                   label=what)
    _finish(a, "F_x^c / its median at that N", "fraction of packings below", drawn)
    # (h) the pair's size
    a = ax[3]
    pp = np.array([r["pair_particles"] for r in rows], float)
    good = np.isfinite(pp)
    a.plot(n[good & (soft == 0)], pp[good & (soft == 0)], ".", color="0.4",
           label="stiff onsets")
    if np.any(good & (soft == 1)):
        a.plot(n[good & (soft == 1)], pp[good & (soft == 1)], "x", color="k",
               label="soft-mode onsets")
    fit = st["pair"]
    if not isinstance(fit, str):
        x = np.geomspace(fit.sizes[0], fit.sizes[-1], 20)
        a.plot(x, fit.prefactor * x ** fit.exponent, "-", color=colors[0],
               label=f"N PR ~ N^{fit.exponent:.2f} [{fit.ci[0]:.2f}, {fit.ci[1]:.2f}]")
    a.axhline(1.0, color="k", lw=0.6, ls="--", label="one disk (a local weakest link)")
    _finish(a, "N", "particles the pair moves, N PR", bool(np.any(good)), logy=True)


def _finish(a, xlabel, ylabel, has_data, logy=False):
    """Labels, log axes and legend of a bottom-row panel; a panel without data
    says so (too few sizes or values for it) and keeps linear axes."""
    a.set_xlabel(xlabel)
    a.set_ylabel(ylabel)
    if not has_data:
        a.text(0.5, 0.5, "too few sizes or values", ha="center", va="center",
               transform=a.transAxes, fontsize=8)
        return
    a.set_xscale("log")
    if logy:
        a.set_yscale("log")
    if a.get_legend_handles_labels()[0]:
        a.legend(fontsize=6.5)
