"""Benchmark: one large sliced point on 1 and k MPI ranks, and a model of many ranks.

The point: the stored relaxed packing of N disks (``benchmarks/data``,
seed 1; N = 6400 and 10^4 by default, one after the other; 1600 with
``--quick``) brought to F_x = 1e-4 by
one Newton-first equilibrium (a ramp's first step), its dump cached under
``$REMOTE_TRIGGER_BENCH_CACHE`` (default ``~/.cache/remote_trigger``)
``/parallel_point``. Its verdict on the whole spectrum (``decide`` with
``VerdictOptions(method='sliced')``, as ``remote-trigger jacobian`` does;
one BLAS thread):

* the whole scan (``part_size`` None) on one rank: today's cost;
* the scan in parts of ``--part-size`` eigenvalues on 1, 2, ... ranks
  (``mpirun -np k``, ``pywrap.runtime.rankmap``): wall time, and a check
  that decision, margin and eigenvalues are bitwise the same on every rank
  count.

Each run is its own process (``mpirun -np k python THIS --run ...``),
timing on rank 0: ``setup`` (K scaled, norms, bounds: before the first
task), the cut tasks and the part tasks (each task's wall seconds on the
rank that ran it), ``merge`` (after the last part's result). The model of k
ranks (printed last) schedules the measured tasks of the one-rank run on k
ranks (each task to the first free rank, in order, as the MPI map hands
them out; a static partition beside it; the two rounds one after the
other) and adds setup,
merge and the sending of the matrices (a ``bcast`` of the pickled problem:
its size and log2 k steps at the measured rate); for N = 10^4 it scales
the measured costs with n by the exponents fitted between the two largest
sizes whose one-rank runs are kept in the cache, with parts of n / k
eigenvalues (not for N = 10^5: ``bench_slice_cost`` measures its pieces
there). What it cannot know: the memory per rank and a
network's latency.

    python benchmarks/bench_parallel_point.py [--quick] [--n 6400 10000] [--part-size 2400]
                                              [--ranks 1 2] [--no-whole]
"""
import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import hashlib
import json
import math
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

#: the load of the point (a ramp's first step from the relaxed packing)
F_X = 1e-4


def cache_dir():
    d = os.environ.get("REMOTE_TRIGGER_BENCH_CACHE",
                       os.path.join(os.path.expanduser("~"), ".cache", "remote_trigger"))
    d = os.path.join(d, "parallel_point")
    os.makedirs(d, exist_ok=True)
    return d


def state(n):
    """The dump of the N = n point (built once, then cached)."""
    from degenerate import equilibrate_at

    prefix = os.path.join(cache_dir(), f"N{n}_seed1_F{F_X:g}")
    if not os.path.exists(prefix + ".dump"):
        start = os.path.join(HERE, "data", f"relaxed_N{n}_seed1.data")
        t0 = time.perf_counter()
        equilibrate_at(start, [F_X], prefix)
        print(f"(built the N = {n} point in {time.perf_counter() - t0:.0f} s: {prefix}.dump)",
              flush=True)
    return prefix + ".dump"


class TimedMap:
    """Wraps a map_tasks (None: the builtin map): when each call began, when each
    result was read, and (one rank) each task's seconds."""

    def __init__(self, inner):
        self.inner, self.calls, self.tasks = inner, [], []

    def __call__(self, fn, tasks):
        rec = {"fn": fn.__name__, "start": time.perf_counter(), "read": []}
        self.calls.append(rec)
        if self.inner is None:
            def timed(t):
                t0, c0 = time.perf_counter(), time.thread_time()
                r = fn(t)
                self.tasks.append((fn.__name__, time.perf_counter() - t0, 0,
                                   time.thread_time() - c0))
                return r
            it = map(timed, tasks)
        else:
            it = iter(self.inner(fn, tasks))

        def gen():
            try:
                for r in it:
                    rec["read"].append(time.perf_counter())
                    yield r
            finally:
                close = getattr(it, "close", None)
                if close is not None:
                    close()
        return gen()


def run_one(dump, part_size, out):
    """One verdict on the ranks of COMM_WORLD (the ``--run`` mode); rank 0 writes
    ``out`` (JSON)."""
    import pickle

    import numpy as np
    from mpi4py import MPI

    from remote_trigger.analysis.stability.sliced import scaled_parts
    from remote_trigger.analysis.stability.sliced.parts import PartsProblem
    from remote_trigger.analysis.stability.system import reduced_system
    from remote_trigger.analysis.stability.verdict import VerdictOptions, decide
    from remote_trigger.analysis.state.dumpfile import read_equilibrium
    from remote_trigger.pywrap.runtime.rankmap import on_rank0_with_ranks

    comm = MPI.COMM_WORLD
    system = reduced_system(read_equilibrium(dump)) if comm.Get_rank() == 0 else None
    opts = VerdictOptions(method="sliced", part_size=part_size or None)
    comm.Barrier()

    def work(pmap):
        tm = TimedMap(pmap)
        t0, c0 = time.perf_counter(), time.process_time()
        res = decide(system, opts, map_tasks=tm)
        t1, c1 = time.perf_counter(), time.process_time()
        if pmap is not None:
            names = {1: "find_cut", 2: "scan_part"}
            tm.tasks = [(names[r.round], r.seconds, r.rank, r.cpu) for r in pmap.log]
        lam = np.asarray(res.eigenvalues)
        # what the other ranks receive: the scaled matrices (ctx and S hold them)
        problem = len(pickle.dumps(scaled_parts(system.K, system.mass),
                                   protocol=pickle.HIGHEST_PROTOCOL))
        return {
            "n": int(system.n), "ranks": comm.Get_size(), "part_size": part_size,
            "wall": t1 - t0, "cpu0": c1 - c0,
            "setup": (tm.calls[0]["start"] - t0) if tm.calls else t1 - t0,
            "merge": (t1 - max(tm.calls[-1]["read"])) if tm.calls and tm.calls[-1]["read"]
            else 0.0,
            "tasks": [list(t) for t in tm.tasks],
            "bcast": getattr(pmap, "bcast_seconds", 0.0),
            "decision": res.decision.label, "confidence": res.confidence,
            "n_eig": int(lam.size), "problem_bytes": problem,
            "bits": hashlib.sha256(lam.tobytes() + repr((int(res.decision),
                                                         res.confidence)).encode()
                                   ).hexdigest()[:16],
            "load": os.getloadavg()[0],
        }

    res = on_rank0_with_ranks(comm, work, (PartsProblem,))
    if comm.Get_rank() == 0:
        with open(out, "w") as fh:
            json.dump(res, fh)


def measure(dump, part_size, ranks):
    """Run the verdict in its own process on ``ranks`` ranks; its JSON record."""
    out = os.path.join(cache_dir(), f"run_{os.getpid()}_{ranks}_{part_size}.json")
    cmd = [sys.executable, os.path.abspath(__file__), "--run", dump, "--part-size",
           str(part_size), "--json", out]
    if ranks > 1:
        cmd = [os.path.join(os.path.dirname(sys.executable), "mpirun"), "-np",
               str(ranks)] + cmd
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise SystemExit(f"bench_parallel_point: run on {ranks} rank(s) failed:\n"
                         f"{res.stderr[-3000:]}")
    with open(out) as fh:
        rec = json.load(fh)
    os.unlink(out)
    return rec


def schedule(costs, k):
    """Wall time of independent tasks ``costs`` on k workers handed out in their
    order, each to the first free worker (what ``rankmap`` does)."""
    loads = [0.0] * k
    for c in costs:
        i = loads.index(min(loads))
        loads[i] += c
    return max(loads)


def static(costs, k):
    """The same, task i on worker i mod k (a static partition, for comparison)."""
    return max(sum(costs[i::k]) for i in range(k))


#: the rate (bytes/s) and latency (s) of one step of the problem's bcast in the
#: model (a node's shared memory; a network's would be lower)
BCAST_RATE, BCAST_LATENCY = 2e9, 1e-4


def model(rec, k, how=schedule):
    """Predicted wall of ``rec``'s point (the same parts) on k ranks from its
    tasks' CPU seconds on one rank: setup, bcast, the two rounds (each task
    to the first free rank, in order; ``how=static``: task i on rank i mod k),
    merge."""
    cuts = [t[3] for t in rec["tasks"] if t[0] == "find_cut"]
    parts = [t[3] for t in rec["tasks"] if t[0] == "scan_part"]
    steps = math.ceil(math.log2(k)) if k > 1 else 0
    send = steps * (BCAST_LATENCY + rec["problem_bytes"] / BCAST_RATE)
    return rec["setup"] + send + how(cuts, k) + how(parts, k) + rec["merge"]


def fitted(records, key):
    """``key(rec)`` at every n measured, as (n, value) pairs sorted by n."""
    return sorted((r["n"], key(r)) for r in records)


def power(points, n):
    """The power law through the two largest (n, value) points, at n (one point: linear)."""
    if len(points) == 1:
        (n1, v1), = points
        return v1 * n / n1, 1.0
    (n1, v1), (n2, v2) = points[-2:]
    a = math.log(v2 / v1) / math.log(n2 / n1)
    return v2 * (n / n2) ** a, a


def extrapolate(runs, n, k):
    """Predicted wall of a point of n dofs on k ranks in k parts (part size n / k),
    from the one-rank runs measured (``runs``: {'whole': rec, 'parts': rec} per
    size): a part costs its share of the whole scan plus one cut's region (the
    region its scan repeats), a cut task one cut; setup and merge as measured,
    each scaled in n by the power law through the two largest sizes."""
    whole = [r["whole"] for r in runs]
    prt = [r["parts"] for r in runs]
    e, ae = power(fitted(whole, lambda r: r["cpu0"]), n)
    c, ac = power(fitted(prt, lambda r: sum(t[3] for t in r["tasks"] if t[0] == "find_cut")
                         / max(1, sum(1 for t in r["tasks"] if t[0] == "find_cut"))), n)
    su, asu = power(fitted(prt, lambda r: r["setup"]), n)
    me, ame = power(fitted(prt, lambda r: max(r["merge"], 1e-3)), n)
    b, ab = power(fitted(prt, lambda r: r["problem_bytes"]), n)
    steps = math.ceil(math.log2(k)) if k > 1 else 0
    send = steps * (BCAST_LATENCY + b / BCAST_RATE)
    t = su + send + c + (e / k + c) + me
    return t, {"whole scan, one core": (e, ae), "cut task": (c, ac), "setup": (su, asu),
               "merge": (me, ame), "bcast": (send, ab)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    ap.add_argument("--quick", action="store_true", help="N = 1600, ranks 1 2")
    ap.add_argument("--n", type=int, nargs="+", default=None,
                    help="the stored packings, one point each (default 6400 10000)")
    ap.add_argument("--part-size", type=int, default=None,
                    help="eigenvalues per part (default: about n / 8)")
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--no-whole", action="store_true", help="skip the whole scan")
    ap.add_argument("--run", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--json", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.run:
        return run_one(args.run, args.part_size, args.json)
    sizes = args.n or ([1600] if args.quick else [6400, 10000])
    status = 0
    for n in sizes:
        status |= one_size(n, args)
    model_large()
    return status


def one_size(n, args):
    """The point of N = n on the ranks asked; 0 if the bits agree on every rank count."""
    dump = state(n)
    print(f"One sliced point, N = {n} (stored packing, seed 1, F_x = {F_X:g}); "
          f"{os.cpu_count()} cores, load {os.getloadavg()[0]:.1f} at the start; one BLAS "
          f"thread per rank", flush=True)
    recs = {}
    if not args.no_whole:
        recs["whole"] = measure(dump, 0, 1)
    part = args.part_size
    if part is None:                    # about n / 8, rounded to 100
        from remote_trigger.analysis.stability.system import reduced_system
        from remote_trigger.analysis.state.dumpfile import read_equilibrium

        dofs = reduced_system(read_equilibrium(dump)).n
        part = max(100, int(round(dofs / 8, -2)))
    for k in args.ranks:
        recs[k] = measure(dump, part, k)
    rows = [("whole scan", recs["whole"])] if "whole" in recs else []
    rows += [(f"parts of {part}, {k} rank{'s' if k > 1 else ''}", recs[k]) for k in args.ranks]
    base = recs.get("whole", recs[args.ranks[0]])["wall"]
    r1 = recs[args.ranks[0]]
    print(f"n = {r1['n']} dofs; decision {r1['decision']}; the matrices sent to each rank "
          f"{r1['problem_bytes'] / 2**20:.0f} MiB")
    print(f"{'run':<26}{'wall s':>8}{'speed-up':>9}{'setup':>7}{'cuts: n, CPU s':>16}"
          f"{'parts: n, CPU s':>17}{'merge':>7}{'load':>6}  bits")
    for name, r in rows:
        cuts = [t[3] for t in r["tasks"] if t[0] == "find_cut"]
        prts = [t[3] for t in r["tasks"] if t[0] == "scan_part"]
        setup = f"{r['setup']:7.1f}" if r["tasks"] else f"{'-':>7}"
        print(f"{name:<26}{r['wall']:>8.1f}{base / r['wall']:>8.2f}x{setup}"
              f"{len(cuts):>5} {sum(cuts):>9.1f}{len(prts):>6} {sum(prts):>9.1f}"
              f"{r['merge']:>7.2f}{r['load']:>6.1f}  {r['bits']}")
        if cuts and prts and r["ranks"] == 1:   # (one rank runs cuts j = 1.., parts j = 0.. in order)
            jc, jp = max(range(len(cuts)), key=cuts.__getitem__), max(range(len(prts)),
                                                                   key=prts.__getitem__)
            print(f"{'':<26}longest cut {cuts[jc]:.1f} s (j = {jc + 1}), longest part "
                  f"{prts[jp]:.1f} s (j = {jp}, 0 the bottom of the spectrum); parts "
                  f"{min(prts):.1f}-{max(prts):.1f} s, mean {sum(prts) / len(prts):.1f} s")
        per_rank = {}
        for t in r["tasks"]:
            per_rank[t[2]] = per_rank.get(t[2], 0.0) + t[3]
        if len(per_rank) > 1:
            print(f"{'':<26}task CPU s by rank: " + ", ".join(
                f"{rk}: {v:.1f}" for rk, v in sorted(per_rank.items())))
    same = len({recs[k]["bits"] for k in args.ranks}) == 1
    print(f"decision, margin and eigenvalues bitwise the same on {args.ranks} ranks: {same}")
    one = recs[args.ranks[0]] if args.ranks[0] == 1 else None
    if one is not None:
        print("model of k ranks, the same parts (one-rank tasks' CPU s, each to the first "
              "free rank in order, + setup, bcast, merge; static i mod k in brackets): "
              + ", ".join(f"k = {k}: {model(one, k):.1f} s ({model(one, k, static):.1f})"
                          for k in (1, 2, 4, 8, 16)))
        from remote_trigger.analysis.output import write_json_atomic
        from remote_trigger.pywrap.runtime.environment import source

        stamp = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
                 "commit": (source()["commit"] or "unknown")[:7]}
        # every one-rank run's tasks (name, wall s, rank, CPU s), for a later look
        kept = os.path.join(cache_dir(), f"tasks_N{n}_parts{part}.json")
        write_json_atomic(kept, {"parts": one, "recorded": stamp})
        print(f"(its tasks: {kept})")
        # keep the one-rank records for the model of larger n
        if "whole" in recs:
            write_json_atomic(os.path.join(cache_dir(), f"records_N{n}.json"),
                              {"whole": recs["whole"], "parts": one, "recorded": stamp})
    return 0 if same else 1


def model_large():
    """The model of N = 10^4 from the one-rank records kept in the cache (not of
    10^5: ``bench_slice_cost`` measures its pieces there)."""
    runs = []
    for name in sorted(os.listdir(cache_dir())):
        if name.startswith("records_N"):
            with open(os.path.join(cache_dir(), name)) as fh:
                runs.append(json.load(fh))
    if runs:
        runs.sort(key=lambda r: r["parts"]["n"])
        used = ", ".join(f"n = {r['parts']['n']} ({r.get('recorded', {}).get('date', 'undated')}, "
                         f"{r.get('recorded', {}).get('commit', 'commit unknown')})" for r in runs)
        print(f"model of N = 10^4 (n = 28 800), k parts of n / k, from the one-rank runs "
              f"kept in the cache (power laws through the two largest): {used}; N = 10^5: "
              f"none here (bench_slice_cost measures it)")
        for nn, ks in ((28800, (1, 2, 16)),):
            for k in ks:
                t, parts = extrapolate(runs, nn, k)
                what = "; ".join(f"{key} {v:.3g} s (n^{a:.2f})" if key != "bcast" else
                                 f"bcast {v:.3g} s" for key, (v, a) in parts.items())
                print(f"  n = {nn}, k = {k}: {t:.0f} s  [{what}]")


if __name__ == "__main__":
    sys.exit(main())
