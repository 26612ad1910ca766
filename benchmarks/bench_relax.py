"""Benchmark: re-equilibration after an F_x step, Newton-polished vs over-damped only.

The default N = 100 packing (``generate --n 100 --seed S``) is relaxed with
the default protocol (timed, and its geometry checked: every top disk centre
above every bulk disk centre); then, from that equilibrium, F_x is raised by
one default ramp step dF_x = 1e-4 and the packing re-equilibrated twice,
side by side:

* ``newton``: the ramp's path (``equilibrate(..., newton_first=True)``:
  Newton steps with the analytic stiffness from the previous equilibrium,
  damped dynamics only if Newton fails);
* ``damped``: over-damped dynamics only until the residual (damping force
  removed) is below the target, or ``--max-damped-steps``; the times at
  which it passes 1e-6, 1e-8, 1e-9 and the target are listed.

The target is ``--target`` (default 1e-10 = f_accept: over-damped dynamics
stagnates at ~5e-11, the round-off floor of the force evaluation is
~2e-11, docs/driver.md), so both runs stop at the floor; the table shows the
residual each reached, wall time and the ratio (goal >= 20).

    python benchmarks/bench_relax.py [--seed 1] [--n 100] [--target 1e-10]
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
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--dF-x", dest="dF_x", type=float, default=1e-4)
    ap.add_argument("--target", type=float, default=1e-10)
    ap.add_argument("--max-damped-steps", dest="max_damped_steps", type=int,
                    default=300_000, help="cap of the damped-only run")
    args = ap.parse_args(argv)

    from mpi4py import MPI  # noqa: F401  (libmpi before liblammps)
    import numpy as np
    from remote_trigger.pywrap.stages import equilibrium as eq
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RelaxConfig
    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.stages.packing import generate, write_data

    work = tempfile.mkdtemp(prefix="bench_relax_")
    data = os.path.join(work, "p.data")
    write_data(generate(args.n, seed=args.seed), data)
    rel = stages.relax(RelaxConfig(datafile=data), work, quiet=True)
    print(f"relax (default protocol) N = {args.n}, seed {args.seed}: "
          f"{rel.wall_time:.2f} s (compaction + piston {rel.compaction_time:.2f} s, "
          f"{rel.top_attempts} placement(s)), residual {rel.residual:.2e}, "
          f"phi {rel.packing_fraction:.4f}, ||K-K^T||/||K|| {rel.antisymmetry:.1e}, "
          f"top clearance {rel.top_clearance:+.3f}")

    F = args.dF_x
    cfg = RelaxConfig(datafile=rel.datafile, F_x=F, f_min=args.target, f_accept=args.target)
    # Newton-polished (the ramp's path)
    with Engine() as eng:
        stages.load_relax_scene(eng, cfg, rel.datafile, F, deck="in.ramp_step")
        t0 = time.perf_counter()
        r_n, _, rec = eq.equilibrate(eng, cfg, F, newton_first=True)
        wall_n = time.perf_counter() - t0
    # over-damped only: chunks of check_every steps, residual with damping removed
    levels = [1e-6, 1e-8, 1e-9, args.target]
    reached = {}
    with Engine() as eng:
        stages.load_relax_scene(eng, cfg, rel.datafile, F, deck="in.ramp_step")
        eng.command(f"variable load_x equal {F!r}")
        t0 = time.perf_counter()
        steps, r_d = 0, np.inf
        while steps < args.max_damped_steps and r_d >= args.target:
            eng.run(cfg.check_every, pre=(steps == 0))
            steps += cfg.check_every
            _, r_d = eq.residual_of(eng.gather_state(), (cfg.gamma, cfg.gamma_rot))
            for lv in levels:
                if r_d < lv and lv not in reached:
                    reached[lv] = (time.perf_counter() - t0, steps)
        wall_d = time.perf_counter() - t0
    print(f"\nre-equilibration after F_x: 0 -> {F:g}")
    print(f"{'method':<8} {'target':>8} {'residual':>10} {'wall [s]':>9} {'steps':>9} "
          f"{'ratio':>7}")
    print(f"{'newton':<8} {args.target:8.0e} {r_n:10.2e} {wall_n:9.3f} "
          f"{sum(p == 'newton' for p in rec.phase):9d} {'1':>7}")
    for lv in levels:
        if lv in reached:
            w, st = reached[lv]
            print(f"{'damped':<8} {lv:8.0e} {'< target':>10} {w:9.3f} {st:9d} "
                  f"{w / wall_n:7.0f}")
        else:
            print(f"{'damped':<8} {lv:8.0e} {'not reached':>10} {'> ' + format(wall_d, '.1f'):>9} "
                  f"{steps:9d} {'> ' + format(wall_d / wall_n, '.0f'):>7}")
    print(f"damped dynamics stopped at residual {r_d:.2e} after {steps} steps "
          f"({wall_d:.1f} s); Newton reached {r_n:.2e} in {wall_n:.3f} s")
    ratio = wall_d / wall_n
    return 0 if np.isfinite(ratio) else 1


if __name__ == "__main__":
    raise SystemExit(main())
