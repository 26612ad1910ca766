"""The ``paper`` job: phase order, MPI rank groups, manifest checkpoints, resume."""
import os
import sys
import time

from remote_trigger.analysis.output import bracket_text
from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.jobs.paper.config import PAPER
from remote_trigger.pywrap.runtime.environment import environment
from remote_trigger.pywrap.runtime.jobfolder import write_json
from remote_trigger.pywrap.jobs.paper.manifest import (
    MANIFEST, prepare_out, load_manifest, finished_phases, json_normalised, report_done,
    utc_now, ordered_phases)
from remote_trigger.pywrap.jobs.paper.phases import (
    Clock, run_instability, run_normal_form, run_perturb, run_ramp)
from remote_trigger.pywrap.jobs.paper.stage_configs import relax_config


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


def run_paper(cfg, out, comm=None, speak=True, resume=False, overwrite=False):
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
    overwrite : bool
        A new job in the folder of an earlier one (``out/paper.json``, and
        not ``resume``) first deletes that job's outputs; without
        ``overwrite`` it is refused (:func:`prepare_out`).

    Returns
    -------
    str
        Path of ``report.md`` (on every rank).

    Notes
    -----
    The manifest ``paper.json`` (written by rank 0 only, atomically) holds
    the resolved configuration, ``status`` (``'running'``, ``'complete'``),
    ``out``, one entry per session in ``sessions`` (start time, resumed or
    not, ranks, elapsed seconds at its last checkpoint, phases reused, the
    environment: :func:`~remote_trigger.pywrap.runtime.environment.environment`), the
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
    job = _PaperJob(cfg, out, comm, speak, resume, overwrite)
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

    def __init__(self, cfg, out, comm, speak, resume, overwrite=False):
        from mpi4py import MPI

        self.cfg, self.speak, self.resume, self.overwrite = cfg, speak, resume, overwrite
        self.comm = MPI.COMM_WORLD if comm is None else comm
        self.rank, self.size = self.comm.Get_rank(), self.comm.Get_size()
        self.out = os.path.abspath(out)
        self.mpath = os.path.join(self.out, MANIFEST)
        self.path = os.path.join(self.out, "report.md")
        self.t_job = time.perf_counter()
        self.wclock = Clock(speak and self.rank == 0)
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
                    prepare_out(out, self.overwrite)
                    done, sessions, phases = {}, [], {}
                else:
                    done = finished_phases(man, out)
                    complete = (report_done(out, man) and
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
                           "sessions": sessions + [{"started": utc_now(),
                                                    "resume": man is not None,
                                                    "n_ranks": size, "elapsed": 0.0,
                                                    "reused": sorted(done),
                                                    "environment": environment()}],
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
        from remote_trigger.pywrap.stages.packing import generate, write_data
        from remote_trigger.pywrap import stages

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
            self.wclock.say(f"relax: N = {cfg.n}" + (" spheres" if cfg.dim == 3 else "")
                            + f", seed {cfg.seed}")
            solo = comm.Split(0, 0) if size > 1 else comm
            try:
                write_data(generate(cfg.n, seed=cfg.seed, phi=cfg.phi, dim=cfg.dim), datafile)
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
        self.clock = Clock(self.speak and self.leader, t0=self.wclock.t0,
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
                          (f"F_x^c in {bracket_text(rr['F_x_c_low'], rr['F_x_c_high'], 9)}"
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
            from remote_trigger.pywrap.jobs.paper import figures, report

            try:
                t0 = time.perf_counter()
                summary["figures"] = figures.make_all(self.out, json_normalised(summary))
                summary["phases"]["figures"] = time.perf_counter() - t0
                summary["phases"]["total"] = time.perf_counter() - self.t_job
                summary["phases"] = ordered_phases(summary["phases"], self.cfg)
                summary["status"] = "complete"
                self.checkpoint()
                report.write_report(self.out, json_normalised(summary))
                self.wclock.say(f"done in {summary['phases']['total']:.0f} s")
            except Exception as exc:  # noqa: BLE001 - re-raised on every rank below
                err = exc
        if self.size >= 2:
            self.group.Free()
            err = self.comm.bcast(err, root=0)
        if err is not None:
            raise err
        return self.path
