"""Measurements and ``report.md`` of ``remote-trigger paper``.

Every number of the report is measured here from the files of the output
folder (HDF5, dumps) and the job summary (``paper.json``); the only
constants are the paper's reference values
(:data:`remote_trigger.pywrap.paper_config.PAPER`), labelled as such.

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

from remote_trigger.analysis.series import exp_rate, growth_window, noise_level  # noqa: F401 (API)

from .paper_config import PAPER
from remote_trigger.analysis.output import write_json_atomic, write_text_atomic

VERDICTS = ("pass", "differs")


# --------------------------------------------------------------------------- readers
def _read_series(path):
    import h5py

    with h5py.File(path, "r") as fh:
        d = {k: fh[k][()] for k in ("t", "D", "v_top", "mu")}
        d["attrs"] = {k: (v.decode() if isinstance(v, bytes) else v)
                      for k, v in fh.attrs.items()}
    return d


def packing_fraction_of(state):
    """phi = sum pi R^2 / (L h), h = max(y + R) (wall at y = 0), as the driver's relax."""
    L = state.box_hi[0] - state.box_lo[0]
    h = float(np.max(state.positions[:, 1] + state.radii))
    return float(np.sum(np.pi * state.radii ** 2) / (L * h))


def tracks(out, summary):
    """:class:`~remote_trigger.analysis.eigtrack.PairTrack` per ramp index (0: mu, 1: mu_low), None if none."""
    import h5py
    from remote_trigger.analysis.eigtrack import track_pair
    from .ramp_file import read_spectra

    res = {}
    for k, r in enumerate(summary.get("ramps", [])):
        if r.get("status") != "complete":
            res[k] = None
            continue
        folder = os.path.dirname(r["h5"])
        extra = []
        ext = os.path.join(folder, "extend.h5")
        if os.path.exists(ext):
            with h5py.File(ext, "r") as fh:
                F = fh["F_x"][()]
                C = fh["complex"][()]
                for i in range(len(F)):
                    extra.append((float(F[i]), fh[f"eigenvalues/ext_{i:02d}"][()],
                                  bool(C[i] > 0)))
        res[k] = track_pair(read_spectra(r["h5"], extra))
    return res


def spectrum_at_zero(h5path):
    """Decision and extreme eigenvalues of the first ramp step (F_x = 0)."""
    import h5py

    from . import ramp_file as rf

    def first(fh, name):
        key = rf.column(rf.STEPS, name)
        return fh[key][0] if key in fh else float("nan")

    with h5py.File(h5path, "r") as fh:
        lam = fh[f"{rf.EIGENVALUES}/{rf.STEPS}/{rf.point_name(rf.STEPS, 0)}"][()]
        cplx, dec, conf, F0 = (float(first(fh, c))
                               for c in ("complex", "decision", "confidence", "F_x"))
        datafile = first(fh, rf.DATAFILE)
    datafile = datafile.decode() if isinstance(datafile, bytes) else str(datafile)
    asym = float("nan")
    dump = datafile[:-len(".data")] + ".dump"
    if os.path.isfile(dump):
        from remote_trigger.analysis.state import read_dump
        from remote_trigger.analysis.jacobian import stiffness_matrix

        K = stiffness_matrix(read_dump(dump))
        asym = float(np.sqrt(abs((K - K.T).multiply(K - K.T).sum()))
                     / np.sqrt(abs(K.multiply(K).sum())))
    return {"F_x": F0, "complex": cplx > 0, "decision": dec, "confidence": conf,
            "min_re": float(np.min(lam.real)), "max_re": float(np.max(lam.real)),
            "max_abs_im": float(np.max(np.abs(lam.imag))), "n_modes": int(lam.size),
            "real_positive": bool(cplx <= 0 and np.min(lam.real) > 0), "asymmetry": asym}


def certified_bracket(h5path):
    """The certified bracket of F_x^c of a ramp and the number of undecided equilibria.

    Returns
    -------
    dict
        ``real`` (largest F_x certified real below the first certified
        complex one), ``complex`` (smallest F_x certified complex), ``width``
        (complex - real), ``undecided`` (number of equilibria the certified
        test left undecided), ``message`` (why the bracket is wider than the
        ramp's ``tol``; empty otherwise); NaN / 0 when the file has no
        ``decision`` column.
    """
    import h5py

    F, dec = [], []
    with h5py.File(h5path, "r") as fh:
        msg = fh.attrs.get("message", "") if not fh.attrs.get("tol_reached", True) else ""
        for kind in ("steps", "bisection"):
            if f"{kind}/decision" not in fh:
                return {"real": float("nan"), "complex": float("nan"), "width": float("nan"),
                        "undecided": 0, "message": ""}
            F.extend(fh[f"{kind}/F_x"][()])
            dec.extend(fh[f"{kind}/decision"][()])
    F, dec = np.asarray(F, float), np.asarray(dec, float)
    c = F[dec == 1]
    first_c = float(np.min(c)) if c.size else float("nan")
    r = F[(dec == 0) & (F < first_c)] if c.size else F[dec == 0]
    real = float(np.max(r)) if r.size else float("nan")
    return {"real": real, "complex": first_c, "width": first_c - real,
            "undecided": int(np.count_nonzero(dec < 0)),
            "message": msg.decode() if isinstance(msg, bytes) else str(msg)}


def instability_metrics(out, summary):
    """Numbers and series of the Fig. 4 run."""
    s = _read_series(os.path.join(out, "instability.h5"))
    t, D = s["t"], s["D"]
    noise = noise_level(t, D)
    Dmax = float(np.max(D))
    window, g_meas = growth_window(t, D, noise)
    inst = summary.get("instability", {})
    g_pred = float(inst.get("predicted_growth_rate", s["attrs"].get("predicted_growth_rate",
                                                                     float("nan"))))
    # saturation: D in the last 10 % of the run no longer grows at the linear rate
    n = len(t)
    tail = slice(int(0.9 * n), n)
    late = exp_rate(t[tail], np.maximum(D[tail], 1e-300), min_records=1) if n > 20 \
        else float("nan")
    return {"t": t, "D": D, "noise": noise, "D_max": Dmax,
            "decades": float(np.log10(Dmax / noise)) if noise > 0 else float("nan"),
            "window": window, "measured_growth_rate": g_meas,
            "predicted_growth_rate": g_pred, "late_rate": float(late),
            "t_end": float(t[-1]), "status": s["attrs"].get("status", ""),
            "saturated": bool(np.isfinite(late) and np.isfinite(g_pred) and g_pred > 0
                              and late < 0.5 * g_pred)}


def perturb_metrics(out, summary):
    """Numbers and series of the Fig. 5 runs (a)-(e), (p) (:mod:`.fig5`).

    Definitions in docs/paper.md ("Fig. 5: criteria"); every level is
    measured from the files, every prediction comes from the friction-drop
    analyses in the summary.
    """
    from remote_trigger.analysis import series as ser

    pz = summary["perturb"]
    mu0 = float(pz.get("mu0", summary["config"]["mu"]))
    runs = {}
    for k in "abcdep":
        p = os.path.join(out, f"perturb_{k}.h5")
        if os.path.exists(p):
            runs[k] = _read_series(p)
    a = runs["a"]
    pos = (a["t"] > 0) & (a["D"] > 0)
    level = float(np.median(a["D"][pos]))
    v_level = float(np.median(np.abs(a["v_top"][a["t"] > 0])))
    m = {"series": runs, "level_a": level, "v_level_a": v_level, "mu0": mu0,
         "v0": float(pz.get("v0", float("nan"))), "v_ss": float(pz.get("v_ss", float("nan"))),
         "a_forcing": float(pz.get("a", float("nan"))),
         "compliance": float(pz.get("compliance", float("nan")))}
    for k, s_ in runs.items():
        t, D, v, mu = s_["t"], s_["D"], s_["v_top"], s_["mu"]
        ts = ser.friction_switch_time(t, mu, mu0)
        lvl = ser.post_switch_level(t, D, mu, mu0)
        half = t[-1] / 2
        first, second = D[(t > 0) & (t <= half)], D[t > half]
        m[k] = {"t_end": float(t[-1]), "status": s_["attrs"].get("status", ""),
                "max_D": float(np.max(D)), "decades": ser.decades_above(D, level),
                "v_decades": ser.decades_above(v, v_level),
                "max_v": float(np.max(np.abs(v))), "min_mu": float(np.min(mu)),
                "switch_time": ts, "post_switch_level": lvl,
                "triggered": bool(np.isfinite(lvl) and np.max(D) >= 1e3 * lvl),
                "late_growth": (float(np.log10(second.max() / first.max()))
                                if first.size and second.size and first.max() > 0
                                else float("nan"))}
        if np.isfinite(ts):
            m[k]["growth_after_switch"] = ser.growth_over(t, D, ts + 100.0, float(t[-1]))
    # what switched mu(v) on in (c): the quasi-static velocity of f(t) at the switch
    c = m.get("c")
    if c is not None and np.isfinite(c["switch_time"]) and np.isfinite(m["compliance"]):
        tq = np.array([c["switch_time"]])
        vq = ser.quasi_static_velocity(tq, m["a_forcing"], summary["config"]["omega_p"],
                                       m["compliance"], pz.get("t_on", 0.0))
        c["qs_over_v0_at_switch"] = float(abs(vq[0]) / m["v0"])
    return m


def normal_form_metrics(out):
    """A sqrt(eps), the slope of log A vs log eps (no damping), A / estimate (damped)."""
    import h5py

    with h5py.File(os.path.join(out, "normal_form.h5"), "r") as fh:
        eps, tau = fh["eps"][()], fh["tau"][()]
        amp, est = fh["amplitude"][()], fh["estimate"][()]
        td = fh["beat_time"][()]
        delta = float(fh.attrs["delta"])
    o = np.argsort(eps)
    res = {"delta": delta, "eps_min": float(eps[o[0]]), "eps": eps, "tau": tau,
           "amplitude": amp, "estimate": est, "beat_time": td}
    inf = np.flatnonzero(np.isinf(tau))
    if inf.size:
        a = amp[inf[0]]
        res["A_sqrt_eps"] = float(a[o[0]] * math.sqrt(eps[o[0]]))
        if eps.size >= 2:
            res["slope"] = float(np.log(a[o[1]] / a[o[0]]) / np.log(eps[o[1]] / eps[o[0]]))
    fin = np.flatnonzero(np.isfinite(tau))
    res["damped_ratio"] = {float(tau[i]): float(amp[i, o[0]] / est[i, o[0]]) for i in fin}
    res["damped_sqrt_eps"] = {float(tau[i]): float(amp[i, o[0]] * math.sqrt(eps[o[0]]))
                              for i in fin}
    return res


# --------------------------------------------------------------------------- checks
def _fmt(x, digits=4):
    if isinstance(x, (bool, np.bool_)):
        return "yes" if x else "no"
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "nan"
    if isinstance(x, str):
        return x
    return f"{x:.{digits}g}"


def _check(rows, cid, quantity, measured, paper, ok, reason="", note=""):
    rows.append({"id": cid, "quantity": quantity, "measured": measured, "paper": paper,
                 "verdict": "pass" if ok else "differs",
                 "reason": note if ok else (reason or "see text")})


def _relax_rows(out, summary, checks, info, extra):
    """Rows of the relaxation (appended to ``checks``, ``info``, ``extra``)."""
    cfg = summary["config"]
    P = PAPER
    rel = summary["relax"]
    phi = rel["packing_fraction"]
    _check(checks, "packing_fraction", "packing fraction phi of the relaxed packing", phi,
           P["packing_fraction"], abs(phi - P["packing_fraction"]) <= 0.01,
           reason=(f"phi is set by the preparation (generator box at phi = {cfg['phi']:g}, "
                   f"protocol {rel.get('protocol') or 'default'}, N = {cfg['n']}); the paper "
                   f"does not describe its settling beyond 'loosely packed disks'; "
                   f"difference {phi - P['packing_fraction']:+.4f}"),
           note="within 0.01 of the paper")
    r = rel["residual"]
    _check(checks, "residual", "largest residual force max|F_i|, |T_i|/R_i reached", r,
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
    _check(checks, f"real_at_zero_mu{mu:g}",
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
    _check(checks, f"coalescence_mu{mu:g}",
           f"mu = {mu:g}: two real eigenvalues coalesce into a complex pair at F_x^c",
           coal, "yes", coal,
           reason=f"ramp status {rr['status']}: {rr.get('message', '')}",
           note=(f"lambda_c = {t.lam_c:.6g} (mode {t.rank + 1} of {t.n_modes} from "
                 f"the softest; tracking ambiguity {t.ambiguity:.2f})") if t else "")
    if t is not None and rr["status"] == "complete":
        from remote_trigger.analysis.exceptional import sqrt_law

        sq = sqrt_law(t.F_x, t.lam_a, t.lam_b, rr["F_x_c_low"], rr["F_x_c_high"])
        extra[f"sqrt_law_{k}"] = sq
        ok = all(math.isfinite(sq[s_]) and abs(sq[s_] - 0.5) <= 0.1
                 for s_ in ("below", "above"))
        _check(checks, f"sqrt_law_mu{mu:g}",
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
        _check(checks, f"F_x_c_mu{mus[0]:g}", f"F_x^c(mu = {mus[0]:g}) (midpoint of the "
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
        _check(checks, f"F_x_c_mu{mus[0]:g}", f"F_x^c(mu = {mus[0]:g})", float("nan"),
               "0.0091 < F_x^c < 0.012", False,
               reason=f"ramp {ramps[0]['status']}: {ramps[0].get('message', '')}")
    if 1 in Fc:
        rr = ramps[1]
        info.append(("F_x_c_mu%g" % mus[1], f"F_x^c(mu = {mus[1]:g}) (midpoint of the "
                     f"certified bracket [{rr['F_x_c_low']:.9g}, {rr['F_x_c_high']:.9g}], "
                     f"width {rr['F_x_c_high'] - rr['F_x_c_low']:.2g})", Fc[1]))
    order_ok = 0 in Fc and 1 in Fc and ((Fc[1] < Fc[0]) == (mus[1] < mus[0]))
    ratio = Fc[1] / Fc[0] if (0 in Fc and 1 in Fc) else float("nan")
    _check(checks, "F_x_c_ratio", f"F_x^c(mu = {mus[1]:g}) / F_x^c(mu = {mus[0]:g})", ratio,
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
        _check(checks, "msd_decades_fig4", "Fig. 4: decades of MSD growth from the noise "
               "level (log10 max D / noise)", m["decades"], f"~{P['msd_decades_fig4']:g}",
               m["decades"] >= 12.0,
               reason=(f"the run ended at t = {m['t_end']:.4g} with D = {m['D_max']:.3g} "
                       f"(noise {m['noise']:.3g})"),
               note=f"noise {m['noise']:.3g} -> max {m['D_max']:.3g}")
        rel_err = m["measured_growth_rate"] / m["predicted_growth_rate"] - 1 \
            if m["predicted_growth_rate"] > 0 else float("nan")
        _check(checks, "growth_rate_fig4", "Fig. 4: measured growth rate g of D ~ e^{2gt} / "
               "predicted max Im sqrt(lambda) - 1", rel_err,
               "D grows as e^{2 Im(omega) t} (Eq. 6)",
               np.isfinite(rel_err) and abs(rel_err) < 0.1,
               reason=(f"measured {m['measured_growth_rate']:.4g} vs predicted "
                       f"{m['predicted_growth_rate']:.4g}"),
               note=(f"measured {m['measured_growth_rate']:.4g}, predicted "
                     f"{m['predicted_growth_rate']:.4g} [1/tau]"))
        _check(checks, "saturation_fig4", "Fig. 4: growth saturates (nonlinear) by the end "
               "of the run", m["saturated"], "yes", m["saturated"],
               reason=(f"at t = {m['t_end']:.4g} D still grows at "
                       f"{m['late_rate']:.3g} (predicted {m['predicted_growth_rate']:.3g}); "
                       "a longer run (t_instability, instability_span, d_sat) would show "
                       "the saturation"),
               note=(f"late growth rate {m['late_rate']:.3g} < half the linear rate; "
                     f"D_max = {m['D_max']:.3g}"))
        info.append(("F_x_fig4", "Fig. 4: F_x of the run (fig4_ratio x F_x^c)",
                     summary["instability"]["F_x"]))


def _fig5_rows(out, summary, checks, info, extra):
    """Rows of Fig. 5 (docs/paper.md, "Fig. 5: criteria") (appended to ``checks``, ``info``, ``extra``).

    One method of :class:`_Fig5` per part: the equilibrium and the friction
    drop, runs (a), (b), (c), the controls (d) and (e), the paper's
    amplitude (p), and the informational rows.
    """
    if not summary.get("perturb"):
        return
    pz = summary["perturb"]
    pm = perturb_metrics(out, summary)
    extra["perturb"] = pm
    f = _Fig5(summary, pz, pm, checks, info, extra)
    f.equilibrium_rows()
    f.run_a_rows()
    f.run_b_rows()
    f.run_c_rows()
    f.control_d_rows()
    f.control_e_rows()
    f.paper_amplitude_rows()
    f.info_rows()


class _Fig5:
    """The Fig. 5 part of the report: its inputs, and one method per group of rows."""

    def __init__(self, summary, pz, pm, checks, info, extra):
        self.summary, self.cfg, self.pz, self.pm = summary, summary["config"], pz, pm
        self.checks, self.info, self.extra = checks, info, extra
        self.mu0, self.mu_ss = pm["mu0"], float(pz["mu_ss"])
        self.ms = pz["mu_star"]

    def equilibrium_rows(self):
        pz, checks, mu0, mu_ss, ms = self.pz, self.checks, self.mu0, self.mu_ss, self.ms
        eq5, drop = pz["equilibrium"], pz["drop"]
        _check(checks, "stable_fig5", f"Fig. 5: the equilibrium at F_x = {pz['F_x']:.7g} "
               f"(window fraction {pz.get('window_fraction')}) is certified linearly stable "
               f"with mu0 = {mu0:g} (all eigenvalues real)", eq5["decision"] == "real", "yes",
               eq5["decision"] == "real",
               reason=f"decision {eq5['decision']} (margin {eq5['confidence']:.3g})",
               note=f"margin {eq5['confidence']:.3g}")
        mus = (f"mu* in [{ms['low']:.5g}, {ms['high']:.5g}]" if np.isfinite(ms["low"])
               else "mu* not bisected") + (f"; {ms['message']}" if ms.get("message") else "")
        _check(checks, "drop_unstable_fig5", "Fig. 5: the same state (history built at mu0) "
               f"re-equilibrated with mu = mu_ss mu0 = {mu_ss:g} has a certified complex "
               "pair: a friction drop destabilises it", drop["decision"] == "complex", "yes",
               drop["decision"] == "complex",
               reason=(f"decision {drop['decision']} (margin {drop['confidence']:.3g}): the "
                       "load is not inside the window for this history"),
               note=f"growth rate {drop['growth_rate']:.4g}; {mus}")

    def run_a_rows(self):
        pm, checks, P = self.pm, self.checks, PAPER
        ra = pm["a"]
        _check(checks, "msd_growth_fig5a", "Fig. 5 (a): growth of D over the run "
               "(log10 max D_a / median D_a)", ra["decades"], "~0 (stays at ~1e-20)",
               ra["decades"] < 2.0, reason="D grows in the unperturbed run")
        _check(checks, "msd_level_fig5a", "Fig. 5 (a): noise level of D (median D_a)",
               pm["level_a"], P["msd_level_fig5a"],
               abs(math.log10(pm["level_a"] / P["msd_level_fig5a"])) <= 1.0,
               reason=("the noise comes from the residual force of the equilibrium and "
                       "round-off; positions move by ~sqrt(D) = "
                       f"{math.sqrt(pm['level_a']):.2g}, consistent with residual "
                       f"{self.summary['relax']['residual']:.2g} / contact stiffness ~1e3-1e4"))

    def run_b_rows(self):
        cfg, pm, checks, extra = self.cfg, self.pm, self.checks, self.extra
        rb = pm.get("b")
        ratio_f = cfg["omega_p"] * abs(pm["compliance"]) * pm["a_forcing"] / pm["v0"]
        extra["forced_over_noise"] = ratio_f
        _check(checks, "forcing_fig5b", "Fig. 5 (b): quasi-static velocity of the top line "
               "under f(t) over v0, omega_p C a / v0 (C = d<x_top>/dF_x of the ramp)",
               ratio_f, "> 1 (f(t) can switch mu(v) on)", np.isfinite(ratio_f) and ratio_f > 1,
               reason=f"a = {pm['a_forcing']:.3g} moves the top line below the noise threshold",
               note=(f"a = {pm['a_forcing']:.3g} (measured: fig5_forcing_margin x v0 / "
                     f"(omega_p C), C = {pm['compliance']:.4g}); v0 = {pm['v0']:.3g} = "
                     f"{cfg['fig5_v0_margin']:g} x max |v_top| of the first half of (a)"))
        if rb is not None:
            _check(checks, "msd_fig5b", "Fig. 5 (b): f(t) alone stays bounded: growth of the "
                   "largest D from the first to the second half of the run (decades)",
                   rb["late_growth"], "bounded (max ~1e-17)",
                   np.isfinite(rb["late_growth"]) and rb["late_growth"] < 1.0,
                   reason=f"D grows with f(t) alone (max {rb['max_D']:.3g})",
                   note=f"max D_b = {rb['max_D']:.3g}, {rb['decades']:.3g} decades above D_a")

    def run_c_rows(self):
        pz, pm, checks, extra, P = self.pz, self.pm, self.checks, self.extra, PAPER
        mu_ss = self.mu_ss
        rc = pm.get("c")
        if rc is not None:
            reached = pz.get("reached") or {}
            fit = reached.get("analysis") or {}
            g_meas = float(reached.get("growth_rate", float("nan")))
            g_pred = float(fit.get("growth_rate", float("nan")))
            rel = g_meas / g_pred - 1 if g_pred > 0 else float("nan")
            tw = reached.get("t_window") or [float("nan")] * 2
            extra["growth_fig5c"] = {"measured": g_meas, "predicted": g_pred}
            _check(checks, "growth_rate_fig5c", "Fig. 5 (c): D grows exponentially after mu "
                   "has settled, at the rate max Im sqrt(lambda) of M^-1 K at the friction "
                   "reached (measured / predicted - 1)", rel, "D ~ e^{2 Im(omega) t} (Eq. 6)",
                   np.isfinite(rel) and abs(rel) <= 0.25,
                   reason=(f"measured {g_meas:.4g}, predicted {g_pred:.4g} at mu = "
                           f"{reached.get('mu_fit', float('nan')):.4g}; no exponential window "
                           "of >= 5 records between 10 x the jump and 1e-2 x max D"
                           if reached and not reached.get("window") else
                           f"measured {g_meas:.4g}, predicted {g_pred:.4g} at mu = "
                           f"{reached.get('mu_fit', float('nan')):.4g}" if reached else
                           "mu(v) never settled at mu_ss mu0 or no exponential window"),
                   note=(f"measured {g_meas:.4g} over t in [{tw[0]:.4g}, {tw[1]:.4g}], "
                         f"predicted {g_pred:.4g} at mu = "
                         f"{reached.get('mu_fit', float('nan')):.4g} (certified "
                         f"{fit.get('decision', '?')})" if reached else ""))
            _check(checks, "msd_decades_fig5c", "Fig. 5 (c): decades of D above the median "
                   "D of (a) with f(t) + mu(v)", rc["decades"],
                   f"> {P['msd_decades_fig5c']:g}", rc["decades"] > P["msd_decades_fig5c"],
                   reason=f"max D_c = {rc['max_D']:.3g}",
                   note=(f"max D_c = {rc['max_D']:.3g}; the friction drop alone (control d) "
                         f"reaches {pm['d']['max_D']:.3g}" if "d" in pm else
                         f"max D_c = {rc['max_D']:.3g}"))
            _check(checks, "velocity_decades_fig5c", "Fig. 5 (c): rise of |v_top| above the "
                   "median |v_top| of (a) (log10 max |v_c| / median |v_a|)", rc["v_decades"],
                   f"> {P['velocity_decades_fig5c']:g}",
                   rc["v_decades"] > P["velocity_decades_fig5c"],
                   reason=f"max |v_c| = {rc['max_v']:.3g}, median |v_a| = {pm['v_level_a']:.3g}",
                   note=f"max |v_c| = {rc['max_v']:.3g}, median |v_a| = {pm['v_level_a']:.3g}")
            qs = rc.get("qs_over_v0_at_switch", float("nan"))
            cause = ("not switched on" if not np.isfinite(rc["switch_time"]) else
                     "the steady (quasi-static) response to f(t): omega_p C a e(t) |sin| "
                     f"= {qs:.3g} v0 at the switch" if qs >= 1 else
                     "the onset transient of f(t) (its quasi-static velocity was only "
                     f"{qs:.3g} v0 at the switch)")
            extra["switch_cause"] = cause
            _check(checks, "mu_drop_fig5c", "Fig. 5 (c): mu(v) switches on and the friction "
                   "falls to mu_ss mu0 (lowest mu reached)", rc["min_mu"],
                   f"mu(v) -> mu_ss mu0 = {mu_ss:g}", rc["min_mu"] <= mu_ss * (1 + 1e-3),
                   reason=(f"|v_top| never exceeded v0 = {pm['v0']:.2g}" if
                           not np.isfinite(rc["switch_time"]) else
                           f"mu fell only to {rc['min_mu']:.4g}"),
                   note=f"switched on at t = {rc['switch_time']:.4g} by {cause}")

    def control_d_rows(self):
        pz, pm, checks, extra = self.pz, self.pm, self.checks, self.extra
        mu_ss = self.mu_ss
        if "d" in pm:
            rd = pm["d"]
            ctl = pz["control"]
            g_c = extra.get("growth_fig5c", {}).get("predicted", float("nan"))
            span = rd["t_end"] - rd["switch_time"] - 100.0
            expect = 2 * g_c * 0.75 * span / math.log(10) if g_c > 0 else float("nan")
            gd = rd.get("growth_after_switch", float("nan"))
            _check(checks, "control_fig5d", f"Fig. 5 (d): control at F_x = {ctl['F_x']:.6g} "
                   f"(certified real after the drop to mu = {mu_ss:g}): growth of D after its "
                   "re-equilibration jump (decades, max over the last vs the first quarter "
                   "after t_switch + 100)", gd, "no exponential growth (< 1 decade)",
                   np.isfinite(gd) and gd < 1.0,
                   reason=(f"D_d grows by {gd:.3g} decades after the friction drop "
                           f"(max {rd['max_D']:.3g})" if np.isfinite(rd["switch_time"]) else
                           "mu(v) never switched on in the control: it does not test the "
                           "friction drop"),
                   note=(f"jump to {rd['post_switch_level']:.3g}, max {rd['max_D']:.3g}; "
                         f"at the rate of (c) it would grow {expect:.3g} decades"))
        else:
            _check(checks, "control_fig5d", "Fig. 5 (d): control below the window", float("nan"),
                   "no exponential growth", False,
                   reason="no ramp step below the window is certified real after the drop "
                          "(see paper.json perturb.control_tried)")

    def control_e_rows(self):
        cfg, pm, checks, mu0 = self.cfg, self.pm, self.checks, self.mu0
        if "e" in pm:
            re_ = pm["e"]
            ok = not np.isfinite(re_["switch_time"]) and not re_["triggered"]
            _check(checks, "control_fig5e", "Fig. 5 (e): mu(v) without forcing at the Fig. 5 "
                   "load stays untriggered (mu never leaves mu0)", re_["min_mu"],
                   f"mu0 = {mu0:g} throughout", ok,
                   reason=(f"noise alone switched mu(v) on at t = {re_['switch_time']:.4g}: "
                           f"v0's margin ({cfg['fig5_v0_margin']:g}) is too small"),
                   note=(f"max |v_top| {re_['max_v']:.3g} < v0 = {pm['v0']:.3g} over "
                         f"t = {re_['t_end']:.4g} (v0 was set from the first half of (a); "
                         "while |v| <= v0, (e) is step by step the same run as (a))"))

    def paper_amplitude_rows(self):
        cfg, pm, checks, P = self.cfg, self.pm, self.checks, PAPER
        if "p" in pm:
            rp = pm["p"]
            qs_p = cfg["omega_p"] * abs(pm["compliance"]) * cfg["a_paper"] / pm["v0"]
            _check(checks, "paper_amplitude_fig5", f"Fig. 5 (p): the paper's a = "
                   f"{cfg['a_paper']:g} with mu(v): decades of D above the (a) level",
                   rp["decades"], f"> {P['msd_decades_fig5c']:g} (paper's red line)",
                   rp["triggered"] and rp["decades"] > P["msd_decades_fig5c"],
                   reason=(f"not triggered: omega_p C a = {qs_p:.2g} v0, so the forced motion "
                           f"of the top line stays below v0 (set by our noise, {pm['v0']:.2g}) "
                           "and mu(v) never switches on; the paper's noise was ~1e-20 in D"
                           if not np.isfinite(rp["switch_time"]) else
                           f"mu switched at t = {rp['switch_time']:.4g} but D grew only "
                           f"{rp['decades']:.3g} decades"),
                   note=f"switched on at t = {rp['switch_time']:.4g}")

    def info_rows(self):
        pz, pm, info, ms = self.pz, self.pm, self.info, self.ms
        rc = pm.get("c")
        info.append(("F_x_fig5", "Fig. 5: F_x of the runs", pz["F_x"]))
        info.append(("fig5_window", "Fig. 5: the window [F_x^c(mu_ss mu0), F_x^c(mu0)] "
                     f"= [{pz['window'][0]:.8g}, {pz['window'][1]:.8g}]; fraction",
                     pz.get("window_fraction")))
        info.append(("mu_star", "Fig. 5: mu* (pair turns complex below it), bracket midpoint"
                     + (f" [{ms['low']:.6g}, {ms['high']:.6g}]" if np.isfinite(ms["low"]) else
                        ""), 0.5 * (ms["low"] + ms["high"])))
        info.append(("v0", "Fig. 5: v0 = v_ss [sigma/tau]", pm["v0"]))
        info.append(("a_fig5", "Fig. 5: amplitude a of f(t) in (b)-(d)", pm["a_forcing"]))
        info.append(("compliance", "d<x_top>/dF_x near the Fig. 5 load [length/force]",
                     pm["compliance"]))
        info.append(("dt_fig5", "Fig. 5: time step (fig5_dt_fraction x limit)", pz["dt"]))
        if rc is not None:
            info.append(("trigger_time", "Fig. 5 (c): first time with mu < mu0 [tau]",
                         rc["switch_time"]))


def _normal_form_rows(out, summary, checks, info, extra):
    """Rows of the normal form (appended to ``checks``, ``info``, ``extra``)."""
    if os.path.exists(os.path.join(out, "normal_form.h5")):
        nf = normal_form_metrics(out)
        extra["normal_form"] = nf
        if "A_sqrt_eps" in nf:
            v = nf["A_sqrt_eps"]
            _check(checks, "nf_A_sqrt_eps", f"normal form: A sqrt(eps) at eps = "
                   f"{nf['eps_min']:g}, no damping", v, "-> 1 (A ~ eps^-1/2, Eq. 17)",
                   abs(v - 1) < 0.05, reason="the amplitude does not follow eps^-1/2")
        if "slope" in nf:
            s = nf["slope"]
            _check(checks, "nf_slope", "normal form: d log A / d log eps at the smallest eps",
                   s, -0.5, abs(s + 0.5) < 0.05, reason="A does not scale as eps^-1/2")
        for tau, ratio in nf["damped_ratio"].items():
            _check(checks, f"nf_damped_tau{tau:g}", f"normal form, tau = {tau:g}: A / damped "
                   f"estimate at eps = {nf['eps_min']:g}", ratio,
                   "1 (damped estimate, Section IV, with decay e^{-t/2tau})", abs(ratio - 1) < 0.1,
                   reason="the damped amplitude departs from the estimate")


def collect(out, summary):
    """All checks and informational numbers: ``(checks, info, extra)``.

    One function per part of the job (:func:`_relax_rows`, :func:`_ramp_rows`,
    :func:`_fig4_rows`, :func:`_fig5_rows`, :func:`_normal_form_rows`), in the
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
          f"{' --quick' if cfg.get('quick') else ''}: N = {cfg['n']}, seed {cfg['seed']}, "
          f"k_n = {cfg['k_n']:g}, k_t = {cfg['k_t']:.6g}, F_y = {cfg['F_y']:g}, "
          f"mu = {cfg['mu']:g} and {cfg['mu_low']:g}, dF_x = {cfg['dF_x']:g}, "
          f"tol = {cfg['tol']:g}; {summary.get('n_ranks', 1)} MPI rank(s). Units: LAMMPS lj "
          "(length sigma = 2R1, mass m, time tau, force in lj units). Every *measured* number comes from this run's "
          "files; the *paper* column holds the paper's reference values "
          "(`remote_trigger.pywrap.paper_config.PAPER`). Verdicts: **pass** = the paper's "
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
          "< 2 contacts); complex = certified by the analyzer (docs/analysis.md).",
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
