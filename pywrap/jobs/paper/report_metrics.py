"""The measurements behind ``report.md`` of ``remote-trigger paper``.

Each function reads the files of the job's output folder (HDF5 series,
ramp files, dumps) and the job summary (``paper.json``) and returns plain
numbers; :mod:`~remote_trigger.pywrap.jobs.paper.report` turns them into rows
with verdicts (docs/paper.md, definitions in that module's docstring).
"""
import math
import os

import numpy as np

from remote_trigger.analysis.dynamics.series import (
    below_exponential, exp_rate, growth_window, noise_level)
from remote_trigger.analysis.stability.decision import Decision

# --------------------------------------------------------------------------- readers
def read_series(path):
    """A series file of the paper job (``t``, ``D``, ``v_top``, ``mu`` and its
    attributes, bytes decoded), as a dict."""
    import h5py

    with h5py.File(path, "r") as fh:
        d = {k: fh[k][()] for k in ("t", "D", "v_top", "mu")}
        d["attrs"] = {k: (v.decode() if isinstance(v, bytes) else v)
                      for k, v in fh.attrs.items()}
    return d


def tracks(out, summary):
    """:class:`~remote_trigger.analysis.stability.eigtrack.PairTrack` per ramp index (0: mu, 1: mu_low), None if none."""
    import h5py
    from remote_trigger.analysis.stability.eigtrack import track_pair
    from remote_trigger.pywrap.stages.ramp_file import read_spectra

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
                                  Decision.certified(C[i] > 0)))
        res[k] = track_pair(read_spectra(r["h5"], extra))
    return res


def spectrum_at_zero(h5path):
    """Decision and extreme eigenvalues of the first ramp step (F_x = 0)."""
    import h5py

    from remote_trigger.pywrap.stages import ramp_file as rf

    def first(fh, name):
        key = rf.column(rf.STEPS, name)
        return fh[key][0] if key in fh else float("nan")

    with h5py.File(h5path, "r") as fh:
        lam = fh[f"{rf.EIGENVALUES}/{rf.STEPS}/{rf.point_name(rf.STEPS, 0)}"][()]
        cplx, dec, conf, F0 = (float(first(fh, c))
                               for c in ("complex", "decision", "confidence", "F_x"))
        datafile = first(fh, rf.DATAFILE)
        datafile = (rf.point_file(h5path, datafile, fh.attrs)
                    if isinstance(datafile, (str, bytes)) else "")
    asym = float("nan")
    dump = datafile[:-len(".data")] + ".dump"
    if os.path.isfile(dump):
        from remote_trigger.analysis.state.dumpfile import read_equilibrium
        from remote_trigger.analysis.stability.jacobian import stiffness_matrix
        from remote_trigger.analysis.stability.jacobian3d import stiffness_matrix3d

        st = read_equilibrium(dump)
        K = (stiffness_matrix3d if st.positions.shape[1] == 3 else stiffness_matrix)(st)
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
    c = F[dec == Decision.COMPLEX]
    first_c = float(np.min(c)) if c.size else float("nan")
    r = F[(dec == 0) & (F < first_c)] if c.size else F[dec == 0]
    real = float(np.max(r)) if r.size else float("nan")
    return {"real": real, "complex": first_c, "width": first_c - real,
            "undecided": int(np.count_nonzero(dec < 0)),
            "message": msg.decode() if isinstance(msg, bytes) else str(msg)}


#: Fig. 4 has saturated when D over the last 10 % of the run is more than this
#: many decades below the growth window's exponential extrapolated to the end
SATURATION_DECADES = 3.0


def instability_metrics(out, summary):
    """Numbers and series of the Fig. 4 run."""
    s = read_series(os.path.join(out, "instability.h5"))
    t, D = s["t"], s["D"]
    noise = noise_level(t, D)
    Dmax = float(np.max(D))
    window, g_meas = growth_window(t, D, noise)
    inst = summary.get("instability", {})
    g_pred = float(inst.get("predicted_growth_rate", s["attrs"].get("predicted_growth_rate",
                                                                     float("nan"))))
    # saturation: D over the last 10 % of the run stays far below the
    # exponential of the growth window extrapolated to the end (the rate over
    # the tail alone is no test: a late slip event can fall inside it)
    n = len(t)
    tail = slice(int(0.9 * n), n)
    late = exp_rate(t[tail], np.maximum(D[tail], 1e-300), min_records=1) if n > 20 \
        else float("nan")
    below = below_exponential(t, D, window, g_meas) if n > 20 else float("nan")
    return {"t": t, "D": D, "noise": noise, "D_max": Dmax,
            "decades": float(np.log10(Dmax / noise)) if noise > 0 else float("nan"),
            "window": window, "measured_growth_rate": g_meas,
            "predicted_growth_rate": g_pred, "late_rate": float(late),
            "t_end": float(t[-1]), "status": s["attrs"].get("status", ""),
            "below_exponential": below,
            "saturated": bool(np.isfinite(below) and below > SATURATION_DECADES)}


def perturb_metrics(out, summary):
    """Numbers and series of the Fig. 5 runs (a)-(e), (p) (:mod:`.fig5`).

    Definitions in docs/paper.md ("Fig. 5: criteria"); every level is
    measured from the files, every prediction comes from the friction-drop
    analyses in the summary.
    """
    from remote_trigger.analysis.dynamics import series as ser

    pz = summary["perturb"]
    mu0 = float(pz.get("mu0", summary["config"]["mu"]))
    runs = {}
    for k in "abcdep":
        p = os.path.join(out, f"perturb_{k}.h5")
        if os.path.exists(p):
            runs[k] = read_series(p)
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
                # over every step (the series file's running max), as v0 is
                "v_top_max": float(s_["attrs"].get("v_top_max", np.max(np.abs(v)))),
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
