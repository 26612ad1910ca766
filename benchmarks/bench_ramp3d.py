"""Benchmark: one ramp point of the default 3D scene beside the 2D one, and its memory.

Issue 29 (performance). Two scenes, measured side by side in one run:

* disks, N = 100: the default job's packing (``generate``, seed 1, the
  default relax protocol);
* spheres, N = 160: the default of ``paper --dim 3`` (``generate --dim 3
  --seed 1``, relaxed by ``relax``: FIRE, then Newton with the 3D Jacobian).

Each is generated and relaxed once (time printed). Then ramp points as the
ramp makes them (``stages.point.ramp_point``'s steps, timed one by one):
F_x = dF_x from the relaxed equilibrium (warm-up; its verified basis starts
the next decision), then F_x = 2 dF_x from that equilibrium, made
``--repeat`` times (medians reported), dF_x = 2.5e-4 (the paper job's
default for both). A point is:

* **equilibrium**: load the scene from the previous equilibrium (spheres:
  data file, ``run 0``, history written back from the dump), Newton from
  there (dense LU of K: 3N or 6N dof <= 1200), write the equilibrium files;
* **decision**: ``stability_of_dump`` as the ramp calls it: read the dump,
  K and rattlers, the dense M^-1 K, the certified decision started from the
  previous point's basis (most ramp steps); the decision from dgeev (no
  basis: a bisection point's fallback, or a ramp's first point) is timed
  beside it, with its LAPACK eigen-solve.

Memory, at the reported point's dump of each scene, each number from a
fresh process (``--memory``) that has read the dump, imported every module
of ``analysis.stability`` and made a first small LAPACK call (OpenBLAS
allocates its buffers then) before it measures:

* **tracemalloc peak**: the largest Python-visible allocation (NumPy and
  SciPy arrays included, LAPACK's internal workspace not) during the
  operation, above what was allocated before it;
* **peak RSS delta**: growth of the process's peak resident set size over
  the operation (``VmHWM`` of /proc/self/status, the high-water mark of the
  process's own address space; ``getrusage``'s ru_maxrss is not used: across
  fork + exec Linux carries the parent's peak into it, here the benchmark's
  with LAMMPS loaded), measured in a separate process without tracemalloc
  (its bookkeeping would count); everything the operation touched, LAPACK
  included, less what fitted into memory freed earlier by the same process.

The operations: the **Jacobian** (``stiffness_matrix``/``stiffness_matrix3d``
of the state: sparse K, 3N or 6N square; its own size = data + indices +
indptr) and the **decision** (``stability_of`` of the state from dgeev: K,
rattlers, dense M^-1 K, eigen-solve, verification, certified decision; the
dense matrix n x n float64 is the unit, the verdict's admission check
assumes 14 of them, ``verdict.DENSE_PEAK_MATRICES``).

    python benchmarks/bench_ramp3d.py [--repeat 3] [--quick]
"""
import os

# one BLAS thread next to LAMMPS, as the remote-trigger command line does
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import json
import subprocess
import sys
import tempfile
import time

DF_X = 2.5e-4
SCENES = ((2, 100), (3, 160))
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

from bench_step import _commit  # noqa: E402  (the source commit measured)


def relaxed(dim, n, seed, base):
    """Generate and relax the default packing of ``dim``; (data file, seconds, residual)."""
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RelaxConfig
    from remote_trigger.pywrap.stages.packing import generate, write_data

    out = os.path.join(base, f"d{dim}")
    os.makedirs(out, exist_ok=True)
    data = os.path.join(out, "p.data")
    write_data(generate(n, seed=seed, dim=dim), data)
    t0 = time.perf_counter()
    rel = stages.relax(RelaxConfig(datafile=data), out, quiet=True)
    return rel.datafile, time.perf_counter() - t0, rel.residual


def point(eng, cfg, start, F_x, prefix, dim, basis):
    """One ramp point, timed by part (the steps of ``stages.point.ramp_point``)."""
    from remote_trigger.analysis.stability.verdict import stability_of_dump
    from remote_trigger.pywrap.stages import equilibrium as eq
    from remote_trigger.pywrap.stages.common import load_equilibrium_scene, save_equilibrium

    t0, c0 = time.perf_counter(), time.process_time()
    load_equilibrium_scene(eng, cfg, start, F_x, dim)
    t1 = time.perf_counter()
    r, t_sim, rec = eq.equilibrate(eng, cfg, F_x, newton_first=True)
    t2 = time.perf_counter()
    save_equilibrium(eng, cfg, F_x, prefix)
    t3, c3 = time.perf_counter(), time.process_time()
    res = stability_of_dump(prefix + ".dump", basis=basis, allow_residual=True)
    t4, c4 = time.perf_counter(), time.process_time()
    cold = stability_of_dump(prefix + ".dump", allow_residual=True)
    t5 = time.perf_counter()
    assert cold.decision == res.decision, (cold.decision, res.decision)
    return dict(scene=t1 - t0, newton=t2 - t1, files=t3 - t2, decision=t4 - t3,
                start=res.start, dgeev=t5 - t4, eigen=cold.timing["eigen"],
                equilibrium=t3 - t0, residual=r, damped=t_sim,
                equilibrium_cpu=c3 - c0, decision_cpu=c4 - c3,
                newton_steps=max(0, sum(p == "newton" for p in rec.phase) - 1),
                verdict=res.decision, n_eig=res.eigenvalues.size, basis=res.basis)


def scene(dim, n, seed, repeat, base):
    """Relax once, then the warm-up point and ``repeat`` reported points."""
    import numpy as np

    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.stages.config import RampConfig

    data, t_relax, r_relax = relaxed(dim, n, seed, base)
    cfg = RampConfig(datafile=data, dF_x=DF_X, F_x=0.0)
    out = os.path.dirname(data)
    with Engine() as eng:
        first = point(eng, cfg, data, DF_X, os.path.join(out, "step1"), dim, None)
        rows = [point(eng, cfg, os.path.join(out, "step1.data"), 2 * DF_X,
                      os.path.join(out, f"step2_{k}"), dim, first["basis"])
                for k in range(repeat)]
    med = {k: float(np.median([r[k] for r in rows]))
           for k in ("scene", "newton", "files", "decision", "dgeev", "eigen", "equilibrium",
                     "residual", "newton_steps", "equilibrium_cpu", "decision_cpu")}
    med.update(dim=dim, n=n, relax=t_relax, relax_residual=r_relax, verdict=rows[0]["verdict"],
               start=rows[0]["start"], n_eig=rows[0]["n_eig"],
               dump=os.path.join(out, "step2_0.dump"),
               damped=max(r["damped"] for r in rows))
    return med


# ---------------------------------------------------------------- memory (own process)
def peak_rss():
    """Peak resident set size of this process's address space (bytes): VmHWM."""
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024
    raise OSError("no VmHWM in /proc/self/status")


def _warm_up():
    """Import every module the operations import lazily, and make the first BLAS and
    LAPACK calls (OpenBLAS allocates its buffers then): neither is counted."""
    import importlib
    import pkgutil

    import numpy as np
    import scipy.linalg
    import scipy.sparse.linalg  # noqa: F401

    import remote_trigger.analysis.stability as stab

    for m in pkgutil.iter_modules(stab.__path__):
        importlib.import_module(f"{stab.__name__}.{m.name}")
    a = np.random.default_rng(0).standard_normal((64, 64))
    scipy.linalg.eig(a)
    scipy.linalg.lu_factor(a)
    np.linalg.solve(a, a @ a)


def _measure(what, dump, traced):
    """Run in a fresh process: read ``dump``, then one operation; print its memory."""
    import numpy as np

    from remote_trigger.analysis.state.dumpfile import read_equilibrium
    from remote_trigger.analysis.state.state3d import State3D

    state = read_equilibrium(dump)
    spheres = isinstance(state, State3D)
    _warm_up()
    if what == "jacobian":
        from remote_trigger.analysis.stability import jacobian, jacobian3d

        op = (lambda: jacobian3d.stiffness_matrix3d(state)) if spheres else \
            (lambda: jacobian.stiffness_matrix(state))
    else:
        from remote_trigger.analysis.stability.verdict import stability_of

        op = lambda: stability_of(state)              # noqa: E731
    if traced:
        import tracemalloc

        tracemalloc.start()
        base = tracemalloc.get_traced_memory()[0]
        tracemalloc.reset_peak()
        out = op()
        peak = tracemalloc.get_traced_memory()[1] - base
        tracemalloc.stop()
        rss = None
    else:
        rss0 = peak_rss()
        out = op()
        rss = peak_rss() - rss0
        peak = None
    info = {"peak": peak, "rss": rss}
    if what == "jacobian":
        info.update(nbytes=int(out.data.nbytes + out.indices.nbytes + out.indptr.nbytes),
                    nnz=int(out.nnz), shape=int(out.shape[0]))
    else:
        info.update(n=int(np.asarray(out.eigenvalues).size), verdict=out.decision)
    print(json.dumps(info))


def memory(dump):
    """{'jacobian': {...}, 'decision': {...}} measured in fresh processes."""
    res = {}
    for what in ("jacobian", "decision"):
        res[what] = {}
        for traced in (True, False):
            p = subprocess.run([sys.executable, os.path.abspath(__file__), "--memory", what,
                                dump] + (["--traced"] if traced else []),
                               capture_output=True, text=True, check=True)
            res[what].update({k: v for k, v in json.loads(p.stdout.splitlines()[-1]).items()
                              if v is not None})
    return res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--quick", action="store_true", help="one reported point per scene")
    ap.add_argument("--memory", nargs=2, metavar=("WHAT", "DUMP"), help=argparse.SUPPRESS)
    ap.add_argument("--traced", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.memory:
        _measure(args.memory[0], args.memory[1], args.traced)
        return 0
    repeat = 1 if args.quick else args.repeat
    MB = 2.0 ** 20
    load0 = os.getloadavg()[0]
    with tempfile.TemporaryDirectory(prefix="bench_ramp3d_") as base:
        rows = [scene(dim, n, args.seed, repeat, base) for dim, n in SCENES]
        mem = [memory(r["dump"]) for r in rows]
    load = os.getloadavg()[0]
    print(f"bench_ramp3d: commit {_commit()}; one ramp point, disks N = 100 and spheres "
          f"N = 160 (default scenes, seed {args.seed}), F_x = {2 * DF_X:g} from the "
          f"equilibrium at {DF_X:g}; 1 MPI rank, 1 BLAS thread; medians of {repeat}; load "
          f"average {load0:.2f} at the start, {load:.2f} at the end (2 cores)")
    print(f"{'scene':>9} {'dof':>5} {'relax[s]':>8} {'newton':>6} {'scene':>6} "
          f"{'Newton':>7} {'files':>6} {'equil.':>7} {'decision':>8} {'point':>7} "
          f"{'dgeev':>7} {'eigen':>7} {'cpu eq.':>7} {'cpu dec':>7} {'residual':>8} "
          f"verdict   (times in ms)")
    for r in rows:
        name = f"{'spheres' if r['dim'] == 3 else 'disks'} {r['n']}"
        print(f"{name:>9} {r['n_eig']:5d} {r['relax']:8.1f} {r['newton_steps']:6.0f} "
              f"{r['scene'] * 1e3:6.1f} {r['newton'] * 1e3:7.1f} {r['files'] * 1e3:6.1f} "
              f"{r['equilibrium'] * 1e3:7.1f} {r['decision'] * 1e3:8.1f} "
              f"{(r['equilibrium'] + r['decision']) * 1e3:7.1f} {r['dgeev'] * 1e3:7.1f} "
              f"{r['eigen'] * 1e3:7.1f} {r['equilibrium_cpu'] * 1e3:7.1f} "
              f"{r['decision_cpu'] * 1e3:7.1f} {r['residual']:8.2g} {r['verdict']} "
              f"(from {r['start']})")
    two, three = rows
    ratio = {k: three[k] / two[k] for k in ("equilibrium", "decision", "equilibrium_cpu",
                                             "decision_cpu")}
    pt = ((three["equilibrium"] + three["decision"]) / (two["equilibrium"] + two["decision"]))
    print(f"3D / 2D: equilibrium {ratio['equilibrium']:.1f} x (CPU {ratio['equilibrium_cpu']:.1f}"
          f" x), decision {ratio['decision']:.1f} x (CPU {ratio['decision_cpu']:.1f} x), point "
          f"{pt:.1f} x; dof kept {three['n_eig']} / {two['n_eig']}")
    print("memory (fresh process per number, after reading the dump, the imports and a "
          "first LAPACK call; tracemalloc: Python-visible peak incl. NumPy/SciPy arrays; "
          "peak RSS: growth of VmHWM)")
    for r, m in zip(rows, mem):
        name = f"{'spheres' if r['dim'] == 3 else 'disks'} {r['n']}"
        j, d = m["jacobian"], m["decision"]
        dense = d["n"] ** 2 * 8
        print(f"  {name}: Jacobian {j['shape']} x {j['shape']}, nnz {j['nnz']}: K "
              f"{j['nbytes'] / MB:.2f} MB, tracemalloc peak {j['peak'] / MB:.2f} MB, peak RSS "
              f"+{j['rss'] / MB:.1f} MB; decision ({d['n']} x {d['n']} M^-1 K = "
              f"{dense / MB:.2f} MB dense): tracemalloc peak {d['peak'] / MB:.1f} MB = "
              f"{d['peak'] / dense:.1f} matrices, peak RSS +{d['rss'] / MB:.1f} MB = "
              f"{d['rss'] / dense:.1f} matrices (admission check assumes 14)")
    print("dof: eigenvalues (kept dofs); newton: Newton steps of the point; scene: load "
          "the previous equilibrium (spheres: + history from the dump); files: write "
          ".data/.dump/.json; decision: stability_of_dump from the previous point's basis "
          "(as the ramp); dgeev: the same from dgeev, eigen: its LAPACK eigen-solve; cpu: "
          "process CPU time of the equilibrium and of the decision (LAMMPS included: 1 rank, "
          "1 BLAS thread; on a loaded machine less inflated than the wall times)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
