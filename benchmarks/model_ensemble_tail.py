"""Model: the idle tail of an ensemble on k ranks, from the packing times it recorded.

What ranks that join a running point (docs/analysis.md, "One large point on
many cores") could give an ensemble. The job hands its tasks out largest N
first to the first free rank (``pywrap.runtime.taskfarm``); once fewer tasks
are left than ranks, the other ranks wait. For the packing wall times of a
stored run (``tasks/*.json``: ``result.wall``, the packing's relaxation and
both ramps, or the sum of its tasks' times where it ran in parts), and k
ranks, this prints:

* the queue's makespan (tasks in the job's order, each to the first free rank);
* the rank-time idle in it, 1 - sum(w) / (k makespan);
* sum(w) / k, the makespan if every idle rank joined a running packing with
  no loss (parallel efficiency 1): what joining could give at best; the
  gain, makespan / (sum(w) / k) = 1 / (1 - idle). A point on r ranks runs at
  an efficiency below 1 (0.88 on 2 free cores at N = 6400, about 0.6 modelled
  on 16 at N = 10^4: docs/results/analysis.md), so the real gain is smaller.

The wall of a packing finished by a resumed run is the time of that run
only (docs/ensemble.md): in the default folder the two N = 10^4 packings
record 2577 s and 10 351 s against hours of computing each, so there the
longest tasks, and the idle tail, are understated. A packing is one task here. Since the ramps run as tasks of their own, a
packing's two ramps can run side by side, so the queue's makespan is somewhat
shorter than this model's; the idle tail has the same cause.

    python benchmarks/model_ensemble_tail.py [RUN_FOLDER] [--ranks 2 4 8 16 32]

Default folder: the stored run docs/results/runs/N100_10000_s52.
"""
import argparse
import glob
import heapq
import json
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_RUN = os.path.join(HERE, "..", "docs", "results", "runs", "N100_10000_s52")


def packing_times(folder):
    """[(N, wall seconds)] of the finished packings of an ensemble folder, largest N first."""
    rows = []
    for path in sorted(glob.glob(os.path.join(folder, "tasks", "*.json"))):
        with open(path) as fh:
            rec = json.load(fh)
        wall = (rec.get("result") or {}).get("wall")
        if rec.get("status") == "complete" and wall is not None:
            rows.append((int(rec["task"]["n"]), float(wall)))
    if not rows:
        raise SystemExit(f"model_ensemble_tail: no finished packing with a wall time in "
                         f"{folder!r}/tasks")
    return sorted(rows, key=lambda r: -r[0])


def queue_makespan(walls, k):
    """Makespan of ``walls`` handed out in order, each to the first free of ``k`` ranks."""
    free = [0.0] * k
    for w in walls:
        heapq.heappush(free, heapq.heappop(free) + w)
    return max(free)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", nargs="?", default=DEFAULT_RUN)
    ap.add_argument("--ranks", type=int, nargs="+", default=[2, 4, 8, 16, 32])
    args = ap.parse_args(argv)
    if min(args.ranks) < 1:
        ap.error(f"--ranks must be >= 1, got --ranks {min(args.ranks)}")
    rows = packing_times(args.folder)
    walls = [w for _, w in rows]
    total, longest = sum(walls), max(walls)
    sizes = sorted({n for n, _ in rows})
    print(f"{os.path.normpath(args.folder)}: {len(walls)} packings (N = "
          f"{', '.join(map(str, sizes))}), sum of walls {total:.0f} s, longest {longest:.0f} s")
    print(f"{'k':>4} {'queue [s]':>10} {'idle':>6} {'sum/k [s]':>10} {'gain at best':>13}")
    for k in args.ranks:
        ms = queue_makespan(walls, k)
        print(f"{k:4d} {ms:10.0f} {1 - total / (k * ms):6.2f} {total / k:10.0f} "
              f"{ms / (total / k):13.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
