"""Outputs of ``remote-trigger trigger-map``: the table of map points
(``trigger_map.h5``), the figure and ``trigger_map.md``, made on rank 0 from
the task logs (:mod:`remote_trigger.pywrap.jobs.trigger_map.job`)."""
import json
import math
import os

import numpy as np

from remote_trigger.analysis.output import savefig_atomic, write_text_atomic
from remote_trigger.analysis.dynamics.series import RUNAWAY_RATE_TOL, RUNAWAY_MIN_RECORDS
from remote_trigger.pywrap.jobs.trigger_map.loads import predicted_rate
from remote_trigger.pywrap.runtime.jobfolder import read_json

#: a bracketed point whose triggering run reached D_run after this fraction of
#: t_max is flagged ``marginal`` (its a_c is t_max-limited)
MARGINAL = 0.95


def collect(out, tasks, setup):
    """One row per threshold task (with its control's verdict)."""
    logs = {}
    for t in tasks:
        logs[t["key"]] = read_json(os.path.join(out, "tasks", t["key"] + ".json"))
    taus = [None] + list(setup["taus"])
    rows = []
    for t in tasks:
        if t["kind"] != "threshold":
            continue
        d = logs[t["key"]]
        if d.get("status") == "failed":
            d = dict(d, bracket_status="failed: " + d.get("error", ""), a_c=None, a_lo=None,
                     a_hi=None, a_lin=math.nan, a_max=math.nan,
                     n_runs=len(d.get("runs", [])),
                     wall=sum(r["wall"] for r in d.get("runs", [])))
        j = taus.index(t["tau"])
        ctrl = logs[f"control_L{t['load']}_T{j}"]
        if ctrl.get("status") == "failed":
            ctrl = {"noise_triggered": None, "switched": None}
        ld = setup["loads"][t["load"]]
        noise = bool(ctrl.get("noise_triggered"))
        status = "noise-triggered" if noise else d["bracket_status"]
        if ctrl.get("noise_triggered") is None:
            status += " (control failed)"
        trig = [r for r in d["runs"] if r["kind"] == "mu(v)" and r["triggered"]]
        first = min(trig, key=lambda r: r["a"]) if trig else None
        rows.append({
            "key": t["key"], "load": t["load"], "F_x": ld["F_x"], "kind": ld["kind"],
            "tau": math.inf if t["tau"] is None else t["tau"], "omega_p": t["omega_p"],
            "onset": t["onset"], "dt_fraction": t["dt_fraction"],
            "check_of": t.get("check_of", ""), "status": status,
            "a_c": (d["a_c"] if not noise and d["a_c"] is not None else math.nan),
            "a_lo": d["a_lo"] if d["a_lo"] is not None else math.nan,
            "a_hi": d["a_hi"] if d["a_hi"] is not None else math.nan,
            "a_lin": math.nan if d["a_lin"] is None else d["a_lin"], "a_max": d["a_max"],
            "n_runs": d["n_runs"],
            "wall": d["wall"], "control_switched": bool(ctrl.get("switched")),
            "t_switch": first["t_switch"] if first and first["t_switch"] is not None
            else math.nan,
            "t_run": first["t_run"] if first else math.nan,
            # the triggering run reached D_run in the last 5 % of t_max: whether the
            # bracket's lower end would trigger a little later is not resolved
            # (measured: such a point does not survive dt / 2)
            "marginal": float(bool(first and first["t_run"] is not None
                                   and first["t_run"] > MARGINAL * t.get("t_max", math.inf))),
            "growth_tau": predicted_rate(setup, ld, t["tau"]),
            # the a_hi run's rise to D_run (growth check) and why a point is forced
            "rise_rate": (d.get("rise_rate") if d.get("rise_rate") is not None
                          else math.nan),
            "rise_records": d.get("rise_records") or 0,
            "forced_by": d.get("forced_by") or "",
        })
    return rows


_STR_COLS = ("key", "kind", "onset", "check_of", "status", "forced_by")


def write_table(path, rows, setup, cfg):
    """``trigger_map.h5``: columns under ``points/``, loads under ``loads/``."""
    from remote_trigger.pywrap.runtime.results import write_atomic

    ds = {}
    for c in rows[0]:
        vals = [r[c] for r in rows]
        ds[f"points/{c}"] = (np.array([str(v) for v in vals], dtype=object)
                             if c in _STR_COLS else np.asarray(vals, dtype=float))
    for c in ("F_x", "fraction", "D_drop", "growth", "kappa_mu0", "kappa_drop", "gap_mu0",
              "omega_1", "dt_max", "compliance", "a_max", "margin_mu0", "margin_drop"):
        ds[f"loads/{c}"] = np.array([ld[c] for ld in setup["loads"]], float)
    ds["loads/kind"] = np.array([ld["kind"] for ld in setup["loads"]], dtype=object)
    ds["loads/growth_tau"] = np.array([ld["growth_tau"] for ld in setup["loads"]], float)
    rk = setup.get("ramp_kappa")
    if rk:
        for c in ("F_x", "kappa", "gap", "kappa_max"):
            ds[f"ramp_kappa/{c}"] = np.array(rk[c], float)
    ds["taus"] = np.array(setup["taus"], float)
    ds["omegas"] = np.array(setup["omegas"], float)
    attrs = {"stage": "trigger-map", "v0": setup["v0"], "a_paper": setup["a_paper"],
             "g_ref": setup["g_ref"], "window": setup["window"],
             "config": json.dumps(cfg.to_dict(), sort_keys=True)}
    write_atomic(path, attrs, ds)


def plot_map(path, rows, setup):
    """a_c(omega_p): one panel per load, one line per tau and onset."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    loads = setup["loads"]
    fig, axes = plt.subplots(1, len(loads), figsize=(4.2 * len(loads), 3.8), squeeze=False,
                             sharey=True)
    taus = [math.inf] + list(setup["taus"])
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, ld in enumerate(loads):
        ax = axes[0, i]
        for j, tau in enumerate(taus):
            for onset, ls, mk in (("step", "--", "s"), ("smooth", "-", "o")):
                pts = sorted([r for r in rows if r["load"] == i and r["tau"] == tau
                              and r["onset"] == onset and not r["check_of"]],
                             key=lambda r: r["omega_p"])
                if not pts:
                    continue
                w = np.array([r["omega_p"] for r in pts])
                ac = np.array([r["a_c"] for r in pts])
                lab = f"tau = {'inf' if math.isinf(tau) else f'{tau:.3g}'}, {onset}"
                ax.plot(w, ac, ls, marker=mk, mfc="none" if onset == "step" else None,
                        color=colors[j % len(colors)], label=lab)
                none = np.array([r["status"] == "none up to a_max" for r in pts])
                if none.any():
                    ax.plot(w[none], [r["a_max"] for r, n in zip(pts, none) if n], "v",
                            color=colors[j % len(colors)], mfc="none")
        ax.axhline(setup["a_paper"], color="k", lw=0.8, ls=":")
        ax.text(ax.get_xlim()[0] if False else min(setup["omegas"]), setup["a_paper"] * 2,
                "paper a = 1e-12", fontsize=7)
        v0 = setup["v0"]
        C = abs(ld["compliance"])
        wg = np.array(setup["omegas"])
        # (a line of one omega_p is a point: drawn with a marker)
        ax.plot(wg, v0 / (wg * C), color="0.5", lw=0.8, marker="_" if wg.size == 1 else None,
                ms=12, label="v0 / (omega_p C)")
        for wn in (ld["omega_1"],):
            ax.axvline(wn, color="0.7", lw=0.8)
        ax.set_xscale("log")
        ax.set_yscale("log")
        # minor tick labels of a narrow log range ran into each other
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_title(f"F_x = {ld['F_x']:.5g} ({ld['kind']})", fontsize=9)
        ax.set_xlabel("omega_p")
        if i == 0:
            ax.set_ylabel("a_c")
    axes[0, 0].legend(fontsize=6)
    fig.tight_layout()
    savefig_atomic(fig, path, dpi=110)
    plt.close(fig)


def _fmt(x, f=".3g"):
    return "-" if x is None or (isinstance(x, float) and not math.isfinite(x)) else format(x, f)


def _rise_ratio(r):
    """Measured rise rate / predicted rate of a point's a_hi run, as text."""
    if not math.isfinite(r["rise_rate"]):
        return f"- ({r['rise_records']} rec.)" if r["rise_records"] else "-"
    g = r["growth_tau"]
    return (f"{r['rise_rate'] / g:.2f}" if g > 0 else
            f"- (g = {g:.3g} <= 0; rise rate {r['rise_rate']:.3g})")


def write_summary(path, rows, setup, cfg, wall, size):
    """``trigger_map.md``: loads, the map table, dt check, costs."""
    L = ["# Trigger map", "",
         f"Paper job: `{cfg.paper}`. v0 = {setup['v0']:.3g} (Fig. 5's), mu0 = "
         f"{setup['mu0']:g}, mu_ss mu0 = {setup['mu_ss']:g}; window "
         f"[{setup['window'][0]:.7g}, {setup['window'][1]:.7g}]. Runaway level D_run = "
         f"{cfg.d_run_factor:g} x max(D_drop, (C a)^2); t_max = {cfg.t_max:g}; bisection "
         f"to a_hi/a_lo <= {cfg.factor:g}. Growth check: the a_hi run's last decade of D "
         f"below D_run rose at {1 / RUNAWAY_RATE_TOL:g}-{RUNAWAY_RATE_TOL:g} x the predicted "
         f"rate g (> 0; least squares over >= {RUNAWAY_MIN_RECORDS} records), else forced "
         f"response (growth); rise / g in the table.", "",
         "## Loads", "",
         "| F_x | kind | mu0 | after drop | g | g with tau | D_drop | kappa (mu0) | "
         "gap (mu0) | kappa (drop) | omega_1 |",
         "|---|---|---|---|---|---|---|---|---|---|---|"]
    for ld in setup["loads"]:
        L.append(f"| {ld['F_x']:.7g} | {ld['kind']} | {ld['decision_mu0']} | "
                 f"{ld['decision_drop']} | {ld['growth']:.4g} | "
                 + ", ".join(f"{g:.3g}" for g in ld["growth_tau"])
                 + f" | {ld['D_drop']:.3g} | {ld['kappa_mu0']:.3g} | {ld['gap_mu0']:.3g} | "
                 f"{ld['kappa_drop']:.3g} | {ld['omega_1']:.4g} |")
    L += ["", "tau = " + ", ".join(f"{t:.4g}" for t in setup["taus"])
          + f" (tau_g / g_ref, g_ref = {setup['g_ref']:.4g}).", "",
          "## Map", "",
          "| F_x | tau | omega_p | onset | a_c | [a_lo, a_hi] | a_lin | status | "
          "rise / g | t_switch | t_run | runs | s |",
          "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if r["check_of"]:
            continue
        L.append(f"| {r['F_x']:.6g} | {_fmt(r['tau'])} | {r['omega_p']:.4g} | {r['onset']} |"
                 f" {_fmt(r['a_c'])} | [{_fmt(r['a_lo'])}, {_fmt(r['a_hi'])}] | "
                 f"{_fmt(r['a_lin'])} | {r['status']}"
                 + (f" ({r['forced_by']})" if r["forced_by"] else "")
                 + f" | {_rise_ratio(r)} | {_fmt(r['t_switch'], '.4g')} | "
                 f"{_fmt(r['t_run'], '.4g')} | {r['n_runs']} | {r['wall']:.0f} |")
    marg = [r["key"] for r in rows if r["marginal"] and r["status"] == "bracketed"]
    L += ["", f"t_max-marginal points (the triggering run reached D_run after "
              f"{MARGINAL:g} t_max; their a_c is limited by t_max, not resolved): "
              f"{len(marg)}" + (": " + ", ".join(marg) if marg else "")]
    checks = [r for r in rows if r["check_of"]]
    if checks:
        L += ["", "## Time step check (dt / 2)", "",
              "| point | dt fraction | [a_lo, a_hi] | at dt / 2 | overlap |", "|---|---|---|---|---|"]
        by = {r["key"]: r for r in rows}
        for r in checks:
            o = by[r["check_of"]]
            ov = (max(o["a_lo"], r["a_lo"]) <= min(o["a_hi"], r["a_hi"])
                  if all(math.isfinite(x) for x in (o["a_lo"], o["a_hi"], r["a_lo"], r["a_hi"]))
                  else None)
            L.append(f"| {o['key']} | {o['dt_fraction']:g} | [{_fmt(o['a_lo'])}, "
                     f"{_fmt(o['a_hi'])}] | [{_fmt(r['a_lo'])}, {_fmt(r['a_hi'])}] | "
                     f"{'-' if ov is None else ('yes' if ov else 'no')} |")
    rk = setup.get("ramp_kappa")
    if rk and rk["F_x"]:
        L += ["", "## Condition number of the coalescing pair along the mu0 ramp", "",
              f"Pair at F_x^c: lambda_c = {rk['lambda_c'][0]:.6g} +- {abs(rk['lambda_c'][1]):.3g} i."
              " gap = |lambda_i - lambda_j| / |lambda| of the two real eigenvalues that"
              " coalesce (tracked down from F_x^c).", "",
              "| F_x | gap | kappa | kappa_max |", "|---|---|---|---|"]
        n_r = len(rk["F_x"])
        for k in sorted(set(list(range(0, n_r, max(1, n_r // 12))) + [n_r - 1])):
            L.append(f"| {rk['F_x'][k]:.7g} | {rk['gap'][k]:.3g} | {rk['kappa'][k]:.3g} | "
                     f"{rk['kappa_max'][k]:.3g} |")
    n = sum(r["n_runs"] for r in rows)
    cpu = sum(r["wall"] for r in rows)
    L += ["", "## Cost", "",
          f"{len(rows)} map points, {n} runs (plus one control per load and tau), "
          f"{cpu:.0f} s of run time; wall time {wall:.0f} s on {size} rank(s)."]
    write_text_atomic(path, "\n".join(L) + "\n")
