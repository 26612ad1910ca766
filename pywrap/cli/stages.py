"""Subcommands ``generate``, ``relax``, ``ramp``, ``perturb``, ``instability``.

All of them run under ``mpirun -np K remote-trigger ...`` as well (LAMMPS
domain decomposition, output and analysis on rank 0). The model (F_x, F_y,
mu, k_n, k_t) comes from the start file's sidecar (``X.data`` ->
``X.dump.json``) when the options do not give it; an option that contradicts
the sidecar is refused unless ``--override``
(:func:`remote_trigger.analysis.state.sidecar.merge_model`). Other options not
given keep the defaults of :mod:`remote_trigger.pywrap.config`;
``--set KEY=VALUE`` sets any other configuration field (unknown keys are an
error). Errors and exit statuses: :mod:`remote_trigger.pywrap.cli`.
``ramp --np K`` re-launches itself under ``mpirun -np K``; with
``--part-size P`` every rank also runs parts of each sliced verdict.
"""
import json
import math
import os
import sys


def _add_model(p, default=None, shown=None):
    """The options every stage takes. ``shown``: the default of ``--datafile``
    as its help names it (None: the option is required); ``default``: its
    value (None for ``ramp``: OUT/relax/equilibrium.data, set in :func:`_config`)."""
    if shown is None:
        p.add_argument("--datafile", required=True, help="LAMMPS data file to start from")
    else:
        p.add_argument("--datafile", default=default,
                       help=f"LAMMPS data file to start from (default {shown})")
    p.add_argument("--out", default="out", help="output folder (default ./out)")
    p.add_argument("--mu", type=float, help="friction coefficient (default: the start "
                   "file's sidecar, else 1)")
    p.add_argument("--F-x", dest="F_x", type=float, help="horizontal load on each top disk "
                   "or sphere (default: the start file's sidecar, else 0)")
    p.add_argument("--F-y", dest="F_y", type=float, help="downward load on each top disk "
                   "or sphere (default: the start file's sidecar, else 3)")
    p.add_argument("--override", action="store_true",
                   help="use --F-x/--F-y/--mu/--set k_n=/k_t= even where they contradict the "
                        "start file's sidecar (the state is re-equilibrated at them)")
    p.add_argument("--dt", type=_dt_arg, help="time step, or 'auto' = 0.1 x the stability "
                   "limit of the start state (default 1e-3); a dt at or above the limit "
                   "is refused")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="any configuration field, e.g. --set k_n=2e5 (repeatable)")
    p.add_argument("--quiet", action="store_true",
                   help="no progress bar and no model line (the result lines remain)")
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


#: option of each model key, for messages
_FLAGS = {"F_x": "--F-x", "F_y": "--F-y", "mu": "--mu", "k_n": "--set k_n=",
          "k_t": "--set k_t="}


def _resumed_start(out):
    """``ramp --resume`` without --datafile: the start file OUT/ramp.h5 names
    (its absolute path, else as given when the ramp began), else relax's
    equilibrium in OUT (the default start; a moved ramp folder), or None
    without OUT/ramp.h5. Which file it is, is checked by its SHA-256 when
    the ramp log is loaded.

    Raises
    ------
    ConfigError
        OUT/ramp.h5 unreadable, or none of those files found from here (it
        was the default ``OUT/relax/equilibrium.data`` that did not exist,
        or the h5 error was hidden behind it).
    """
    from remote_trigger.pywrap.config import ConfigError
    from remote_trigger.pywrap.stages.ramp_file import recorded_start

    h5 = os.path.join(out, "ramp.h5")
    if not os.path.exists(h5):
        return None
    names = [n for n in recorded_start(h5) if n is not None]
    names.append(os.path.join(out, "relax", "equilibrium.data"))
    for name in names:
        if os.path.isfile(name):
            return name
    raise ConfigError(f"cannot resume {h5} without --datafile: its start file "
                      f"({' or '.join(map(repr, names))}) is not found from "
                      f"{os.getcwd()!r}; give --datafile")


def _option_of(key):
    """The command-line option of a configuration key (``dF_x`` -> ``--dF-x``)."""
    return {"newton": "--no-newton", **_FLAGS}.get(key, "--" + key.replace("_", "-"))


def _config(cls, args, extra=()):
    """The stage's configuration: options, ``--set``, and the start file's sidecar.

    Raises
    ------
    ConfigError
        A malformed ``--set``, an unknown key, a bad value, a missing data
        file, or a model value that contradicts the sidecar (without
        ``--override``).
    """
    from remote_trigger.analysis.state.sidecar import MODEL_KEYS, merge_model
    from remote_trigger.pywrap.config import ConfigError

    if args.datafile is None:               # ramp's default: relax's equilibrium in --out,
        args.datafile = (_resumed_start(args.out) if getattr(args, "resume", False)
                         else None) or os.path.join(args.out, "relax", "equilibrium.data")
    d = {"datafile": args.datafile}
    options = {}                            # key -> the option that gave it
    for key in ("mu", "F_x", "F_y", "dt") + tuple(extra):
        val = getattr(args, key, None)
        if val is not None:
            d[key] = val
            options[key] = _option_of(key)
    flags = dict(_FLAGS)
    for item in args.set:
        if "=" not in item:
            raise ConfigError(f"--set expects KEY=VALUE, got {item!r}")
        k, v = item.split("=", 1)
        k = k.strip()
        if k in options:
            raise ConfigError(f"--set {item} and {options[k]} both set {k}; give one of them")
        try:
            d[k] = json.loads(v)
        except json.JSONDecodeError:
            d[k] = v
        options[k] = flags[k] = f"--set {k}="
    for k in MODEL_KEYS:                    # before they are compared with the sidecar
        v = d.get(k)
        if v is not None and not (isinstance(v, (int, float)) and not isinstance(v, bool)
                                  and math.isfinite(v)):
            raise ConfigError(f"{k} must be a finite number, got {k} = {v!r} "
                              f"({options.get(k, k)})")
    if os.path.isfile(args.datafile):
        given = {k: d[k] for k in MODEL_KEYS if d.get(k) is not None}
        try:
            model, source = merge_model(given, args.datafile, flags,
                                        override=getattr(args, "override", False))
        except ValueError as exc:
            raise ConfigError(str(exc)) from None
        d.update(model)
        args.model_source = source
        args.model_given = [options[k] for k in MODEL_KEYS if k in given]
    return cls.from_dict(d)


def _note_model(args, cfg):
    """On rank 0 (not with --quiet): one line naming the run's model, taken from
    the start file's sidecar but for the values given (with --override where
    they differ from it), or, for a start file without a sidecar (e.g. from
    ``generate``), from the defaults and the options given."""
    if _rank() != 0 or args.quiet:
        return
    src = getattr(args, "model_source", None)
    given = getattr(args, "model_given", [])
    if src:
        but = f"; {', '.join(given)} as given" if given else ""
        whence = f"the start state's sidecar {src}{but}"
    else:
        whence = "no sidecar beside the start file: the defaults" + (
            f", {', '.join(given)} as given" if given else "")
    print(f"{args.command}: model: F_x = {cfg.F_x!r}, F_y = {cfg.F_y!r}, mu = "
          f"{cfg.mu!r}, k_n = {cfg.k_n!r}, k_t = {cfg.k_t!r} ({whence})", flush=True)


def _runs_arg(text):
    """``--runs``: letters of a, b, c."""
    import argparse

    bad = sorted(set(text) - set("abc"))
    if not text or bad:
        raise argparse.ArgumentTypeError(
            f"unknown run letter(s) {', '.join(map(repr, bad))} in {text!r}: the runs are "
            f"a (unperturbed), b (f(t)), c (f(t) + mu(v))" if bad else
            "give at least one of the runs a, b, c")
    return text


#: printed after Ctrl-C, per subcommand (docs/driver.md, "Exit status")
INTERRUPT_HINTS = {
    "relax": "nothing of the relaxation is kept (relax has no --resume): rerun it",
    "ramp": "ramp.h5 holds the equilibria up to its last checkpoint (at most 5 s old): the "
            "same command with --resume continues from there (bitwise the same result)",
    "perturb": "the finished runs are kept: the same command with --resume continues with "
               "the interrupted one (bitwise the same result)",
    "instability": "instability.h5 is kept up to its last checkpoint (status 'running'); "
                   "instability has no --resume: rerun it into another --out",
}


def register(subparsers):
    """Add the driver's subcommands to the ``remote-trigger`` parser."""
    g = subparsers.add_parser(
        "generate", help="write a loose bidisperse packing data file",
        description="Write a loose, non-overlapping bidisperse packing (radii 0.5 and 0.7) "
                    "above a flat floor wall with a top line of disks (spheres: a top "
                    "layer), periodic in x (and z), as a LAMMPS data file. Next: "
                    "`remote-trigger relax`.")
    g.add_argument("--dim", type=int, choices=(2, 3), default=2,
                   help="2: disks (default); 3: spheres, periodic in x and z")
    g.add_argument("--n", type=int, default=None,
                   help="number of disks or spheres, even (default 100; spheres 160)")
    g.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    g.add_argument("--phi", type=float, default=None,
                   help="packing fraction for L (default 0.82; spheres 0.64)")
    g.add_argument("-o", "--output", default="packing.data", help="data file (packing.data)")
    g.add_argument("--overwrite", action="store_true",
                   help="replace an existing --output file (default: refuse, exit status 2)")
    g.set_defaults(func=run_generate, serial=True)

    r = subparsers.add_parser(
        "relax", help="settle / relax to equilibrium (f_min)",
        description="Relax a packing to a force-balanced equilibrium under the load "
                    "F_y by the default protocol (docs/driver.md): compaction "
                    "without friction, then friction, then a Newton polish to the "
                    "round-off floor (no F_x: without friction nothing balances it; "
                    "ramp to it from the result, or --set protocol=frictional). "
                    "Writes OUT/relax.h5 and OUT/relax/equilibrium.* "
                    "(.data, .dump, .dump.json), where `remote-trigger ramp` starts.")
    _add_model(r, "packing.data", shown="packing.data")     # generate's default --output
    r.add_argument("--dim", type=int, choices=(2, 3), default=None,
                   help="2 or 3 (default: that of the data file; a contradicting value "
                        "is an error)")
    r.add_argument("--settle-steps", dest="settle_steps", type=int,
                   help="compaction aid for a loose packing (frictionless + gravity), steps "
                        "(30000)")
    r.add_argument("--f-min", dest="f_min", type=float, help="target residual (1e-15)")
    r.add_argument("--no-newton", dest="newton", action="store_false", default=None,
                   help="over-damped dynamics only, down to the acceptance level (the "
                        "round-off floor, or --set f_accept=) instead of --f-min; disks only")
    r.set_defaults(func=run_relax, resume_hint=INTERRUPT_HINTS["relax"])

    m = subparsers.add_parser(
        "ramp", help="F_x ramp, eigenvalues, bisection of F_x^c",
        description="Raise F_x on the top disks step by step from an equilibrium, "
                    "re-equilibrate at each load and decide whether M^-1 K has a "
                    "complex eigenvalue pair (certified: real, complex or undecided, "
                    "on the whole spectrum), then bisect F_x^c between the last real "
                    "and the first complex point. Writes OUT/ramp.h5 (every point, "
                    "its eigenvalues and the bracket of F_x^c) and OUT/ramp/ (the "
                    "equilibria).")
    _add_model(m, shown="OUT/relax/equilibrium.data")
    m.add_argument("--dim", type=int, choices=(2, 3), default=None,
                   help="2 or 3 (default: that of the data file; a contradicting value "
                        "is an error)")
    m.add_argument("--dF-x", dest="dF_x", type=float, help="ramp step (1e-4)")
    m.add_argument("--tol", type=float, help="bisection tolerance (1e-7)")
    m.add_argument("--dF-x-max", dest="dF_x_max", type=float,
                   help="adaptive ramp: largest step (default: every step is dF_x)")
    m.add_argument("--between", type=int,
                   help="before the bisection, decide M - 1 loads between every two steps "
                        "below the first complex one (the lower real), lowest first: a "
                        "complex window narrower than a step looked for at step / M "
                        "(default 1: none)")
    m.add_argument("--resume", action="store_true",
                   help="continue an interrupted ramp from its last equilibrium (without "
                        "--datafile: the start file OUT/ramp.h5 names)")
    m.add_argument("--part-size", dest="part_size", type=int,
                   help="sliced verdicts (above 3000 dofs) in parts of about this many "
                        "eigenvalues, run on every MPI rank (>= 60; the answer depends on it, "
                        "never on the number of ranks; default: one scan on rank 0)")
    m.add_argument("--np", type=int, default=1,
                   help="MPI ranks: re-launch under mpirun -np NP (LAMMPS and, with "
                        "--part-size, the verdicts on every rank; default 1)")
    m.set_defaults(func=run_ramp, resume_hint=INTERRUPT_HINTS["ramp"])

    p = subparsers.add_parser(
        "perturb", help="undamped runs (a), (b) f(t), (c) f(t)+mu(v)",
        description="The three undamped runs of the paper's Fig. 5 from the equilibrium "
                    "at --F-x (below F_x^c): (a) unperturbed, (b) with f(t) = a "
                    "cos(omega_p t) added to F_x on the top disks, (c) like (b) with the "
                    "velocity-dependent friction mu(v) of Eq. (4). Writes "
                    "OUT/perturb_a.h5, perturb_b.h5, perturb_c.h5 (time series of the MSD "
                    "D(t), the top's mean x-velocity and mu).")
    _add_model(p)
    p.add_argument("--t-max", dest="t_max", type=float, help="time of each run (1000)")
    p.add_argument("--a", type=float, help="amplitude of f(t) (1e-12)")
    p.add_argument("--omega-p", dest="omega_p", type=float, help="frequency of f(t) (0.01)")
    p.add_argument("--runs", default="abc", type=_runs_arg,
                   help="which runs, letters of a, b, c (default abc); c without "
                        "--set v0= also runs a: v0 = v0_margin (default 10) x its "
                        "largest |v_top|")
    p.add_argument("--resume", action="store_true",
                   help="continue an interrupted perturb in --out (same options): its "
                        "equilibrium and finished runs are kept")
    p.set_defaults(func=run_perturb, resume_hint=INTERRUPT_HINTS["perturb"])

    i = subparsers.add_parser(
        "instability", help="undamped run above F_x^c until D saturates",
        description="An undamped run from the equilibrium at --F-x above F_x^c (the "
                    "paper's Fig. 4) until the MSD D(t) exceeds --d-sat; the measured "
                    "growth rate of D ~ exp(2 g t) beside the one predicted from the "
                    "complex pair, max Im sqrt(lambda) (Eq. 6). Writes "
                    "OUT/instability.h5 and OUT/instability/equilibrium.*.")
    _add_model(i)
    i.add_argument("--t-max", dest="t_max", type=float, help="maximum time (1000)")
    i.add_argument("--d-sat", dest="d_sat", type=float, help="stop when D exceeds (1e-2)")
    i.add_argument("--allow-stable", action="store_true",
                   help="run also from a linearly stable equilibrium (no certified complex "
                        "pair; default: refuse, exit status 2)")
    i.set_defaults(func=run_instability, resume_hint=INTERRUPT_HINTS["instability"])


def _rank():
    from mpi4py import MPI
    return MPI.COMM_WORLD.Get_rank()


def run_generate(args):
    """``remote-trigger generate`` (rank 0 only: ``serial``)."""
    from remote_trigger.pywrap.config import ConfigError
    from remote_trigger.pywrap.stages.config import check_packing_args
    from remote_trigger.pywrap.stages.packing import generate, write_data

    from remote_trigger.analysis.output import output_dir, output_file

    from remote_trigger.pywrap.stages.packing import N_3D, PHI

    n = args.n if args.n is not None else (N_3D if args.dim == 3 else 100)
    phi = args.phi if args.phi is not None else PHI[args.dim]
    check_packing_args(n, args.seed, phi, args.dim)
    if os.path.isdir(args.output) or args.output.endswith(os.sep):
        output_file(args.output, "--output")
    folder = os.path.dirname(os.path.abspath(args.output))
    if os.path.exists(folder) and not os.path.isdir(folder):
        raise ConfigError(f"--output {args.output!r}: {folder!r} is a file, not a folder")
    output_dir(folder, "--output's folder")
    output_file(args.output, "--output")
    if os.path.exists(args.output) and not args.overwrite:
        raise ConfigError(f"--output {args.output!r} exists; choose another file or add "
                          f"--overwrite (nothing was written)")
    p = generate(n, seed=args.seed, phi=phi, dim=args.dim)
    write_data(p, args.output)
    what = "spheres" if args.dim == 3 else "disks"
    print(f"generate: {p.n} {what} ({p.n_top} in top), L = {p.width:.6g}, "
          f"seed {p.seed} -> {args.output}")
    return 0


def run_relax(args):
    """``remote-trigger relax``."""
    from remote_trigger.pywrap.stages.config import RelaxConfig
    from remote_trigger.pywrap import stages

    cfg = _config(RelaxConfig, args, ("settle_steps", "f_min", "newton"))
    if args.dim is not None:
        _check_dim(args.dim, cfg.datafile)
    _note_model(args, cfg)
    res = stages.relax(cfg, args.out, quiet=args.quiet, log=args.log)
    if _rank() == 0:
        print(f"relax: residual {res.residual:.3e} ({'< f_min' if res.converged else 'round-off floor'}), "
              f"{res.newton_iterations} Newton steps, damped time {res.damped_time:.4g}, "
              f"wall {res.wall_time:.2f} s, phi {res.packing_fraction:.4f} -> {res.h5}; "
              f"a ramp starts from {res.datafile}")
        if not res.top_clearance > 0:       # a bulk disk came up beside the top line
            why = ("settle_steps = 0 skips the compaction and the placements of the top "
                   "line: give a loose packing the default settle_steps" if
                   cfg.settle_steps == 0 else
                   f"none of the {res.top_attempts} placements was clear; the one with the "
                   "largest clearance is kept")
            print(f"relax: warning: the top line is not clear of the bulk (top_clearance = "
                  f"{res.top_clearance:.3g} by rule {res.clearance_rule!r}, docs/driver.md "
                  f"'Relax protocol'): {why}", file=sys.stderr)
    return 0


def _check_dim(dim, datafile):
    """Refuse a ``--dim`` that contradicts the data file (ConfigError, one line)."""
    from remote_trigger.pywrap.bindings.datafile import data_dimension
    from remote_trigger.pywrap.config import ConfigError

    found = data_dimension(datafile)
    if dim != found:
        what = "spheres" if found == 3 else "disks"
        raise ConfigError(f"--dim {dim} contradicts the data file {datafile}, which holds "
                          f"{what} (dimension {found}); leave --dim out or give --dim {found}")


def run_ramp(args):
    """``remote-trigger ramp``."""
    from remote_trigger.analysis.output import bracket_text
    from remote_trigger.pywrap.config import ConfigError
    from remote_trigger.pywrap.runtime.relaunch import RELAUNCHED
    from remote_trigger.pywrap.stages.config import RampConfig
    from remote_trigger.pywrap import stages

    cfg = _config(RampConfig, args, ("dF_x", "tol", "dF_x_max", "part_size", "between"))
    if args.dim is not None:
        _check_dim(args.dim, cfg.datafile)
    _note_model(args, cfg)
    if args.np < 1:
        raise ConfigError(f"--np must be >= 1, got --np {args.np}")
    if args.np > 1 and not os.environ.get(RELAUNCHED):
        from mpi4py import MPI

        if MPI.COMM_WORLD.Get_size() == 1:
            from remote_trigger.pywrap.cli import Parser
            from remote_trigger.pywrap.runtime.relaunch import relaunch_words

            return relaunch_words("ramp", Parser.words, args.np, args.resume_hint,
                                  getattr(args, "out_lock", None))
    res = stages.ramp(cfg, args.out, quiet=args.quiet, resume=args.resume, log=args.log)
    if _rank() == 0:
        if res.status == "complete":
            # what is certified: the two ends; between two real points a
            # complex window narrower than a step is not excluded (docs/driver.md)
            ends = ("real at the lower end, complex at the upper end: the first complex "
                    "load" if cfg.pairs == "all" else
                    "at the lower end no complex pair that is not soft, one at the upper end: "
                    "the first such load (pairs = 'collective')")
            print(f"ramp: F_x^c in {bracket_text(res.F_x_c_low, res.F_x_c_high, 10)} "
                  f"(certified {ends} at the loads sampled; width {res.F_x_c_width:.3g}; "
                  f"{len(res.F_x)} steps, "
                  f"{len(res.bisection_F_x)} bisections, {res.n_undecided} undecided) "
                  f"-> {res.h5}")
            if not res.tol_reached:
                print(f"ramp: {res.message}")
        else:
            print(f"ramp: {res.status}: {res.message} -> {res.h5}")
        if res.n_escaped or res.n_saddle:
            print(f"ramp: {res.n_escaped} point(s) whose Newton equilibrium was a saddle, "
                  f"equilibrated again by damped dynamics; {res.n_saddle} left on a saddle")
        if res.start_damped_time > 0:   # the start file was not an equilibrium
            print(f"ramp: note: {cfg.datafile} was not an equilibrium at the start load: "
                  f"the first point came to rest by damped dynamics with friction on (time "
                  f"{res.start_damped_time:.4g}), not by the relax protocol; a ramp usually "
                  f"starts from `remote-trigger relax`'s relax/equilibrium.data")
    return 0 if res.status == "complete" else 1


def run_perturb(args):
    """``remote-trigger perturb``."""
    from remote_trigger.pywrap.stages.config import DynamicsConfig
    from remote_trigger.pywrap import stages

    cfg = _config(DynamicsConfig, args, ("t_max", "a", "omega_p"))
    _note_model(args, cfg)
    res = stages.perturb(cfg, args.out, quiet=args.quiet, log=args.log, runs=args.runs,
                         resume=args.resume)
    if _rank() == 0:
        for k, r in res.items():
            # max |v_top| over every step (run (a)'s makes v0 when not given),
            # not only over the records; run (c) names its v0
            vmax = r.extra.get("v_top_max", float(abs(r.v_top).max()))
            v0 = f" (v0 {r.extra['v0']:.3e})" if k == "c" else ""
            print(f"perturb ({k}): max D {r.D.max():.3e}, max |v_top| "
                  f"{vmax:.3e} (every step), min mu {r.mu.min():.4f}{v0} -> {r.h5}")
    return 0


def run_instability(args):
    """``remote-trigger instability``."""
    from remote_trigger.pywrap.stages.config import DynamicsConfig
    from remote_trigger.pywrap import stages

    cfg = _config(DynamicsConfig, args, ("t_max", "d_sat"))
    _note_model(args, cfg)
    res = stages.instability(cfg, args.out, quiet=args.quiet, log=args.log,
                             allow_stable=args.allow_stable)
    if _rank() == 0:
        e = res.extra
        g = e["measured_growth_rate"]
        meas = (f"measured {g:.4g}" if g == g else
                "not measured (D did not grow clear of the noise level)")
        pred = (f"predicted {e['predicted_growth_rate']:.4g}" if e["complex_pair"] else
                f"predicted none (the start is linearly stable: {e['decision']})")
        print(f"instability: D from {res.D[1]:.3e} to {res.D[-1]:.3e} in t = {res.t[-1]:.4g}; "
              f"growth rate {meas}, {pred} -> {res.h5}")
    return 0
