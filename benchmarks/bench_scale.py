"""Benchmark: cost of one ramp point against the system size N (issue 15).

For each N: generate a packing (the ``ensemble`` generator, seed 1), relax it
with the default protocol (time printed), then make one ramp point at
F_x = dF_x from the relaxed equilibrium and a second at 2 dF_x from the
first (the one reported; the first warms up), as the ramp does: load the scene,
re-equilibrate (Newton first; dense LU up to ``DENSE_NEWTON_MAX`` = 1200 dof,
sparse LU above), write the equilibrium files, and the certified decision:

* N <= 400: the ramp's dense path (``analysis.stability.stability_of_dump``:
  all 3N eigenvalues and the certified decision on the whole spectrum,
  started from the first point's basis as the ramp does; the decision from
  dgeev on the same dump is timed beside it);
* N > 400: the whole-spectrum certified verdict by slicing
  (``analysis.stability.sliced.classify_sliced``, what the ramp uses above
  ``eigen.DENSE_MAX`` dofs), with its peak traced memory (tracemalloc); the
  dense eigen-solve (LAPACK eigenvalues only) of the same matrix is timed
  beside it up to ``DENSE_TIMED_MAX`` dofs. The synthetic points (no stored
  packing) still use the PARTIAL decision on the 12 eigenvalues nearest a
  shift (``classify_projected``), labelled so: no verdict.

Above ``--relax-max`` (default 400) a relaxation takes too long here
(N = 1600: 1-2 min, N = 1e4: ~18 min on one core). A packing relaxed once
beforehand is used where there is one (``--relaxed N=DATAFILE``; by default
the N = 1600, 6400 and 1e4 packings kept in ``benchmarks/data/``, from the
ensemble generator's seed 1, N = 1600 relaxed by the damped protocol of its
day, 6400 and 1e4 by today's default): its points
are measured like the relaxed ones, two up to N = 1600 and one above
(``ONE_POINT_ABOVE``: the verdict there takes minutes). Larger N (asked for with --sizes; not by default: such tiles have
exactly degenerate Bloch sectors, docs/ensemble.md) are made of copies of the largest
stored packing side by side (``tiled_packing``: 6 copies of N = 1600 =
9600 disks; an exact equilibrium of the wider box but for a 1e-6 jitter of
the diameters that lifts the copies' degenerate spectrum), re-equilibrated
at F_x = 0 and measured the same way. Without a stored packing the point is
assembled from measured parts: a generated, unrelaxed packing of N disks in
LAMMPS (scene load, one Newton iteration's engine part: scatter, ``run
1``, gather; the equilibrium files), and a jittered-lattice State of the
same N (the analyzer's test packing, contacts at and near the Coulomb
limit) for K, the sparse LU factorisation and solve of a Newton step (of K
+ 1e-8 max|K_ii| I: the lattice is no equilibrium and its K is singular)
and the certified decision; the
Newton iterations per point are those measured at the largest relaxed N.

Prints per N: dof, relax time, Newton steps and time, files, decision
(dense or sparse), total per point, and the point cost multiplied into a
fine ramp (F_x^c / dF_x + 12 points with the ensemble's median
F_x^c at that N, extrapolated above N = 400) and an adaptive one (38
points, docs/driver.md).

    python benchmarks/bench_scale.py [--sizes 100 400 1600 10000] [--quick]
                                     [--relaxed 1600=path/equilibrium.data]
                                     [--points 1]
"""
import os

# one BLAS thread next to LAMMPS, as the remote-trigger command line does
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import atexit
import shutil
import tempfile
import time

#: median position of the coalescing pair, Re lambda_c / lambda_max (N = 100 ensemble)
PAIR_RE_REL = 0.094
#: points of an adaptive ramp of the default job (26 steps + 12 bisections)
ADAPTIVE_POINTS = 38
#: median F_x^c(mu0) of the stored ensemble run docs/results/runs/N100_10000_s52
#: (20, 11, 12, 6 and 2 packings at N = 100, 400, 1600, 6400 and 10^4; its
#: ensemble.json, n_fit) and the exponent of the power law fitted there over
#: its 51 usable packings, soft onsets included (docs/ensemble.md, "The size
#: dependence"), used to extrapolate from N = 100 to other N
FC_MEDIAN = {100: 0.0255, 400: 0.00411, 1600: 0.00149, 6400: 0.00067, 10000: 0.000408}
FC_EXPONENT = -0.92


#: packings relaxed once with the default protocol (ensemble generator, seed 1)
#: and kept, so that a point is measured where a relaxation takes too long here
DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data")
STORED = {n: os.path.join(DATA, f"relaxed_N{n}_seed1.data") for n in (1600, 6400, 10000)
          if os.path.exists(os.path.join(DATA, f"relaxed_N{n}_seed1.data"))}
#: above this N a stored packing gets one point (F_x = 0 -> dF_x), not two: its
#: whole-spectrum verdict takes minutes (N = 6400 ~4, N = 1e4 ~12 on one core)
ONE_POINT_ABOVE = 1600


#: largest order of M^-1 K whose dense eigen-solve is timed beside the sliced verdict
DENSE_TIMED_MAX = 5000


def fine_points(n, dF_x):
    """Points of a fine ramp to the median F_x^c at N = n (+ 12 bisections)."""
    fc = FC_MEDIAN.get(n, FC_MEDIAN[100] * (n / 100.0) ** FC_EXPONENT)
    return fc / dF_x + 12


def one_point(n, seed, dF_x, base):
    """Relax a packing of n disks and make two ramp points; returns the second's timings."""
    from mpi4py import MPI

    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RelaxConfig
    from remote_trigger.pywrap.stages.packing import generate, write_data

    out = os.path.join(base, f"N{n}")
    os.makedirs(out, exist_ok=True)
    data = os.path.join(out, "p.data")
    write_data(generate(n, seed=seed), data)
    t0 = time.perf_counter()
    rel = stages.relax(RelaxConfig(datafile=data), out, comm=MPI.COMM_SELF, quiet=True)
    row = {"n": n, "dof": 3 * n, "relax": time.perf_counter() - t0, "phi": rel.packing_fraction}
    return two_points(rel.datafile, dF_x, out, row)


def stored_point(n, datafile, dF_x, base, points=2):
    """Two ramp points from a packing relaxed beforehand (``--relaxed``)."""
    from remote_trigger.analysis.state.datafile import read_data
    from remote_trigger.pywrap.stages.common import packing_fraction

    out = os.path.join(base, f"N{n}")
    os.makedirs(out, exist_ok=True)
    d = read_data(datafile)
    if d.positions.shape[0] != n:
        raise SystemExit(f"bench_scale: {datafile} has {d.positions.shape[0]} atoms, not {n}")
    row = {"n": n, "dof": 3 * n, "relax": float("nan"), "phi": packing_fraction(d),
           "stored": datafile}
    return two_points(datafile, dF_x, out, row, points)


def tiled_packing(src, copies, path, seed=1, jitter=1e-6):
    """Write ``copies`` side-by-side copies of a relaxed packing (periodic in x).

    Copy m is the source shifted by m L_x, atom ids + m N; a contact's history
    follows its partner into the copy across the periodic boundary, so the
    tiled state is an equilibrium of the wider box, force for force. Its
    spectrum is the source's Bloch spectrum, degenerate in pairs; every
    diameter is scaled by 1 + jitter xi (xi normal, seed) to lift that, so
    the file is *near* an equilibrium (forces ~ k_eff jitter R). Image flags
    are reset to 0. A benchmark construction: a packing of copies N at the
    cost of the source's relaxation, not a packing of the ensemble's law.
    """
    import numpy as np

    with open(src) as fh:
        lines = fh.read().splitlines()
    heads = [k for k, ln in enumerate(lines) if ln and ln[0].isalpha() and k > 0]
    sections = {}
    for a, b in zip(heads, heads[1:] + [len(lines)]):
        sections[lines[a].split()[0]] = [ln for ln in lines[a + 1:b] if ln.strip()]
    header = lines[:heads[0]]
    n = len(sections["Atoms"])
    atoms = {int(ln.split()[0]): ln.split() for ln in sections["Atoms"]}
    x = {i: float(w[4]) for i, w in atoms.items()}
    xlo, xhi = next([float(v) for v in ln.split()[:2]] for ln in header if "xlo xhi" in ln)
    L = xhi - xlo
    rng = np.random.default_rng(seed)
    out = []
    for ln in header:
        if ln.endswith(" atoms"):
            ln = f"{n * copies} atoms"
        elif ln.endswith("xlo xhi"):
            ln = f"{xlo!r} {xlo + copies * L!r} xlo xhi"
        out.append(ln)
    out += ["Atoms # sphere", ""]
    for m in range(copies):
        for i, w in atoms.items():
            d = float(w[2]) * (1.0 + jitter * rng.standard_normal())
            out.append(f"{i + m * n} {w[1]} {d!r} {w[3]} {x[i] + m * L!r} {w[5]} {w[6]} 0 0 0")
    out += ["", "Velocities", ""]
    out += [f"{i + m * n} 0 0 0 0 0 0" for m in range(copies) for i in atoms]
    hist = [ln.split() for ln in sections["hist"]]
    K = (len(hist[0]) - 2) // 2
    out += ["", "hist # i_mindlin_partner d_mindlin_t d_mindlin_wall_t", ""]
    for m in range(copies):
        for w in hist:
            i = int(w[0])
            partners = []
            for p in (int(v) for v in w[1:1 + K]):
                if p == 0:
                    partners.append(0)
                    continue
                dx = x[p] - x[i]          # the partner's copy: across the boundary or not
                shift = 0 if abs(dx) <= 0.5 * L else (1 if dx < 0 else -1)
                partners.append(p + ((m + shift) % copies) * n)
            out.append(" ".join([str(i + m * n)] + [str(p) for p in partners] + w[1 + K:]))
    out += ["", "topflag # i_top", ""]
    out += [f"{int(w.split()[0]) + m * n} {w.split()[1]}" for m in range(copies)
            for w in sections["topflag"]]
    with open(path, "w") as fh:
        fh.write("\n".join(out) + "\n")
    return n * copies


def tiled_point(src, copies, dF_x, base, seed):
    """Tile the stored packing, re-equilibrate it at F_x = 0, then two ramp points."""
    from mpi4py import MPI

    from remote_trigger.pywrap.stages import equilibrium as eq
    from remote_trigger.pywrap.stages.config import RampConfig
    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.stages.common import load_relax_scene, save_equilibrium

    out = os.path.join(base, f"tiled{copies}")
    os.makedirs(out, exist_ok=True)
    data = os.path.join(out, "tiled.data")
    n = tiled_packing(src, copies, data, seed=seed)
    cfg = RampConfig(datafile=data, dF_x=dF_x, F_x=0.0)
    t0 = time.perf_counter()
    with Engine(comm=MPI.COMM_SELF) as eng:
        load_relax_scene(eng, cfg, data, 0.0, deck="in.ramp_step")
        r, _, rec = eq.equilibrate(eng, cfg, 0.0, newton_first=True)
        save_equilibrium(eng, cfg, 0.0, os.path.join(out, "equilibrium"))
    row = {"n": n, "dof": 3 * n, "relax": float("nan"), "phi": float("nan"),
           "tiled": (copies, src, time.perf_counter() - t0, r,
                     max(0, sum(p == "newton" for p in rec.phase) - 1),
                     sum(p == "damped" for p in rec.phase))}
    return two_points(os.path.join(out, "equilibrium.data"), dF_x, out, row)


def two_points(start, dF_x, out, row, points=2):
    """The ramp points F_x = dF_x and 2 dF_x from the equilibrium ``start``
    (``points`` = 1: only the first, reported)."""
    from remote_trigger.pywrap.stages.config import RampConfig

    cfg = RampConfig(datafile=start, dF_x=dF_x, F_x=0.0)
    # two ramp steps, F_x = dF_x then 2 dF_x, each from the previous
    # equilibrium; the first warms up (imports, first LAMMPS instance), the
    # second is reported
    basis = None
    for k in range(1, points + 1):
        pt = _point(cfg, start, k * dF_x, os.path.join(out, f"step{k}"), basis)
        basis = pt.pop("basis", None)
        if k == 1:
            row["first"] = pt
        row.update(pt)
        start = os.path.join(out, f"step{k}.data")
    return row


def _point(cfg, start, F_x, prefix, basis=None):
    """One ramp point: scene, Newton, files, certified decision (timings).

    Dense path: the decision starts from ``basis`` (the previous point's, as
    in the ramp; returned under ``basis``) and, for comparison, is timed
    again from dgeev (``decision_dgeev``, not part of the point)."""
    import numpy as np
    import scipy.sparse.linalg as spla
    from mpi4py import MPI

    from remote_trigger.analysis.stability import eigen, projected
    from remote_trigger.analysis.stability.system import reduced_system
    from remote_trigger.analysis.stability.verdict import stability_of_dump
    from remote_trigger.analysis.state.dumpfile import read_dump
    from remote_trigger.pywrap.stages import equilibrium as eq
    from remote_trigger.pywrap.stages.newton_solve import DENSE_NEWTON_MAX
    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.stages.common import load_relax_scene, save_equilibrium

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
               damped=sum(p == "damped" for p in rec.phase),
               path="sparse" if 3 * n > DENSE_NEWTON_MAX else "dense")
    if 3 * n <= DENSE_NEWTON_MAX:
        t0 = time.perf_counter()
        res = stability_of_dump(prefix + ".dump", basis=basis, allow_residual=True)
        t1 = time.perf_counter()
        cold = stability_of_dump(prefix + ".dump", allow_residual=True)
        row.update(decision=t1 - t0, decision_dgeev=time.perf_counter() - t1,
                   eigen=cold.timing["eigen"], verdict=res.decision, start=res.start,
                   n_eig=res.eigenvalues.size, basis=res.basis)
        assert cold.decision == res.decision, (cold.decision, res.decision)
    else:
        # the whole-spectrum verdict by slicing (analysis.stability.sliced), and
        # the dense eigen-solve (eigenvalues only) of the same matrix beside it
        # where it fits (n <= DENSE_TIMED_MAX)
        import tracemalloc
        from remote_trigger.analysis.stability.sliced import SlicedStats, classify_sliced

        t0 = time.perf_counter()
        st = read_dump(prefix + ".dump", require_contacts=False)
        ana = reduced_system(st)
        Kr, mr = ana.K, ana.mass
        stats = SlicedStats()
        tracemalloc.start()
        dec = classify_sliced(Kr, mr, stats=stats)
        t1 = time.perf_counter()
        traced = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        verdict = dec.decision.label
        row.update(decision=t1 - t0, eigen=dec.timing.get("eigen", np.nan),
                   verdict=f"{verdict} (whole spectrum, sliced: {stats.slices} slices, "
                           f"strips {stats.strips}"
                           + (f"; {dec.reason}" if dec.decision.label == "undecided" else "") + ")",
                   n_eig=Kr.shape[0], traced_MB=traced / 2**20,
                   dense_matrix_MB=8.0 * Kr.shape[0] ** 2 / 2**20)
        if Kr.shape[0] <= DENSE_TIMED_MAX:
            import scipy.linalg as sla
            A = eigen.dynamical_matrix(Kr, mr).toarray()
            t2 = time.perf_counter()
            sla.eigvals(A, check_finite=False)
            row["dense_eigvals"] = time.perf_counter() - t2
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

    from remote_trigger.analysis.stability import eigen, projected
    from remote_trigger.analysis.stability.jacobian import (
        find_rattlers, remove_dofs, stiffness_matrix)
    from remote_trigger.pywrap.stages import equilibrium as eq
    from remote_trigger.pywrap.stages.config import RampConfig
    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.stages.packing import generate, write_data
    from remote_trigger.pywrap.stages.common import load_relax_scene, save_equilibrium

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
    dec, _ = projected.classify_projected(A, PAIR_RE_REL * lam_max, k=12)
    t9 = time.perf_counter()
    verdict = dec.decision.label
    iteration = (t3 - t2) + (t6 - t5) + (t7 - t6)
    row = dict(n=st.n, dof=3 * st.n, relax=float("nan"), phi=float("nan"), scene=t1 - t0,
               newton=newton_steps * iteration, newton_steps=newton_steps,
               files=t4 - t3, decision=t9 - t8, lam_max_time=t8 - t7, path="sparse",
               verdict="partial, not a verdict: " + verdict + " among the 12 nearest the shift; synthetic packing",
               parts=dict(engine_iteration=t3 - t2, K=t6 - t5, solve=t7 - t6))
    row["point"] = row["scene"] + row["newton"] + row["files"] + row["decision"]
    row["point_cpu"] = float("nan")
    return row


def _per_point(r):
    """Cost per point of a ramp: above N = 400 the mean of the two points measured
    (one of them may be a point where Newton stalls, see the note printed)."""
    if r["n"] > 400 and "first" in r:
        return 0.5 * (r["point"] + r["first"]["point"])
    return r["point"]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[100, 400, 1600, 6400, 10000],
                    help="N values (default 100 400 1600 6400 10000; N above 400 from the "
                         "packings stored in benchmarks/data; other large N are tiled "
                         "copies of a stored packing, degenerate spectra that are no test "
                         "systems for a verdict)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--dF-x", dest="dF_x", type=float, default=2.5e-4)
    ap.add_argument("--quick", action="store_true", help="N = 100 and 400 only")
    ap.add_argument("--relax-max", dest="relax_max", type=int, default=400,
                    help="largest N relaxed here; above it a stored packing (--relaxed), "
                         "copies of the largest stored one side by side, or parts")
    ap.add_argument("--relaxed", nargs="*", default=None, metavar="N=DATAFILE",
                    help="packings relaxed beforehand: their points are measured without "
                         "relaxing (default: " + ", ".join(f"{n}={p}" for n, p in
                                                           STORED.items()) + ")")
    ap.add_argument("--points", type=int, choices=(1, 2), default=None,
                    help="ramp points measured from a stored packing: 2 (the second is "
                         "reported) or 1 (F_x = dF_x only: for N whose verdict takes many "
                         f"minutes); default 2 up to N = {ONE_POINT_ABOVE}, 1 above")
    ap.add_argument("--out", default=None, help="keep outputs here (default: temp dir)")
    args = ap.parse_args(argv)
    sizes = [n for n in args.sizes if n <= 400] if args.quick else args.sizes
    stored = dict(STORED) if args.relaxed is None else {}
    for item in args.relaxed or ():
        n, sep, path = item.partition("=")
        if not (sep and n.isdigit() and os.path.exists(path)):
            raise SystemExit(f"bench_scale: --relaxed needs N=DATAFILE of an existing file, "
                             f"got {item!r}")
        stored[int(n)] = path
    base = args.out or tempfile.mkdtemp(prefix="bench_scale_")
    if args.out is None:          # (the temporary folder was left behind)
        atexit.register(shutil.rmtree, base, True)
    rows = []
    for n in sizes:
        src = max((m for m in stored if m <= n), default=None)
        if n in stored and n > args.relax_max:
            pts = args.points or (2 if n <= ONE_POINT_ABOVE else 1)
            rows.append(stored_point(n, stored[n], args.dF_x, base, pts))
            rows[-1]["points"] = pts
        elif n <= args.relax_max:
            rows.append(one_point(n, args.seed, args.dF_x, base))
        elif src is not None:
            rows.append(tiled_point(stored[src], max(1, round(n / src)), args.dF_x, base,
                                    args.seed))
        else:
            steps = max((r["newton_steps"] for r in rows), default=4)
            rows.append(synthetic_point(n, args.seed, base, steps))
        r = rows[-1]
        relax = ("relaxed beforehand" if "stored" in r else
                 f"{r['tiled'][0]} copies of a stored packing" if "tiled" in r else
                 f"relax {r['relax']:.1f} s")
        print(f"N = {r['n']}: {relax}, point {r['point']:.3f} s "
              f"({r['path']} Newton, {r['verdict']})", flush=True)
    e100 = next((r["eigen"] for r in rows if r["n"] == 100), None)
    print(f"\none ramp point vs N (seed {args.seed}, the step F_x = {args.dF_x:g} -> "
          f"{2 * args.dF_x:g}; one core; times in s)")
    print(f"{'N':>6} {'dof':>6} {'relax':>8} {'newton':>6} {'t_newton':>8} {'scene+files':>11} "
          f"{'decision':>9} {'point':>8} {'cpu':>8} {'fine ramp':>10} {'adaptive':>9}  "
          f"decision path")
    for r in rows:
        what = (f"dense: all eigenvalues, certified, from {r['start']} (from dgeev: "
                f"{r['decision_dgeev']:.3f} s, its eigen-solve {r['eigen']:.3f} s)"
                if r["path"] == "dense" else
                f"sparse, PARTIAL (not a stability verdict): 12 of {r['dof']} eigenvalues, "
                f"nearest sigma = {PAIR_RE_REL} lambda_max (lambda_max by ARPACK "
                f"{r['lam_max_time']:.2f} s, not counted)" if "parts" in r else
                f"{r['verdict']}; peak memory {r['traced_MB']:.0f} MB (tracemalloc: NumPy "
                f"arrays, not the factors) = {r['traced_MB'] / r['dense_matrix_MB']:.2f} "
                f"dense n x n matrices"
                + (f"; dense LAPACK eigenvalues of the same matrix {r['dense_eigvals']:.1f} s"
                   if "dense_eigvals" in r else ""))
        relax = "stored" if "stored" in r else "tiled" if "tiled" in r else f"{r['relax']:.1f}"
        print(f"{r['n']:6d} {r['dof']:6d} {relax:>8} {r['newton_steps']:6d} "
              f"{r['newton']:8.3f} {r['scene'] + r['files']:11.3f} {r['decision']:9.3f} "
              f"{r['point']:8.3f} {r['point_cpu']:8.3f} "
              f"{_per_point(r) * fine_points(r['n'], args.dF_x):10.0f} "
              f"{_per_point(r) * ADAPTIVE_POINTS:9.0f}  {what}")
        if "tiled" in r:
            c, src, t_eq, r_eq, n_newton, n_damped = r["tiled"]
            print(f"{'':6} N = {r['n']}: {c} copies side by side of the stored N = "
                  f"{r['n'] // c} packing, diameters x (1 + 1e-6 xi), re-equilibrated at "
                  f"F_x = 0 in {t_eq:.1f} s ({n_newton} Newton steps, {n_damped} damped "
                  f"chunks, residual {r_eq:.2g})")
        if r.get("damped"):
            print(f"{'':6} Newton stalled: {r['damped']} chunks of damped dynamics between "
                  f"its {r['newton_steps']} steps")
        if "first" in r and r["n"] > 400:
            f = r["first"]
            print(f"{'':6} the first point (F_x = 0 -> {args.dF_x:g} from the equilibrium): "
                  f"{f['point']:.3f} s, {f['newton_steps']} Newton steps"
                  + (f", {f['damped']} damped chunks" if f.get("damped") else ""))
        if "parts" in r:
            p = r["parts"]
            print(f"{'':6} assembled: {r['newton_steps']} Newton iterations x (engine "
                  f"{p['engine_iteration']:.3f} + K {p['K']:.3f} + sparse LU solve "
                  f"{p['solve']:.3f}); relax not run (relax-max {args.relax_max})")
        if r["path"] == "sparse" and e100 and "dense_eigvals" not in r:
            dense = e100 * (r["dof"] / 300.0) ** 3
            print(f"{'':6} dense eigen-solve at this size, extrapolated as n^3 from N = 100: "
                  f"{dense:.0f} s per point")
    one = sorted(r["n"] for r in rows if r.get("points") == 1)
    print("point, cpu: the second point"
          + (f", the first (F_x = 0 -> {args.dF_x:g}) at N = "
             + ", ".join(map(str, one)) + " (one point measured there)" if one else "")
          + "; fine ramp, adaptive: points x the mean of the points measured above "
          "N = 400, x the second below")
    print(f"fine ramp: F_x^c / dF_x + 12 points, F_x^c the ensemble's median "
          f"({', '.join(f'{v:g} at N = {k}' for k, v in FC_MEDIAN.items())}; at other N "
          f"{FC_MEDIAN[100]:g} (N/100)^{FC_EXPONENT:g}, the fit over the 51 usable packings "
          f"of docs/results/runs/N100_10000_s52); adaptive: {ADAPTIVE_POINTS} points "
          f"(default job); both in s on one core (wall). cpu: process CPU time of the point "
          f"(equals its wall time on an idle core; the measure to trust on a loaded machine)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
