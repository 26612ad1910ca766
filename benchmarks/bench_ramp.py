"""Benchmark: the full default ramp (N = 100, dF_x = 1e-4, bisection to 1e-7).

For each seed: generate the default packing, relax it with the default
protocol, then ramp F_x for each mu (default 1 and 0.8) from the *same*
relaxed equilibrium, up to the first certified complex pair and bisection
to ``tol``. Prints a table: relax time, ramp time, steps, bisections,
certified F_x^c bracket and its width, undecided equilibria, growth rate
just above F_x^c, Newton steps per ramp step.
Goal: the mu = 1 ramp in <= 2 minutes on a 2-core machine.

    python benchmarks/bench_ramp.py [--seeds 1] [--mu 1 0.8] [--n 100]
    mpirun -np 2 python benchmarks/bench_ramp.py     # LAMMPS on 2 ranks
"""
import os

# one BLAS thread next to LAMMPS, as the remote-trigger command line does
# (pywrap/cli.py); must be set before numpy is imported
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import tempfile
import time


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1])
    ap.add_argument("--mu", type=float, nargs="+", default=[1.0, 0.8])
    ap.add_argument("--dF-x", dest="dF_x", type=float, default=1e-4)
    ap.add_argument("--tol", type=float, default=1e-7)
    ap.add_argument("--out", default=None, help="keep outputs here (default: temp dir)")
    args = ap.parse_args(argv)

    from mpi4py import MPI
    import numpy as np
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.config import RelaxConfig, RampConfig
    from remote_trigger.pywrap.packing import generate, write_data
    from remote_trigger.pywrap.results import read_all

    comm = MPI.COMM_WORLD
    rank = comm.Get_rank()
    base = args.out or (tempfile.mkdtemp(prefix="bench_ramp_") if rank == 0 else None)
    base = comm.bcast(base, root=0)
    rows = []
    for seed in args.seeds:
        out = os.path.join(base, f"seed{seed}")
        data = os.path.join(out, "p.data")
        if rank == 0:
            os.makedirs(out, exist_ok=True)
            write_data(generate(args.n, seed=seed), data)
        comm.Barrier()
        rel = stages.relax(RelaxConfig(datafile=data), out, quiet=True)
        for mu in args.mu:
            cfg = RampConfig(datafile=rel.datafile, mu=mu, dF_x=args.dF_x, tol=args.tol)
            rout = os.path.join(out, f"mu{mu:g}")
            t0 = time.perf_counter()
            res = stages.ramp(cfg, rout, quiet=True)
            wall = time.perf_counter() - t0
            nst = 0.0
            if rank == 0:
                _, d = read_all(res.h5)
                nst = float(np.mean(d["steps/newton_steps"]))
            g = float(res.growth_rate[-1]) if res.growth_rate.size else float("nan")
            rows.append((seed, mu, rel.wall_time, rel.packing_fraction, wall, res.F_x.size,
                         res.bisection_F_x.size, res.F_x_c_low, res.F_x_c_high, g, nst,
                         res.status, res.n_undecided, res.F_x_c_width))
    if rank == 0:
        print(f"N = {args.n}, dF_x = {args.dF_x:g}, tol = {args.tol:g}, "
              f"{comm.Get_size()} MPI rank(s)")
        print(f"{'seed':>4} {'mu':>4} {'relax[s]':>8} {'phi':>6} {'ramp[s]':>8} "
              f"{'steps':>6} {'bisect':>6} {'F_x^c low':>12} {'F_x^c high':>12} "
              f"{'width':>8} {'undec':>5} {'growth':>9} {'newton/step':>11} status")
        for r in rows:
            print(f"{r[0]:4d} {r[1]:4g} {r[2]:8.2f} {r[3]:6.4f} {r[4]:8.1f} {r[5]:6d} "
                  f"{r[6]:6d} {r[7]:12.9f} {r[8]:12.9f} {r[13]:8.2g} {r[12]:5d} {r[9]:9.2e} "
                  f"{r[10]:11.2f} {r[11]}")
        print("F_x^c low/high: the certified bracket (largest load certified real, smallest "
              "certified complex); undec: equilibria the analyzer left undecided")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
