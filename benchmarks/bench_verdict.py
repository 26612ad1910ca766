"""Benchmark: the sliced whole-spectrum verdict against the dense certified decision
on every point of fine ramps (issue 26: the validation of the large-N verdict).

For each seed at each N: generate a packing (the ``ensemble`` generator), relax it
with the default protocol, ramp F_x at every friction of ``--mu`` with fixed steps
``--dF-x`` and bisection to ``--tol`` (every equilibrium kept), then decide every
point (steps and bisection) twice from the same K and M (rattlers removed):

* dense: :func:`analysis.stability.exceptional.classify_spectrum` of the dense
  M^-1 K (dgeev, the reference up to 3000 dofs);
* sliced: :func:`analysis.stability.sliced.classify_sliced` (what the ramp uses
  above 3000 dofs).

A **disagreement** is a point certified complex by one and certified real by the
other; an undecided answer is none, and is listed with its reason. Each ramp's
comparison is stored in ``--out`` (``N<n>_s<seed>_mu<mu>.json``), so a re-run
skips what is done (the relaxations and ramps resume as well).

    python benchmarks/bench_verdict.py [--n 100] [--seeds 1 2 3] [--mu 1 0.8]
                                       [--dF-x 1e-3] [--tol 1e-6] [--out DIR] [--quick]

``make bench`` runs the defaults (6 ramps at N = 100, ~200 points); the
validation in docs/results/analysis.md ran more seeds (its command is given
there). ``--quick``: N = 40, seed 1, mu0 only.
"""
import os

# one BLAS thread, as the remote-trigger command line does
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import atexit
import glob
import json
import statistics
import shutil
import tempfile
import time


def _ramp(n, seed, mu, dF_x, tol, base):
    """Relax (once per packing) and ramp at friction mu; returns the ramp folder."""
    from mpi4py import MPI

    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RampConfig, RelaxConfig
    from remote_trigger.pywrap.stages.packing import generate, write_data

    pk = os.path.join(base, f"N{n}_s{seed}")
    relaxed = os.path.join(pk, "relax", "equilibrium.data")
    if not os.path.exists(relaxed):
        os.makedirs(pk, exist_ok=True)
        data = os.path.join(pk, "p.data")
        write_data(generate(n, seed=seed), data)
        stages.relax(RelaxConfig(datafile=data), pk, comm=MPI.COMM_SELF, quiet=True)
    out = os.path.join(pk, f"ramp_mu{mu:g}")
    cfg = RampConfig(datafile=relaxed, mu=float(mu), dF_x=dF_x, tol=tol)
    stages.ramp(cfg, out, comm=MPI.COMM_SELF, quiet=True, resume=True)
    return out


def _compare(dump):
    """Both decisions of one equilibrium dump, a dict: ``dense`` and ``sliced``
    (the Decision codes: 1 complex, 0 real, -1 undecided), their reasons when undecided,
    the strip sizes, ``n`` and the CPU time of each decision."""
    from remote_trigger.analysis.stability import eigen, exceptional
    from remote_trigger.analysis.stability.decision import Decision
    from remote_trigger.analysis.stability.system import reduced_system
    from remote_trigger.analysis.stability.sliced import SlicedStats, classify_sliced
    from remote_trigger.analysis.state.dumpfile import read_equilibrium

    system = reduced_system(read_equilibrium(dump))
    Kr, mr = system.K, system.mass
    t0 = time.process_time()
    dense = exceptional.classify_spectrum(eigen.dynamical_matrix(Kr, mr).toarray())
    t1 = time.process_time()
    st = SlicedStats()
    sliced = classify_sliced(Kr, mr, stats=st)
    t2 = time.process_time()
    return {"dump": os.path.basename(dump), "n": int(Kr.shape[0]),
            "dense": int(dense.decision), "sliced": int(sliced.decision),
            "reason": "" if sliced.decision is not Decision.UNDECIDED else str(sliced.reason),
            "dense_reason": "" if dense.decision is not Decision.UNDECIDED
            else str(dense.reason),
            "strips": {str(k): int(v) for k, v in st.strips.items()},
            "t_dense": t1 - t0, "t_sliced": t2 - t1}


def compare_ramp(folder, cache):
    """Every point of one ramp folder compared (cached in ``cache``)."""
    if os.path.exists(cache):
        with open(cache) as fh:
            return json.load(fh)
    dumps = sorted(glob.glob(os.path.join(folder, "ramp", "*.dump")))
    rows = [_compare(d) for d in dumps]
    tmp = cache + ".part"
    with open(tmp, "w") as fh:
        json.dump(rows, fh)
    os.replace(tmp, cache)
    return rows


def _code(v):
    """A stored decision as its Decision: a code, or the True / False / None of
    caches written before the codes."""
    from remote_trigger.analysis.stability.decision import Decision

    return Decision.UNDECIDED if v is None else Decision.of(int(v))


def summary(rows):
    """Counts of one set of compared points."""
    from remote_trigger.analysis.stability.decision import Decision

    d = [(_code(r["dense"]), _code(r["sliced"])) for r in rows]
    dis = [r for r, (a, b) in zip(rows, d) if Decision.UNDECIDED not in (a, b) and a != b]
    return {"points": len(rows),
            "complex": sum(a is Decision.COMPLEX for a, _ in d),
            "real": sum(a is Decision.REAL for a, _ in d),
            "dense_undecided": sum(a is Decision.UNDECIDED for a, _ in d),
            "disagree": len(dis), "disagreements": [r["dump"] for r in dis],
            "sliced_undecided": [(r["dump"], r["reason"]) for r, (_, b) in zip(rows, d)
                                 if b is Decision.UNDECIDED],
            "multi_strips": sum(any(int(k) >= 2 for k in r["strips"]) for r in rows),
            "n": sorted({r["n"] for r in rows}),
            "t_dense": statistics.median(r["t_dense"] for r in rows) if rows else float("nan"),
            "t_sliced": statistics.median(r["t_sliced"] for r in rows) if rows else float("nan")}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[100])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--mu", type=float, nargs="+", default=[1.0, 0.8])
    ap.add_argument("--dF-x", dest="dF_x", type=float, default=1e-3)
    ap.add_argument("--tol", type=float, default=1e-6)
    ap.add_argument("--quick", action="store_true", help="N = 40, seed 1, mu0 only")
    ap.add_argument("--out", default=None, help="work folder (default: a temp dir); a "
                                                "re-run with the same folder skips what is done")
    args = ap.parse_args(argv)
    if args.quick:
        args.n, args.seeds, args.mu = [40], [1], [1.0]
    base = args.out or tempfile.mkdtemp(prefix="bench_verdict_")
    if args.out is None:          # (the temporary folder was left behind)
        atexit.register(shutil.rmtree, base, True)
    t_start = time.perf_counter()
    print(f"bench_verdict: sliced vs dense on every ramp point; dF_x = {args.dF_x:g}, "
          f"tol = {args.tol:g}; work folder {base}", flush=True)
    print(f"{'N':>5} {'seed':>4} {'mu':>4} {'n':>11} {'points':>6} {'cx/real':>8} "
          f"{'dense und':>9} {'disagree':>8} {'sliced und':>10} {'strips>=2':>9} "
          f"{'t dense':>8} {'t sliced':>8}", flush=True)
    everything = []
    for n in args.n:
        for seed in args.seeds:
            for mu in args.mu:
                try:
                    folder = _ramp(n, seed, mu, args.dF_x, args.tol, base)
                except Exception as exc:   # noqa: BLE001 - one packing does not stop the rest
                    print(f"{n:5d} {seed:4d} {mu:4g}  no ramp: {type(exc).__name__}: {exc}",
                          flush=True)
                    continue
                rows = compare_ramp(folder, os.path.join(base, f"N{n}_s{seed}_mu{mu:g}.json"))
                everything.extend(rows)
                s = summary(rows)
                nn = f"{s['n'][0]}-{s['n'][-1]}" if s["n"] else "-"
                print(f"{n:5d} {seed:4d} {mu:4g} {nn:>11} {s['points']:6d} "
                      f"{s['complex']:>3d}/{s['real']:<4d} {s['dense_undecided']:9d} "
                      f"{s['disagree']:8d} {len(s['sliced_undecided']):10d} "
                      f"{s['multi_strips']:9d} {s['t_dense']:8.3f} {s['t_sliced']:8.3f}",
                      flush=True)
                for dump, why in s["sliced_undecided"]:
                    print(f"{'':11}sliced undecided at {dump}: {why}")
                for dump in s["disagreements"]:
                    print(f"{'':11}DISAGREEMENT at {dump}")
    s = summary(everything)
    print(f"total: {s['points']} points (dense: {s['complex']} complex, {s['real']} real, "
          f"{s['dense_undecided']} undecided), disagreements: {s['disagree']}, sliced "
          f"undecided: {len(s['sliced_undecided'])}, points with a strip of 2 or more "
          f"eigenvalues: {s['multi_strips']}; median CPU per point dense {s['t_dense']:.3f} s, "
          f"sliced {s['t_sliced']:.3f} s; wall {time.perf_counter() - t_start:.0f} s")
    print("disagreement: one decision certified complex, the other certified real (an "
          "undecided answer is none); times: process CPU time of each decision alone, K "
          "assembled once")
    return 1 if s["disagree"] else 0


if __name__ == "__main__":
    raise SystemExit(main())
