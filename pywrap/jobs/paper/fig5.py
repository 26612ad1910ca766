"""Fig. 5 of the paper job: remote triggering shown, with controls that could fail.

The paper's design (Section III.C.3): a load F_x that is linearly stable for
the static friction mu0 but lies above F_x^c of the lower, dynamic friction
mu_ss mu0, so that a friction drop makes the state linearly unstable. This
module builds Fig. 5 around that window (docs/paper.md, "Fig. 5"):

1. **Load.** F_5 = F_x^c(mu_ss mu0) + w (F_x^c(mu0) - F_x^c(mu_ss mu0)),
   w = ``fig5_window`` (or an explicit ``fig5_F_x``), equilibrated with mu0
   from the nearest lower step of the mu0 ramp.
2. **Friction-drop analysis** (:func:`friction_drop`): the equilibrium's
   data file (tangential history built at mu0) is loaded with a lower
   friction mu, re-equilibrated (contacts above the new Coulomb limit slide)
   and analysed (certified decision, growth rate max Im sqrt(lambda)). At
   F_5: certified real with mu0, certified complex with mu_ss mu0, and mu*
   (where the pair turns complex) by bisection in mu (:func:`mu_star`).
3. **Runs** (undamped, ``in.perturb``; spheres ``in.perturb3d``): (a) unperturbed, (b) f(t), (c) f(t)
   + mu(v), (d) control: f(t) + mu(v) at a load certified real after the
   friction drop, (e) control: mu(v) without forcing at F_5, and (p) the
   paper's amplitude a = 1e-12 with mu(v). v0 = ``fig5_v0_margin`` x the
   largest |v_top| of run (a) over every step of its first half; the
   amplitude a = ``fig5_forcing_margin`` x v0 / (omega_p C), C = d<x_top>/dF_x
   of the ramp (the quasi-static velocity of the top line under f(t) is
   omega_p C a). A run stops once D passes the runaway level ``fig5_d_run``.

Everything is written under ``out/perturb/`` (equilibria, friction-drop
analyses) and ``out/perturb_{a,b,c,d,e,p}.h5``; the verdicts are computed by
:mod:`~remote_trigger.pywrap.jobs.paper.report` from these files and the summary returned here.
"""
import math
import os
import time

import numpy as np

from remote_trigger.analysis.stability.decision import Decision
from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.stages import ramp_file

#: the runs of Fig. 5, in order
RUNS = ("a", "b", "c", "d", "e", "p")


def friction_drop(eng, rcfg, datafile, F_x, mu, prefix):
    """Equilibrium after the friction coefficient drops to ``mu``, analysed.

    The data file (positions and tangential history of an equilibrium, e.g.
    built at mu0; spheres: the history of the dump beside it) is loaded with friction ``mu`` on every contact and the
    wall, re-equilibrated at ``F_x`` (Newton first, damped dynamics if
    needed; contacts beyond the new Coulomb limit slide) and analysed.

    Parameters
    ----------
    eng : Engine
    rcfg : RampConfig
        Model of the ramp (its ``mu`` is replaced by ``mu``).
    datafile : str
    F_x : float
    mu : float
    prefix : str
        Output ``prefix.{data,dump,dump.json}``.

    Returns
    -------
    dict
        ``mu``, ``decision`` (the label of the
        :class:`~remote_trigger.analysis.stability.decision.Decision`: 'real',
        'complex', 'undecided', as the job's JSON records store it), ``confidence``,
        ``growth_rate`` (max Im sqrt(lambda), 1/time), ``residual``,
        ``datafile``.
    """
    from remote_trigger.pywrap.bindings.datafile import data_dimension
    from remote_trigger.pywrap.stages.point import ramp_point

    vals, res = ramp_point(eng, rcfg.replace(mu=float(mu)), datafile, float(F_x), prefix,
                            dim=data_dimension(datafile))
    return {"mu": float(mu), "decision": res.decision.label,
            "confidence": float(res.confidence),
            "growth_rate": float(res.growth_rate), "residual": float(vals["residual"]),
            "datafile": prefix + ".data"}


def mu_star(eng, rcfg, datafile, F_x, mu_lo, mu_hi, tol, folder):
    """Friction at which the pair turns complex, by bisection in mu.

    ``mu_lo`` must be certified complex and ``mu_hi`` certified real (history
    of ``datafile`` kept, as in :func:`friction_drop`). Only certified
    decisions move the bracket; an undecided point ends the bisection (the
    bracket reached is returned with a message).

    Returns
    -------
    dict
        ``low`` (largest mu certified complex), ``high`` (smallest mu
        certified real), ``points`` (list of friction-drop dicts),
        ``message``.
    """
    lo, hi = float(mu_lo), float(mu_hi)
    points, message = [], ""
    j = 0
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        p = friction_drop(eng, rcfg, datafile, F_x, mid, os.path.join(folder, f"mu_{j:02d}"))
        points.append(p)
        j += 1
        if Decision.of(p["decision"]) is Decision.COMPLEX:
            lo = mid
        elif Decision.of(p["decision"]) is Decision.REAL:
            hi = mid
        else:
            message = (f"undecided at mu = {mid:.6g} (margin {p['confidence']:.2g}): "
                       f"bisection stopped at width {hi - lo:.3g}")
            break
    return {"low": lo, "high": hi, "points": points, "message": message}


def top_compliance(ramp_h5, F):
    """d<x_top>/dF_x of a ramp between its two steps around F (length/force).

    Parameters
    ----------
    ramp_h5 : str
        ``ramp.h5`` of the ramp (its step dumps are read).
    F : float

    Returns
    -------
    float
    """
    from remote_trigger.analysis.state.dumpfile import read_equilibrium

    Fs, files = ramp_file.read_points(ramp_h5)
    k = int(np.clip(np.searchsorted(Fs, F) - 1, 0, len(Fs) - 2))
    xs = []
    for i in (k, k + 1):
        st = read_equilibrium(files[i][:-len(".data")] + ".dump")
        top = st.external[:, 1] != 0
        xs.append(float(np.mean(st.positions[top, 0])))
    return (xs[1] - xs[0]) / (Fs[k + 1] - Fs[k])


def fig5_load(cfg, ramps):
    """F_x of Fig. 5 and the window it lies in.

    Parameters
    ----------
    cfg : PaperConfig
    ramps : list of dict
        Ramp summaries ``[mu0, mu_low]`` (``F_x_c_low``, ``F_x_c_high``).

    Returns
    -------
    (float, float, float)
        F_5, lower end of the window (F_x^c(mu_low) bracket's high end),
        upper end (F_x^c(mu0) bracket's low end).

    Raises
    ------
    ConfigError
        If the window is empty, or ``fig5_F_x`` is not below F_x^c(mu0).
    """
    hi = float(ramps[0]["F_x_c_low"])
    lo = float(ramps[1]["F_x_c_high"]) if ramps[1] and ramps[1].get("status") == "complete" \
        else float("nan")
    if cfg.fig5_F_x is not None:
        if not cfg.fig5_F_x < hi:
            raise ConfigError(f"fig5_F_x must be below F_x^c(mu = {cfg.mu:g}) = {hi:.8g} "
                              f"(a linearly stable load), got fig5_F_x = {cfg.fig5_F_x!r}")
        return float(cfg.fig5_F_x), lo, hi
    if not (math.isfinite(lo) and lo < hi):
        raise ConfigError(f"no window for Fig. 5: F_x^c(mu = {cfg.mu_low:g}) = {lo:.8g} is not "
                          f"below F_x^c(mu = {cfg.mu:g}) = {hi:.8g}; give fig5_F_x below "
                          f"{hi:.8g} (--resume with it keeps the relaxation and the ramps), "
                          f"or take another packing (--seed)")
    return lo + cfg.fig5_window * (hi - lo), lo, hi


def _load_analysis(eng, cfg, rcfg, start, F5, mu0, mu_ss, folder, clock):
    """The equilibrium at F5 with mu0, the friction drop to mu_ss and mu*.

    Returns
    -------
    (dict, dict, dict)
        :func:`friction_drop` at mu0 (``datafile`` is the equilibrium) and at
        mu_ss, and the :func:`mu_star` bracket (NaN unless real -> complex).
    """
    eq5 = friction_drop(eng, rcfg, start, F5, mu0, os.path.join(folder, "equilibrium"))
    data5 = eq5["datafile"]
    drop = friction_drop(eng, rcfg, data5, F5, mu_ss, os.path.join(folder, "drop"))
    ms = {"low": float("nan"), "high": float("nan"), "points": [], "message": ""}
    if Decision.of(eq5["decision"]) is Decision.REAL and \
            Decision.of(drop["decision"]) is Decision.COMPLEX:
        ms = mu_star(eng, rcfg, data5, F5, mu_ss, mu0, cfg.mu_star_tol,
                     os.path.join(folder, "mu_star"))
    clock.say(f"Fig. 5: at F_x = {F5:.7g}: mu = {mu0:g} {eq5['decision']} (margin "
              f"{eq5['confidence']:.3g}); after a drop to mu = {mu_ss:g}: {drop['decision']}"
              f" (growth rate {drop['growth_rate']:.4g}); mu* in "
              f"[{ms['low']:.5g}, {ms['high']:.5g}]")
    return eq5, drop, ms


def _control_load(eng, rcfg, F_steps, files, w_lo, F5, mu_ss, folder, clock):
    """A ramp step below the window certified real after the drop to mu_ss.

    The step nearest F_m = w_lo - (F5 - w_lo) from below, then every 4th step
    further down (at most 6 tried).

    Returns
    -------
    (dict or None, list of dict)
        ``F_x``, ``datafile``, ``drop`` of the control (None if none), and
        every step tried.
    """
    F_m = w_lo - (F5 - w_lo)
    cand = np.flatnonzero(F_steps <= F_m)
    control = None
    tried = []
    for k in list(cand[::-1])[:1] + list(cand[::-1][4::4])[:5]:
        d = friction_drop(eng, rcfg, files[int(k)], float(F_steps[k]), mu_ss,
                          os.path.join(folder, f"control_drop_{int(k):05d}"))
        d["F_x"] = float(F_steps[k])
        tried.append(d)
        if Decision.of(d["decision"]) is Decision.REAL:
            control = {"F_x": float(F_steps[k]), "datafile": files[int(k)], "drop": d}
            break
    clock.say("Fig. 5 (d): control load " + (
        f"F_x = {control['F_x']:.7g}: certified real after the drop to mu = {mu_ss:g} "
        f"(margin {control['drop']['confidence']:.3g})" if control else
        "not found: no ramp step below the window certified real after the drop "
        "(tried " + ", ".join(f"{d['F_x']:.5g}" for d in tried) + ")"))
    return control, tried


def run_fig5(cfg, out, ramps, comm, clock):
    """The whole Fig. 5 phase; all ranks of ``comm`` call it.

    Returns
    -------
    dict
        Summary (JSON-able) with the loads, analyses, v0, a, the runs' files
        and wall times; the report reads the series from the files.
    """
    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.jobs.paper.stage_configs import ramp_config

    t_start = time.perf_counter()
    rank0 = comm.Get_rank() == 0
    F5, w_lo, w_hi = fig5_load(cfg, ramps)
    h5_0 = ramps[0]["h5"]
    F_steps, files = ramp_file.read_points(h5_0) if rank0 else (None, None)
    F_steps, files = comm.bcast((F_steps, files), root=0)
    folder = os.path.join(out, "perturb")
    if rank0:
        os.makedirs(folder, exist_ok=True)
        os.makedirs(os.path.join(folder, "mu_star"), exist_ok=True)
    comm.Barrier()
    mu0 = float(cfg.mu)
    mu_ss = float(cfg.mu_ss) * mu0
    below = np.flatnonzero(F_steps <= F5)
    start = files[int(below[-1])] if below.size else files[0]
    rcfg = ramp_config(cfg, start, mu0)
    # the window is that of the second ramp, at mu_low (= mu_ss mu0 unless
    # fig5_F_x is given); a given F_x has its own fraction of it
    frac = (cfg.fig5_window if cfg.fig5_F_x is None else
            (F5 - w_lo) / (w_hi - w_lo) if math.isfinite(w_lo) and w_hi > w_lo
            else float("nan"))
    summ = {"F_x": F5, "window": [w_lo, w_hi], "window_fraction": frac,
            "start": start, "mu0": mu0, "mu_ss": mu_ss}
    clock.say(f"Fig. 5: F_x = {F5:.7g} in the window [{w_lo:.7g}, {w_hi:.7g}] of "
              f"F_x^c(mu = {float(cfg.mu_low):g}) and F_x^c(mu = {mu0:g})")
    with Engine(comm=comm) as eng:
        # ---- the equilibrium at F5 (mu0), its spectrum, the friction drop, mu*
        eq5, drop, ms = _load_analysis(eng, cfg, rcfg, start, F5, mu0, mu_ss, folder, clock)
        summ.update(equilibrium=eq5, drop=drop, mu_star=ms)
        # ---- the control load: certified real after the friction drop
        control, tried = _control_load(eng, rcfg, F_steps, files, w_lo, F5, mu_ss, folder,
                                       clock)
        summ["control"] = control
        summ["control_tried"] = tried
        # ---- the undamped runs, then the friction reached in (c): its spectrum
        #      (predicted growth rate); (c)'s records are on every rank, so every
        #      rank gets the same window
        runs = _Fig5Runs(eng, cfg, out, summ, eq5, F5, mu0,
                         os.path.join(folder, "equilibrium.dump"))
        rc = runs.all_runs(h5_0, F5, control, clock)
        from remote_trigger.analysis.dynamics import series as ser

        pred = ser.settled_growth(rc.t, rc.D, rc.mu, mu0, mu_ss, cfg.fig5_settle_tol)
        if pred is not None and math.isfinite(pred["mu_fit"]):
            fit = friction_drop(eng, rcfg, eq5["datafile"], F5, pred["mu_fit"],
                                os.path.join(folder, "drop_fit"))
            pred["analysis"] = fit
        summ["reached"] = pred
    summ["wall"] = time.perf_counter() - t_start
    return summ


class _Fig5Runs:
    """The undamped runs (a)-(e) and (p) of Fig. 5 from the equilibrium at F5.

    Sets the time step (``fig5_dt_fraction`` x the stability limit at F5),
    runs (a), derives v0 and the forcing amplitude a from it, then the
    forced and control runs; their results go into ``summ`` in this order.
    """

    def __init__(self, eng, cfg, out, summ, eq5, F5, mu0, dump):
        from remote_trigger.analysis.state.dumpfile import read_equilibrium
        from remote_trigger.analysis.stability.timestep import stability_limit
        from remote_trigger.pywrap.jobs.paper.stage_configs import dynamics_config

        self.eng, self.cfg, self.out, self.summ, self.mu0 = eng, cfg, out, summ, mu0
        self.data5 = eq5["datafile"]
        lim = None
        if eng.comm.Get_rank() == 0:
            lim = float(stability_limit(read_equilibrium(dump)))
        lim = eng.comm.bcast(lim, root=0)
        dt = cfg.fig5_dt_fraction * lim
        summ.update(dt=dt, dt_max=lim)
        t_on = cfg.t_on if cfg.t_on is not None else 0.5 * math.pi / cfg.omega_p
        summ["t_on"] = t_on
        self.dcfg = dynamics_config(cfg, self.data5, F5, cfg.t_perturb, dt=dt, t_on=t_on)
        self.base = {"stage": "perturb", "equilibrium": self.data5,
                     "equilibrium_residual": eq5["residual"], "dt_used": dt, "dt_max": lim,
                     "dt_fraction": cfg.fig5_dt_fraction}
        self.walls, self.files = {}, {}
        # saturation span: fig5_sat_span, longer where the certified growth
        # rate after the drop is too slow to grow 8x over it
        from remote_trigger.analysis.dynamics.series import saturation_span
        self.sat_span = saturation_span(summ["drop"]["growth_rate"], cfg.fig5_sat_span)
        summ["sat_span"] = self.sat_span

    def _stop(self, o):
        from remote_trigger.analysis.dynamics import series as ser

        cfg = self.cfg
        return o["D"][-1] > cfg.fig5_d_run or (
            o["mu"][-1] < self.mu0 and ser.saturated(o["t"], o["D"], o["mu"], self.mu0,
                                                     span=self.sat_span))

    def run(self, key, dc, datafile, variables, stop=True, **attrs):
        """One undamped run ``perturb_<key>.h5`` (stopped at fig5_d_run or saturation)."""
        from remote_trigger.pywrap.stages.runs import undamped_run

        cfg = self.cfg
        t0 = time.perf_counter()
        h5 = os.path.join(self.out, f"perturb_{key}.h5")
        res = undamped_run(
            self.eng, dc, datafile, h5, variables, f"perturb ({key})", True,
            stop=self._stop if stop else None, dim=cfg.dim,
            attrs=dict(self.base, run=key, d_run=cfg.fig5_d_run, sat_span=self.sat_span,
                       **attrs))
        self.walls[key] = time.perf_counter() - t0
        self.files[key] = h5
        return res

    def _amplitude(self, ra, h5_0, F5, clock):
        """v0 from the noise of (a), the top line's compliance C, the forcing a."""
        cfg, comm = self.cfg, self.eng.comm
        rm = ra.extra["v_top_running_max"]
        half = int(np.searchsorted(ra.t, 0.5 * ra.t[-1], side="right")) - 1
        noise_v = float(rm[max(half, 1)])
        v0 = cfg.fig5_v0_margin * noise_v
        if not v0 > 0:
            v0 = float(np.finfo(float).tiny)
        C = None
        if comm.Get_rank() == 0:
            C = top_compliance(h5_0, F5)
        C = comm.bcast(C, root=0)
        a = cfg.a if cfg.a is not None else cfg.fig5_forcing_margin * v0 / (cfg.omega_p * abs(C))
        self.summ.update(v0=v0, v_ss=v0, noise_v_half=noise_v,
                         noise_v_full=float(ra.extra["v_top_max"]), compliance=C, a=a)
        clock.say(f"Fig. 5 (a): max |v_top| {noise_v:.3g} (first half), "
                  f"{ra.extra['v_top_max']:.3g} (whole run); v0 = {v0:.3g}; "
                  f"C = {C:.4g}; a = {a:.3g} (omega_p C a = {cfg.omega_p * abs(C) * a / v0:.3g} v0)")
        return v0, a

    def all_runs(self, h5_0, F5, control, clock):
        """Runs (a), (b), (c), (d) (if a control load exists), (e), (p); returns (c)."""
        cfg, dcfg, data5 = self.cfg, self.dcfg, self.data5
        ra = self.run("a", dcfg, data5, {"a": 0.0, "muv": 0}, stop=False)
        v0, a = self._amplitude(ra, h5_0, F5, clock)
        muv = {"muv": 1, "v0": v0, "vss": v0, "B": float(cfg.B), "w": float(cfg.w),
               "muss": float(cfg.mu_ss)}
        force = {"a": float(a), "wp": float(cfg.omega_p)}
        self.run("b", dcfg, data5, dict(force, muv=0), a_forcing=a)
        rc = self.run("c", dcfg, data5, dict(force, **muv), a_forcing=a, v0=v0, v_ss=v0)
        if control is not None:
            ccfg = dcfg.replace(datafile=control["datafile"], F_x=control["F_x"])
            self.run("d", ccfg, control["datafile"], dict(force, **muv), a_forcing=a, v0=v0,
                     v_ss=v0, control_F_x=control["F_x"])
        self.run("e", dcfg, data5, dict({"a": 0.0}, **muv), v0=v0, v_ss=v0)
        self.run("p", dcfg, data5,
                 dict({"a": float(cfg.a_paper), "wp": float(cfg.omega_p)}, **muv),
                 a_forcing=float(cfg.a_paper), v0=v0, v_ss=v0)
        self.summ.update(walls=self.walls, files=self.files)
        return rc
