"""``remote-trigger trigger-map``: the threshold amplitude a_c of remote triggering.

From the equilibria of a finished ``paper`` job (its mu0 ramp, Fig. 5's v0
and friction law), for each load F_x (fractions of the window between
F_x^c(mu_ss mu0) and F_x^c(mu0), and one load below it), each damping time
tau (none, and LAMMPS ``fix viscous``), each angular frequency omega_p and
each onset of f(t) (step, raised cosine), the smallest amplitude a of
f(t) = a cos(omega_p t) that triggers: D(t) passes the runaway level
D_run within t_max, with mu(v) (Eq. 4) on. docs/trigger_map.md describes the
design; in short:

* **Runaway level.** D_run = ``d_run_factor`` x max(D_drop, (C a)^2):
  D_drop is the mean-square displacement of the load's equilibrium when the
  friction drops to mu_ss mu0 and the packing re-equilibrates (computed
  statically by Newton, :func:`.fig5.friction_drop`): what a friction drop
  does without any instability; (C a)^2 that of the quasi-static response
  to the forcing (C = d<x_top>/dF_x).
* **Prediction, then bisection.** A probe run without mu(v) at
  a_probe = v0 / (omega_p C) measures the largest |v_top| within t_max;
  before mu(v) first switches, a run with mu(v) is the same run, so the
  linear-response estimate a_lin = a_probe v0 / max |v_top| seeds the
  bisection. The bracket [a_lo, a_hi] (a_lo not triggered, a_hi triggered)
  is then narrowed in log a to a factor <= ``factor``. A run stops as soon
  as D > D_run (triggered) or at t_max (not triggered).
* **Growth check.** A bracketed point's run at a_hi must rise to D_run as the
  instability does: the least-squares rate of its last decade of D below
  D_run (:func:`.series.runaway_rate`, >= 5 records) within a factor 2 of the
  predicted growth rate after the drop (with the run's damping, > 0;
  :func:`.series.runaway_consistent`). Otherwise the point is a ``forced
  response`` (``forced_by = 'growth'``): a resonance enlarged by the lower
  friction passes D_run too (measured below the window at omega_1), in a
  few records or with no growth predicted.
* **Forced twin.** For a bracketed point, the run at a_hi is repeated with
  mu0 throughout (no mu(v)). If that run also passes D_run, the forcing
  alone moves the packing that far (at a natural frequency, for instance):
  the point is a ``forced response`` (``forced_by = 'twin'``), not a
  trigger, and gets no a_c.
* **Controls.** For each load and tau, the run with mu(v) and no forcing (the
  same run for every omega_p and onset: it has no forcing). If it triggers,
  every point of that load and tau is ``noise-triggered`` and gets no a_c.
* **Prediction of the damped rate.** The growth rate after the friction
  drop with damping, from the quadratic eigenproblem
  (:func:`remote_trigger.analysis.stability.eigen.damped_growth_rate`).

Work is spread over MPI ranks with ``mpi4py.futures``
(:func:`remote_trigger.pywrap.runtime.taskfarm.run_tasks`: rank 0 hands out
the tasks, a free rank takes the next one and runs it on its own LAMMPS
instance on ``MPI.COMM_SELF``); each task's runs are logged to
``tasks/<key>.json`` (atomic), so a job killed (also ``kill -9``) and run
again with ``--resume`` keeps every finished run. Rank 0 writes
``trigger_map.h5`` (one row per map point), ``trigger_map.png`` and
``trigger_map.md``.
"""
import json
import math
import os
import time

import numpy as np

from remote_trigger.analysis.dynamics.series import runaway_rate, runaway_consistent
from remote_trigger.pywrap.runtime.parallel import on_rank0
from remote_trigger.pywrap.runtime.taskfarm import n_workers, run_tasks
from remote_trigger.pywrap.runtime.jobfolder import (
    add_job_arguments, describe_keys, job_overrides, read_json, write_json)
from remote_trigger.pywrap.jobs.trigger_map.config import build_config
from remote_trigger.pywrap.jobs.trigger_map.loads import (
    load_paper_job, ramp_kappa, prepare_loads, map_omegas, predicted_rate)
from remote_trigger.pywrap.jobs.trigger_map.report import (
    collect, write_table, plot_map, write_summary)

__all__ = ["MANIFEST", "TABLE", "make_tasks", "run_map", "run_task", "rise_of", "d_run_level",
           "register", "config_from_args", "main"]

#: name of the job's manifest
MANIFEST = "trigger_map.json"
#: file of the table
TABLE = "trigger_map.h5"



# --------------------------------------------------------------------------- tasks
def make_tasks(cfg, setup):
    """Controls (per load and tau) and threshold searches (per map point).

    Returns
    -------
    list of dict
        Each with ``key``, ``kind`` ('control' or 'threshold'), ``load``
        (index), ``tau`` (None: undamped), and for thresholds ``omega_p``,
        ``onset``, ``dt_fraction``.
    """
    taus = [None] + list(setup["taus"])
    tasks = []
    for i, _ in enumerate(setup["loads"]):
        for j, tau in enumerate(taus):
            tasks.append({"key": f"control_L{i}_T{j}", "kind": "control", "load": i,
                          "tau": tau, "dt_fraction": cfg.dt_fraction})
    for i, _ in enumerate(setup["loads"]):
        for j, tau in enumerate(taus):
            for k, w in enumerate(setup["omegas"]):
                for onset in cfg.onsets:
                    tasks.append({"key": f"L{i}_T{j}_W{k}_{onset}", "kind": "threshold",
                                  "load": i, "tau": tau, "omega_p": w, "onset": onset,
                                  "dt_fraction": cfg.dt_fraction})
    # the dt check: the first points of the undamped column of the reference load
    inside = [i for i, ld in enumerate(setup["loads"]) if ld["kind"] != "below"]
    ref = min(inside or [0], key=lambda i: abs(setup["loads"][i]["fraction"] - 0.5))
    picks = [t for t in tasks if t["kind"] == "threshold" and t["load"] == ref
             and t["tau"] is None][:cfg.dt_check]
    for t in picks:
        tasks.append(dict(t, key=t["key"] + "_half", dt_fraction=0.5 * cfg.dt_fraction,
                          check_of=t["key"]))
    return tasks


class _TaskLog:
    """Runs of one task, checkpointed to ``tasks/<key>.json`` after each run."""

    def __init__(self, path, task):
        self.path = path
        self.data = {"task": task, "runs": [], "status": "running"}
        if os.path.isfile(path):
            try:
                with open(path) as fh:
                    old = json.load(fh)
                if old.get("task") == json.loads(json.dumps(task)):
                    self.data = old
            except (OSError, ValueError):
                pass

    def find(self, kind, a):
        for r in self.data["runs"]:
            if r["kind"] == kind and r["a"] == a:
                return r
        return None

    def add(self, run):
        self.data["runs"].append(run)
        write_json(self.path, self.data)

    def finish(self, **result):
        """Record the result; the file is rewritten only if it changes (a resumed
        map re-walks finished tasks: their files stay untouched)."""
        new = dict(self.data, **result, status="complete")
        if new == self.data:
            return
        self.data = new
        write_json(self.path, self.data)

    def fail(self, error):
        """Record the task as failed (redone by ``--resume``); returns the log data."""
        self.data.update(status="failed", error=str(error))
        write_json(self.path, self.data)
        return self.data

    @property
    def done(self):
        return self.data.get("status") == "complete"


def _dyn_config(setup, ld, task, dt):
    from remote_trigger.pywrap.stages.config import DynamicsConfig

    t_on = 0.0
    if task.get("onset") == "smooth":
        t_on = 0.5 * math.pi / task["omega_p"]
    return DynamicsConfig.from_dict(dict(
        datafile=ld["equilibrium"], k_n=setup["k_n"], k_t=setup["k_t"], F_y=setup["F_y"],
        mu=setup["mu0"], F_x=ld["F_x"], dt=dt, t_max=task["t_max"],
        record_every=task["record_every"], a=0.0, omega_p=task.get("omega_p", 0.01),
        B=setup["B"], w=setup["w"], mu_ss=setup["mu_ss_ratio"], t_on=t_on, tau=task["tau"]))


def _one_run(eng, setup, ld, task, a, muv, h5, d_run):
    """One run from the load's equilibrium; returns its summary dict."""
    from remote_trigger.pywrap.stages.runs import undamped_run

    dt = task["dt_fraction"] * ld["dt_max"]
    dc = _dyn_config(setup, ld, task, dt)
    v = {"a": float(a), "wp": float(task.get("omega_p", 0.01)), "muv": int(muv)}
    if muv:
        v.update(v0=setup["v0"], vss=setup["v0"], B=setup["B"], w=setup["w"],
                 muss=setup["mu_ss_ratio"])
    mu0 = setup["mu0"]

    def stop(o):
        return d_run is not None and o["D"][-1] > d_run

    t0 = time.perf_counter()
    # the run's own forcing and mu(v) in its attributes (dc's are the defaults)
    applied = {"a": v["a"], "omega_p": v["wp"], "muv": v["muv"]}
    if muv:
        applied.update(v0=v["v0"], v_ss=v["vss"])
    r = undamped_run(eng, dc, ld["equilibrium"], h5, v, h5, True, stop=stop,
                      attrs=dict(applied, stage="trigger-map", d_run=d_run or 0.0),
                      dim=int(setup.get("dim", 2)))
    wall = time.perf_counter() - t0
    sw = np.flatnonzero(r.mu < mu0)
    hit = np.flatnonzero(r.D > d_run) if d_run is not None else np.zeros(0, int)
    rise, n_rise = (runaway_rate(r.t, r.D, d_run) if hit.size else (math.nan, 0))
    return {"a": float(a), "muv": int(muv), "triggered": bool(hit.size),
            "rise_rate": rise if math.isfinite(rise) else None, "rise_records": int(n_rise),
            "t_switch": float(r.t[sw[0]]) if sw.size else None,
            "t_run": float(r.t[hit[0]]) if hit.size else None,
            "D_max": float(np.max(r.D)), "v_max": float(r.extra["v_top_max"]),
            "t_end": float(r.t[-1]), "steps": int(round(r.t[-1] / dt)), "dt": dt,
            "d_run": d_run, "wall": wall, "h5": h5}


def d_run_level(cfg, ld, a):
    """Runaway level of a run at amplitude a: d_run_factor x max(D_drop, (C a)^2)."""
    return cfg.d_run_factor * max(ld["D_drop"], (ld["compliance"] * a) ** 2)


def rise_of(run):
    """(rate, records) of a run's last rise to D_run (:func:`.series.runaway_rate`).

    Read from the run's log; a log written before the growth check existed
    is measured from the run's HDF5 records (``t``, ``D``), so a map resumed
    with ``--resume`` is re-classified without redoing a run.
    """
    if "rise_records" in run:
        r = run["rise_rate"]
        return (math.nan if r is None else float(r)), int(run["rise_records"])
    if not run.get("triggered"):
        return math.nan, 0
    import h5py
    with h5py.File(run["h5"], "r") as fh:
        t, D = fh["t"][()], fh["D"][()]
    return runaway_rate(t, D, run["d_run"])


def run_task(eng, cfg, setup, task, out):
    """Do one task (resumable); returns its log data."""
    ld = setup["loads"][task["load"]]
    folder = os.path.join(out, "runs", task["key"])
    os.makedirs(folder, exist_ok=True)
    log = _TaskLog(os.path.join(out, "tasks", task["key"] + ".json"), task)
    # a finished task is walked again: every run is found in its log (the same
    # amplitudes, bitwise), only the classification is redone (--resume after a
    # change of the criterion re-classifies without redoing a run)

    def run(kind, a, muv, d_run):
        old = log.find(kind, a)
        if old is not None:
            return old
        r = _one_run(eng, setup, ld, task, a, muv,
                     os.path.join(folder, f"{kind}_{len(log.data['runs']):02d}.h5"), d_run)
        r["kind"] = kind
        log.add(r)
        return r

    if task["kind"] == "control":
        r = run("control", 0.0, 1, d_run_level(cfg, ld, 0.0))
        log.finish(noise_triggered=r["triggered"], switched=r["t_switch"] is not None)
        return log.data
    a_max = ld["a_max"]
    if predicted_rate(setup, ld, task["tau"]) <= 0:
        # no complex pair after the drop, or damping faster than its growth: no
        # runaway is predicted. Ask a_max first (a smaller a switches mu(v) later
        # or not at all): if it does not trigger, no a does -- one run, not three
        r = run("mu(v)", a_max, 1, d_run_level(cfg, ld, a_max))
        if not r["triggered"]:
            res = {"a_lo": a_max, "a_hi": None, "a_lin": None, "a_probe": None,
                   "a_max": a_max, "a_min": None, "bracket_status": "none up to a_max",
                   "forced": None, "a_c": None, "shortcut": "decay predicted",
                   "n_runs": len(log.data["runs"]),
                   "wall": sum(x["wall"] for x in log.data["runs"])}
            log.finish(**res)
            return log.data
    v0 = setup["v0"]
    C = abs(ld["compliance"])
    w = task["omega_p"]
    a_probe = v0 / (w * C)
    probe = run("probe", a_probe, 0, None)
    a_lin = a_probe * v0 / probe["v_max"] if probe["v_max"] > 0 else math.inf
    a_min = 1e-6 * min(a_lin, a_max)
    lo, hi, status = _bracket(cfg, ld, run, a_lin, a_max, a_min)
    forced, forced_by, rise, n_rise = None, None, None, 0
    if status == "bracketed":
        forced, forced_by, rise, n_rise = _forced_check(cfg, setup, ld, task, log, run, hi)
        if forced:
            status = "forced response"
    res = {"a_lo": lo, "a_hi": hi, "a_lin": a_lin, "a_probe": a_probe, "a_max": a_max,
           "a_min": a_min, "bracket_status": status, "forced": forced,
           "forced_by": forced_by, "rise_rate": rise if rise is None or math.isfinite(rise)
           else None, "rise_records": n_rise,
           "a_c": math.sqrt(lo * hi) if status == "bracketed" else None,
           "n_runs": len(log.data["runs"]),
           "wall": sum(r["wall"] for r in log.data["runs"])}
    log.finish(**res)
    return log.data


def _bracket(cfg, ld, run, a_lin, a_max, a_min):
    """Bracket the triggering amplitude: (a_lo, a_hi, status).

    Starts at sqrt(factor) a_lin (capped at a_max), walks up or down with
    steps that square each time until one run triggers and one does not,
    then bisects geometrically to the ratio ``cfg.factor``. ``run(kind, a,
    muv, d_run)`` makes (or finds in the task's log) one run.
    """
    f = cfg.factor
    lo, hi = None, None
    a = min(a_lin * math.sqrt(f), a_max)
    step = f
    status = None
    while True:
        r = run("mu(v)", a, 1, d_run_level(cfg, ld, a))
        if r["triggered"]:
            hi = a if hi is None else min(hi, a)
        else:
            lo = a if lo is None else max(lo, a)
        if lo is not None and hi is not None:
            if hi / lo <= f * (1 + 1e-12):
                status = "bracketed"
                break
            a = math.sqrt(lo * hi)
            continue
        if hi is None:                       # nothing triggered yet: go up
            if lo >= a_max:
                status = "none up to a_max"
                break
            # mu(v) switched and nothing ran away: a larger forcing switches it
            # earlier, no more; ask a_max at once
            a = a_max if r["t_switch"] is not None else min(lo * step, a_max)
        else:                                # everything triggered: go down
            if hi <= a_min:
                status = "all down to a_min"
                break
            a = max(hi / step, a_min)
        step = step * step
    return lo, hi, status


def _forced_check(cfg, setup, ld, task, log, run, hi):
    """Is the bracketed point a forced response? (forced, forced_by, rise, n_rise)."""
    # the growth check: the run at a_hi rose to D_run at the predicted (damped)
    # rate (within RUNAWAY_RATE_TOL, >= RUNAWAY_MIN_RECORDS records). A rise in a
    # few records, far faster than predicted, or with no growth predicted at all
    # is the forcing's response (enlarged by the lower friction), not the
    # instability: a forced response.
    # The forced twin: the same forcing at a_hi with mu0 throughout (no mu(v)). If it
    # also passes D_run, the forcing alone moves the packing that far (e.g. at a
    # natural frequency): a forced response, not a triggered instability.
    rise, n_rise = rise_of(log.find("mu(v)", hi))
    if not runaway_consistent(rise, n_rise, predicted_rate(setup, ld, task["tau"])):
        return True, "growth", rise, n_rise
    tw = run("twin", hi, 0, d_run_level(cfg, ld, hi))
    forced = bool(tw["triggered"])
    return forced, "twin" if forced else None, rise, n_rise


# --------------------------------------------------------------------------- job
#: the LAMMPS instance of this process's tasks (created by the first one)
_ENGINE = None


def _map_task(t, cfg, setup, out):
    """One task of :func:`run_map` (on a worker rank); a failure is logged, not raised."""
    global _ENGINE
    if _ENGINE is None:
        from mpi4py import MPI
        from remote_trigger.pywrap.bindings.engine import Engine

        _ENGINE = Engine(comm=MPI.COMM_SELF)
    try:
        return run_task(_ENGINE, cfg, setup, t, out)
    except Exception as exc:  # noqa: BLE001 - one failed point must not stop the map
        return _TaskLog(os.path.join(out, "tasks", t["key"] + ".json"), t).fail(
            f"{type(exc).__name__}: {exc}")


def _close_worker_engine():
    """Close this process's task engine (every rank, once the tasks have ended)."""
    global _ENGINE
    if _ENGINE is not None:
        _ENGINE.close()
        _ENGINE = None


def run_map(cfg, out, comm=None, speak=True, resume=False):
    """The whole trigger map; every rank of ``comm`` calls it.

    Returns
    -------
    str
        Path of ``trigger_map.md`` (on every rank).
    """
    from mpi4py import MPI

    comm = comm or MPI.COMM_WORLD
    rank, size = comm.Get_rank(), comm.Get_size()
    out = os.path.abspath(out)
    t_start = time.perf_counter()

    def say(msg):
        if speak and rank == 0:
            print(f"[trigger-map {time.perf_counter() - t_start:7.1f} s] {msg}", flush=True)

    pcfg, man = load_paper_job(cfg.paper)            # refused before --out is made
    on_rank0(comm, _check_out, cfg, out, resume)
    setup = prepare_loads(cfg, pcfg, man, out, comm)
    setup["omegas"] = map_omegas(cfg, setup["loads"])     # the current grid (resume)
    say(f"{len(setup['loads'])} loads, tau = "
        + ", ".join(f"{t:.4g}" for t in setup["taus"])
        + " (and none), omega_p = " + ", ".join(f"{w:.4g}" for w in setup["omegas"])
        + f"; v0 = {setup['v0']:.3g}")
    for ld in setup["loads"]:
        say(f"  F_x = {ld['F_x']:.7g} ({ld['kind']}): mu0 {ld['decision_mu0']}, after the "
            f"drop {ld['decision_drop']} (g = {ld['growth']:.4g}), D_drop = "
            f"{ld['D_drop']:.3g}, kappa = {ld['kappa_mu0']:.3g} / {ld['kappa_drop']:.3g}")
    tasks = make_tasks(cfg, setup)
    rec = cfg.record_every
    for t in tasks:
        ld = setup["loads"][t["load"]]
        t["t_max"] = float(cfg.t_max)
        t["record_every"] = int(rec if rec is not None else
                                max(1, round(1.0 / (t["dt_fraction"] * ld["dt_max"]))))
    tdir = os.path.join(out, "tasks")
    if rank == 0:
        os.makedirs(tdir, exist_ok=True)
        os.makedirs(os.path.join(out, "runs"), exist_ok=True)
    comm.Barrier()
    ended = []

    def done(t, res, wall):
        ended.append(t["key"])
        txt = (f"a_c in [{res.get('a_lo') or 0:.3g}, {res.get('a_hi') or math.inf:.3g}]"
               f" ({res.get('bracket_status')})" if t["kind"] == "threshold" else
               f"noise-triggered: {res.get('noise_triggered')}")
        say(f"{t['key']} ({len(ended)} of {len(tasks)}): {txt}")

    try:
        run_tasks(comm, tasks, _map_task, (cfg, setup, out), done)
    finally:
        _close_worker_engine()
    path = os.path.join(out, "trigger_map.md")
    err = None
    if rank == 0:
        try:
            rows = collect(out, tasks, setup)
            kpath = os.path.join(out, "ramp_kappa.json")
            if os.path.isfile(kpath):
                setup["ramp_kappa"] = read_json(kpath)
            else:
                setup["ramp_kappa"] = ramp_kappa(man["ramps"][0]["h5"], cfg.kappa_steps)
                write_json(kpath, setup["ramp_kappa"])
            write_table(os.path.join(out, TABLE), rows, setup, cfg)
            plot_map(os.path.join(out, "trigger_map.png"), rows, setup)
            write_summary(path, rows, setup, cfg, time.perf_counter() - t_start, n_workers(comm))
            write_json(os.path.join(out, MANIFEST),
                       {"config": cfg.to_dict(), "out": out, "status": "complete",
                        "n_tasks": len(tasks), "n_ranks": n_workers(comm), "mpi_size": size,
                        "wall": time.perf_counter() - t_start})
        except Exception as exc:  # noqa: BLE001 - re-raised on every rank
            err = exc
    err = comm.bcast(err, root=0)
    if err is not None:
        raise err
    say(f"done: {path}")
    return path


def _check_out(cfg, out, resume):
    """Refuse an --out that is a file or holds other results; check --resume's config."""
    from remote_trigger.pywrap.runtime.jobfolder import CONFIG_FILE, check_job_folder

    config = cfg.to_dict()
    # the paper folder is not compared by its name on --resume ('q', 'q/',
    # /abs/q, or a relative name given from another working directory): the
    # paper job itself is compared by what the map took from it (loads.json's
    # paper_job, loads.prepare_loads); before loads.json nothing was taken
    try:
        with open(os.path.join(out, CONFIG_FILE)) as fh:
            then = json.load(fh).get("paper")
        if resume and isinstance(then, str):
            config["paper"] = then
    except (OSError, ValueError, AttributeError):
        pass
    check_job_folder(out, config, resume, "a trigger map")


# --------------------------------------------------------------------------- command line
def register(subparsers):
    """Add the ``trigger-map`` subcommand."""
    p = subparsers.add_parser(
        "trigger-map", help="threshold amplitude a_c of remote triggering vs omega_p, load, "
                            "damping (from a paper job)",
        description="From a complete `remote-trigger paper` job: bisect the smallest "
                    "amplitude a of f(t) = a cos(omega_p t) whose run with mu(v) runs away, "
                    "per load, damping time, frequency and onset; trigger_map.h5, "
                    "trigger_map.png and trigger_map.md under --out. docs/trigger_map.md.")
    p.add_argument("--paper", help="output folder of the paper job (required unless in "
                                   "--config)")
    add_job_arguments(p, "trigger-map", "MapConfig",
                      "small test variant (2 loads: window 0.6 and below; omega_p = 1; "
                      "1 damping time)",
                      "continue an interrupted map in --out (same configuration; finished "
                      "runs are kept)", "--set omega_p=[0.01,1]")
    from remote_trigger.pywrap.jobs.trigger_map.config import MapConfig

    describe_keys(p, MapConfig)
    # a key with no flag of its own: the usage error names --set KEY=VALUE
    p.set_defaults(func=main, config_keys=tuple(MapConfig.names()), resume_hint=(
        "every finished run is logged in tasks/: the same command with --resume continues the map"))


def config_from_args(args):
    """MapConfig from parsed arguments."""
    over = job_overrides(args, paper=args.paper)
    return build_config(args.config, over, quick=bool(args.quick))


def main(args):
    """``remote-trigger trigger-map``; returns the exit status."""
    cfg = config_from_args(args)
    from mpi4py import MPI

    world = MPI.COMM_WORLD
    if cfg.np > 1 and world.Get_size() == 1 and not os.environ.get("REMOTE_TRIGGER_MAP_CHILD"):
        from remote_trigger.pywrap.runtime.relaunch import relaunch

        load_paper_job(cfg.paper)
        return relaunch("trigger-map", args, cfg.np + 1, "REMOTE_TRIGGER_MAP_CHILD",
                        extra=["--paper", args.paper] if args.paper else [])
    load_paper_job(cfg.paper)
    path = run_map(cfg, args.out, comm=world, speak=not args.quiet, resume=args.resume)
    if world.Get_rank() == 0:
        print(f"trigger map: {path}")
    return 0
