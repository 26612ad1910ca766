"""Benchmark: relaxing sphere packings by the default protocol, by size.

For each N of ``--sizes`` (default 160, 640 and 2560 spheres: the sizes of
the 3D size dependence, docs/ensemble.md) and each seed of ``--seeds``:
``generate(N, seed, dim=3)``, then the ``relax`` stage with the default
configuration (FIRE, then Newton with the 3D Jacobian; docs/driver.md,
"Spheres") on one rank (``MPI.COMM_SELF``) and one BLAS thread. Wall and
CPU seconds (the process's: LAMMPS runs in it), the residual reached and
whether it converged, Newton steps, the packing fraction, the line
placements tried and the top clearance. A size whose relaxation takes
longer than ``--timeout`` (wall) is reported as not finished.

    python benchmarks/bench_relax3d.py [--quick] [--sizes 160 640 2560] [--seeds 1]

``--quick``: N = 160 only.
"""
import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import json
import subprocess
import sys
import tempfile
import time


def relax_one(n, seed, folder):
    """Relax ``generate(n, seed, dim=3)`` in ``folder``; a dict of what was measured."""
    from mpi4py import MPI

    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RelaxConfig
    from remote_trigger.pywrap.stages.packing import generate, write_data

    data = os.path.join(folder, "p.data")
    write_data(generate(n, seed=seed, dim=3), data)
    w0, c0 = time.perf_counter(), time.process_time()
    rel = stages.relax(RelaxConfig(datafile=data), folder, comm=MPI.COMM_SELF, quiet=True)
    return {"wall": time.perf_counter() - w0, "cpu": time.process_time() - c0,
            "residual": rel.residual, "converged": bool(rel.converged),
            "newton": int(rel.newton_iterations), "phi": rel.packing_fraction,
            "clearance": rel.top_clearance, "rule": rel.clearance_rule}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="N = 160 only")
    ap.add_argument("--sizes", type=int, nargs="+", default=[160, 640, 2560])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1])
    ap.add_argument("--timeout", type=float, default=3600.0,
                    help="wall seconds per relaxation (default 3600)")
    ap.add_argument("--one", nargs=2, type=int, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.one:
        with tempfile.TemporaryDirectory() as tmp:
            print(json.dumps(relax_one(*args.one, tmp)))
        return 0
    if not args.timeout > 0:
        ap.error(f"--timeout must be > 0, got {args.timeout}")
    sizes = [160] if args.quick else args.sizes
    print("relax, default protocol, spheres (generate --dim 3), one rank, one BLAS thread")
    print(f"{'N':>6} {'seed':>4} {'dofs':>6} {'wall[s]':>9} {'cpu[s]':>9} {'residual':>9} "
          f"{'conv':>4} {'newton':>6} {'phi':>6} {'clearance':>9}")
    for n in sizes:
        for seed in args.seeds:
            cmd = [sys.executable, os.path.abspath(__file__), "--one", str(n), str(seed)]
            try:
                out = subprocess.run(cmd, capture_output=True, text=True, check=True,
                                     timeout=args.timeout).stdout
            except subprocess.TimeoutExpired:
                print(f"{n:6d} {seed:4d} {6 * n:6d} not finished after {args.timeout:g} s",
                      flush=True)
                continue
            except subprocess.CalledProcessError as exc:
                print(f"{n:6d} {seed:4d} failed: {exc.stderr.strip().splitlines()[-1][:100]}",
                      flush=True)
                continue
            r = json.loads(out.strip().splitlines()[-1])
            print(f"{n:6d} {seed:4d} {6 * n:6d} {r['wall']:9.1f} {r['cpu']:9.1f} "
                  f"{r['residual']:9.2e} {'yes' if r['converged'] else 'no':>4} "
                  f"{r['newton']:6d} {r['phi']:6.3f} {r['clearance']:+9.3f} ({r['rule']})",
                  flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
