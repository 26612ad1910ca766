"""The phases of ``remote-trigger paper``: the runs of each phase (their stage
configurations from :mod:`.stage_configs`)."""
import math
import os
import time

import numpy as np

from remote_trigger.analysis.output import bracket_text
from remote_trigger.pywrap.jobs.paper.manifest import ramp_dir
from remote_trigger.pywrap.jobs.paper.stage_configs import dynamics_config, ramp_config


class Clock:
    """Brief progress lines with the elapsed time.

    Printed at once on world rank 0; a clock with ``buffer`` (the leader of
    the second rank group) keeps its lines in ``lines`` until the groups meet,
    where rank 0 prints them (under MPI only rank 0 prints).
    """

    def __init__(self, speak, t0=None, buffer=False):
        self.t0 = time.perf_counter() if t0 is None else t0
        self.speak = speak
        self.buffer = buffer
        self.lines = []

    def say(self, msg):
        """Print ``msg`` with the elapsed time (or buffer it); nothing unless speaking."""
        if self.speak:
            line = f"[paper {time.perf_counter() - self.t0:7.1f} s] {msg}"
            if self.buffer:
                self.lines.append(line)
            else:
                print(line, flush=True)

    def take(self):
        """The buffered lines (emptied)."""
        lines, self.lines = self.lines, []
        return lines


def analyze_on_root(comm, dump):
    """Eigen-analysis of an equilibrium dump on rank 0 of ``comm``, broadcast.

    The dump is an equilibrium the driver accepted (its own Newton test), so
    the analyzer's residual check is not repeated (``allow_residual=True``).

    Returns
    -------
    StabilityResult
    """
    from remote_trigger.pywrap.runtime.parallel import on_rank0
    from remote_trigger.analysis.stability.verdict import stability_of_dump

    return on_rank0(comm, stability_of_dump, dump, allow_residual=True)


def continue_ramp(rcfg, start_file, loads, folder, comm):
    """Equilibria above F_x^c: the continuation of the ramp for Figs. 3 and 4.

    Each load starts from the previous equilibrium (the first from
    ``start_file``), is equilibrated exactly as a ramp step (the scene of
    ``stages.common.load_equilibrium_scene``: disks or spheres with the
    history of the dump beside the data file; Newton first, damped dynamics
    if needed), written to
    ``folder/ext_NN.*`` and analysed. Stops at the first load without an
    equilibrium.

    Parameters
    ----------
    rcfg : RampConfig
        Model and friction of the ramp.
    start_file : str
        Data file of an equilibrium just above F_x^c.
    loads : sequence of float
        Increasing loads F_x.
    folder : str
        Output folder (created).
    comm : mpi4py communicator

    Returns
    -------
    list of dict
        One per equilibrium reached: ``F_x``, ``residual``, ``complex``,
        ``growth_rate``, ``confidence``, ``eigenvalues``, ``datafile``.
    """
    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.stages import equilibrium as eq
    from remote_trigger.pywrap.bindings.datafile import data_dimension
    from remote_trigger.pywrap.stages.common import load_equilibrium_scene, save_equilibrium

    if comm.Get_rank() == 0:
        os.makedirs(folder, exist_ok=True)
    comm.Barrier()
    rows = []
    start = start_file
    dim = data_dimension(start_file)
    with Engine(comm=comm) as eng:
        for k, F in enumerate(loads):
            prefix = os.path.join(folder, f"ext_{k:02d}")
            load_equilibrium_scene(eng, rcfg, start, F, dim)
            try:
                r, _, _ = eq.equilibrate(eng, rcfg, F, newton_first=True)
            except eq.NoEquilibriumError as exc:
                rows.append({"F_x": float(F), "error": str(exc)})
                break
            save_equilibrium(eng, rcfg, F, prefix)
            res = analyze_on_root(comm, prefix + ".dump")
            rows.append({"F_x": float(F), "residual": float(r),
                         "complex": bool(res.complex_pair),
                         "growth_rate": float(res.growth_rate),
                         "confidence": float(getattr(res, "confidence", float("nan"))),
                         "eigenvalues": np.asarray(res.eigenvalues, complex),
                         "datafile": prefix + ".data"})
            start = prefix + ".data"
    if comm.Get_rank() == 0:
        from remote_trigger.pywrap.runtime.results import write_atomic

        ok = [r for r in rows if "error" not in r]
        ds = {"F_x": np.array([r["F_x"] for r in ok], float),
              "residual": np.array([r["residual"] for r in ok], float),
              "complex": np.array([float(r["complex"]) for r in ok]),
              "growth_rate": np.array([r["growth_rate"] for r in ok], float),
              "confidence": np.array([r["confidence"] for r in ok], float),
              "datafile": np.array([r["datafile"] for r in ok], dtype=object)}
        for k, r in enumerate(ok):
            ds[f"eigenvalues/ext_{k:02d}"] = r["eigenvalues"]
        err = [r["error"] for r in rows if "error" in r]
        write_atomic(os.path.join(folder, "..", "extend.h5"),
                     dict(rcfg.to_attrs(), stage="extend", status="complete",
                          message=err[0] if err else ""), ds)
    comm.Barrier()
    return rows


def extension_loads(F_lo, F_hi, F_c, cfg, main):
    """Loads of the continuation above F_x^c.

    ``extend_steps`` loads evenly spaced from F_hi (first unstable ramp step)
    to extend_factor * F_c; for the main friction also exactly
    fig4_ratio * F_c (the start of Fig. 4) and, if larger, up to it.
    """
    top = cfg.extend_factor * F_c
    F4 = cfg.fig4_ratio * F_c
    if main:
        top = max(top, F4)
    loads = list(np.linspace(F_hi, top, cfg.extend_steps + 1)[1:])
    if main:
        loads.append(F4)
    loads = sorted(set(round(float(F), 15) for F in loads if F > F_hi))
    return loads


def run_ramp(cfg, out, mu, relaxed, comm, clock, main, resume=False):
    """Ramp at friction ``mu`` plus its continuation; returns a summary dict.

    With ``resume`` an existing ``ramp.h5`` is continued
    (``stages.ramp(..., resume=True)``); the continuation is always run
    from its start.
    """
    from remote_trigger.pywrap import stages

    rcfg = ramp_config(cfg, relaxed, mu)
    folder = ramp_dir(out, mu)
    t0 = time.perf_counter()
    again = resume and os.path.exists(os.path.join(folder, "ramp.h5"))
    clock.say(f"ramp mu = {mu:g}: dF_x = {cfg.dF_x:g}, bisection to {cfg.tol:g}"
              + (f" (continuing {os.path.join(os.path.basename(folder), 'ramp.h5')})"
                 if again else ""))
    res = stages.ramp(rcfg, folder, comm=comm, quiet=True, resume=resume)
    t_ramp = time.perf_counter() - t0
    summ = {"mu": float(mu), "status": res.status, "message": res.message,
            "F_x_c_low": res.F_x_c_low, "F_x_c_high": res.F_x_c_high,
            "n_steps": int(len(res.F_x)), "n_bisection": int(len(res.bisection_F_x)),
            "wall_ramp": t_ramp, "h5": res.h5, "extension": []}
    if res.status != "complete":
        clock.say(f"ramp mu = {mu:g}: {res.status} ({res.message})")
        return summ
    clock.say(f"ramp mu = {mu:g}: F_x^c in {bracket_text(res.F_x_c_low, res.F_x_c_high, 9)} "
              f"(certified, width {res.F_x_c_width:.2g}; {len(res.F_x)} steps + "
              f"{len(res.bisection_F_x)} bisections, {res.n_undecided} undecided, "
              f"{t_ramp:.0f} s)")
    if not res.tol_reached:
        clock.say(f"ramp mu = {mu:g}: {res.message}")
    F_c = 0.5 * (res.F_x_c_low + res.F_x_c_high)
    first_complex = int(np.flatnonzero(res.complex_pair)[0])
    start = os.path.join(folder, "ramp", f"step_{first_complex:05d}.data")
    loads = extension_loads(res.F_x_c_low, float(res.F_x[first_complex]), F_c, cfg, main)
    t1 = time.perf_counter()
    rows = continue_ramp(rcfg, start, loads, os.path.join(folder, "extend"), comm)
    summ["wall_extend"] = time.perf_counter() - t1
    summ["extension"] = [{k: v for k, v in r.items() if k != "eigenvalues"} for r in rows]
    return summ


def run_instability(cfg, out, F_c, ext_rows, ramp_summary, comm, clock):
    """Fig. 4: the undamped run at fig4_ratio * F_x^c from its equilibrium."""
    from remote_trigger.pywrap import stages

    F4 = cfg.fig4_ratio * F_c
    ok = [r for r in ext_rows if "error" not in r]
    match = [r for r in ok if abs(r["F_x"] - F4) <= 1e-12 * max(1.0, F4)]
    if match:
        start, g = match[0]["datafile"], match[0]["growth_rate"]
    else:   # continuation did not reach F4: start from the first unstable ramp step
        folder = ramp_dir(out, cfg.mu)
        start = ok[-1]["datafile"] if ok else None
        if start is None:
            with_c = os.path.join(folder, "ramp")
            steps = sorted(f for f in os.listdir(with_c) if f.startswith("step_")
                           and f.endswith(".data"))
            start = os.path.join(with_c, steps[-1])
        g = ok[-1]["growth_rate"] if ok else 0.0
    t_max = cfg.t_instability
    if g > 0:
        t_max = min(t_max, cfg.instability_span / g)
    dcfg = dynamics_config(cfg, start, F4, t_max, a=0.0)
    clock.say(f"Fig. 4: undamped run at F_x = {F4:.6g} = {cfg.fig4_ratio:.4g} F_x^c, "
              f"predicted growth rate {g:.4g}, t_max = {t_max:.4g}")
    t0 = time.perf_counter()
    res = stages.instability(dcfg, out, comm=comm, quiet=True, overwrite=True)
    wall = time.perf_counter() - t0
    e = res.extra
    from remote_trigger.analysis.dynamics.series import growth_window, noise_level

    _, g_meas = growth_window(res.t, res.D, noise_level(res.t, res.D))
    clock.say(f"Fig. 4: D from {res.D[1]:.2e} to {res.D.max():.2e} in t = {res.t[-1]:.4g}; "
              f"growth rate measured {g_meas:.4g}, predicted "
              f"{e['predicted_growth_rate']:.4g} ({wall:.0f} s)")
    return {"F_x": F4, "t_max": t_max, "start": start, "wall": wall,
            "predicted_growth_rate": float(e["predicted_growth_rate"]),
            "measured_growth_rate": float(g_meas),
            "stage_growth_fit": float(e["measured_growth_rate"]),
            "saturated": bool(e["saturated"]), "h5": res.h5}


def run_perturb(cfg, out, ramps, comm, clock):
    """Fig. 5: the load in the friction window, its analysis and runs (a)-(e), (p).

    See :mod:`.fig5`; returns its summary.
    """
    from remote_trigger.pywrap.jobs.paper.fig5 import run_fig5

    summ = run_fig5(cfg, out, ramps, comm, clock)
    # tenths of seconds: the runs of a quick job take < 1 s each
    clock.say(f"Fig. 5: done ({summ['wall']:.1f} s: " +
              ", ".join(f"({k}) {v:.1f} s" for k, v in summ["walls"].items()) + ")")
    return summ


def run_normal_form(cfg, out, clock):
    """Normal form (docs/model.md section 8): A vs eps for several tau; HDF5 + PNG."""
    from remote_trigger.analysis.dynamics import normal_form as nf
    from remote_trigger.pywrap.runtime.results import write_atomic

    t0 = time.perf_counter()
    eps = np.array(sorted(cfg.nf_eps, reverse=True), float)
    taus = np.array(cfg.nf_tau, float)
    amp = nf.amplitude_scan(cfg.nf_delta, eps, taus)
    est = np.array([[nf.damped_estimate(cfg.nf_delta, e, t) for e in eps] for t in taus])
    td = np.array([nf.beat_time(cfg.nf_delta, e) for e in eps])
    write_atomic(os.path.join(out, "normal_form.h5"),
                 {"delta": cfg.nf_delta, "source": "paper Eqs. 9-17; "
                  "remote_trigger.analysis.dynamics.normal_form"},
                 {"eps": eps, "tau": taus, "amplitude": amp, "estimate": est,
                  "beat_time": td})
    nf.plot_amplitude(eps, taus, amp, est, cfg.nf_delta,
                      os.path.join(out, "fig_normal_form.png"))
    wall = time.perf_counter() - t0
    clock.say(f"normal form: A sqrt(eps) = {amp[np.isinf(taus)][0, -1] * math.sqrt(eps[-1]):.4g}"
              f" at eps = {eps[-1]:g} (no damping) ({wall:.0f} s)"
              if np.any(np.isinf(taus)) else f"normal form done ({wall:.0f} s)")
    return {"wall": wall}
