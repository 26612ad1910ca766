"""Benchmark: cost of one ramp point against the system size N (issue 15).

For each N: generate a packing (the ``ensemble`` generator, seed 1), relax it
with the default protocol (time printed), then make one ramp point at
F_x = dF_x from the relaxed equilibrium and a second at 2 dF_x from the
first (the one reported; the first warms up), as the ramp does: load the scene,
re-equilibrate (Newton first; dense LU up to ``DENSE_NEWTON_MAX`` = 1200 dof,
sparse LU above), write the equilibrium files, and the certified decision:

* N <= 400: the ramp's dense path (``analysis.stability.stability_of_dump``:
  all 3N eigenvalues and the certified decision on the whole spectrum);
* N > 400: the sparse path, ``analysis.exceptional.classify_projected`` on
  the k = 12 eigenvalues of M^-1 K nearest a shift sigma (the shift at
  which the ramp last saw the pair; here the coalescing pair's median
  position measured on the N = 100 ensemble, Re lambda_c = 0.094
  lambda_max, with lambda_max from ARPACK). The dense path's eigen-solve
  is timed too up to N = 400 and extrapolated as n^3 above.

Above ``--relax-max`` (default 400) a relaxation takes too long here
(N = 1600: ~30 min on one loaded core); there the point is assembled from
measured parts instead: a generated, unrelaxed packing of N disks in
LAMMPS (scene load, one Newton iteration's engine part: scatter, ``run
1``, gather; the equilibrium files), and a jittered-lattice State of the
same N (the analyzer's test packing, contacts at and near the Coulomb
limit) for K, the sparse LU factorisation and solve of a Newton step (of K
+ 1e-8 max|K_ii| I: the lattice is no equilibrium and its K is singular)
and the certified decision; the
Newton iterations per point are those measured at the largest relaxed N.

Prints per N: dof, relax time, Newton steps and time, files, decision
(dense or sparse), total per point, and the point cost multiplied into a
fine ramp (F_x^c / dF_x + 12 points with the default ensemble's median
F_x^c at that N, extrapolated above N = 400) and an adaptive one (38
points, docs/driver.md).

    python benchmarks/bench_scale.py [--sizes 100 400 1600 10000] [--quick]
"""
import os

# one BLAS thread next to LAMMPS, as the remote-trigger command line does
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import tempfile
import time

#: median position of the coalescing pair, Re lambda_c / lambda_max (N = 100 ensemble)
PAIR_RE_REL = 0.094
#: points of an adaptive ramp of the default job (26 steps + 12 bisections)
ADAPTIVE_POINTS = 38
#: median F_x^c(mu0) of the default ensemble (docs/ensemble.md) at N = 100 and
#: 400, and the exponent of their ratio, used to extrapolate to larger N
FC_MEDIAN = {100: 0.0256, 400: 0.0049}
FC_EXPONENT = -1.19


def fine_points(n, dF_x):
    """Points of a fine ramp to the median F_x^c at N = n (+ 12 bisections)."""
    fc = FC_MEDIAN.get(n, FC_MEDIAN[100] * (n / 100.0) ** FC_EXPONENT)
    return fc / dF_x + 12


def one_point(n, seed, dF_x, base):
    """Relax a packing of n disks and make two ramp points; returns the second's timings."""
    from mpi4py import MPI

    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.config import RampConfig, RelaxConfig
    from remote_trigger.pywrap.packing import generate, write_data

    out = os.path.join(base, f"N{n}")
    os.makedirs(out, exist_ok=True)
    data = os.path.join(out, "p.data")
    write_data(generate(n, seed=seed), data)
    t0 = time.perf_counter()
    rel = stages.relax(RelaxConfig(datafile=data), out, comm=MPI.COMM_SELF, quiet=True)
    row = {"n": n, "dof": 3 * n, "relax": time.perf_counter() - t0, "phi": rel.packing_fraction}
    cfg = RampConfig(datafile=rel.datafile, dF_x=dF_x, F_x=0.0)
    start = rel.datafile
    # two ramp steps, F_x = dF_x then 2 dF_x, each from the previous
    # equilibrium; the first warms up (imports, first LAMMPS instance), the
    # second is reported
    for k in (1, 2):
        row.update(_point(cfg, start, k * dF_x, os.path.join(out, f"step{k}")))
        start = os.path.join(out, f"step{k}.data")
    return row


def _point(cfg, start, F_x, prefix):
    """One ramp point: scene, Newton, files, certified decision (timings)."""
    import numpy as np
    import scipy.sparse.linalg as spla
    from mpi4py import MPI

    from remote_trigger.analysis import eigen, exceptional
    from remote_trigger.analysis.analyze import analyze
    from remote_trigger.analysis.jacobian import remove_dofs
    from remote_trigger.analysis.stability import stability_of_dump
    from remote_trigger.analysis.state import read_dump
    from remote_trigger.pywrap import equilibrium as eq
    from remote_trigger.pywrap.engine import Engine
    from remote_trigger.pywrap.stage_common import load_relax_scene, save_equilibrium

    c0 = time.process_time()
    with Engine(comm=MPI.COMM_SELF) as eng:
        t0 = time.perf_counter()
        load_relax_scene(eng, cfg, start, F_x, deck="in.ramp_step")
        n = eng.gather_state().n
        t1 = time.perf_counter()
        r, _, rec = eq.equilibrate(eng, cfg, F_x, newton_first=True)
        t2 = time.perf_counter()
        save_equilibrium(eng, cfg, F_x, prefix)
        t3 = time.perf_counter()
    row = dict(scene=t1 - t0, newton=t2 - t1, files=t3 - t2, residual=r,
               newton_steps=max(0, sum(p == "newton" for p in rec.phase) - 1),
               path="sparse" if 3 * n > eq.DENSE_NEWTON_MAX else "dense")
    if 3 * n <= eq.DENSE_NEWTON_MAX:
        t0 = time.perf_counter()
        res = stability_of_dump(prefix + ".dump")
        row.update(decision=time.perf_counter() - t0, eigen=res.timing["eigen"],
                   verdict=res.decision, n_eig=res.eigenvalues.size)
    else:
        t0 = time.perf_counter()
        st = read_dump(prefix + ".dump", require_contacts=False)
        ana = analyze(st, eigenvalues=False, decide=False)
        Kr, mr = remove_dofs(ana.K, ana.mass, ana.rattlers.keep_dofs)
        A = eigen.dynamical_matrix(Kr, mr)
        t1, c1 = time.perf_counter(), time.process_time()
        lam_max = float(abs(spla.eigs(A, k=1, which="LM", return_eigenvectors=False)[0]))
        t2, c2 = time.perf_counter(), time.process_time()
        dec, _ = exceptional.classify_projected(A, PAIR_RE_REL * lam_max, k=12)
        t3 = time.perf_counter()
        verdict = {True: "complex", False: "real", None: "undecided"}[dec.complex_present]
        row.update(decision=(t1 - t0) + (t3 - t2), eigen=dec.timing.get("eigen", np.nan),
                   lam_max_time=t2 - t1, lam_max_cpu=c2 - c1, verdict=verdict + " (12 nearest the shift)",
                   n_eig=12)
    row["point"] = row["scene"] + row["newton"] + row["files"] + row["decision"]
    row["point_cpu"] = time.process_time() - c0 - row.get("lam_max_cpu", 0.0)
    return row


def synthetic_point(n, seed, base, newton_steps):
    """Measured parts of one ramp point at N = n without a relaxed packing (see above)."""
    import sys

    import numpy as np
    import scipy.sparse.linalg as spla
    from mpi4py import MPI

    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    from tests.analysis.builders import random_packing

    from remote_trigger.analysis import eigen, exceptional
    from remote_trigger.analysis.jacobian import find_rattlers, remove_dofs, stiffness_matrix
    from remote_trigger.pywrap import equilibrium as eq
    from remote_trigger.pywrap.config import RampConfig
    from remote_trigger.pywrap.engine import Engine
    from remote_trigger.pywrap.packing import generate, write_data
    from remote_trigger.pywrap.stage_common import load_relax_scene, save_equilibrium

    out = os.path.join(base, f"N{n}")
    os.makedirs(out, exist_ok=True)
    data = os.path.join(out, "p.data")
    write_data(generate(n, seed=seed), data)
    cfg = RampConfig(datafile=data, F_x=0.0)
    with Engine(comm=MPI.COMM_SELF) as eng:
        t0 = time.perf_counter()
        load_relax_scene(eng, cfg, data, 0.0, deck="in.ramp_step")
        eng.unfix(*eq.DAMPING_FIXES, *eq.INTEGRATOR_FIXES)
        st0 = eng.gather_state()
        t1 = time.perf_counter()
        for _ in range(2):                      # the second is timed
            t2 = time.perf_counter()
            eng.scatter("x", st0.positions)
            eng.scatter("v", np.zeros((st0.n, 2)))
            eng.scatter("omega", np.zeros(st0.n))
            eng.run(1, pre=True)
            eng.scatter("v", np.zeros((st0.n, 2)))
            eng.scatter("omega", np.zeros(st0.n))
            eq.residual_of(eng.gather_state())
            t3 = time.perf_counter()
        save_equilibrium(eng, cfg, 0.0, os.path.join(out, "point"))
        t4 = time.perf_counter()
    side = int(round(np.sqrt(n)))
    st = random_packing(seed, nx=side, ny=side)
    t5 = time.perf_counter()
    K = stiffness_matrix(st)
    t6 = time.perf_counter()
    # the regular Newton solve: SuperLU of K on its live dofs and one solve. The
    # jittered lattice (capped and beyond-cap contacts, not an equilibrium) makes K
    # singular; a near-equilibrium K is not, so K + 1e-8 max|K_ii| I is factorised
    import scipy.sparse as sp

    live = np.flatnonzero(np.diff(K.tocsr().indptr) > 0)
    Kl = K.tocsr()[live][:, live].tocsc()
    Kl = (Kl + 1e-8 * float(np.max(np.abs(Kl.diagonal()))) * sp.identity(live.size,
                                                                        format="csc")).tocsc()
    spla.splu(Kl).solve(np.random.default_rng(seed).normal(size=live.size))
    t7 = time.perf_counter()
    rat = find_rattlers(st)
    Kr, mr = remove_dofs(K, st.mass_diagonal(), rat.keep_dofs)
    A = eigen.dynamical_matrix(Kr, mr)
    lam_max = float(abs(spla.eigs(A, k=1, which="LM", return_eigenvectors=False)[0]))
    t8 = time.perf_counter()
    dec, _ = exceptional.classify_projected(A, PAIR_RE_REL * lam_max, k=12)
    t9 = time.perf_counter()
    verdict = {True: "complex", False: "real", None: "undecided"}[dec.complex_present]
    iteration = (t3 - t2) + (t6 - t5) + (t7 - t6)
    row = dict(n=st.n, dof=3 * st.n, relax=float("nan"), phi=float("nan"), scene=t1 - t0,
               newton=newton_steps * iteration, newton_steps=newton_steps,
               files=t4 - t3, decision=t9 - t8, lam_max_time=t8 - t7, path="sparse",
               verdict=verdict + " (12 nearest the shift; synthetic packing)",
               parts=dict(engine_iteration=t3 - t2, K=t6 - t5, solve=t7 - t6))
    row["point"] = row["scene"] + row["newton"] + row["files"] + row["decision"]
    row["point_cpu"] = float("nan")
    return row


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[100, 400, 1600, 10000])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--dF-x", dest="dF_x", type=float, default=2.5e-4)
    ap.add_argument("--quick", action="store_true", help="N = 100 and 400 only")
    ap.add_argument("--relax-max", dest="relax_max", type=int, default=400,
                    help="largest N relaxed; above it the point is assembled from parts")
    ap.add_argument("--out", default=None, help="keep outputs here (default: temp dir)")
    args = ap.parse_args(argv)
    sizes = [n for n in args.sizes if n <= 400] if args.quick else args.sizes
    base = args.out or tempfile.mkdtemp(prefix="bench_scale_")
    rows = []
    for n in sizes:
        if n <= args.relax_max:
            rows.append(one_point(n, args.seed, args.dF_x, base))
        else:
            steps = max((r["newton_steps"] for r in rows), default=4)
            rows.append(synthetic_point(n, args.seed, base, steps))
        r = rows[-1]
        print(f"N = {n}: relax {r['relax']:.1f} s, point {r['point']:.3f} s "
              f"({r['path']} Newton, {r['verdict']})", flush=True)
    e100 = next((r["eigen"] for r in rows if r["n"] == 100), None)
    print(f"\none ramp point vs N (seed {args.seed}, the step F_x = {args.dF_x:g} -> "
          f"{2 * args.dF_x:g}; one core; times in s)")
    print(f"{'N':>6} {'dof':>6} {'relax':>8} {'newton':>6} {'t_newton':>8} {'scene+files':>11} "
          f"{'decision':>9} {'point':>8} {'cpu':>8} {'fine ramp':>10} {'adaptive':>9}  "
          f"decision path")
    for r in rows:
        what = ("dense: all eigenvalues, certified" if r["path"] == "dense" else
                f"sparse: 12 nearest sigma = {PAIR_RE_REL} lambda_max, certified "
                f"(lambda_max by ARPACK {r['lam_max_time']:.2f} s, not counted)")
        print(f"{r['n']:6d} {r['dof']:6d} {r['relax']:8.1f} {r['newton_steps']:6d} "
              f"{r['newton']:8.3f} {r['scene'] + r['files']:11.3f} {r['decision']:9.3f} "
              f"{r['point']:8.3f} {r['point_cpu']:8.3f} "
              f"{r['point'] * fine_points(r['n'], args.dF_x):10.0f} "
              f"{r['point'] * ADAPTIVE_POINTS:9.0f}  {what}")
        if "parts" in r:
            p = r["parts"]
            print(f"{'':6} assembled: {r['newton_steps']} Newton iterations x (engine "
                  f"{p['engine_iteration']:.3f} + K {p['K']:.3f} + sparse LU solve "
                  f"{p['solve']:.3f}); relax not run (relax-max {args.relax_max})")
        if r["path"] == "sparse" and e100:
            dense = e100 * (r["dof"] / 300.0) ** 3
            print(f"{'':6} dense eigen-solve at this size, extrapolated as n^3 from N = 100: "
                  f"{dense:.0f} s per point")
    print(f"fine ramp: F_x^c / dF_x + 12 points, F_x^c the default ensemble's median "
          f"({FC_MEDIAN[100]:g} at N = 100, {FC_MEDIAN[400]:g} at 400, extrapolated as "
          f"N^{FC_EXPONENT:g} above); adaptive: {ADAPTIVE_POINTS} points "
          f"(default job); both in s on one core (wall). cpu: process CPU time of the point "
          f"(equals its wall time on an idle core; the measure to trust on a loaded machine)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
