"""``remote-trigger paper``: its command line (options, configuration, re-launch)."""
import json
import math
import os
import sys

from remote_trigger.pywrap.jobs.paper.config import PaperConfig, build_config
from remote_trigger.pywrap.config import ConfigError, parse_set
from remote_trigger.pywrap.jobs.paper.manifest import (
    MANIFEST, earlier_job_refusal, load_manifest)
from remote_trigger.pywrap.jobs.paper.job import run_paper  # noqa: F401


def register(subparsers):
    """Add the ``paper`` subcommand."""
    import argparse

    p = subparsers.add_parser(
        "paper", help="reproduce the paper end to end: HDF5, figures, report.md",
        description="Generate and relax the default packing, ramp F_x for mu and mu_low "
                    "with eigenvalues and F_x^c, run the instability (Fig. 4) and the "
                    "perturbation runs (Fig. 5), the normal form, and write PNG figures and "
                    "report.md under --out. Values: defaults < --quick < --config FILE < "
                    "flags. The job checkpoints after every phase (paper.json); --resume "
                    "continues an interrupted one. docs/paper.md describes everything.")
    p.add_argument("--out", default="demo-out",
                   help="output folder (default demo-out); a folder of an earlier job is "
                        "refused unless --resume (continue it) or --overwrite")
    p.add_argument("--overwrite", action="store_true",
                   help="a new job in the folder of an earlier one: delete that job's "
                        "outputs first (other files there are left alone)")
    p.add_argument("--resume", action="store_true",
                   help="continue the interrupted job in --out: give the same options as "
                        "that job (any other configuration is refused, naming the key, and "
                        "nothing is deleted; --np may differ); phases finished (recorded in "
                        "paper.json) are not redone, the ramps continue from ramp.h5, a "
                        "phase cut short otherwise restarts; the report equals that of an "
                        "uninterrupted run except for its timings. A complete job is left "
                        "as it is (only the report path is printed); a folder without "
                        "paper.json starts a new job")
    p.add_argument("--config", metavar="FILE",
                   help="TOML file with any of the keys below (or JSON, *.json)")
    p.add_argument("--quick", action="store_true", default=None,
                   help="small, fast variant (N = 40, spheres 96; coarse steps, short runs)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="any configuration key (repeatable), e.g. --set nf_eps=[0.1,0.01]")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.add_argument("--resolved-config", help=argparse.SUPPRESS)
    helps = PaperConfig.field_help()
    for f in PaperConfig.names():
        if f in ("quick", "relax", "nf_eps", "nf_tau"):
            continue
        default = PaperConfig.__dataclass_fields__[f].default
        typ = int if isinstance(default, int) and not isinstance(default, bool) else float
        flags = [f"--{f}"] + ([f"--{f.replace('_', '-')}"] if "_" in f else [])
        p.add_argument(*flags, dest=f"opt_{f}", type=typ, metavar=typ.__name__.upper(),
                       help=helps.get(f, "see docs/paper.md"))
    p.set_defaults(func=main, config_keys=tuple(PaperConfig.names()), resume_hint=(
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
            if f in over:           # the option silently won, and --set went unchecked
                raise ConfigError(f"--set {f}={over[f]!r} and --{f.replace('_', '-')} {v!r} "
                                  f"both set {f}; give one of them")
            over[f] = v
    return build_config(args.config, over, quick=bool(args.quick))


def _relaunch(cfg, args):
    """Run the job under ``mpirun -np cfg.np`` of this environment; returns its status."""
    import tempfile

    from remote_trigger.pywrap.runtime.relaunch import call_under_mpirun, find_mpirun

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
    if args.overwrite:
        cmd.append("--overwrite")
    env = dict(os.environ, REMOTE_TRIGGER_PAPER_CHILD="1")
    try:
        return call_under_mpirun(cmd, env, "paper", cfg.np, args.resume_hint,
                                 getattr(args, "out_lock", None))
    finally:
        os.unlink(path)


def main(args):
    """``remote-trigger paper``; returns the exit status."""
    cfg = config_from_args(args)
    from mpi4py import MPI

    world = MPI.COMM_WORLD
    if args.resume and args.overwrite:
        raise ConfigError("--resume continues the job in --out and --overwrite replaces it; "
                          "give one of them")
    if (not args.resume and not args.overwrite
            and os.path.isfile(os.path.join(args.out, MANIFEST))):
        raise ConfigError(earlier_job_refusal(os.path.abspath(args.out)))
    if cfg.np > 1 and world.Get_size() == 1 and not os.environ.get(
            "REMOTE_TRIGGER_PAPER_CHILD"):
        if args.resume and os.path.isfile(os.path.join(args.out, MANIFEST)):
            load_manifest(os.path.abspath(args.out), cfg)   # refuse before mpirun starts
        return _relaunch(cfg, args)
    from remote_trigger.analysis.stability.timestep import TimestepError

    try:
        path = run_paper(cfg, args.out, comm=world, speak=not args.quiet, resume=args.resume,
                         overwrite=args.overwrite)
    except TimestepError as exc:    # the stages' hint 'auto' is not a value of the job's dt
        raise TimestepError(str(exc).replace(
            ", or dt = 'auto'", " (the paper job takes a number: --dt VALUE)")) from None
    status = 0
    if world.Get_rank() == 0:
        print(f"report: {path}")
        # a ramp without F_x^c (Figs. 4-5 skipped): a report, but no result
        with open(os.path.join(os.path.dirname(path), MANIFEST)) as fh:
            ramps = json.load(fh).get("ramps") or []
        if any(r and r.get("status") != "complete" for r in ramps):
            print("paper: a ramp ended without F_x^c (see the report): exit status 1")
            status = 1
    return world.bcast(status, root=0)
