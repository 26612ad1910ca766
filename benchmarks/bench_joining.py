"""Benchmark: the tail of a task farm, free workers joining a running point.

An ensemble's tail is a packing's point running on one worker while the
other workers have no task left. With ``part_size`` set they join the
point's parts (:mod:`remote_trigger.pywrap.runtime.joining`). This runs that
tail: a farm (``pywrap.runtime.taskfarm.run_tasks(..., join=True)``) whose
one task is the verdict of one large point in parts, as a ramp's point is
decided (``pywrap.stages.common.decide_on_rank0`` on the task's
``MPI.COMM_SELF``; ``VerdictOptions(method='sliced', part_size=P)``), on
``mpirun -np 1+w`` for each number of workers w (rank 0 schedules; one
worker runs the task, the w - 1 others are free). It prints each run's wall
time of the task, the points the helpers joined, the CPU time of rank 0
(the scheduler, which polls for the helpers' and points' messages, every
5-200 ms: ``joining.POLL_BUSY``, ``POLL_IDLE``) and a fingerprint of the verdict (decision and eigenvalues, which
must be the same bits for every w).

The point is that of ``bench_parallel_point.py`` (the stored relaxed packing
of N disks, seed 1, at F_x = 1e-4; built once and cached).

    python benchmarks/bench_joining.py [--quick] [--n 6400] [--part-size 2300] [--workers 1 2]
"""
import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import hashlib
import json
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)


def point_task(args):
    """The farm's task: the verdict of the dump in parts; (wall s, fingerprint)."""
    from types import SimpleNamespace

    import numpy as np
    from mpi4py import MPI

    from remote_trigger.analysis.stability.verdict import VerdictOptions
    from remote_trigger.pywrap.stages.common import decide_on_rank0

    dump, part_size = args
    time.sleep(0.5)                      # (the free workers report to rank 0 first)
    t0 = time.perf_counter()
    res = decide_on_rank0(SimpleNamespace(comm=MPI.COMM_SELF), dump,
                          VerdictOptions(method="sliced", part_size=part_size))
    wall = time.perf_counter() - t0
    h = hashlib.sha256(np.ascontiguousarray(res.eigenvalues).tobytes()).hexdigest()[:16]
    return wall, f"{res.decision.name} {len(res.eigenvalues)} eigenvalues sha256 {h}"


def run(dump, part_size):
    """Inside ``mpirun``: the farm of one task; rank 0 prints a JSON line."""
    from mpi4py import MPI

    from remote_trigger.pywrap.runtime import taskfarm

    comm = MPI.COMM_WORLD
    c0 = time.process_time()
    res = taskfarm.run_tasks(comm, [(dump, part_size)], point_task, join=True)
    if comm.Get_rank() == 0:
        (_, (wall, fp)), = res
        print("RESULT " + json.dumps({"workers": comm.Get_size() - 1, "wall": wall,
                                      "fingerprint": fp, "scheduler_cpu": time.process_time() - c0,
                                      "joined": taskfarm.helped.get("points", 0)}), flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true",
                    help="N = 1600, parts of 600 (a smoke test)")
    ap.add_argument("--n", type=int, default=None, help="default 6400 (--quick: 1600)")
    ap.add_argument("--part-size", type=int, default=None,
                    help="default 2300 (--quick: 600): about n / 8")
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--run", nargs=2, metavar=("DUMP", "PART_SIZE"), help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.run:
        return run(a.run[0], int(a.run[1]))
    a.n = a.n or (1600 if a.quick else 6400)
    a.part_size = a.part_size or (600 if a.quick else 2300)
    from bench_parallel_point import state

    dump = state(a.n)
    mpirun = os.path.join(os.path.dirname(sys.executable), "mpirun")
    rows = []
    for w in a.workers:
        out = subprocess.run([mpirun, "-np", str(w + 1), sys.executable, __file__, "--run",
                              dump, str(a.part_size)], capture_output=True, text=True)
        line = [x for x in out.stdout.splitlines() if x.startswith("RESULT ")]
        if out.returncode or not line:
            sys.exit(f"the run on {w} worker(s) failed:\n{out.stdout[-2000:]}{out.stderr[-2000:]}")
        rows.append(json.loads(line[0][len("RESULT "):]))
        r = rows[-1]
        print(f"N = {a.n}, parts of {a.part_size}, {w} worker(s): the point {r['wall']:.1f} s, "
              f"points joined {r['joined']}, rank 0 (scheduler) CPU {r['scheduler_cpu']:.1f} s; "
              f"{r['fingerprint']}", flush=True)
    same = len({r["fingerprint"] for r in rows}) == 1
    base = rows[0]["wall"]
    print("speed-up against the first: " + ", ".join(
        f"{r['workers']} worker(s) {base / r['wall']:.2f}x" for r in rows))
    print("verdict and eigenvalues bitwise the same on every run: " + ("yes" if same else "NO"))
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
