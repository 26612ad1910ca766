"""``ensemble.png``: the figure of the ensemble job (docs/ensemble.md).

Part of :mod:`remote_trigger.pywrap.jobs.ensemble`; the table, statistics
and fits it draws are those of
:mod:`remote_trigger.pywrap.jobs.ensemble.report`.
"""
import math

import numpy as np

from remote_trigger.analysis.output import savefig_atomic
from remote_trigger.pywrap.jobs.ensemble.report import (PAPER_BRACKET, quartiles, select,
                                                        size_fits)

__all__ = ["plot"]


def plot(path, rows, cfg, fits=None):
    """``ensemble.png``: F_x^c(mu0) histograms per N, the ratio, F_x^c vs N, and
    F_x^c(mu0), F_x^c(mu_ss mu0) and the window width vs N with their fits
    (``fits``: :func:`~remote_trigger.pywrap.jobs.ensemble.report.size_fits` of the
    dynamics' convention, as in
    :func:`~remote_trigger.pywrap.jobs.ensemble.report.statistics`; computed here if
    not given)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ft = "frictionless-then-friction"
    convs = cfg.conventions()
    i0_dyn = cfg.I0_dynamics
    paper = cfg.dim == 2          # the paper's bracket is of disks
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    fig, ax = plt.subplots(1, 4, figsize=(18.5, 4.2))
    allx = [r["F_x_c"] for r in rows if math.isfinite(r["F_x_c"]) and r["F_x_c"] > 0
            and r["status"] != "failed"]
    ref = list(PAPER_BRACKET) if paper else []
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
            for a_, col, b_ in ((ax[0], "F_x_c", bins), (ax[1], "ratio", rbins)):
                x = [r[col] for r in sel if math.isfinite(r[col])]
                if x:
                    a_.hist(x, bins=b_, histtype="stepfilled" if fill else "step",
                            alpha=0.35 if fill else 1.0, ls=ls, color=colors[k % len(colors)],
                            label=f"N = {n}, I0 = {I0:g}")
    if paper:
        ax[0].axvspan(*PAPER_BRACKET, color="k", alpha=0.15, label="paper (N = 100)")
    ax[0].set_xscale("log")
    ax[0].set_xlabel("F_x^c(mu0) (bracket midpoint)" + ("" if paper else ", spheres"))
    ax[0].set_ylabel("packings")
    ax[0].legend(fontsize=7)
    ax[1].axvline(1.0, color="k", lw=0.8)
    ax[1].set_xlabel(f"F_x^c(mu_ss mu0) / F_x^c(mu0), mu_ss = {cfg.mu_ss:g}")
    if ax[1].get_legend_handles_labels()[0]:     # no usable packing: no legend
        ax[1].legend(fontsize=7)
    soft_label = "soft-mode onset"      # in the legend once, not once a size
    for j, I0 in enumerate(convs):
        for n in cfg.n:
            x = [r["F_x_c"] for r in select(rows, ft, I0, n) if math.isfinite(r["F_x_c"])]
            if not x:
                continue
            shift = 1.0 + 0.04 * j
            ax[2].plot([n * shift] * len(x), x, ".", color=colors[j], alpha=0.5)
            soft = [r["F_x_c"] for r in select(rows, ft, I0, n)
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
        ax[2].fill_between([90, 110], *PAPER_BRACKET, color="k", alpha=0.15, label="paper")
    ax[2].set_xscale("log")
    ax[2].set_yscale("log")
    ax[2].set_xlabel("N")
    ax[2].set_ylabel("F_x^c(mu0): packings, median and quartiles")
    if ax[2].get_legend_handles_labels()[0]:
        ax[2].legend(fontsize=7)
    _plot_window(ax[3], select(rows, ft, float(i0_dyn)), cfg, colors, fits)
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
    a = np.array([r["F_x_c"] for r in rows], float)
    b = np.array([r["F_x_c_ss"] for r in rows], float)
    for j, (key, y, label) in enumerate((("F_x_c", a, "F_x^c(mu0)"),
                                         ("F_x_c_ss", b, f"F_x^c({cfg.mu_ss:g} mu0)"),
                                         ("width", a - b, "window F_x^c(mu0) - "
                                                          f"F_x^c({cfg.mu_ss:g} mu0) > 0"))):
        ok = np.isfinite(y) & (y > 0)
        for k, size in enumerate(sorted(set(n[ok].tolist()))):
            c, q1, m, q3 = quartiles(y[ok & (n == size)])
            ax.errorbar([size * (1.0 + 0.04 * j)], [m], yerr=[[m - q1], [q3 - m]], fmt="os^"[j],
                        color=colors[j], capsize=4, label=label if k == 0 else None)
        fit = fits.get(key)
        if fit is not None:
            x = np.geomspace(fit.sizes[0], fit.sizes[-1], 20)
            ax.plot(x, fit.prefactor * x ** fit.exponent, "-", lw=0.8, color=colors[j],
                    label=f"fit: N^{fit.exponent:.2f}" + (f" +- {fit.stderr:.2f}" if
                                                         np.isfinite(fit.stderr) else ""))
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("N")
    ax.set_ylabel(f"median and quartiles (I0 = {cfg.I0_dynamics:g})")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7)
