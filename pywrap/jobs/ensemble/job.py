"""``remote-trigger ensemble``: F_x^c over packings, protocols, inertia and size.

The paper reports one packing of N = 100. This command measures the
distribution: for every seed of a list and every N of a list it generates a
packing (:func:`.packing.generate`), relaxes it with the driver's default
protocol (frictionless, then friction with zero history), ramps F_x at the
static friction mu0 and at the dynamic friction mu_ss mu0 (the ramp of
:func:`.stages.ramp`: certified decision at every equilibrium, bisection of
F_x^c), and records, per packing (docs/ensemble.md):

* the certified brackets [F_x_c_low, F_x_c_high] of F_x^c(mu0) and
  F_x^c(mu_ss mu0), their ratio and whether F_x^c(mu_ss mu0) < F_x^c(mu0)
  holds (certified: the brackets do not overlap);
* the packing fraction phi;
* the coalescing pair at the first certified complex point: lambda_c / lambda_max
  (real parts; lambda_max the stiffest eigenvalue of M^-1 K) and its mode index
  counted from the softest mode (1 = softest);
* the growth rate's slope s in g = s sqrt(F_x - F_x^c) just above onset,
  from the certified complex points within one ramp step of F_x^c: a least-
  squares line g^2 = s^2 (F_x - F_x0) (F_x0 is the extrapolated onset), or
  with one point s = g / sqrt(F_x - F_x^c) (F_x^c the bracket's midpoint);
* the **frictional** relaxation protocol (friction on during settling, as in
  the paper): stable at F_x = 0 or not, the number of certified complex
  pairs and max Im sqrt(lambda) there;
* the **I0 = 1 convention** (the paper's Jacobian): the equilibria of both
  ramps re-analysed with I = I0 m R^2, I0 = 1 in M (``read_dump(...,
  inertia_factor=1)``). The equilibria are those of the dynamics, which use
  I0 = 1/2: these rows are flagged ``dynamics_consistent = 0``. F_x^c under
  this convention is the bracket of the ramp's own equilibria with the
  certified decision recomputed (no new equilibria; if no pair is certified up
  to the ramp's last step only a lower bound is known).

One row of the table per packing and protocol/convention:

==========================  ====  ========================================
protocol                    I0    what
==========================  ====  ========================================
frictionless-then-friction  0.5   ramps, brackets, pair, slope
frictionless-then-friction  1.0   same equilibria, I0 = 1 analysis
frictional                  0.5   stability at F_x = 0
==========================  ====  ========================================

With ``dim = 3`` the packings are spheres (the stages' 3D path) and only the
first row is made, with I0 = 2/5 (solid spheres): the frictional protocol
and the I0 re-analysis are 2D only (:data:`.config.ONLY_2D`).

One packing is one task (:func:`.task.run_packing`); this module hands
them out, gathers the results and holds the subcommand.

Work is spread over MPI ranks with ``mpi4py.futures``
(:func:`remote_trigger.pywrap.runtime.taskfarm.run_tasks`): rank 0 hands
out the packings (largest N first) and a free rank takes the next one,
running its own LAMMPS instances on ``MPI.COMM_SELF``. With two or more
worker ranks a packing's task ends once it is relaxed, and its two ramps
(mu0, mu_ss mu0) become two tasks (:func:`.task.run_ramp`) that free ranks
take side by side; rank 0 records each ramp part in the packing's
``progress.json`` and, once both are there, hands out the packing's end
(the frictional part, the onset numbers, the result). A packing's results
are those of the sequential path (one process, the ramps one after the
other), except that each ramp has its own folder of sliced verdicts, so the
second ramp does not take the first's verdict at F_x = 0. Rank 0 writes a
packing's result atomically to ``tasks/<key>.json`` when it is finished; a job killed (also ``kill -9``) and run again with ``--resume``
keeps every finished packing, and of a packing it had started every
finished stage (relaxation, ramp part, frictional part; an interrupted
ramp continues from its ``ramp.h5``). One
packing's failure (no equilibrium, no certified bracket, any exception) is
recorded in its rows (``status``, ``reason``) and does not stop the others.
Rank 0 writes ``ensemble.h5``, ``ensemble.png`` and ``ensemble.md``.
With ``part_size`` set, ranks left without a task join the sliced points
of the running ones (:mod:`remote_trigger.pywrap.runtime.joining`).

.. warning::
   The I0 = 1 rows are an analysis convention, not a simulation: their
   eigenvalues do not predict the simulated motion (docs/model.md section 1).
"""
from collections import Counter
import math
import os
import time

from remote_trigger.pywrap.jobs.ensemble.onset import bracket_words
from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.runtime.parallel import on_rank0
from remote_trigger.pywrap.runtime.environment import environment
from remote_trigger.pywrap.runtime.jobfolder import (
    CONFIG_FILE, add_job_arguments, describe_keys, job_overrides)
from remote_trigger.pywrap.runtime import taskfarm
from remote_trigger.pywrap.runtime.taskfarm import n_workers, run_tasks
from remote_trigger.pywrap.jobs.ensemble.config import build_config
from remote_trigger.pywrap.jobs.ensemble.figure import plot
from remote_trigger.pywrap.jobs.ensemble.report import (
    rows_of, statistics, write_table, write_summary)
from remote_trigger.pywrap.jobs.ensemble.task import (
    run_packing, run_ramp, record_ramp, jsonable, task_path, load_task, packing_failed,
    saddle_escape_of, add_missing_shape)

__all__ = ["MANIFEST", "TABLE", "run_ensemble", "combine_runs", "check_out", "register",
           "config_from_args", "main"]

#: manifest of the job
MANIFEST = "ensemble.json"
#: file of the table
TABLE = "ensemble.h5"


# --------------------------------------------------------------------------- job
def check_out(cfg, out, resume):
    """Refuse an --out that is a file or holds other results; check --resume's config.

    Creates ``out`` and writes ``config.json`` for a new job (rank 0 only).

    Raises
    ------
    ConfigError
        ``out`` is a file; it holds files of another kind; it holds an
        ensemble and ``resume`` is False; or that ensemble's configuration
        differs (every differing key is named; ``np`` may differ).
    """
    from remote_trigger.pywrap.runtime.jobfolder import check_job_folder

    check_job_folder(out, cfg.to_dict(), resume, "an ensemble")


def _packing_task(t, cfg, out, resume, ramps_apart):
    """One task of :func:`run_ensemble` (on a worker rank): a packing
    (:func:`run_packing`; ``ramps_apart``: up to its relaxation), one of its
    ramps (``t["ramp"]``, :func:`run_ramp`), or its end once its ramps are
    recorded (``t["final"]``)."""
    folder = os.path.join(out, "packings", t["key"])
    cfg = cfg.for_size(t["n"])         # the ramp step and tolerance of this N
    if "ramp" in t:
        return run_ramp(cfg, folder, t["ramp"])
    final = bool(t.get("final"))
    return run_packing(cfg, t["n"], t["seed"], folder, resume=resume or final,
                       ramps_apart=ramps_apart and not final)


def _packing_of(t):
    """The packing of a task (its ``key``, ``n``, ``seed``: what ``tasks/<key>.json``
    records)."""
    return {k: v for k, v in t.items() if k not in ("ramp", "final")}


def _check_retry(resume, retry_failed):
    """Refuse ``retry_failed`` without ``resume`` (ConfigError)."""
    if retry_failed and not resume:
        raise ConfigError("--retry-failed runs the failed packings of a run again: "
                          "give --resume too")


def run_ensemble(cfg, out, comm=None, speak=True, resume=False, retry_failed=False):
    """The whole ensemble; every rank of ``comm`` calls it.

    Parameters
    ----------
    cfg : EnsembleConfig
    out : str
        Output folder (see :func:`check_out`).
    comm : mpi4py communicator, optional
        Default ``MPI.COMM_WORLD``. With more than one rank, rank 0 hands out
        the packings (largest N first) and ranks 1.. run them, each with
        LAMMPS on ``MPI.COMM_SELF`` (:func:`.taskfarm.run_tasks`).
    speak : bool
        Progress lines (rank 0 only).
    resume : bool
        Continue the ensemble in ``out``: finished packings
        (``tasks/<key>.json``) are kept; a packing a killed run had
        started keeps its finished stages (:func:`run_packing`), the others
        run from their start.
    retry_failed : bool
        With ``resume``: a finished packing whose result records an error
        (of the default protocol or of the frictional part) is run again,
        with ``resume`` semantics: its recorded stages are kept and an
        interrupted ramp goes on from its ``ramp.h5`` and kept equilibria.
        Default False: such a packing counts as finished.

    Returns
    -------
    str
        Path of ``ensemble.md`` (on every rank).

    Raises
    ------
    ConfigError
        From :func:`check_out` (on every rank; nothing written); if
        ``retry_failed`` is given without ``resume``.
    """
    from mpi4py import MPI
    from remote_trigger.pywrap.runtime.jobfolder import read_json, write_json

    comm = comm or MPI.COMM_WORLD
    rank, size = comm.Get_rank(), comm.Get_size()
    out = os.path.abspath(out)
    _check_retry(resume, retry_failed)
    t_start = time.perf_counter()

    def say(msg):
        if speak and rank == 0:
            print(f"[ensemble {time.perf_counter() - t_start:7.1f} s] {msg}", flush=True)

    def prepare():
        check_out(cfg, out, resume)
        os.makedirs(os.path.join(out, "tasks"), exist_ok=True)
        os.makedirs(os.path.join(out, "packings"), exist_ok=True)
        for t in tasks:
            res = load_task(out, t)
            if res is not None and saddle_escape_of(res) not in (None, cfg.saddle_escape):
                raise ConfigError(f"cannot resume {out!r}: packing {t['key']} was run with "
                                  f"saddle_escape = {saddle_escape_of(res)}, this run has "
                                  f"saddle_escape = {cfg.saddle_escape}")
        todo = []
        for t in (tasks[i] for i in order):
            res = load_task(out, t)
            if res is None or (retry_failed and packing_failed(res)):
                todo.append(t)
        return todo

    tasks = cfg.packings()
    order = sorted(range(len(tasks)), key=lambda i: (-tasks[i]["n"], i))
    todo = on_rank0(comm, prepare)
    say(f"{len(tasks)} packings ({len(todo)} to run"
        + (", failed ones again" if retry_failed else "") + f") on {n_workers(comm)} rank(s)")
    computed = []
    # with two or more worker ranks, a relaxed packing's two ramps are two tasks
    # (side by side); rank 0 records each part and then hands out the packing's end
    apart = n_workers(comm) > 1
    waiting, part_wall = {}, {}

    def done(t, res, wall):
        key = t["key"]
        if "ramp" in t:
            part_wall[key] = part_wall.get(key, 0.0) + wall
            record_ramp(os.path.join(out, "packings", key), t["ramp"], res)
            waiting[key].discard(t["ramp"])
            return [dict(_packing_of(t), final=True)] if not waiting[key] else None
        if "ramps_apart" in res:
            part_wall[key] = part_wall.get(key, 0.0) + res["wall"]
            waiting[key] = set(res["ramps_apart"])
            say(f"{key}: relaxed; its ramps {', '.join(res['ramps_apart'])} as tasks of "
                f"their own")
            return [dict(_packing_of(t), ramp=k) for k in res["ramps_apart"]]
        t = _packing_of(t)
        # a packing run in parts: its wall time is that of its tasks, summed
        res = dict(res, saddle_escape=cfg.saddle_escape,
                   wall=res["wall"] + part_wall.pop(key, 0.0))
        write_json(task_path(out, t["key"]), {"task": t, "status": "complete",
                                               "result": jsonable(res)})
        computed.append(t["key"])
        d = res["default"]
        r0 = d["ramps"].get("mu0", {}).get(f"I0_{cfg.I0_dynamics:g}", {})
        onset = bracket_words(r0.get("F_x_c_low", math.nan), r0.get("F_x_c_high", math.nan),
                              "F_x^c(mu0)")
        say(f"{t['key']}: {onset}"
            + (f"; error: {d['error']}" if d["error"] else "")
            + f" ({res['wall']:.0f} s"
            + (f"; {len(res['warnings'])} distinct warning(s) in tasks/{t['key']}.json"
               if res["warnings"] else "") + ")")

    join = cfg.part_size is not None
    run_tasks(comm, todo, _packing_task, (cfg, out, resume, apart), done, join=join)
    if join and taskfarm.helped.get("points"):
        say(f"ranks left without a packing joined {taskfarm.helped['points']} point(s) ("
            + ", ".join(f"rank {r}: {p}" for p, r in taskfarm.helped["helpers"] if p) + ")")
    path = os.path.join(out, "ensemble.md")
    err = None
    if rank == 0:
        try:
            computed = sorted(computed)
            rows, shaped, measured = [], [], 0
            for t in tasks:
                res = load_task(out, t)
                if res is None:
                    raise RuntimeError(f"packing {t['key']} has no result in "
                                       f"{task_path(out, t['key'])}")
                added, got = add_missing_shape(cfg.for_size(t["n"]), res,
                                               os.path.join(out, "packings", t["key"]))
                if added:
                    # recorded by a version without the pair's long-wave
                    # fraction: measured on the ramp's kept equilibria, else NaN
                    write_json(task_path(out, t["key"]), {"task": t, "status": "complete",
                                                           "result": jsonable(res)})
                    shaped.append(t["key"])
                    measured += got
                rows.extend(rows_of(t, res, cfg))
            if shaped:
                say(f"{len(shaped)} packing(s) recorded without the pair's long-wave fraction: "
                    f"measured for {measured} ramp(s) from their kept equilibria, the others "
                    f"NaN (equilibria gone)")
            st = statistics(rows, cfg)
            write_table(os.path.join(out, TABLE), rows, cfg)
            plot(os.path.join(out, "ensemble.png"), rows, cfg,
                 st["n_fit"].get(cfg.I0_dynamics), st["limit"])
            wall = time.perf_counter() - t_start
            write_summary(path, rows, cfg, st, wall, n_workers(comm), computed)
            mpath = os.path.join(out, MANIFEST)
            sessions = []
            if os.path.isfile(mpath):
                sessions = read_json(mpath).get("sessions", [])
            sessions.append({"n_ranks": n_workers(comm), "mpi_size": size,
                             "computed": computed, "wall": wall, "resume": bool(resume),
                             "retry_failed": bool(retry_failed),
                             "environment": environment()})
            write_json(mpath, {"config": cfg.to_dict(), "out": out, "status": "complete",
                               "n_packings": len(tasks), "sessions": sessions,
                               "statistics": jsonable(
                                   {k: v for k, v in st.items()
                                    if k not in ("order", "paper_percentile", "n_exponent")})})
            # rows without every bracket certified ('failed', 'incomplete'),
            # named here so that a failure is not seen only in the files
            not_ok = Counter(r["status"] for r in rows if r["status"] != "ok")
            tail = ", ".join(f"{n} {k}" for k, n in sorted(not_ok.items()))
            say(f"done: {len(rows)} rows, {len(computed)} packing(s) computed now"
                + (f"; rows not ok: {tail} (reasons in ensemble.md)" if not_ok else ""))
        except Exception as exc:  # noqa: BLE001 - re-raised on every rank
            err = exc
    err = comm.bcast(err, root=0)
    if err is not None:
        raise err
    return path


def combine_runs(dirs, out, speak=True):
    """``ensemble --combine``: the finished packings of several runs in one new folder.

    :func:`~remote_trigger.pywrap.jobs.ensemble.combine.collect_runs` writes
    ``out/config.json`` (every size and finished seed) and copies the result
    files; the job is then completed in ``out`` as :func:`run_ensemble` with
    ``resume`` (nothing to compute), and ``ensemble.json`` records
    ``combined_from`` and ``left_out``.

    Parameters
    ----------
    dirs : sequence of str
        Ensemble folders, at least two, agreeing in every key but ``n``,
        ``seeds`` and ``np``.
    out : str
        A new or empty folder.
    speak : bool
        Progress lines.

    Returns
    -------
    str
        Path of ``out/ensemble.md``.

    Raises
    ------
    ConfigError
        From :func:`~remote_trigger.pywrap.jobs.ensemble.combine.collect_runs`
        (nothing written then).
    """
    from mpi4py import MPI
    from remote_trigger.pywrap.jobs.ensemble.combine import collect_runs
    from remote_trigger.pywrap.runtime.jobfolder import read_json, write_json

    cfg, dirs, missing = collect_runs(dirs, out, speak)
    path = run_ensemble(cfg, out, comm=MPI.COMM_SELF, speak=speak, resume=True)
    mpath = os.path.join(os.path.abspath(out), MANIFEST)
    manifest = read_json(mpath)
    write_json(mpath, dict(manifest, combined_from=dirs, left_out=missing))
    return path


# --------------------------------------------------------------------------- command line
def register(subparsers):
    """Add the ``ensemble`` subcommand."""
    p = subparsers.add_parser(
        "ensemble", help="F_x^c over packings: seeds x N, relax protocols, inertia convention",
        description="For every seed and N: generate, relax, ramp F_x at mu0 and mu_ss mu0 "
                    "(certified brackets of F_x^c), the coalescing pair, the growth-rate "
                    "slope, the frictional relax protocol at F_x = 0 and the I0 = 1 "
                    "analysis convention; ensemble.h5, ensemble.png and ensemble.md under "
                    "--out. docs/ensemble.md.")
    p.add_argument("--dim", type=int, default=None,
                   help="2: disks (default), 3: spheres (N = 160, seeds 1..12, phi = 0.64 "
                        "unless given; no frictional protocol, no I0 = 1 rows)")
    add_job_arguments(p, "ensemble", "EnsembleConfig",
                      "small test variant (3 packings of N = 16 and 20, coarse ramps)",
                      "continue an interrupted ensemble in --out (same configuration; "
                      "finished packings and the finished stages of a started one are kept); "
                      "without --config, --quick, --set or --dim: the configuration --out "
                      "records", "--set n=[100] --set seeds=[1,2,3]")
    p.add_argument("--retry-failed", action="store_true",
                   help="with --resume: run again the packings recorded with an error "
                        "(their finished stages kept, an interrupted ramp continued)")
    p.add_argument("--combine", nargs="+", metavar="DIR", default=None,
                   help="instead of running: put the finished packings of these ensemble "
                        "folders (runs of other sizes or seeds, the same other keys) into "
                        "the new folder --out and write its table, figure and fits over "
                        "every size; nothing is recomputed")
    p.add_argument("--compare", nargs="+", metavar="DIR", default=None,
                   help="instead of running: the F_x^c(N) laws of these finished ensemble "
                        "folders (e.g. disks and spheres) side by side: compare.png and "
                        "compare.md in --out; nothing is recomputed")
    p.add_argument("--status", action="store_true",
                   help="instead of running: say how far the ensemble in --out has come "
                        "(per packing: finished, relaxing, or each ramp's points and "
                        "bracket so far); reads the folder only, safe beside the running job")
    from remote_trigger.pywrap.jobs.ensemble.config import EnsembleConfig

    describe_keys(p, EnsembleConfig)
    # a key with no flag of its own: the usage error names --set KEY=VALUE
    p.set_defaults(func=main, config_keys=tuple(EnsembleConfig.names()), resume_hint=(
        "every finished packing is kept: the same command with --resume continues the ensemble"))


def config_from_args(args):
    """EnsembleConfig from parsed arguments. ``--resume`` with no configuration
    option (``--config``, ``--quick``, ``--set``, ``--dim``) continues with the
    configuration the folder --out records (its ``config.json``)."""
    source = args.config
    if source is None and args.resume and not (args.quick or args.set or args.dim is not None):
        stored = os.path.join(args.out, CONFIG_FILE)
        if os.path.isfile(stored):
            source = stored
    return build_config(source, job_overrides(args, dim=args.dim), quick=bool(args.quick))


def _run_options_given(args):
    """The options of a run that were given (``--status`` and ``--combine`` take none)."""
    return [o for o, v in (("--config", args.config), ("--quick", args.quick),
                           ("--resume", args.resume), ("--retry-failed", args.retry_failed),
                           ("--np", args.np),
                           ("--set", args.set), ("--dim", args.dim)) if v]


def main(args):
    """``remote-trigger ensemble``; returns the exit status."""
    if args.combine is not None and args.compare is not None:
        raise ConfigError("--combine and --compare are two different commands; give one")
    if args.status:
        given = _run_options_given(args) + (["--combine"] if args.combine else []) + \
            (["--compare"] if args.compare else [])
        if given:
            raise ConfigError(f"--status reads the folder --out only; drop {given[0]}")
        from remote_trigger.pywrap.jobs.ensemble.status import ensemble_status

        print("\n".join(ensemble_status(args.out)))
        return 0
    if args.combine is not None:
        given = _run_options_given(args)
        if given:
            raise ConfigError(f"--combine takes its configuration from the folders; "
                              f"drop {given[0]}")
        print(f"ensemble: {combine_runs(args.combine, args.out, speak=not args.quiet)}")
        return 0
    if args.compare is not None:
        given = _run_options_given(args)
        if given:
            raise ConfigError(f"--compare reads finished folders only; drop {given[0]}")
        from remote_trigger.pywrap.jobs.ensemble.compare import compare_runs

        print(f"ensemble: {compare_runs(args.compare, args.out, speak=not args.quiet)}")
        return 0
    _check_retry(args.resume, args.retry_failed)      # (before a relaunch under mpirun)
    cfg = config_from_args(args)
    from mpi4py import MPI

    world = MPI.COMM_WORLD
    if cfg.np > 1 and world.Get_size() == 1 and not os.environ.get("REMOTE_TRIGGER_ENS_CHILD"):
        out = os.path.abspath(args.out)
        if os.path.isdir(out) and os.listdir(out) or os.path.isfile(out):
            check_out(cfg, out, args.resume)       # refuse before mpirun starts
        from remote_trigger.pywrap.runtime.relaunch import relaunch

        extra = (("--dim", str(args.dim)) if args.dim is not None else ()) + \
            (("--retry-failed",) if args.retry_failed else ())
        return relaunch("ensemble", args, cfg.np + 1, "REMOTE_TRIGGER_ENS_CHILD", extra=extra)
    path = run_ensemble(cfg, args.out, comm=world, speak=not args.quiet, resume=args.resume,
                        retry_failed=args.retry_failed)
    if world.Get_rank() == 0:
        print(f"ensemble: {path}")
    return 0
