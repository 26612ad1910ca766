"""Benchmark: the factorizations of a sliced verdict for spheres, QDLDL against SuperLU
and the multifrontal LDL^T.

A 3D contact network fills the factor of S - a I (S the symmetric part of
M^-1/2 K M^-1/2) as a 3D grid does, and QDLDL's scalar LDL^T then costs a
slice most of its time (docs/results/analysis.md, "Spheres at N = 2560:
where a slice's time goes"). The sliced scan therefore makes its
shift-invert factorizations with SuperLU's supernodal LU where the factor
has more than ``inertia.SUPERNODAL_FILL`` entries per row
(``inertia.SymmetricLU``), and its Sylvester counts with the multifrontal
LDL^T in SuperLU's order (``supernodal.SupernodalLDL``). This benchmark
measures them side by side in one process, one core, one BLAS thread, CPU
seconds:

* **The state.** ``generate(N, seed, dim=3)`` relaxed by the ``relax``
  stage with the top layer as a rigid plate (``top_layer = 'rigid'``, the
  protocol of the sphere ensembles), its equilibrium at F_x = 0; cached
  under ``$REMOTE_TRIGGER_BENCH_CACHE`` (default ``~/.cache/remote_trigger``)
  ``/sphere_factor`` (the relaxation of N = 2560 takes ~7 min).
* **At shifts 0.01, 0.2 and 0.5 lambda_max:** QDLDL's numeric
  refactorization (``Solver.update``) and a solve; ``SymmetricLU`` in the
  order of its first factorization and a solve; their counts of negative
  pivots (must be equal: the same inertia); a Sylvester count each way:
  QDLDL's (refactorization + ``inertia.count_below``'s bound) and
  ``SupernodalLDL.count_below`` (count and fuzz; its symbolic analysis timed
  once), their counts equal to the pivots'; each float64 count's fuzz over
  ``inertia.fuzz_limit`` (above 1 the scan makes the count again in
  double-word arithmetic). At the shift of the largest ratio, the time of
  that double-word count (what the limit trades against).
* **The bound of ||W||_2** (``inertia.norm2_skew``, once per scan): its
  whole time (the multifrontal count of [[0, W], [W^T, 0]] + tI where W's
  pattern fills densely) beside QDLDL's count of that matrix alone, at the
  same t (QDLDL's count 0 must go with a bound sharper than ||W||_1, which
  norm2_skew returns when its count is not 0). The state is at F_x = 0, where W is
  tiny but has its full pattern: the cost depends on the pattern.

    python benchmarks/bench_sphere_factor.py [--quick] [--n 2560] [--seed 1]

``--quick``: N = 640 (fill ~126-145 per row, below the threshold).
"""
import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import time

SHIFTS = (0.01, 0.2, 0.5)
SOLVES = 20


def cache_dir():
    root = os.environ.get("REMOTE_TRIGGER_BENCH_CACHE",
                          os.path.join(os.path.expanduser("~"), ".cache", "remote_trigger"))
    return os.path.join(root, "sphere_factor")


def state(n, seed):
    """The relaxed plate state's equilibrium dump (built once, then cached)."""
    folder = os.path.join(cache_dir(), f"N{n}_s{seed}_rigid")
    dump = os.path.join(folder, "relax", "equilibrium.dump")
    if os.path.exists(dump) and os.path.exists(dump + ".json"):
        return dump
    from mpi4py import MPI

    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RelaxConfig
    from remote_trigger.pywrap.stages.packing import generate, write_data

    os.makedirs(folder, exist_ok=True)
    data = os.path.join(folder, "packing.data")
    write_data(generate(n, seed=seed, dim=3), data)
    t0 = time.perf_counter()
    stages.relax(RelaxConfig(datafile=data, top_layer="rigid"), folder, comm=MPI.COMM_SELF,
                 quiet=True)
    print(f"(relaxed N = {n} seed {seed} with the plate in {time.perf_counter() - t0:.0f} s)",
          flush=True)
    return dump


def cpu(fn, repeat=1):
    """(fn's last result, mean CPU seconds of ``repeat`` calls)."""
    t0 = time.process_time()
    for _ in range(repeat):
        out = fn()
    return out, (time.process_time() - t0) / repeat


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    ap.add_argument("--quick", action="store_true", help="N = 640")
    ap.add_argument("--n", type=int, default=2560, help="spheres (default 2560)")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    n_spheres = 640 if args.quick else args.n

    import numpy as np
    import qdldl
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    from remote_trigger.analysis.stability.sliced import inertia, scaled_parts
    from remote_trigger.analysis.stability.sliced.supernodal import SupernodalLDL
    from remote_trigger.analysis.stability.system import reduced_system
    from remote_trigger.analysis.state.dumpfile import read_equilibrium
    from remote_trigger.pywrap.runtime.environment import source

    dump = state(n_spheres, args.seed)
    system = reduced_system(read_equilibrium(dump))
    _, S, W = scaled_parts(system.K, system.mass)
    n = S.shape[0]
    lam_max = float(spla.eigsh(S, k=1, which="LA", return_eigenvectors=False,
                               v0=np.ones(n))[0])
    limit = inertia.fuzz_limit(inertia.norm1(S), n)
    b = np.random.default_rng(0).standard_normal(n)
    print(f"bench_sphere_factor: commit {(source()['commit'] or 'unknown')[:7]}, "
          f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; N = {n_spheres} spheres "
          f"(seed {args.seed}, top layer rigid), n = {n} kept dofs, one core, CPU s")
    H = inertia.shifted(S, SHIFTS[0] * lam_max)
    qd, t_q0 = cpu(lambda: qdldl.Solver(H))
    L = qd.factors()[0]
    first, t_s0 = cpu(lambda: inertia.SymmetricLU(H))
    print(f"  fill: QDLDL nnz(L) {L.nnz} ({L.nnz / n:.0f} per row); SuperLU {first.fill:.0f} "
          f"per row (threshold {inertia.SUPERNODAL_FILL:.0f}: the scan's solves by "
          f"{'SuperLU' if first.fill > inertia.SUPERNODAL_FILL else 'QDLDL'}); first "
          f"factorization with its ordering: QDLDL {t_q0:.3f} s, SuperLU {t_s0:.3f} s")
    sn, t_sym = cpu(lambda: SupernodalLDL(S, first.perm))
    print(f"  multifrontal LDL^T in SuperLU's order: {sn.supernodes} fronts, nnz(L) {sn.nnz_L} "
          f"({sn.nnz_L / n:.0f} per row), symbolic analysis {t_sym:.3f} s")
    print("  a/lambda_max | QDLDL update, solve | SuperLU, solve | factorization ratio | "
          "negative pivots (both) | count: QDLDL, multifrontal, ratio | fuzz / limit: QDLDL, "
          "multifrontal")
    worst = (-1.0, None)
    for f in SHIFTS:
        a = f * lam_max
        Ha = inertia.shifted(S, a)
        _, t_u = cpu(lambda: qd.update(Ha))
        _, t_qs = cpu(lambda: qd.solve(b), SOLVES)
        lu, t_l = cpu(lambda: inertia.SymmetricLU(Ha, first.perm))
        _, t_ls = cpu(lambda: lu.solve(b), SOLVES)
        neg_q = int(np.count_nonzero(qd.factors()[1] < 0))
        neg_s = int(np.count_nonzero(lu.lu.U.diagonal() < 0))
        (cnt, fuzz, _), t_c = cpu(lambda: inertia.count_below(S, a, qd))
        (cnt_m, fz_m), t_m = cpu(lambda: sn.count_below(a))
        if neg_q != neg_s or cnt != neg_q or cnt_m != neg_q:
            raise SystemExit(f"bench_sphere_factor: counts differ at a = {a!r}: QDLDL {neg_q}, "
                             f"SuperLU {neg_s}, multifrontal {cnt_m}")
        print(f"  {f:5.2f} | {t_u:.3f} s, {t_qs * 1e3:.2f} ms | {t_l:.3f} s, {t_ls * 1e3:.2f} ms | "
              f"{t_u / t_l:.2f} x | {neg_q} | {t_u + t_c:.3f} s, {t_m:.3f} s, "
              f"{(t_u + t_c) / t_m:.2f} x | {fuzz / limit:.2f}, {fz_m / limit:.2f}")
        worst = max(worst, (fuzz / limit, (f, a, cnt)))
    f, a, cnt = worst[1]
    qd.update(inertia.shifted(S, a))
    (cnt_dw, fz_dw), t_dw = cpu(lambda: inertia.count_below_dw(S, a, qd.factors()[2]))
    print(f"  double-word count at {f} lambda_max: {t_dw:.1f} s, count {cnt_dw} "
          f"({'equal' if cnt_dw == cnt else 'DIFFERS'}), fuzz {fz_dw:.2g}")
    bound, t_nw = cpu(lambda: inertia.norm2_skew(W))
    est = float(spla.svds(W, k=1, return_singular_vectors=False, tol=1e-6,
                          v0=np.random.default_rng(0).standard_normal(n))[0])
    aug = sp.bmat([[None, W], [W.T, None]], format="csc")
    (cnt_a, _, _), t_aq = cpu(lambda: inertia.count_below(aug, -1.02 * est))
    if (cnt_a == 0) != (bound < inertia.norm1(W)):
        raise SystemExit(f"bench_sphere_factor: QDLDL's count of the augmented matrix is "
                         f"{cnt_a}, and norm2_skew's bound {bound!r} against ||W||_1 "
                         f"{inertia.norm1(W)!r} says otherwise")
    print(f"  bound of ||W||_2 (norm2_skew, nnz(W) {W.nnz}): {bound:.4g} in {t_nw:.1f} s in all; "
          f"QDLDL's count of the 2n augmented matrix alone {t_aq:.1f} s (count {cnt_a}; ||W||_1 "
          f"{inertia.norm1(W):.4g})")

if __name__ == "__main__":
    main()
