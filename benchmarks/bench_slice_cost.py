"""Benchmark: what a slice of the sliced scan costs at N = 10^4 and 10^5, whether it
can be certified there, and the wall of one point on k ranks built from it.

``bench_parallel_point`` measures whole points at N = 6400 and 10^4 and
extrapolates to N = 10^5 by power laws through those two sizes. This
benchmark measures at N = 10^5 the pieces a point on k ranks is made of,
and the same pieces at N = 10^4 in the same run:

* **The states.** The N = 10^4 point of ``bench_parallel_point`` (the
  stored packing of seed 1 at F_x = 1e-4). No relaxed packing of 10^5 disks
  is stored (relaxing one would take many hours), and the cost of a slice
  depends on the pattern and scale of K, not on the state being exactly an
  equilibrium: the N = 10^4 point is tiled ``--copies`` times side by side
  along the periodic x axis (``bench_scale.tiled_packing``: the copies, with
  their contact histories, are an equilibrium of the wider box force for
  force) and every diameter is scaled by 1 + ``--jitter`` xi (xi normal) to
  lift the copies' degenerate Bloch spectrum. The state is written as read
  (``run 0``), **not re-equilibrated**: forces of order k_eff jitter R
  remain. (Re-equilibrating by Newton was tried, from the tiled loaded
  point with jitter 1e-5 and from the tiled relaxed packing with jitter
  1e-6: at two copies it left a few disks on two contacts of overlap
  ~1e-8 R near the Coulomb limit, which raised ||W||_2 to 977 and 46-66
  (3.24 at N = 10^4); at N = 10^5 it took 12 min from the loaded point,
  and from the relaxed packing was stopped after 18 and 23 min, in the
  solver for the rolling modes' singular K and in damped dynamics.)
  A wide layer (10 x as wide as
  high) with the contact network of the N = 10^4 packing, not a packing of
  the ensemble's law. Cached under ``$REMOTE_TRIGGER_BENCH_CACHE`` (default
  ``~/.cache/remote_trigger``) ``/parallel_point``.
* **Measured, one rank, one BLAS thread, CPU seconds.** Assembling K and
  finding the rattlers; the verdict's setup on rank 0 (scaled parts, norms,
  bounds: ``classify_sliced`` up to its first task); at three places in the
  spectrum (a quarter, half and three quarters of the eigenvalues of S
  below): the bisection for a split point (``parts.split_point``, what a
  cut task starts with), the fuzz of its Sylvester count (the rigorous
  bound of ``inertia.count_below``; where it exceeds ``inertia.fuzz_limit``,
  as the scan does, that of the double-word ``count_below_dw``, with the
  float64 one beside it) beside the mean spacing of the
  eigenvalues there (from a second count 10 Delta above), and ``--slices``
  slices from there (``slices.ritz_slices``, what a scan is made of), or
  more up to the end of a chain where counts are left out (a chain's
  slices come at once, its time on its first: the slices after the last
  one read would cost nothing); those up to the first counted run left
  out of the cost as a warm-up; with the slices computed twice, the shifts
  moved off a tiny pivot, the double-word counts and the counts left out
  (``SlicedStats.reshifted``, ``.moved``, ``.dw_counts``,
  ``.deferred_counts``), or the reason the first cannot be certified; from them the
  cost of a slice per eigenvalue it advances, and how many eigenvalues of
  S the window 2 Delta holds there (Delta =
  10 ||W||_2, the window a cut's first boundary lies above its split point).
* **The model of k ranks, one part of n / k eigenvalues each** (P = k),
  where every place gave slices: setup + the problem's ``bcast`` + the
  longest cut task + the longest part task. A cut task: the bisection + a
  scan over 2 Delta and a slice. A part task: its n / k eigenvalues + the
  region of its own cut again and of the cut above (3 Delta and a slice),
  at the per-eigenvalue cost of the slowest place. The strips' decisions,
  the merge and a network's latency are left out. At N = 10^4 it is checked
  against the tasks ``bench_parallel_point`` measured (when its records are
  in the cache).

    python benchmarks/bench_slice_cost.py [--ranks 16 256] [--copies 10] [--slices 9]
"""
import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import json
import math
import pickle
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from bench_parallel_point import BCAST_LATENCY, BCAST_RATE, F_X  # noqa: E402
from bench_parallel_point import cache_dir, state  # noqa: E402

#: the places sampled, as fractions of the eigenvalues of S below them
FRACTIONS = (0.25, 0.5, 0.75)


def tiled_state(copies, jitter):
    """The dump of the tiled point (built once, then cached)."""
    from mpi4py import MPI

    from bench_scale import tiled_packing
    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.stages.common import load_relax_scene, save_equilibrium
    from remote_trigger.pywrap.stages.config import RampConfig

    src = state(10000)[:-len(".dump")] + ".data"
    prefix = os.path.join(cache_dir(), f"N{10000 * copies}_tiled_seed1_F{F_X:g}_j{jitter:g}")
    if not os.path.exists(prefix + ".dump"):
        t0 = time.perf_counter()
        start = prefix + ".in.data"
        tiled_packing(src, copies, start, jitter=jitter)
        cfg = RampConfig(datafile=start, F_x=F_X)
        with Engine(comm=MPI.COMM_SELF) as eng:
            load_relax_scene(eng, cfg, start, F_X, deck="in.ramp_step")
            eng.command("run 0")
            save_equilibrium(eng, cfg, F_X, prefix)
        os.unlink(start)
        print(f"(built the tiled N = {10000 * copies} state in {time.perf_counter() - t0:.0f} s: "
              f"{prefix}.dump)", flush=True)
    return prefix + ".dump"


class _Grabbed(Exception):
    """Raised by the map that takes the verdict's problem at its first task."""


def measure(dump, nslices, part_size=1000):
    """The pieces of one point (module docstring), as a dict."""
    import numpy as np

    from remote_trigger.analysis.stability.sliced import (SlicedStats, classify_sliced,
                                                          scaled_parts)
    from remote_trigger.analysis.stability.sliced.inertia import Shifts, fuzz_limit
    from remote_trigger.analysis.stability.sliced.numerics import SliceFailure
    from remote_trigger.analysis.stability.sliced.parts import split_point
    from remote_trigger.analysis.stability.sliced.slices import Position, ritz_slices
    from remote_trigger.analysis.stability.system import reduced_system
    from remote_trigger.analysis.state.dumpfile import read_equilibrium

    c0 = time.process_time()
    system = reduced_system(read_equilibrium(dump))
    rec = {"assembly": time.process_time() - c0, "n": int(system.n)}
    got = {}

    def grab(fn, tasks):
        got["cpu"], got["problem"] = time.process_time(), tasks[0].problem
        raise _Grabbed

    c0 = time.process_time()
    try:
        classify_sliced(system.K, system.mass, part_size=part_size, map_tasks=grab)
    except _Grabbed:
        pass
    rec["setup"] = got["cpu"] - c0
    pb = got["problem"]
    rec.update(normW=pb.ctx.normW, Delta=pb.ctx.Delta, problem_bytes=len(pickle.dumps(
        scaled_parts(system.K, system.mass), protocol=pickle.HIGHEST_PROTOCOL)), places=[])
    for f in FRACTIONS:
        c0 = time.process_time()
        shifts = Shifts(pb.S, fuzz_limit(pb.ctx.normS, rec["n"]))
        x, cnt, fz = split_point(shifts, pb.lo0, pb.hi0, round(f * rec["n"]), part_size // 10)
        split = time.process_time() - c0
        dw = shifts.dw_counts > 0
        # the float64 count's own fuzz there (the count kept is double-word above the limit)
        fz64 = shifts.count(x)[1]
        # the local spacing of the eigenvalues of S: counts 10 Delta apart
        hi, _ = shifts.count_below(x + 10 * pb.ctx.Delta)
        place = {"fraction": f, "x": x, "split": split, "fuzz": fz, "fuzz64": fz64,
                 "dw": dw,
                 "spacing": 10 * pb.ctx.Delta / max(1, hi - cnt), "slices": [],
                 "advanced": [], "failure": ""}
        pos = Position(x, cnt, fz, np.random.default_rng([12345, round(1000 * f)]))
        st = SlicedStats()
        slices = ritz_slices(pb.S, pb.ctx.W, 60, pb.ctx.normS, pos, st)
        # where counts are left out, a chain's slices come at once (its time on
        # its first slice): go on to the end of a chain, a slice after which
        # no count is left out (``pos.deferred`` 0), so no work is unread
        ends = []
        try:
            while len(ends) < nslices or not ends[-1]:
                c0, n0 = time.process_time(), pos.count
                next(slices)
                place["slices"].append(time.process_time() - c0)
                place["advanced"].append(pos.count - n0)
                ends.append(pos.deferred == 0)
        except SliceFailure as exc:
            place["failure"] = str(exc)
        place["moved"], place["reshifted"] = st.moved, st.reshifted
        place["dw_counts"], place["deferred"] = st.dw_counts, st.deferred_counts
        # the slices up to the first end left out: a warm-up (the first run)
        first = ends.index(True) + 1 if True in ends else len(ends)
        if len(place["slices"]) > first:
            place["per_eig"] = sum(place["slices"][first:]) / sum(place["advanced"][first:])
        rec["places"].append(place)
    return rec


def model(rec, k):
    """Predicted wall of the point on k ranks, parts of n / k (module docstring):
    (total, its terms)."""
    c = max(p["per_eig"] for p in rec["places"])
    win = max(2 * rec["Delta"] / p["spacing"] for p in rec["places"])
    split = max(p["split"] for p in rec["places"])
    cut = split + (win + 60) * c
    part = (rec["n"] / k + 1.5 * win + 60) * c
    send = math.ceil(math.log2(k)) * (BCAST_LATENCY + rec["problem_bytes"] / BCAST_RATE)
    return rec["setup"] + send + cut + part, {"setup": rec["setup"], "bcast": send,
                                              "cut": cut, "part": part, "window": win}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    ap.add_argument("--ranks", type=int, nargs="+", default=[16, 256])
    ap.add_argument("--copies", type=int, default=10,
                    help="copies of the N = 10^4 packing (default 10: N = 10^5)")
    ap.add_argument("--jitter", type=float, default=1e-6,
                    help="relative jitter of the diameters (default 1e-6)")
    ap.add_argument("--slices", type=int, default=9,
                    help="slices at each place, at least (default 9)")
    args = ap.parse_args(argv)
    from remote_trigger.pywrap.runtime.environment import source

    dumps = [(10000, state(10000)), (10000 * args.copies, tiled_state(args.copies, args.jitter))]
    print(f"bench_slice_cost: commit {(source()['commit'] or 'unknown')[:7]}, "
          f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; {os.cpu_count()} cores, "
          f"load {os.getloadavg()[0]:.1f} at the start; one rank, one BLAS thread; CPU seconds")
    recs = []
    for N, dump in dumps:
        rec = measure(dump, args.slices)
        recs.append(rec)
        what = "stored packing, seed 1, F_x = %g" % F_X if N == 10000 else \
            f"{args.copies} copies of that point, jitter {args.jitter:g}, not re-equilibrated"
        print(f"N = {N} ({what}): n = {rec['n']}; assembly {rec['assembly']:.1f} s, "
              f"setup {rec['setup']:.1f} s; ||W||_2 = {rec['normW']:.3g}, Delta = "
              f"{rec['Delta']:.3g}; problem {rec['problem_bytes'] / 2**20:.0f} MiB")
        for p in rec["places"]:
            what = [f"split point {p['split']:.1f} s, its inertia fuzz {p['fuzz']:.3g}"
                    + (f" (double-word; float64 {p['fuzz64']:.3g})" if p["dw"] else "")
                    + f", mean spacing of the eigenvalues there {p['spacing']:.3g}"]
            if p["slices"]:
                what.append("slices " + " ".join(f"{v:.1f}" for v in p["slices"])
                            + " s advancing " + " ".join(str(v) for v in p["advanced"])
                            + " eigenvalues" + f" ({p.get('reshifted', 0)} computed twice, "
                            f"{p.get('moved', 0)} shifts moved, {p.get('dw_counts', 0)} "
                            f"double-word counts, {p.get('deferred', 0)} counts left out)")
            if "per_eig" in p:
                what.append(f"{p['per_eig'] * 1e3:.1f} ms per eigenvalue; 2 Delta holds "
                            f"{2 * rec['Delta'] / p['spacing']:.0f}")
            if p["failure"]:
                what.append(f"no certified slice: {p['failure']}")
            line = f"  {p['fraction']:.2f} of S below (x = {p['x']:.6g}): " + "; ".join(what)
            print(line)
    for N, rec in zip((d[0] for d in dumps), recs):
        if not all("per_eig" in p for p in rec["places"]):
            print(f"model N = {N}: none (a place without two certified slices)")
            continue
        for k in args.ranks:
            if rec["n"] / k < 600:          # (parts of fewer than 10 slices)
                continue
            t, terms = model(rec, k)
            print(f"model N = {N}, k = {k} ({rec['n'] / k:.0f} per part): {t:.0f} s = "
                  + " + ".join(f"{key} {v:.1f}" for key, v in terms.items() if key != "window")
                  + f" (2 Delta holds {terms['window']:.0f})")
    base = recs[0]
    one = os.path.join(cache_dir(), "records_N10000.json")
    if os.path.exists(one):
        with open(one) as fh:
            r = json.load(fh)["parts"]
        cuts = [t[3] for t in r["tasks"] if t[0] == "find_cut"]
        parts = [t[3] for t in r["tasks"] if t[0] == "scan_part"]
        P = len(parts)
        if all("per_eig" in p for p in base["places"]):
            t, terms = model(base, P)
            print(f"check at N = 10^4, parts of {r['part_size']} (bench_parallel_point's one-rank "
                  f"run kept in the cache): measured longest cut {max(cuts):.1f} s, longest "
                  f"part {max(parts):.1f} s, setup {r['setup']:.1f} s; this model at k = {P}: "
                  f"cut {terms['cut']:.1f} s, part {terms['part']:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
