"""``remote-trigger paper``: the paper end to end, with figures and a report.

One command reproduces Charan, Pomyalov & Procaccia, *Generic Mechanism for
Remote Triggering of Earthquakes*, on the default scene (N = 100, the
paper's parameters; docs/model.md) and writes everything under one folder
(``--out``, default ``demo-out``); docs/paper.md describes it in full.

Steps (each a stage of :mod:`remote_trigger.pywrap.stages`):

1. ``generate`` a seeded packing and ``relax`` it (default protocol of the
   driver); packing fraction and residual go to the report.
2. ``ramp`` F_x for mu and mu_low from the same relaxed packing, with the
   eigenvalues of M^-1 K at every equilibrium and F_x^c by bisection; then a
   short *continuation* above F_x^c (:func:`continue_ramp`) so that Fig. 3
   shows the pair after its birth and Fig. 4 starts from an equilibrium.
3. Fig. 4: ``instability`` at F_x = fig4_ratio * F_x^c(mu).
4. Fig. 5 (:mod:`.fig5`): a load inside the window F_x^c(mu_ss mu) < F_x <
   F_x^c(mu), its friction-drop analysis (mu*), the runs (a)-(c) of the
   paper, the controls (d), (e) and the paper's amplitude (p).
5. The normal form (``remote_trigger.analysis.normal_form``).
6. Figures (:mod:`.figures`) and ``report.md`` (:mod:`.report`), both made
   from the files alone.

With two or more MPI ranks the independent stages run side by side (task
parallelism: ranks split into two groups; the two ramps, then the
instability run + normal form against the perturbation runs); within a
group LAMMPS decomposes the domain as usual.

Checkpoints: the manifest ``paper.json`` is rewritten (atomically, by rank
0) after every phase with that phase's summary; ``--resume``
(:func:`run_paper`, ``resume=True``) reloads the finished phases, continues
the ramps from their ``ramp.h5`` and reruns any other unfinished phase from
its start, so that the report equals that of an uninterrupted run.
"""
import json
import math
import os
import sys
import time

import numpy as np

from .config import ConfigError
from .paper_config import PaperConfig, PAPER, build_config, parse_set
# the output folder and the manifest live in paper_manifest; their names are
# importable from here as before
from .paper_manifest import (OUTPUTS, OUTPUT_GLOBS, MANIFEST, ramp_dir, prepare_out,
                             write_json, config_difference, load_manifest, finished_phases,
                             _normalised, _report_done, _utc_now, _ordered_phases)

__all__ = ["OUTPUTS", "OUTPUT_GLOBS", "MANIFEST", "ramp_dir", "prepare_out", "write_json",
           "config_difference", "load_manifest", "finished_phases", "run_paper",
           "relax_config", "ramp_config", "dynamics_config", "model_fields", "register",
           "config_from_args", "main"]

class _Clock:
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


# --------------------------------------------------------------------------- stages
def model_fields(cfg):
    """The model parameters every stage configuration shares but mu (each stage
    sets its own friction), and the time step."""
    from .config import ContactModel

    d = ContactModel.of(cfg).as_dict()
    del d["mu"]
    return dict(d, dt=float(cfg.dt))


def relax_config(cfg, datafile):
    """RelaxConfig of the relaxation: the model, mu, F_x = 0 and ``cfg.relax``."""
    from .config import RelaxConfig

    d = dict(model_fields(cfg), datafile=datafile, mu=float(cfg.mu), F_x=0.0)
    d.update(cfg.relax)
    return RelaxConfig.from_dict(d)


def ramp_config(cfg, datafile, mu):
    """RampConfig of the ramp at friction ``mu`` (from F_x = 0)."""
    from .config import RampConfig, RelaxConfig

    d = dict(model_fields(cfg), datafile=datafile, mu=float(mu), F_x=0.0,
             dF_x=float(cfg.dF_x), tol=float(cfg.tol), F_x_max=float(cfg.F_x_max),
             dF_x_max=getattr(cfg, "dF_x_max", None))
    ramp_fields = set(RampConfig.__dataclass_fields__) - {"settle_steps", "g_settle",
                                                           "mu_settle", "top_gap"}
    d.update({k: v for k, v in cfg.relax.items() if k in ramp_fields
              and k in RelaxConfig.__dataclass_fields__})
    return RampConfig.from_dict(d)


def dynamics_config(cfg, datafile, F_x, t_max, **extra):
    """DynamicsConfig of an undamped run at F_x with friction ``cfg.mu``."""
    from .config import DynamicsConfig

    d = dict(model_fields(cfg), datafile=datafile, mu=float(cfg.mu), F_x=float(F_x),
             t_max=float(t_max), record_every=int(cfg.record_every), a=float(cfg.a_paper),
             omega_p=float(cfg.omega_p), B=float(cfg.B), w=float(cfg.w),
             mu_ss=float(cfg.mu_ss), d_sat=float(cfg.d_sat))
    d.update(extra)
    return DynamicsConfig.from_dict(d)


def analyze_on_root(comm, dump):
    """Eigen-analysis of an equilibrium dump on rank 0 of ``comm``, broadcast.

    Returns
    -------
    StabilityResult
    """
    from .parallel import on_rank0
    from remote_trigger.analysis.stability import stability_of_dump

    return on_rank0(comm, stability_of_dump, dump)


def continue_ramp(rcfg, start_file, loads, folder, comm):
    """Equilibria above F_x^c: the continuation of the ramp for Figs. 3 and 4.

    Each load starts from the previous equilibrium (the first from
    ``start_file``), is equilibrated exactly as a ramp step (``in.ramp_step``
    scene, Newton first, damped dynamics if needed), written to
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
    from .engine import Engine
    from . import equilibrium as eq
    from .stages import load_relax_scene, save_equilibrium

    if comm.Get_rank() == 0:
        os.makedirs(folder, exist_ok=True)
    comm.Barrier()
    rows = []
    start = start_file
    with Engine(comm=comm) as eng:
        for k, F in enumerate(loads):
            prefix = os.path.join(folder, f"ext_{k:02d}")
            load_relax_scene(eng, rcfg, start, F, deck="in.ramp_step")
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
        from .results import write_atomic

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
    from . import stages

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
    clock.say(f"ramp mu = {mu:g}: F_x^c in [{res.F_x_c_low:.9g}, {res.F_x_c_high:.9g}] "
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
    from . import stages

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
    from remote_trigger.analysis.series import growth_window, noise_level

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
    from .fig5 import run_fig5

    summ = run_fig5(cfg, out, ramps, comm, clock)
    clock.say(f"Fig. 5: done ({summ['wall']:.0f} s: " +
              ", ".join(f"({k}) {v:.0f} s" for k, v in summ["walls"].items()) + ")")
    return summ


def run_normal_form(cfg, out, clock):
    """Normal form (docs/model.md section 8): A vs eps for several tau; HDF5 + PNG."""
    from remote_trigger.analysis import normal_form as nf
    from .results import write_atomic

    t0 = time.perf_counter()
    eps = np.array(sorted(cfg.nf_eps, reverse=True), float)
    taus = np.array(cfg.nf_tau, float)
    amp = nf.amplitude_scan(cfg.nf_delta, eps, taus)
    est = np.array([[nf.damped_estimate(cfg.nf_delta, e, t) for e in eps] for t in taus])
    td = np.array([nf.beat_time(cfg.nf_delta, e) for e in eps])
    write_atomic(os.path.join(out, "normal_form.h5"),
                 {"delta": cfg.nf_delta, "source": "paper Eqs. 9-17; "
                  "remote_trigger.analysis.normal_form"},
                 {"eps": eps, "tau": taus, "amplitude": amp, "estimate": est,
                  "beat_time": td})
    nf.plot_amplitude(eps, taus, amp, est, cfg.nf_delta,
                      os.path.join(out, "fig_normal_form.png"))
    wall = time.perf_counter() - t0
    clock.say(f"normal form: A sqrt(eps) = {amp[np.isinf(taus)][0, -1] * math.sqrt(eps[-1]):.4g}"
              f" at eps = {eps[-1]:g} (no damping) ({wall:.0f} s)"
              if np.any(np.isinf(taus)) else f"normal form done ({wall:.0f} s)")
    return {"wall": wall}


# --------------------------------------------------------------------------- the job
def _guarded(fn):
    """Run fn(); return the exception it raised (None if none), so that all
    ranks can learn of it before any of them raises (no rank left waiting)."""
    try:
        fn()
    except Exception as exc:  # noqa: BLE001 - re-raised by the caller on every rank
        return exc
    return None


def _raise_first(errs):
    err = next((e for e in errs if e is not None), None)
    if err is not None:
        raise err


def run_paper(cfg, out, comm=None, speak=True, resume=False):
    """Run the whole job; all ranks of ``comm`` call it.

    Parameters
    ----------
    cfg : PaperConfig
    out : str
        Output folder (see :func:`prepare_out`).
    comm : mpi4py communicator, optional
        Default ``MPI.COMM_WORLD``. With >= 2 ranks the independent stages
        run in two groups at once.
    speak : bool
        Print progress lines.
    resume : bool
        Continue the job whose manifest ``out/paper.json`` is there (same
        configuration, else :class:`ConfigError`; see :func:`load_manifest`):
        finished phases are reloaded from the manifest, the ramps continue
        from their ``ramp.h5``, any other unfinished phase is run from its
        start. A complete job is left as it is. Without a manifest in
        ``out``, a new job starts (as without ``resume``).

    Returns
    -------
    str
        Path of ``report.md`` (on every rank).

    Notes
    -----
    The manifest ``paper.json`` (written by rank 0 only, atomically) holds
    the resolved configuration, ``status`` (``'running'``, ``'complete'``),
    ``out``, one entry per session in ``sessions`` (start time, resumed or
    not, ranks, elapsed seconds at its last checkpoint, phases reused), the
    wall time of every finished phase in ``phases``, and the summary of each
    finished phase: ``relax``, ``ramps`` (``[main mu, mu_low]``, ``null``
    until done), ``instability``, ``perturb``, ``normal_form``; at the end
    ``figures``. It is rewritten when the job starts and after every phase
    (with two rank groups: after each phase of rank 0's group, and for the
    other group's phases at the next point where the groups meet). The
    figures and the report are made from the manifest as it is on disk
    (one JSON round trip), so that a resumed job and an uninterrupted one
    feed them the same numbers.
    """
    job = _PaperJob(cfg, out, comm, speak, resume)
    if job.start():
        return job.path
    job.relax()
    job.split()
    job.merge(_guarded(job.ramps))
    job.sync_checkpoint()
    job.merge(_guarded(job.dynamics))
    job.sync_checkpoint()
    return job.finish()


class _PaperJob:
    """The phases of one ``paper`` job on the ranks of ``comm`` (:func:`run_paper`).

    State shared by the phases: the manifest ``summary`` (rank 0 writes it),
    the rank groups (two when task-parallel) and the clocks.
    """

    def __init__(self, cfg, out, comm, speak, resume):
        from mpi4py import MPI

        self.cfg, self.speak, self.resume = cfg, speak, resume
        self.comm = MPI.COMM_WORLD if comm is None else comm
        self.rank, self.size = self.comm.Get_rank(), self.comm.Get_size()
        self.out = os.path.abspath(out)
        self.mpath = os.path.join(self.out, MANIFEST)
        self.path = os.path.join(self.out, "report.md")
        self.t_job = time.perf_counter()
        self.wclock = _Clock(speak and self.rank == 0)
        self.summary = None
        self.color, self.group, self.leader, self.clock = 0, self.comm, True, self.wclock

    # ------------------------------------------------------------ manifest
    def start(self):
        """0. A new job (prepare_out), or the manifest of the job to resume.

        Returns True if the job to resume is complete (nothing to do).
        """
        cfg, out, rank, size = self.cfg, self.out, self.rank, self.size
        summary, complete, err = None, False, None
        if rank == 0:
            try:
                man = (load_manifest(out, cfg) if self.resume and os.path.isfile(self.mpath)
                       else None)
                if man is None:
                    prepare_out(out)
                    done, sessions, phases = {}, [], {}
                else:
                    done = finished_phases(man, out)
                    complete = (_report_done(out, man) and
                                len(done) == len(finished_phases(man, out, False)))
                    sessions = list(man.get("sessions") or [])
                    names = {"relax": "relax", "ramp0": f"ramp_mu{cfg.mu:g}",
                             "ramp1": f"ramp_mu{cfg.mu_low:g}", "instability": "instability",
                             "perturb": "perturb", "normal_form": "normal_form"}
                    keep = {names[k] for k in done}
                    phases = {k: v for k, v in (man.get("phases") or {}).items() if k in keep}
                summary = {"job": "remote-trigger paper", "status": "running", "out": out,
                           "config": cfg.to_dict(), "n_ranks": size, "paper": PAPER,
                           "task_parallel": size >= 2, "argv": sys.argv, "phases": phases,
                           "sessions": sessions + [{"started": _utc_now(),
                                                    "resume": man is not None,
                                                    "n_ranks": size, "elapsed": 0.0,
                                                    "reused": sorted(done)}],
                           "ramps": [done.get("ramp0"), done.get("ramp1")]}
                for k in ("relax", "instability", "perturb", "normal_form"):
                    if k in done:
                        summary[k] = done[k]
                if complete:
                    self.wclock.say(f"--resume: the job in {out} is complete; nothing to do")
                else:
                    if man is not None:
                        self.wclock.say("--resume: reusing " + (", ".join(sorted(done))
                                                                 or "nothing")
                                        + f" from {MANIFEST}")
                    write_json(self.mpath, summary)
            except (ConfigError, OSError) as exc:
                err = str(exc)
        summary, complete, err = self.comm.bcast((summary, complete, err), root=0)
        if err:
            raise ConfigError(err)
        self.summary = summary
        if complete:
            self.comm.Barrier()
        return complete

    def checkpoint(self):
        """Rewrite the manifest (rank 0 only; others do nothing)."""
        if self.rank == 0:
            self.summary["sessions"][-1]["elapsed"] = time.perf_counter() - self.t_job
            write_json(self.mpath, self.summary)

    def sync_checkpoint(self):
        """Checkpoint on rank 0; an error there is raised on every rank."""
        errs = self.comm.allgather(_guarded(self.checkpoint))
        _raise_first(errs)

    # ------------------------------------------------------------ phases
    def relax(self):
        """1. Packing + relaxation: on world rank 0 alone, so that the packing does
        not depend on the number of ranks (a domain-decomposed compaction is not
        bitwise equal to a serial one, and the compaction amplifies round-off)."""
        from mpi4py import MPI
        from .packing import generate, write_data
        from . import stages

        cfg, out, comm, rank, size = self.cfg, self.out, self.comm, self.rank, self.size
        summary = self.summary
        datafile = os.path.join(out, "packing.data")
        if summary.get("relax"):
            r = summary["relax"]
            self.wclock.say(f"relax: done earlier ({MANIFEST}): phi = "
                            f"{r['packing_fraction']:.4f}, residual {r['residual']:.2e}")
            return
        t0 = time.perf_counter()
        err = None
        if rank == 0:
            self.wclock.say(f"relax: N = {cfg.n}, seed {cfg.seed}")
            solo = comm.Split(0, 0) if size > 1 else comm
            try:
                write_data(generate(cfg.n, seed=cfg.seed, phi=cfg.phi), datafile)
                rel = stages.relax(relax_config(cfg, datafile), out, comm=solo, quiet=True,
                                   overwrite=True)
                summary["relax"] = {"residual": rel.residual,
                                    "packing_fraction": rel.packing_fraction,
                                    "converged": rel.converged, "wall": rel.wall_time,
                                    "datafile": rel.datafile,
                                    "protocol": getattr(rel, "protocol", "")}
                summary["phases"]["relax"] = time.perf_counter() - t0
                self.checkpoint()
            except Exception as exc:  # noqa: BLE001 - re-raised on every rank below
                err = exc
            finally:
                if size > 1:
                    solo.Free()
        elif size > 1:
            comm.Split(MPI.UNDEFINED, rank)
        if size > 1:
            summary["relax"], summary["phases"], err = comm.bcast(
                (summary.get("relax"), summary["phases"], err), root=0)
        if err is not None:
            raise err
        r = summary["relax"]
        self.wclock.say(f"relax: phi = {r['packing_fraction']:.4f}, residual "
                        f"{r['residual']:.2e} ({time.perf_counter() - t0:.0f} s)")

    def split(self):
        """Two rank groups when task-parallel (>= 2 ranks), else one."""
        if self.size >= 2:
            self.color = self.rank % 2
            self.group = self.comm.Split(self.color, self.rank)
        self.leader = self.group.Get_rank() == 0
        self.clock = _Clock(self.speak and self.leader, t0=self.wclock.t0,
                            buffer=self.rank != 0)

    def merge(self, err):
        """Bring the group leaders' new summaries to every rank; raise the first error."""
        summary = self.summary
        if self.size < 2:
            _raise_first([err])
            return
        parts = self.comm.allgather((summary if self.leader else None, err,
                                     self.clock.take()))
        if self.rank == 0:                  # the other group's progress lines
            for line in (ln for _, _, lines in parts for ln in lines):
                print(line, flush=True)
        for part, _, _ in parts:
            if part is None:
                continue
            for k, rr in enumerate(part["ramps"]):
                if rr is not None and summary["ramps"][k] is None:
                    summary["ramps"][k] = rr
            for k in ("instability", "perturb", "normal_form"):
                if part.get(k) and not summary.get(k):
                    summary[k] = part[k]
            summary["phases"].update(part["phases"])
        _raise_first([e for _, e, _ in parts])

    def ramps(self):
        """2. The ramps at mu and mu_low (one per group when task-parallel)."""
        cfg, summary, clock = self.cfg, self.summary, self.clock
        relaxed = summary["relax"]["datafile"]
        for k, mu in enumerate((cfg.mu, cfg.mu_low)):
            if self.size >= 2 and k % 2 != self.color:
                continue
            if summary["ramps"][k] is not None:
                rr = summary["ramps"][k]
                clock.say(f"ramp mu = {mu:g}: done earlier ({MANIFEST}): " +
                          (f"F_x^c in [{rr['F_x_c_low']:.7g}, {rr['F_x_c_high']:.7g}]"
                           if rr["status"] == "complete" else rr["status"]))
                continue
            t0 = time.perf_counter()
            summ = run_ramp(cfg, self.out, mu, relaxed, self.group, clock, main=(k == 0),
                            resume=self.resume)
            summary["ramps"][k] = summ
            summary["phases"][f"ramp_mu{mu:g}"] = time.perf_counter() - t0
            self.checkpoint()

    def _phase(self, name, fn):
        if self.summary.get(name):
            self.clock.say(f"{name}: done earlier ({MANIFEST})")
            return
        t0 = time.perf_counter()
        self.summary[name] = fn()
        self.summary["phases"][name] = time.perf_counter() - t0
        self.checkpoint()

    def dynamics(self):
        """3.-5. Fig. 4 run and normal form (group 0) against the Fig. 5 runs
        (group 1; both in one group on one rank)."""
        cfg, out, summary, group, clock = (self.cfg, self.out, self.summary, self.group,
                                           self.clock)
        main = summary["ramps"][0]
        F_c = (0.5 * (main["F_x_c_low"] + main["F_x_c_high"])
               if main["status"] == "complete" else None)
        if F_c is None:
            self.wclock.say(f"no F_x^c for mu = {cfg.mu:g} ({main['status']}): Figs. 4 "
                            f"and 5 skipped")
        else:
            if self.color == 0:
                self._phase("instability", lambda: run_instability(
                    cfg, out, F_c, main["extension"], main, group, clock))
            if self.color == (1 if self.size >= 2 else 0):
                self._phase("perturb", lambda: run_perturb(cfg, out, summary["ramps"], group,
                                                           clock))
        if self.color == 0 and self.leader:
            self._phase("normal_form", lambda: run_normal_form(cfg, out, clock))

    def finish(self):
        """6. Figures and report (rank 0), from the manifest as written."""
        summary, err = self.summary, None
        if self.rank == 0:
            from . import figures, report

            try:
                t0 = time.perf_counter()
                summary["figures"] = figures.make_all(self.out, _normalised(summary))
                summary["phases"]["figures"] = time.perf_counter() - t0
                summary["phases"]["total"] = time.perf_counter() - self.t_job
                summary["phases"] = _ordered_phases(summary["phases"], self.cfg)
                summary["status"] = "complete"
                self.checkpoint()
                report.write_report(self.out, _normalised(summary))
                self.wclock.say(f"done in {summary['phases']['total']:.0f} s")
            except Exception as exc:  # noqa: BLE001 - re-raised on every rank below
                err = exc
        if self.size >= 2:
            self.group.Free()
            err = self.comm.bcast(err, root=0)
        if err is not None:
            raise err
        return self.path


# --------------------------------------------------------------------------- command line
_FLAG_HELP = {
    "n": "number of disks (100)", "seed": "packing seed (1)", "mu": "friction of the main "
    "ramp and Figs. 4-5 (1)", "mu_low": "friction of the second ramp (0.8)",
    "dF_x": "ramp step (2.5e-4)", "tol": "bisection tolerance on F_x^c (1e-7)",
    "np": "MPI ranks: re-launch under the environment's mpirun (1)",
}


def register(subparsers):
    """Add the ``paper`` subcommand."""
    import argparse

    p = subparsers.add_parser(
        "paper", help="reproduce the paper end to end: HDF5, figures, report.md",
        description="Generate and relax the default packing, ramp F_x for mu and mu_low "
                    "with eigenvalues and F_x^c, run the instability (Fig. 4) and the "
                    "perturbation runs (Fig. 5), the normal form, and write PNG figures and "
                    "report.md under --out. Values: defaults < --quick < --config TOML < "
                    "flags. The job checkpoints after every phase (paper.json); --resume "
                    "continues an interrupted one. docs/paper.md describes everything.")
    p.add_argument("--out", default="demo-out",
                   help="output folder (default demo-out); rerunning into a folder of an "
                        "earlier job deletes that job's outputs first, unless --resume")
    p.add_argument("--resume", action="store_true",
                   help="continue the interrupted job in --out: give the same options as "
                        "that job (any other configuration is refused, naming the key, and "
                        "nothing is deleted; --np may differ); phases finished (recorded in "
                        "paper.json) are not redone, the ramps continue from ramp.h5, a "
                        "phase cut short otherwise restarts; the report equals that of an "
                        "uninterrupted run except for its timings. A complete job is left "
                        "as it is (only the report path is printed); a folder without "
                        "paper.json starts a new job")
    p.add_argument("--config", metavar="TOML", help="TOML file with any of the keys below")
    p.add_argument("--quick", action="store_true", default=None,
                   help="small, fast variant (N = 40, coarse steps, short runs)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="any configuration key (repeatable), e.g. --set nf_eps=[0.1,0.01]")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.add_argument("--resolved-config", help=argparse.SUPPRESS)
    for f in PaperConfig.names():
        if f in ("quick", "relax", "nf_eps", "nf_tau"):
            continue
        default = PaperConfig.__dataclass_fields__[f].default
        typ = int if isinstance(default, int) and not isinstance(default, bool) else float
        flags = [f"--{f}"] + ([f"--{f.replace('_', '-')}"] if "_" in f else [])
        p.add_argument(*flags, dest=f"opt_{f}", type=typ, metavar=typ.__name__.upper(),
                       help=_FLAG_HELP.get(f, f"see docs/paper.md ({default!r})"
                                           if default is not None else "see docs/paper.md"))
    p.set_defaults(func=main, resume_hint=(
        "paper.json records every finished phase: the same command with --resume "
        "continues the job"))


def config_from_args(args):
    """PaperConfig from parsed arguments (defaults < quick < TOML < flags)."""
    if args.resolved_config:
        with open(args.resolved_config) as fh:
            d = json.load(fh)
        d["nf_tau"] = [math.inf if v is None else v for v in d.get("nf_tau", [])]
        return PaperConfig.from_dict(d)
    over = parse_set(args.set)
    for f in PaperConfig.names():
        v = getattr(args, f"opt_{f}", None)
        if v is not None:
            over[f] = v
    return build_config(args.config, over, quick=bool(args.quick))


def _relaunch(cfg, args):
    """Run the job under ``mpirun -np cfg.np`` of this environment; returns its status."""
    import subprocess
    import tempfile

    from .relaunch import find_mpirun

    mpirun = find_mpirun(cfg.np, "paper")
    d = cfg.to_dict()
    d["nf_tau"] = [None if math.isinf(v) else v for v in d["nf_tau"]]
    fd, path = tempfile.mkstemp(prefix="paper-config-", suffix=".json")
    with os.fdopen(fd, "w") as fh:
        json.dump(d, fh)
    cmd = [mpirun, "-np", str(cfg.np), sys.executable, "-m", "remote_trigger.pywrap.cli",
           "paper", "--out", args.out, "--resolved-config", path]
    if args.quiet:
        cmd.append("--quiet")
    if args.resume:
        cmd.append("--resume")
    env = dict(os.environ, REMOTE_TRIGGER_PAPER_CHILD="1")
    try:
        return subprocess.call(cmd, env=env)
    finally:
        os.unlink(path)


def main(args):
    """``remote-trigger paper``; returns the exit status."""
    cfg = config_from_args(args)
    from mpi4py import MPI

    world = MPI.COMM_WORLD
    if cfg.np > 1 and world.Get_size() == 1 and not os.environ.get(
            "REMOTE_TRIGGER_PAPER_CHILD"):
        if args.resume and os.path.isfile(os.path.join(args.out, MANIFEST)):
            load_manifest(os.path.abspath(args.out), cfg)   # refuse before mpirun starts
        return _relaunch(cfg, args)
    path = run_paper(cfg, args.out, comm=world, speak=not args.quiet, resume=args.resume)
    if world.Get_rank() == 0:
        print(f"report: {path}")
    return 0
