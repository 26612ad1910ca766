"""The table of ``remote-trigger accuracy``: its rows (:class:`Row`) and the
outputs -- the markdown table, the HDF5 table and the figure (docs/accuracy.md),
written atomically.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np
from remote_trigger.analysis.output import savefig_atomic, write_text_atomic

#: the sections of the study, in table order
SECTIONS = ("timestep", "relaxation", "jacobian", "eigen", "normal_form")


@dataclass
class Row:
    """One measurement.

    Attributes
    ----------
    section : str
    method : str
    setting : str
    error : float
        Section-specific error (see :mod:`remote_trigger.pywrap.jobs.accuracy.job`);
        NaN if not defined.
    wall_time : float
        Seconds.
    recommended : bool
    note : str
    value : float
        Setting as a number (for plots), NaN if none.
    """

    section: str
    method: str
    setting: str
    error: float
    wall_time: float
    recommended: bool = False
    note: str = ""
    value: float = float("nan")


def markdown_table(rows):
    """The rows as a markdown table (one table, all sections)."""
    lines = ["| section | method | setting | error | wall time (s) | recommended | note |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        err = "—" if not math.isfinite(r.error) else f"{r.error:.2e}"
        wt = "—" if not math.isfinite(r.wall_time) else f"{r.wall_time:.3g}"
        lines.append(f"| {r.section} | {r.method} | {r.setting} | {err} | {wt} | "
                     f"{'**yes**' if r.recommended else ''} | {r.note} |")
    return "\n".join(lines) + "\n"


def write_table(out, rows, ctx=None, attrs=None):
    """Write ``accuracy.md`` and ``accuracy.h5`` (atomically); return their paths."""
    from remote_trigger.analysis.output import write_h5_atomic

    md = os.path.join(out, "accuracy.md")
    head = "# remote-trigger accuracy\n\n"
    if attrs:
        head += ", ".join(f"{k} = {v}" for k, v in attrs.items()) + "\n\n"
    write_text_atomic(md, head + markdown_table(rows))
    enc = lambda xs: np.array([str(x).encode() for x in xs], dtype="S")  # noqa: E731
    ds = {"table/section": enc(r.section for r in rows),
          "table/method": enc(r.method for r in rows),
          "table/setting": enc(r.setting for r in rows),
          "table/note": enc(r.note for r in rows),
          "table/error": np.array([r.error for r in rows], float),
          "table/wall_time": np.array([r.wall_time for r in rows], float),
          "table/value": np.array([r.value for r in rows], float),
          "table/recommended": np.array([r.recommended for r in rows], bool)}
    if ctx is not None:
        ts_ = ctx.extra.get("timestep")
        if ts_:
            for k, r in enumerate(ts_["runs"]):
                ds[f"timestep/run_{k}/t"] = r["t"]
                ds[f"timestep/run_{k}/D"] = r["D"]
                ds[f"timestep/run_{k}/dt"] = np.array(r["dt"])
        for name, (w, r, ph) in ctx.extra.get("relax_series", {}).items():
            ds[f"relaxation/{name}/wall_time"] = w
            ds[f"relaxation/{name}/residual"] = r
            ds[f"relaxation/{name}/phase"] = enc(ph)
    h5 = os.path.join(out, "accuracy.h5")
    a = {"version": 1}
    if attrs:
        a.update({k: v for k, v in attrs.items() if isinstance(v, (int, float, str, bool))})
    if ctx is not None and ctx.extra.get("timestep"):
        a["dt_limit"] = float(ctx.extra["timestep"]["limit"])
        a["growth_rate_eigen"] = float(ctx.extra["timestep"]["g_eig"])
    write_h5_atomic(h5, ds, attrs=a)
    return md, h5


def plot(out, rows, ctx=None):
    """Log-log error vs wall time, one panel per section; ``accuracy.png``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    secs = [s for s in SECTIONS if any(r.section == s for r in rows)]
    extra = 1 if ctx is not None and ctx.extra.get("relax_series") else 0
    fig, axes = plt.subplots(1, len(secs) + extra, figsize=(4.2 * (len(secs) + extra), 3.8),
                             squeeze=False)
    for ax, s in zip(axes[0], secs):
        methods = []
        for r in rows:
            if r.section == s and r.method not in methods:
                methods.append(r.method)
        for m in methods:
            pts = [(r.wall_time, r.error) for r in rows if r.section == s and r.method == m
                   and math.isfinite(r.error) and r.error > 0 and math.isfinite(r.wall_time)
                   and r.wall_time > 0]
            if pts:
                x, y = zip(*pts)
                ax.loglog(x, y, "o-", ms=4, label=m[:34])
        for r in rows:
            if r.section == s and r.recommended and r.error > 0 and math.isfinite(r.error):
                ax.loglog([r.wall_time], [r.error], "k*", ms=12)
        ax.set_title(s)
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel("error")
        ax.legend(fontsize=6)
    if extra:
        ax = axes[0][-1]
        for name, (w, r, _) in ctx.extra["relax_series"].items():
            ax.loglog(np.maximum(w, 1e-3), r, ".-", ms=3, label=name)
        ax.set_title("relaxation: residual vs wall time")
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel("residual r")
        ax.legend(fontsize=7)
    fig.tight_layout()
    path = os.path.join(out, "accuracy.png")
    savefig_atomic(fig, path, dpi=110)
    plt.close(fig)
    return path
