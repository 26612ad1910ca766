"""Subcommands ``generate``, ``relax``, ``ramp``, ``perturb``, ``instability``.

All of them run under ``mpirun -np K remote-trigger ...`` as well (LAMMPS
domain decomposition, output and analysis on rank 0). Options not given keep
the defaults of :mod:`remote_trigger.pywrap.config`; ``--set KEY=VALUE``
sets any other configuration field (unknown keys are an error).
"""
import json
import os


def _add_model(p):
    p.add_argument("--datafile", required=True, help="LAMMPS data file to start from")
    p.add_argument("--out", default="out", help="output folder (default ./out)")
    p.add_argument("--mu", type=float, help="friction coefficient (default 1)")
    p.add_argument("--F-x", dest="F_x", type=float, help="horizontal load on top disks")
    p.add_argument("--F-y", dest="F_y", type=float, help="downward load on top disks (3)")
    p.add_argument("--dt", type=_dt_arg, help="time step, or 'auto' = 0.1 x the stability "
                   "limit of the start state (default 1e-3); a dt at or above the limit "
                   "is refused")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="any configuration field, e.g. --set k_n=2e5 (repeatable)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--log", default="none", help="LAMMPS log file (default none)")


def _dt_arg(text):
    """``--dt``: a number or 'auto'."""
    import argparse

    if text == "auto":
        return text
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"dt must be a number or 'auto', got {text!r}") \
            from None


def _config(cls, args, extra=()):
    from .config import ConfigError

    d = {"datafile": args.datafile}
    for key in ("mu", "F_x", "F_y", "dt") + tuple(extra):
        val = getattr(args, key, None)
        if val is not None:
            d[key] = val
    for item in args.set:
        if "=" not in item:
            raise ConfigError(f"--set expects KEY=VALUE, got {item!r}")
        k, v = item.split("=", 1)
        try:
            d[k.strip()] = json.loads(v)
        except json.JSONDecodeError:
            d[k.strip()] = v
    return cls.from_dict(d)


def register(subparsers):
    """Add the driver's subcommands to the ``remote-trigger`` parser."""
    g = subparsers.add_parser("generate", help="write a loose bidisperse packing data file")
    g.add_argument("--n", type=int, default=100, help="number of disks, even (default 100)")
    g.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    g.add_argument("--phi", type=float, default=0.82, help="packing fraction for L (0.82)")
    g.add_argument("--output", default="packing.data", help="data file (packing.data)")
    g.set_defaults(func=run_generate)

    r = subparsers.add_parser("relax", help="settle / relax to equilibrium (f_min)")
    _add_model(r)
    r.add_argument("--settle-steps", dest="settle_steps", type=int,
                   help="compaction aid for a loose packing (frictionless + gravity), steps")
    r.add_argument("--f-min", dest="f_min", type=float, help="target residual (1e-15)")
    r.add_argument("--no-newton", dest="newton", action="store_false", default=None,
                   help="over-damped dynamics only")
    r.set_defaults(func=run_relax)

    m = subparsers.add_parser("ramp", help="F_x ramp, eigenvalues, bisection of F_x^c")
    _add_model(m)
    m.add_argument("--dF-x", dest="dF_x", type=float, help="ramp step (1e-4)")
    m.add_argument("--tol", type=float, help="bisection tolerance (1e-7)")
    m.add_argument("--resume", action="store_true",
                   help="continue an interrupted ramp from its last equilibrium")
    m.set_defaults(func=run_ramp)

    p = subparsers.add_parser("perturb", help="undamped runs (a), (b) f(t), (c) f(t)+mu(v)")
    _add_model(p)
    p.add_argument("--t-max", dest="t_max", type=float, help="time of each run (1000)")
    p.add_argument("--a", type=float, help="amplitude of f(t) (1e-12)")
    p.add_argument("--omega-p", dest="omega_p", type=float, help="frequency of f(t) (0.01)")
    p.add_argument("--runs", default="abc", help="which runs (default abc)")
    p.set_defaults(func=run_perturb)

    i = subparsers.add_parser("instability", help="undamped run above F_x^c until D saturates")
    _add_model(i)
    i.add_argument("--t-max", dest="t_max", type=float, help="maximum time (1000)")
    i.add_argument("--d-sat", dest="d_sat", type=float, help="stop when D exceeds (1e-2)")
    i.set_defaults(func=run_instability)


def _guard(fn):
    """Turn a NoEquilibriumError into a message and exit status 3."""
    import functools

    @functools.wraps(fn)
    def wrapper(args):
        import sys
        from .equilibrium import NoEquilibriumError
        try:
            return fn(args)
        except NoEquilibriumError as exc:
            print(f"remote-trigger {args.command}: {exc}", file=sys.stderr)
            return 3
    return wrapper


def _rank():
    from mpi4py import MPI
    return MPI.COMM_WORLD.Get_rank()


def run_generate(args):
    """``remote-trigger generate``."""
    from .config import check_packing_args
    from .packing import generate, write_data

    check_packing_args(args.n, args.seed, args.phi)
    if _rank() == 0:
        p = generate(args.n, seed=args.seed, phi=args.phi)
        d = os.path.dirname(os.path.abspath(args.output))
        os.makedirs(d, exist_ok=True)
        write_data(p, args.output)
        print(f"generate: {p.n} disks ({p.n_top} in top), L = {p.width:.6g}, "
              f"seed {p.seed} -> {args.output}")
    return 0


@_guard
def run_relax(args):
    """``remote-trigger relax``."""
    from .config import RelaxConfig
    from . import stages

    cfg = _config(RelaxConfig, args, ("settle_steps", "f_min", "newton"))
    res = stages.relax(cfg, args.out, quiet=args.quiet, log=args.log)
    if _rank() == 0:
        print(f"relax: residual {res.residual:.3e} ({'< f_min' if res.converged else 'round-off floor'}), "
              f"{res.newton_iterations} Newton steps, damped time {res.damped_time:.4g}, "
              f"wall {res.wall_time:.2f} s, phi {res.packing_fraction:.4f} -> {res.h5}")
    return 0


@_guard
def run_ramp(args):
    """``remote-trigger ramp``."""
    from .config import RampConfig
    from . import stages

    cfg = _config(RampConfig, args, ("dF_x", "tol"))
    res = stages.ramp(cfg, args.out, quiet=args.quiet, resume=args.resume, log=args.log)
    if _rank() == 0:
        if res.status == "complete":
            print(f"ramp: F_x^c in [{res.F_x_c_low:.10g}, {res.F_x_c_high:.10g}] (certified, "
                  f"width {res.F_x_c_width:.3g}; {len(res.F_x)} steps, "
                  f"{len(res.bisection_F_x)} bisections, {res.n_undecided} undecided) "
                  f"-> {res.h5}")
            if not res.tol_reached:
                print(f"ramp: {res.message}")
        else:
            print(f"ramp: {res.status}: {res.message} -> {res.h5}")
    return 0 if res.status == "complete" else 1


@_guard
def run_perturb(args):
    """``remote-trigger perturb``."""
    from .config import DynamicsConfig
    from . import stages

    cfg = _config(DynamicsConfig, args, ("t_max", "a", "omega_p"))
    res = stages.perturb(cfg, args.out, quiet=args.quiet, log=args.log, runs=args.runs)
    if _rank() == 0:
        for k, r in res.items():
            print(f"perturb ({k}): max D {r.D.max():.3e}, max |v_top| "
                  f"{abs(r.v_top).max():.3e}, min mu {r.mu.min():.4f} -> {r.h5}")
    return 0


@_guard
def run_instability(args):
    """``remote-trigger instability``."""
    from .config import DynamicsConfig
    from . import stages

    cfg = _config(DynamicsConfig, args, ("t_max", "d_sat"))
    res = stages.instability(cfg, args.out, quiet=args.quiet, log=args.log)
    if _rank() == 0:
        e = res.extra
        print(f"instability: D from {res.D[1]:.3e} to {res.D[-1]:.3e} in t = {res.t[-1]:.4g}; "
              f"growth rate measured {e['measured_growth_rate']:.4g}, predicted "
              f"{e['predicted_growth_rate']:.4g} -> {res.h5}")
    return 0
