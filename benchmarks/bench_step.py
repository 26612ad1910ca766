#!/usr/bin/env python
"""Per-step cost of the undamped runs (Fig. 5 scenes) against the bare dynamics.

One core, one process, the default job's equilibrium at F_x = 0.0645 (N = 100,
``tests/data/default_job_mu1_step_00258``), side by side in one invocation:

``bare``
    pair mindlin/smooth + fix wall/mindlin/smooth + the load as ``fix
    addforce`` with numbers + nve/sphere + enforce2d (in.perturb's settings):
    the dynamics and nothing else.
``(a)``, ``(b)``, ``(c)``, ``(c) sw``
    in.perturb's scene (the installed deck's ``scene`` and ``dynamics``
    sections, what the driver loads) with the driver's records every 500
    steps (pywrap/stages/runs.py): (a) a = 0, no mu(v); (b) a = 1e-5,
    omega_p = 0.01; (c) the same and mu(v) (v0 = 1, the deck's default: mu
    stays mu0); (c) sw: v0 = 1e-13, below the noise, so mu(v) is switched
    on (mu ~ mu_ss mu0), as in the triggered runs of the trigger map.
    The plugin's fix addforce/oscillating and fix mu/velocity.
``(a) former``, ``(b) former``, ``(c) former``, ``(c) sw former``
    the same scenes the way in.perturb built them before the plugin fixes:
    per-atom variables for the load, mu(v) as an equal-style variable pushed
    by fix adapt and read by the wall, newton on, and the former records
    (max |v_top| through a variable every step); the route
    tests/plugin/mu_routes.py calls ``nested``.
``(c) driver``
    ``stages.runs.undamped_run`` of scene (c) as the paper job runs it
    (records every 500 steps into an HDF5 file, one LAMMPS ``run`` per record).

Timing: process CPU time per step over ``--steps`` steps after a 1000-step
warm-up (the measure to trust on a shared machine; the wall time per step and
the load average are printed beside it), best of ``--repeat`` fresh LAMMPS
instances, cases interleaved. Goal: scene (c) <= 1.3 x bare.

    python benchmarks/bench_step.py [--steps 30000] [--repeat 3] [--quick]
"""
import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import gzip
import shutil
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
DATA = os.path.join(ROOT, "tests", "data", "default_job_mu1_step_00258.data.gz")
sys.path.insert(0, os.path.join(ROOT, "tests", "plugin"))

F_X, F_Y, A, OMEGA = 0.0645, 3.0, 1e-5, 0.01
V0_SWITCHED = 1e-13
EVERY = 500
#: the former driver's records: max |v_top| through a variable, every step
FORMER_RECORDS = ("compute msd all msd\n"
                  f"fix rec all ave/time {EVERY} 1 {EVERY} c_msd[4] v_vtop v_mu_now\n"
                  "variable absvtop equal abs(v_vtop)\n"
                  f"fix vmax all ave/histo 1 {EVERY} {EVERY} 0.0 1.0 1 v_absvtop mode scalar "
                  "ave running\n")
#: the driver's records now (pywrap/stages/runs.py)
RECORDS = ("compute msd all msd\n"
           f"fix rec all ave/time {EVERY} 1 {EVERY} c_msd[4] v_vtop v_mu_now\n"
           "compute vx top reduce ave vx\n"
           f"fix vmax all ave/histo 1 {EVERY} {EVERY} 0.0 1.0 1 c_vx mode scalar ave running\n"
           "thermo_style custom step\nthermo 0\n")


def _numbers(case):
    """(a, muv, v0) of a case."""
    if case.startswith("(a)"):
        return 0.0, False, 1.0
    if case.startswith("(b)"):
        return A, False, 1.0
    return A, True, (V0_SWITCHED if case.startswith("(c) sw") else 1.0)


def _deck_vars(datafile, case):
    a, muv, v0 = _numbers(case)
    v = {"datafile": datafile, "Fx": F_X, "Fy": F_Y, "a": a, "wp": OMEGA}
    if muv:
        v.update(muv=1, v0=v0)
    return v


def build(case, datafile):
    """A LAMMPS instance (Engine) with the scene of ``case``, ready to run."""
    import mu_routes
    from remote_trigger.pywrap.bindings.engine import Engine

    eng = Engine()
    if case != "bare" and not case.endswith("former"):
        eng.load_deck("in.perturb", _deck_vars(datafile, case), ("scene", "dynamics"))
        eng.commands(RECORDS)
        return eng
    a, muv, v0 = _numbers(case)
    p = dict(mu_routes.P, Fx=F_X, Fy=F_Y, a=A, wp=OMEGA, ton=0.0, v0=v0, vss=v0)
    scene = mu_routes.scene_commands(datafile, p)
    if case == "bare":
        cmds = ["newton off"] + scene + [f"fix wall all wall/mindlin/smooth {mu_routes.KN!r} {mu_routes.KT!r} "
                        f"{p['mu']!r} yplane 0.0",
                        f"fix load top addforce {F_X!r} {-F_Y!r} 0.0"]
    else:
        cmds = scene + mu_routes.route_commands("nested", p, muv=muv, a=a)
    eng.commands("\n".join(cmds + ["fix integ all nve/sphere disc", "fix 2d all enforce2d"]))
    if case != "bare":
        eng.commands(FORMER_RECORDS)
    return eng


def time_case(case, datafile, steps):
    """(CPU us/step, wall us/step) of one fresh instance."""
    eng = build(case, datafile)
    try:
        eng.run(1000)
        c0, w0 = time.process_time(), time.perf_counter()
        eng.run(steps, pre=False)
        return ((time.process_time() - c0) / steps * 1e6,
                (time.perf_counter() - w0) / steps * 1e6)
    finally:
        eng.close()


def time_driver(datafile, steps, folder):
    """(CPU us/step, wall us/step) of the driver's run of scene (c)."""
    from remote_trigger.pywrap.stages.config import DynamicsConfig
    from remote_trigger.pywrap.stages.runs import undamped_run
    from remote_trigger.pywrap.bindings.engine import Engine

    cfg = DynamicsConfig(datafile=datafile, F_x=F_X, t_max=steps * 1e-3,
                         record_every=EVERY, a=A, omega_p=OMEGA)
    h5 = os.path.join(folder, f"c_{time.perf_counter_ns()}.h5")
    with Engine() as eng:
        c0, w0 = time.process_time(), time.perf_counter()
        undamped_run(eng, cfg, datafile, h5, {"a": A, "wp": OMEGA, "muv": 1, "v0": 1.0,
                                               "vss": 1.0}, "c", True)
        return ((time.process_time() - c0) / steps * 1e6,
                (time.perf_counter() - w0) / steps * 1e6)


def _commit():
    """The source commit measured (and whether the tree differs from it)."""
    import subprocess
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT,
                             capture_output=True, text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                               cwd=ROOT, capture_output=True, text=True).stdout.strip()
        return rev + (" (with uncommitted changes)" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=30000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="5000 steps, 1 repeat")
    args = ap.parse_args(argv)
    if args.quick:
        args.steps, args.repeat = 5000, 1
    from mpi4py import MPI  # noqa: F401  (libmpi before liblammps)

    cases = ["bare", "(a)", "(b)", "(c)", "(c) sw", "(a) former", "(b) former", "(c) former",
             "(c) sw former", "(c) driver"]
    best = {c: (float("inf"), float("inf")) for c in cases}
    load0 = os.getloadavg()[0]
    t_all = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        datafile = os.path.join(tmp, "eq.data")
        with gzip.open(DATA, "rb") as src, open(datafile, "wb") as dst:
            shutil.copyfileobj(src, dst)
        for _ in range(args.repeat):
            for c in cases:
                got = (time_driver(datafile, args.steps, tmp) if c == "(c) driver"
                       else time_case(c, datafile, args.steps))
                best[c] = min(best[c], got)
    print(f"bench_step: commit {_commit()}; N = 100 (default job, F_x = {F_X}), one core, "
          f"{args.steps} steps, best of {args.repeat}; load average {load0:.2f} at the start, "
          f"{os.getloadavg()[0]:.2f} at the end")
    print(f"{'case':<14} {'cpu us/step':>12} {'wall us/step':>13} {'x bare (cpu)':>13} "
          f"{'former/now':>11}")
    bare = best["bare"][0]
    for c in cases:
        cpu, wall = best[c]
        gain = (f"{best[c + ' former'][0] / cpu:11.2f}" if c + " former" in best else "")
        print(f"{c:<14} {cpu:12.2f} {wall:13.2f} {cpu / bare:13.2f} {gain}")
    ratio = max(best["(c)"][0], best["(c) sw"][0]) / bare
    print(f"scene (c) = {best['(c)'][0] / bare:.2f} x bare, with mu(v) switched on "
          f"{best['(c) sw'][0] / bare:.2f} x (goal <= 1.3); the former route "
          f"{best['(c) former'][0] / bare:.2f} x and {best['(c) sw former'][0] / bare:.2f} x")
    print(f"total {time.perf_counter() - t_all:.0f} s")
    return 0 if ratio <= 1.3 else 1


if __name__ == "__main__":
    raise SystemExit(main())
