"""Measurements and ``report.md`` of ``remote-trigger paper``.

Every number of the report is measured here from the files of the output
folder (HDF5, dumps) and the job summary (``paper.json``); the only
constants are the paper's reference values
(:data:`remote_trigger.pywrap.jobs.paper.config.PAPER`), labelled as such.

Definitions (docs/paper.md)
---------------------------
* **Noise level** of an undamped run: median of D(t) over its first 5 %
  of records (t > 0).
* **Decades of MSD growth** (Fig. 4): log10(max D / noise level).
* **Fit window** (Fig. 4): from the first record with D above 10^3 x noise
  to the first record above max D / 10^3, cut at the first departure from
  a constant rate (:func:`growth_window`); the measured rate g is the slope
  of ln D / 2 there.
* **Fig. 5 levels**: D_a = median D of run (a); decades of run X =
  log10(max D_X / D_a); velocity decades of (c) = log10(max |v_c| / min
  |v_c|) over the run (the velocity axis of the paper's panel b), and the
  rise from the noise, log10(max |v_c| / median |v_a|).
* **Trigger time** of (c): first record with mu < mu0.

Verdicts are ``pass`` (the paper's statement holds for this run) or
``differs`` (with the reason, computed from the run where possible).
"""
import math
import os

import numpy as np

from remote_trigger.analysis.dynamics.series import (  # noqa: F401 (API)
    exp_rate, growth_window, noise_level)

from remote_trigger.pywrap.jobs.paper.config import PAPER
from remote_trigger.pywrap.jobs.paper.report_checks import add_check
from remote_trigger.pywrap.jobs.paper.report_fig5 import fig5_rows as _fig5_rows
from remote_trigger.analysis.output import write_json_atomic, write_text_atomic

# the measurements live in report_metrics; their names stay importable here
from remote_trigger.pywrap.jobs.paper.report_metrics import (
    SATURATION_DECADES, read_series, certified_bracket, instability_metrics, normal_form_metrics,
    perturb_metrics, spectrum_at_zero, tracks)


def _fmt(x, digits=4):
    if isinstance(x, (bool, np.bool_)):
        return "yes" if x else "no"
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "nan"
    if isinstance(x, str):
        return x
    return f"{x:.{digits}g}"


def _relax_rows(out, summary, checks, info, extra):
    """Rows of the relaxation (appended to ``checks``, ``info``, ``extra``)."""
    cfg = summary["config"]
    P = PAPER
    rel = summary["relax"]
    phi = rel["packing_fraction"]
    reason = (f"phi is set by the preparation (generator box at phi = {cfg['phi']:g}, "
              f"protocol {rel.get('protocol') or 'default'}, N = {cfg['n']}); the paper "
              f"does not describe its settling beyond 'loosely packed disks'; "
              f"difference {phi - P['packing_fraction']:+.4f}")
    if cfg.get("dim", 2) == 3:
        reason = (f"spheres: the paper's phi is that of disks in 2D, not comparable (the "
                  f"generator's box is at phi = {cfg['phi']:g}, near random close packing "
                  f"of spheres, and the relaxed packing's height sets phi)")
    add_check(checks, "packing_fraction", "packing fraction phi of the relaxed packing", phi,
           P["packing_fraction"], abs(phi - P["packing_fraction"]) <= 0.01, reason=reason,
           note="within 0.01 of the paper")
    r = rel["residual"]
    add_check(checks, "residual", "largest residual force max|F_i|, |T_i|/R_i reached", r,
           P["f_min"], r <= P["f_min"],
           reason=("double precision cannot resolve forces below ~k_eff eps |x| ~ 1e-11 "
                   "for this packing (docs/driver.md); the paper's f_min = 1e-15 is below "
                   "round-off. This residual sets the noise of the undamped runs"))


def _ramp_rows(out, summary, checks, info, extra):
    """Rows of the two ramps: eigenvalues and F_x^c (appended to ``checks``, ``info``, ``extra``)."""
    cfg = summary["config"]
    ramps = summary["ramps"]
    mus = (cfg["mu"], cfg["mu_low"])
    tr = tracks(out, summary)
    extra["tracks"] = tr
    Fc = {}
    for k, (mu, rr) in enumerate(zip(mus, ramps)):
        _one_ramp_rows(k, mu, rr, tr.get(k), checks, extra)
        if rr["status"] == "complete":
            Fc[k] = 0.5 * (rr["F_x_c_low"] + rr["F_x_c_high"])
    _F_x_c_rows(summary, mus, Fc, tr, checks, info)


def _one_ramp_rows(k, mu, rr, t, checks, extra):
    """Spectrum at F_x = 0, coalescence and square-root law of ramp ``k`` (friction mu)."""
    sp = spectrum_at_zero(rr["h5"])
    extra[f"spectrum0_{k}"] = sp
    add_check(checks, f"real_at_zero_mu{mu:g}",
           f"mu = {mu:g}: all eigenvalues real and positive at F_x = {sp['F_x']:g}",
           sp["real_positive"], "yes", sp["real_positive"],
           reason=(f"certified complex pair at F_x = 0 (min Re lambda = "
                   f"{sp['min_re']:.4g}); ||K - K^T||_F / ||K||_F = "
                   f"{sp['asymmetry']:.3g}"),
           note=(f"min lambda = {sp['min_re']:.4g}, max = {sp['max_re']:.4g}; "
                 f"||K - K^T||_F / ||K||_F = {sp['asymmetry']:.3g}: the protocol "
                 f"(friction switched on with zero tangential history) makes K "
                 f"symmetric at F_x = 0, so this row checks the protocol, not the "
                 f"physics"))
    coal = t is not None and bool(np.any(t.complex_pair)) and \
        t.lam_a[np.argmax(t.complex_pair) - 1].real < t.lam_b[np.argmax(t.complex_pair)
                                                              - 1].real
    add_check(checks, f"coalescence_mu{mu:g}",
           f"mu = {mu:g}: two real eigenvalues coalesce into a complex pair at F_x^c",
           coal, "yes", coal,
           reason=f"ramp status {rr['status']}: {rr.get('message', '')}",
           note=(f"lambda_c = {t.lam_c:.6g} (mode {t.rank + 1} of {t.n_modes} from "
                 f"the softest; tracking ambiguity {t.ambiguity:.2f})") if t else "")
    if t is not None and rr["status"] == "complete":
        from remote_trigger.analysis.stability.eigtrack import sqrt_law

        sq = sqrt_law(t.F_x, t.lam_a, t.lam_b, rr["F_x_c_low"], rr["F_x_c_high"])
        extra[f"sqrt_law_{k}"] = sq
        ok = all(math.isfinite(sq[s_]) and abs(sq[s_] - 0.5) <= 0.1
                 for s_ in ("below", "above"))
        add_check(checks, f"sqrt_law_mu{mu:g}",
               f"mu = {mu:g}: exponent p of the pair's gap lambda_b - lambda_a ~ "
               f"(F_x^c - F_x)^p below F_x^c (Im lambda ~ (F_x - F_x^c)^q above)",
               sq["below"], "p = q = 1/2 (generic exceptional point)", ok,
               reason=(f"p = {sq['below']:.3g} from {sq['n_below']} points, q = "
                       f"{sq['above']:.3g} from {sq['n_above']} points (needs >= 3 "
                       f"each, within 5 % of F_x^c and 10 bracket widths from it; "
                       f"pass if both within 0.1 of 1/2)"),
               note=(f"q = {sq['above']:.3g}; |F_x - F_x^c| in "
                     f"[{sq['range_below'][0]:.2g}, {sq['range_below'][1]:.2g}] below "
                     f"({sq['n_below']} points), [{sq['range_above'][0]:.2g}, "
                     f"{sq['range_above'][1]:.2g}] above ({sq['n_above']})"))


def _F_x_c_rows(summary, mus, Fc, tr, checks, info):
    """F_x^c of both ramps against the paper, their ratio, the pair at birth, ramp sizes."""
    cfg, ramps, P = summary["config"], summary["ramps"], PAPER
    if 0 in Fc:
        lo, hi = P["F_x_c_mu1_low"], P["F_x_c_mu1_high"]
        rr = ramps[0]
        cb0 = certified_bracket(rr["h5"])
        add_check(checks, f"F_x_c_mu{mus[0]:g}", f"F_x^c(mu = {mus[0]:g}) (midpoint of the "
               "certified bracket)",
               Fc[0], f"{lo:g} < F_x^c < {hi:g}", lo < Fc[0] < hi,
               reason=(f"F_x^c is a property of the individual packing; ours (N = "
                       f"{cfg['n']}, seed {cfg['seed']}, phi = "
                       f"{summary['relax']['packing_fraction']:.4f}, zero tangential "
                       f"history at F_x = 0) is {Fc[0] / (0.5 * (lo + hi)):.3g} x the "
                       f"midpoint of the paper's bracket; certified bracket "
                       f"[{cb0['real']:.9g}, {cb0['complex']:.9g}], width "
                       f"{cb0['width']:.2g}"),
               note=f"certified bracket [{cb0['real']:.9g}, {cb0['complex']:.9g}], width "
                    f"{cb0['width']:.2g}")
        for k in (0, 1):
            if ramps[k]["status"] != "complete":
                continue
            cb = certified_bracket(ramps[k]["h5"])
            info.append((f"certified_bracket_mu{mus[k]:g}", f"mu = {mus[k]:g}: width of the "
                         f"certified bracket [{cb['real']:.9g}, {cb['complex']:.9g}] of F_x^c "
                         f"(largest F_x certified real, smallest certified complex); "
                         f"{cb['undecided']} equilibria undecided"
                         + (f"; {cb['message']}" if cb["message"] else ""), cb["width"]))
    else:
        add_check(checks, f"F_x_c_mu{mus[0]:g}", f"F_x^c(mu = {mus[0]:g})", float("nan"),
               "0.0091 < F_x^c < 0.012", False,
               reason=f"ramp {ramps[0]['status']}: {ramps[0].get('message', '')}")
    if 1 in Fc:
        rr = ramps[1]
        info.append(("F_x_c_mu%g" % mus[1], f"F_x^c(mu = {mus[1]:g}) (midpoint of the "
                     f"certified bracket [{rr['F_x_c_low']:.9g}, {rr['F_x_c_high']:.9g}], "
                     f"width {rr['F_x_c_high'] - rr['F_x_c_low']:.2g})", Fc[1]))
    order_ok = 0 in Fc and 1 in Fc and ((Fc[1] < Fc[0]) == (mus[1] < mus[0]))
    ratio = Fc[1] / Fc[0] if (0 in Fc and 1 in Fc) else float("nan")
    add_check(checks, "F_x_c_ratio", f"F_x^c(mu = {mus[1]:g}) / F_x^c(mu = {mus[0]:g})", ratio,
           "< 1 (smaller mu, smaller F_x^c)" if mus[1] < mus[0] else "> 1", order_ok,
           reason=("for this packing the lower friction coefficient is not the less stable "
                   "one: the tangential displacements at F_x^c are small (u = |xi|/t* << 1), "
                   "so mu enters K only through O(u) terms and the order of F_x^c depends on "
                   "the packing" if (0 in Fc and 1 in Fc) else "a ramp did not find F_x^c"))
    for k, t in tr.items():
        if t is not None:
            info.append((f"lambda_c_mu{mus[k]:g}", f"mu = {mus[k]:g}: Re lambda of the pair at "
                         f"birth [1/tau^2] (mode {t.rank + 1} of {t.n_modes})", t.lam_c))
    for k, rr in enumerate(ramps):
        info.append((f"ramp_steps_mu{mus[k]:g}", f"mu = {mus[k]:g}: ramp steps + bisection "
                     "points", rr["n_steps"] + rr["n_bisection"]))


def _fig4_rows(out, summary, checks, info, extra):
    """Rows of Fig. 4 (the instability run) (appended to ``checks``, ``info``, ``extra``)."""
    P = PAPER
    if summary.get("instability"):
        m = instability_metrics(out, summary)
        extra["instability"] = m
        add_check(checks, "msd_decades_fig4", "Fig. 4: decades of MSD growth from the noise "
               "level (log10 max D / noise)", m["decades"], f"~{P['msd_decades_fig4']:g}",
               m["decades"] >= 12.0,
               reason=(f"the run ended at t = {m['t_end']:.4g} with D = {m['D_max']:.3g} "
                       f"(noise {m['noise']:.3g})"),
               note=f"noise {m['noise']:.3g} -> max {m['D_max']:.3g}")
        rel_err = m["measured_growth_rate"] / m["predicted_growth_rate"] - 1 \
            if m["predicted_growth_rate"] > 0 else float("nan")
        add_check(checks, "growth_rate_fig4", "Fig. 4: measured growth rate g of D ~ e^{2gt} / "
               "predicted max Im sqrt(lambda) - 1", rel_err,
               "D grows as e^{2 Im(omega) t} (Eq. 6)",
               np.isfinite(rel_err) and abs(rel_err) < 0.1,
               reason=(f"measured {m['measured_growth_rate']:.4g} vs predicted "
                       f"{m['predicted_growth_rate']:.4g}"),
               note=(f"measured {m['measured_growth_rate']:.4g}, predicted "
                     f"{m['predicted_growth_rate']:.4g} [1/tau]"))
        add_check(checks, "saturation_fig4", "Fig. 4: the exponential growth has stopped "
               "(nonlinear saturation) by the end of the run: D over its last 10 % more "
               f"than {SATURATION_DECADES:g} decades below the exponential",
               m["saturated"], "yes", m["saturated"],
               reason=(f"at t = {m['t_end']:.4g} D is only {m['below_exponential']:.3g} "
                       f"decades below the growth window's exponential (saturated: more "
                       f"than {SATURATION_DECADES:g}); a longer run (t_instability, "
                       f"instability_span, d_sat) would show the saturation"
                       if np.isfinite(m["below_exponential"]) else
                       "not measured: the run has no growth window whose exponential D "
                       "could be compared with"),
               note=(f"max D over the last 10 % of the run is {m['below_exponential']:.3g} "
                     f"decades below the growth window's exponential extrapolated to "
                     f"t = {m['t_end']:.4g} (> {SATURATION_DECADES:g}); growth rate over "
                     f"that tail {m['late_rate']:.3g}; D_max = {m['D_max']:.3g}"))
        info.append(("F_x_fig4", "Fig. 4: F_x of the run (fig4_ratio x F_x^c)",
                     summary["instability"]["F_x"]))


def _normal_form_rows(out, summary, checks, info, extra):
    """Rows of the normal form (appended to ``checks``, ``info``, ``extra``)."""
    if os.path.exists(os.path.join(out, "normal_form.h5")):
        nf = normal_form_metrics(out)
        extra["normal_form"] = nf
        if "A_sqrt_eps" in nf:
            v = nf["A_sqrt_eps"]
            add_check(checks, "nf_A_sqrt_eps", f"normal form: A sqrt(eps) at eps = "
                   f"{nf['eps_min']:g}, no damping", v, "-> 1 (A ~ eps^-1/2, Eq. 17)",
                   abs(v - 1) < 0.05, reason="the amplitude does not follow eps^-1/2")
        if "slope" in nf:
            s = nf["slope"]
            add_check(checks, "nf_slope", "normal form: d log A / d log eps at the smallest eps",
                   s, -0.5, abs(s + 0.5) < 0.05, reason="A does not scale as eps^-1/2")
        for tau, ratio in nf["damped_ratio"].items():
            add_check(checks, f"nf_damped_tau{tau:g}", f"normal form, tau = {tau:g}: A / damped "
                   f"estimate at eps = {nf['eps_min']:g}", ratio,
                   "1 (damped estimate, Section IV, with decay e^{-t/2tau})", abs(ratio - 1) < 0.1,
                   reason="the damped amplitude departs from the estimate")


def collect(out, summary):
    """All checks and informational numbers: ``(checks, info, extra)``.

    One function per part of the job (:func:`_relax_rows`, :func:`_ramp_rows`,
    :func:`_fig4_rows`, :func:`.report_fig5.fig5_rows`, :func:`_normal_form_rows`), in the
    report's order; a part the summary does not hold adds nothing.
    """
    checks, info, extra = [], [], {}
    for rows in (_relax_rows, _ramp_rows, _fig4_rows, _fig5_rows, _normal_form_rows):
        rows(out, summary, checks, info, extra)
    return checks, info, extra


# --------------------------------------------------------------------------- report.md
def cell(text):
    """A markdown table cell: pipes escaped, no line breaks."""
    return str(text).replace("|", "\\|").replace("\n", " ")


def _table(rows):
    lines = ["| id | quantity | measured | paper | verdict | reason / note |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        paper = r["paper"] if isinstance(r["paper"], str) else _fmt(r["paper"])
        lines.append(f"| {r['id']} | {cell(r['quantity'])} | {_fmt(r['measured'])} | "
                     f"{cell(paper)} | **{r['verdict']}** | {cell(r['reason'])} |")
    return lines


SECTIONS = [
    ("relax", "1. Packing and relaxation", ("packing_fraction", "residual")),
    ("eigen", "2. Eigenvalues and F_x^c (Fig. 3)", ("real_at_zero", "coalescence", "sqrt_law",
                                                    "F_x_c")),
    ("fig4", "3. Oscillatory instability above F_x^c (Fig. 4)", ("msd_decades_fig4",
                                                                 "growth_rate_fig4",
                                                                 "saturation_fig4")),
    ("fig5", "4. Perturbations below F_x^c (Fig. 5)", ("stable_fig5", "drop_", "msd_",
                                                       "forcing_", "growth_rate_fig5",
                                                       "velocity_", "mu_drop", "control_",
                                                       "paper_amplitude")),
    ("nf", "5. Normal form (Sections III.C.2 and IV)", ("nf_",)),
]


def write_report(out, summary):
    """Write ``report.md`` and ``report.json`` (the same numbers) into ``out``."""
    checks, info, extra = collect(out, summary)
    cfg = summary["config"]
    ph = summary.get("phases", {})
    L = ["# remote-trigger paper: report", ""]
    L += [f"Reproduction of Charan, Pomyalov & Procaccia, *Generic Mechanism for Remote "
          f"Triggering of Earthquakes*, by `remote-trigger paper`"
          f"{' --dim 3' if cfg.get('dim', 2) == 3 else ''}"
          f"{' --quick' if cfg.get('quick') else ''}: N = {cfg['n']}"
          f"{' spheres (the paper: disks; docs/paper.md, Spheres)' if cfg.get('dim', 2) == 3 else ''}"
          f", seed {cfg['seed']}, "
          f"k_n = {cfg['k_n']:g}, k_t = {cfg['k_t']:.6g}, F_y = {cfg['F_y']:g}, "
          f"mu = {cfg['mu']:g} and {cfg['mu_low']:g}, dF_x = {cfg['dF_x']:g}, "
          f"tol = {cfg['tol']:g}; {summary.get('n_ranks', 1)} MPI rank(s). Units: LAMMPS lj "
          "(length sigma = 2R1, mass m, time tau, force in lj units). Every *measured* number comes from this run's "
          "files; the *paper* column holds the paper's reference values "
          "(`remote_trigger.pywrap.jobs.paper.config.PAPER`). Verdicts: **pass** = the paper's "
          "statement holds for this run; **differs** = it does not, with the reason.", ""]
    n_pass = sum(r["verdict"] == "pass" for r in checks)
    L += [f"Summary: {n_pass} pass, {len(checks) - n_pass} differ, of {len(checks)} checks.",
          ""]
    used = set()
    for key, title, prefixes in SECTIONS:
        rows = [r for r in checks if r["id"].startswith(prefixes) and r["id"] not in used]
        used.update(r["id"] for r in rows)
        L += [f"## {title}", ""]
        if rows:
            L += _table(rows)
        else:
            L += ["(not run)"]
        L += [""]
    rest = [r for r in checks if r["id"] not in used]
    if rest:
        L += ["## Other checks", ""] + _table(rest) + [""]
    L += ["## 6. Other measured numbers (no paper value)", "",
          "| id | quantity | value |", "|---|---|---|"]
    L += [f"| {i} | {cell(q)} | {_fmt(v, 7)} |" for i, q, v in info]
    L += ["", "## 7. Figures", ""]
    for name, path in sorted(summary.get("figures", {}).items()):
        shown = os.path.basename(path) if not str(path).startswith("error") else path
        L += [f"* `{name}`: {shown}" if shown.startswith("error") else f"* ![{name}]({shown})"]
    L += ["", "## 8. Timings (wall clock, seconds)", "", "| phase | seconds |", "|---|---|"]
    L += [f"| {k} | {v:.1f} |" for k, v in ph.items()]
    sessions = summary.get("sessions") or []
    if len(sessions) > 1:
        before = sum(float(s.get("elapsed", 0.0)) for s in sessions[:-1])
        L += ["", f"Resumed job (`--resume`): {len(sessions)} sessions. A phase's time is "
              "that of the session that finished it (a ramp continued from its ramp.h5: "
              "the last part only); total is the last session's; the earlier sessions ran "
              f"{before:.1f} s up to their last checkpoint."]
    L += ["", "## 9. Choices and interpretations", ""]
    pz = summary.get("perturb") or {}
    L += [f"* F_x of Fig. 4 = {cfg['fig4_ratio']:.5g} F_x^c(mu = {cfg['mu']:g}): the paper's 0.012 "
          f"divided by the midpoint {0.5 * (PAPER['F_x_c_mu1_low'] + PAPER['F_x_c_mu1_high']):g} "
          "of its bracket 0.0091 < F_x^c < 0.012, applied to our bisected F_x^c.",
          "* F_x of Fig. 5 lies in the window between F_x^c(mu_ss mu0) and F_x^c(mu0) "
          f"(fraction {cfg.get('fig5_window')}), as the paper's 0.0091 (Fig. 3's vertical "
          "line): stable with the static friction, unstable once mu(v) has dropped. The "
          "friction-drop analysis loads the equilibrium (history built at mu0) with the lower "
          "mu, re-equilibrates it and certifies its spectrum.",
          f"* f(t) = a e(t) cos(omega_p t), omega_p = {cfg['omega_p']:g} /tau (far below the "
          "natural frequencies sqrt(lambda) ~ 5-200 /tau: off resonance), onset e(t) = "
          + (f"raised cosine over t_on = {pz.get('t_on', float('nan')):.4g}"
             if pz.get("t_on", 0) > 0 else "step at t = 0")
          + f"; a = {pz.get('a', float('nan')):.3g} measured (fig5_forcing_margin x v0 / "
          f"(omega_p C)); the paper's a = {cfg['a_paper']:g} is run (p).",
          f"* v0 = v_ss = {cfg['fig5_v0_margin']:g} x the largest |v_top| over every step of "
          "the first half of run (a) (fix ave/histo running max); mu(v) is evaluated every "
          "step. A run stops once D passes fig5_d_run or has saturated "
          "(analysis.series.saturated).",
          "* Eigenvalues are those of M^-1 K after rattler removal (frictional criterion, "
          + ("< 3 contacts, 6 dofs per sphere" if cfg.get("dim", 2) == 3 else "< 2 contacts")
          + "); complex = certified by the analyzer (docs/analysis.md).",
          "* The coalescing pair is tracked from its birth at the first unstable bisection "
          "point down the ramp (nearest neighbour) and up the continuation above F_x^c.",
          "* docs/paper.md describes every step, option and file."]
    L += [""]
    write_text_atomic(os.path.join(out, "report.md"), "\n".join(L))
    js = {"checks": [dict(r, measured=_jsonable(r["measured"]),
                          paper=_jsonable(r["paper"])) for r in checks],
          "info": [{"id": i, "quantity": q, "value": _jsonable(v)} for i, q, v in info],
          "phases": ph, "paper_reference": PAPER}
    write_json_atomic(os.path.join(out, "report.json"), js, indent=1)
    return checks, info


def _jsonable(v):
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        return float(v) if math.isfinite(v) else None
    return v
