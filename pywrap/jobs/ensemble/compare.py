"""``remote-trigger ensemble --compare DIR [DIR ...] --out OUT``: several finished
ensembles on one figure, e.g. disks and spheres side by side.

``--combine`` merges runs that share every key but the sizes and seeds into
one ensemble. Disks and spheres differ in the dimension, the moment of
inertia and the scene, so their packings belong to different laws; this
command keeps each folder apart and puts their laws side by side:

* ``compare.png``: F_x^c(mu0) / F_y against N (every packing, the median
  and quartiles per N, each folder's power law over its stiff onsets), and
  the ratio F_x^c(mu_ss mu0) / F_x^c(mu0) against N (median and quartiles:
  below 1 where the window of Fig. 5 is open);
* ``compare.md``: per folder, its data set (protocol, convention, sizes,
  packings, the commits, CPUs and clearance tests its rows record) and per N
  the quartiles of F_x^c(mu0) / F_y and of the ratio and the order counts,
  then the power laws over stiff onsets and over every onset.

The rows are those of each folder's ``ensemble.h5`` (default protocol,
the dynamics' moment of inertia, status not ``failed``): nothing is
recomputed. A folder without ``ensemble.h5`` (a run not finished, or a
stored run without its table) is refused; the job writes it when every
packing is finished, so ``ensemble --resume --out DIR`` writes it for a
stored run without computing anything.
"""
import math
import os

import numpy as np

from remote_trigger.analysis.output import savefig_atomic, write_text_atomic
from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.jobs.ensemble.report import quartiles, read_table

__all__ = ["Run", "read_run_rows", "compare_runs"]

#: the files this command writes under --out
OUTPUTS = ("compare.png", "compare.md")
#: the protocol whose packings are compared (the paper's)
PROTOCOL = "frictionless-then-friction"


class Run:
    """The usable rows of one finished ensemble folder.

    Attributes
    ----------
    path : str
        The folder.
    cfg : EnsembleConfig
        Its configuration (``config.json``).
    kind : str
        ``'disks'`` or ``'spheres'`` (``cfg.dim``).
    loading : str
        How the top particles are loaded: ``'free top line'`` (disks, the
        paper's), ``'free top layer'`` or ``'top layer a rigid plate'``
        (spheres, ``[relax] top_layer``; docs/model.md section 9.1).
    label : str
        ``kind`` and ``loading`` with the folder's name (its path where two
        folders share a name: :func:`compare_runs`).
    rows : list of dict
        The table's rows of the default protocol under the dynamics' moment
        of inertia whose status is not ``'failed'`` (columns as ``ensemble.h5``).
    """

    def __init__(self, path, cfg, rows):
        self.path, self.cfg, self.rows = path, cfg, rows
        self.kind = "disks" if cfg.dim == 2 else "spheres"
        layer = (cfg.relax or {}).get("top_layer", "free")
        self.loading = ("free top line" if cfg.dim == 2 else
                        "top layer a rigid plate" if layer == "rigid" else "free top layer")
        self.label = f"{self.kind}, {self.loading} ({os.path.basename(os.path.normpath(path))})"

    def onsets(self):
        """(N, F_x^c(mu0) / F_y, soft) of the packings with a finite positive
        F_x^c: arrays of shape (k,), ``soft`` True for a soft-mode onset."""
        sel = [r for r in self.rows if math.isfinite(r["F_x_c"]) and r["F_x_c"] > 0]
        return (np.array([r["n"] for r in sel], float),
                np.array([r["F_x_c"] for r in sel], float) / self.cfg.F_y,
                np.array([r["soft_onset"] == 1 for r in sel], bool))

    def loads(self, stiff_only=False):
        """(N, F_x^c(mu0) / F_y) of :meth:`onsets`; ``stiff_only``: soft-mode
        onsets left out."""
        n, f, soft = self.onsets()
        keep = ~soft if stiff_only else np.ones(n.size, bool)
        return n[keep], f[keep]


def read_run_rows(path):
    """A :class:`Run` of the ensemble folder ``path``.

    Raises
    ------
    ConfigError
        If ``path`` is not an ensemble folder (no readable ``config.json``)
        or has no ``ensemble.h5``.
    """
    from remote_trigger.pywrap.jobs.ensemble.combine import read_run

    _, cfg = read_run(path, flag="--compare")
    table = os.path.join(path, "ensemble.h5")
    if not os.path.isfile(table):
        raise ConfigError(f"--compare {path!r}: no ensemble.h5 there (the job writes it when "
                          f"every packing is finished: ensemble --resume --out {path})")
    cols = read_table(table)
    rows = [dict(zip(cols, vals)) for vals in zip(*cols.values())]
    rows = [r for r in rows if r["protocol"] == PROTOCOL
            and float(r["I0"]) == float(cfg.I0_dynamics) and r["status"] != "failed"]
    return Run(path, cfg, rows)


def _fit(n, y):
    """power_law_fit over (n, y), or the reason there is none (str)."""
    from remote_trigger.analysis.scaling import power_law_fit

    sizes = np.unique(n)
    if sizes.size < 2:
        return f"{sizes.size} size(s): no law"
    return power_law_fit(n, y)


def _per_n(cfg, name):
    """A per-size key of ``cfg`` as text: one value, or one per N."""
    v = getattr(cfg, name)
    if isinstance(v, (tuple, list)):
        return ", ".join(f"{x:g} (N = {n})" for x, n in zip(v, cfg.n))
    return f"{v:g}"


def _q(x):
    count, q1, m, q3 = quartiles(x)
    return f"{m:.4g} [{q1:.4g}, {q3:.4g}]" if count else "-"


def _fit_text(fit):
    if isinstance(fit, str):
        return fit
    warn = ("; two sizes: a line through two clouds, not a test of a power law"
            if fit.n_sizes == 2 else "")
    return fit.describe("F_x^c / F_y") + warn


def _markdown(runs, fits):
    lines = ["# Ensembles side by side", "",
             "F_x^c / F_y: F_x and F_y are both loads per top particle, so this is the "
             "shear-to-normal stress ratio on the top line (disks) or layer (spheres). Rows: "
             f"protocol `{PROTOCOL}`, the dynamics' moment of inertia, status not 'failed'. "
             "Each folder names its loading of the top particles: laws of different loadings "
             "are side by side here, not one law.",
             ""]
    for run in runs:
        cfg, rows = run.cfg, run.rows
        # ('' or '?': a result of a version that did not record it)
        prov = {k: sorted({str(r[k]) if str(r[k]) not in ("", "?") else "not recorded"
                           for r in rows}) for k in ("commit", "cpu", "clearance")}
        lines += [f"## {run.label}", "",
                  f"Folder `{run.path}`; dim {cfg.dim}, {run.loading}, I0 = "
                  f"{cfg.I0_dynamics:g}, mu0 = {cfg.mu:g}, mu_ss = {cfg.mu_ss:g}, F_y = "
                  f"{cfg.F_y:g}; ramp steps dF_x = {_per_n(cfg, 'dF_x')}"
                  f"{'' if cfg.dF_x_max is None else f' (adaptive, up to {cfg.dF_x_max:g})'}"
                  f", sub-steps per "
                  f"step (`between`) {_per_n(cfg, 'between')}, tol = "
                  f"{_per_n(cfg, 'tol')}; commits "
                  f"{', '.join(prov['commit'])}; CPUs {', '.join(prov['cpu'])}; clearance "
                  f"tests {', '.join(prov['clearance'])}.", "",
                  "| N | packings (soft onsets) | F_x^c(mu0) / F_y | F_x^c(mu_ss mu0) / "
                  "F_x^c(mu0) | order: holds / reversed / undecided |",
                  "|---|---|---|---|---|"]
        for n in sorted({int(r["n"]) for r in rows}):
            sel = [r for r in rows if int(r["n"]) == n]
            soft = sum(1 for r in sel if r["soft_onset"] == 1)
            order = [int(r["order"]) for r in sel]
            lines.append(f"| {n} | {len(sel)} ({soft}) | "
                         f"{_q([r['F_x_c'] / cfg.F_y for r in sel])} | "
                         f"{_q([r['ratio'] for r in sel])} | {order.count(1)} / "
                         f"{order.count(0)} / {order.count(-1)} |")
        lines += ["", f"- stiff onsets: {_fit_text(fits[run.path]['stiff'])}",
                  f"- every onset: {_fit_text(fits[run.path]['all'])}", ""]
    return "\n".join(lines)


def _plot(path, runs, fits):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from remote_trigger.pywrap.jobs.ensemble.figure import STRESS

    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    fig, (a, b) = plt.subplots(1, 2, figsize=(12.5, 4.8))
    for j, run in enumerate(runs):
        c = colors[j % len(colors)]
        n, f, soft = run.onsets()
        a.plot(n[~soft], f[~soft], ".", color=c, alpha=0.45)
        if np.any(soft):
            a.plot(n[soft], f[soft], "x", color=c, alpha=0.8)
        for s in np.unique(n):
            _, q1, m, q3 = quartiles(f[n == s])
            a.errorbar([s], [m], yerr=[[m - q1], [q3 - m]], fmt="o", color=c, capsize=4)
        fit = fits[run.path]["stiff"]
        if isinstance(fit, str):
            a.plot([], [], "o", color=c, label=f"{run.label}: {fit}")
        else:
            x = np.geomspace(fit.sizes[0], fit.sizes[-1], 20)
            a.plot(x, fit.prefactor * x ** fit.exponent, "-", color=c,
                   label=f"{run.label}: N^{fit.exponent:.2f} [{fit.ci[0]:.2f}, "
                         f"{fit.ci[1]:.2f}], stiff onsets")
        sizes = sorted({int(r["n"]) for r in run.rows})
        med = []
        for s in sizes:
            count, q1, m, q3 = quartiles([r["ratio"] for r in run.rows if int(r["n"]) == s])
            if count:
                med.append((s, q1, m, q3))
        if med:
            s, q1, m, q3 = (np.array(v) for v in zip(*med))
            b.errorbar(s, m, yerr=[m - q1, q3 - m], fmt="o-", color=c, capsize=4,
                       label=run.label)
    a.set_xscale("log")
    a.set_yscale("log")
    a.set_xlabel("N")
    a.set_ylabel(STRESS.replace("top line", "top particles"))
    a.set_title("F_x^c(mu0): packings (x: soft-mode onsets), median and quartiles of every\n"
                "onset; lines: the power law over stiff onsets, 95 % interval of its exponent",
                fontsize=9)
    a.legend(fontsize=7)
    b.axhline(1.0, color="k", lw=0.8)
    b.set_xscale("log")
    b.set_xlabel("N")
    b.set_ylabel("F_x^c(mu_ss mu0) / F_x^c(mu0): median, quartiles")
    b.set_title("below 1: the window is open", fontsize=9)
    b.legend(fontsize=7)
    fig.tight_layout()
    savefig_atomic(fig, path, dpi=110)
    plt.close(fig)


def compare_runs(dirs, out, speak=True):
    """``ensemble --compare``: ``compare.png`` and ``compare.md`` in ``out``.

    Parameters
    ----------
    dirs : sequence of str
        Finished (or partly finished) ensemble folders, each with its
        ``ensemble.h5``; at least one.
    out : str
        Output folder (made if missing); ``compare.png`` and ``compare.md``
        must not exist there yet.
    speak : bool
        One line per folder read.

    Returns
    -------
    str
        Path of ``out/compare.md``.

    Raises
    ------
    ConfigError
        If a folder is not an ensemble folder or has no ``ensemble.h5``, a
        folder is given twice, or an output file exists already (nothing is
        written then).
    """
    if not dirs:
        raise ConfigError("--compare: give at least one ensemble folder")
    real = [os.path.realpath(d) for d in dirs]
    for i, d in enumerate(real):
        if d in real[:i]:
            raise ConfigError(f"--compare: {dirs[i]!r} is given twice")
    for name in OUTPUTS:
        p = os.path.join(out, name)
        if os.path.exists(p):
            raise ConfigError(f"--compare: {p!r} exists; give another --out (nothing is "
                              "overwritten)")
    runs = [read_run_rows(d) for d in dirs]
    labels = [run.label for run in runs]
    for run in runs:            # two folders of one name and dimension: their paths
        if labels.count(run.label) > 1:
            run.label = f"{run.kind}, {run.loading} ({run.path})"
    fits = {}
    for run in runs:
        n, f = run.loads(stiff_only=True)
        na, fa = run.loads()
        fits[run.path] = {"stiff": _fit(n, f), "all": _fit(na, fa)}
        if speak:
            print(f"[ensemble] {run.label}: {len(run.rows)} rows, sizes "
                  f"{sorted({int(r['n']) for r in run.rows})}", flush=True)
    os.makedirs(out, exist_ok=True)
    _plot(os.path.join(out, "compare.png"), runs, fits)
    md = os.path.join(out, "compare.md")
    write_text_atomic(md, _markdown(runs, fits) + "\n")
    return md
