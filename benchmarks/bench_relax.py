"""Benchmark: relaxing packings (damped vs FIRE, per protocol step) and re-equilibration.

Part 1, large packings (``--sizes``, ``--seeds``): the default protocol from
``generate --n N --seed S`` with ``relax_dynamics = 'fire'`` and, for
N <= ``--old-max``, ``'damped'`` (the path of N <= 400) side by side, in one
process, one core. Wall time per protocol step: (i) compaction, (ii) line
lowered, (iii a) piston, (iii b) frictionless relaxation (FIRE, damped
chunks, Newton polish; summed over the line placements tried), the rest
(friction on, files, final checks). Each relaxed state is checked by the
same tests (exact residual of a fresh ``run 0`` below the acceptance level,
zero history, largest overlap, top line above the bulk) and described by
packing fraction, mean contact number z (disk-disk contacts, 2 N_c / N),
wall contacts, rattlers (< 2 contacts) and the top line's height. For
N > ``--old-max`` the damped time is extrapolated (marked) from the power
law of the two largest measured damped sizes, if there are two.
``--compare FILE``: the same description of a stored relaxed data file
(default: ``benchmarks/data/relaxed_N1600_seed1.data``, the damped path's
N = 1600 seed 1).

Part 2, re-equilibration after an F_x step, Newton-polished vs over-damped only.

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

    python benchmarks/bench_relax.py [--quick] [--sizes 400] [--seeds 1] [--old-max 400]
        [--seed 1] [--n 100] [--target 1e-10]

Default (``make bench``): N = 400 both paths (~2 min), then part 2;
``--quick``: N = 200 both paths. The measurement of docs/results/driver.md:
``--sizes 1600 6400 10000 --seeds 1 2 --old-max 1600`` (seed 2 only at 1600
with ``--seeds-large 1``).
"""
import os

# one BLAS thread next to LAMMPS, as the remote-trigger command line does
# (pywrap/cli.py); must be set before numpy is imported
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import sys
import tempfile
import time


STEPS = ("i", "ii", "iiia", "iiib_fire", "iiib_damped", "iiib_newton", "rest")
STEP_NAMES = {"i": "(i) compact", "ii": "(ii) lower", "iiia": "(iii a) piston",
              "iiib_fire": "(iii b) FIRE", "iiib_damped": "(iii b) damped",
              "iiib_newton": "(iii b) Newton", "rest": "(iv) + rest"}


class StepTimer:
    """Wall time per protocol step: wraps the stage functions that do the steps.

    Each wrapped function is charged its exclusive time (its calls of other
    wrapped functions go to theirs): ``_fire_relax`` is FIRE (and its retries),
    the ``polish`` calls inside it Newton, an ``equilibrate`` inside it the
    damped fallback.
    """

    def __init__(self):
        import importlib

        self.rx = importlib.import_module("remote_trigger.pywrap.stages.relax")
        self.eq = importlib.import_module("remote_trigger.pywrap.stages.equilibrium")
        self.t = {}
        self._orig = []
        self._stack = []            # [start, time of wrapped calls inside] per open call
        for mod, name, key in ((self.rx, "compact_bulk", "i"), (self.rx, "place_top", "ii"),
                               (self.rx, "press_top", "iiia"), (self.rx, "press_top_fire", "iiia"),
                               (self.rx, "_fire_relax", "iiib_fire"),
                               (self.eq, "equilibrate", "iiib_damped"),
                               (self.eq, "polish", "iiib_newton")):
            self._wrap(mod, name, key)

    def _wrap(self, mod, name, key):
        f = getattr(mod, name)
        self._orig.append((mod, name, f))

        def timed(*a, **k):
            frame = [time.perf_counter(), 0.0]
            self._stack.append(frame)
            try:
                return f(*a, **k)
            finally:
                self._stack.pop()
                dt = time.perf_counter() - frame[0]
                if self._stack:
                    self._stack[-1][1] += dt
                self.t[key] = self.t.get(key, 0.0) + dt - frame[1]
                self.t[key + "_calls"] = self.t.get(key + "_calls", 0) + 1
                if dt > 1.0 and name != "polish":      # progress, on stderr
                    print(f"    {name}: {dt:.1f} s", file=sys.stderr, flush=True)
        setattr(mod, name, timed)

    def steps(self, total):
        """Per-step seconds of the run just finished; resets the counters."""
        t, self.t = self.t, {}
        out = {k: t.get(k, 0.0) for k in ("i", "ii", "iiia", "iiib_fire", "iiib_damped",
                                          "iiib_newton")}
        out["rest"] = total - sum(out.values())
        out["tried"] = int(t.get("iiia_calls", 0))     # one piston per placement tried
        return out


def describe(datafile, cfg):
    """Checks and macroscopic numbers of a relaxed data file (fresh LAMMPS, ``run 0``)."""
    import numpy as np
    from remote_trigger.analysis.state.contacts import find_contacts
    from remote_trigger.analysis.state.datafile import read_data
    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.stages import equilibrium as eq

    with Engine() as eng:
        eng.load_deck("in.relax", {"datafile": datafile, "Fx": cfg.F_x, "Fy": cfg.F_y,
                                   "kn": cfg.k_n, "mu": cfg.mu}, ("scene",))
        eng.command("run 0")
        st = eng.gather_state()
    _, r = eq.residual_of(st)
    d = read_data(datafile)
    pos, R, top = st.positions, st.radii, st.top
    i, j, rho = find_contacts(pos, R, st.box_lo[:2], st.box_hi[:2])
    overlap = R[i] + R[j] - rho
    wall = pos[:, 1] - R < 0.0
    ncont = np.bincount(i, minlength=st.n) + np.bincount(j, minlength=st.n) + wall
    L = float(st.box_hi[0] - st.box_lo[0])
    h = float(np.max(pos[:, 1] + R))
    max_wall = float(np.max(R[wall] - pos[wall, 1])) if np.any(wall) else 0.0
    return dict(n=st.n, residual=r, accept=eq.accept_level(cfg, st),
                zero_history=bool(d.n == st.n and np.all(st.xi == 0) and np.all(st.wall_xi == 0)),
                max_overlap=max(float(np.max(overlap)), max_wall),
                hertz_5Fy=(5 * cfg.F_y / cfg.k_n) ** (2.0 / 3.0),
                phi=float(np.sum(np.pi * R ** 2) / (L * h)), z=2.0 * i.size / st.n,
                wall_contacts=int(np.count_nonzero(wall)),
                rattlers=int(np.count_nonzero(ncont < 2)), height=h,
                top_mean_y=float(np.mean(pos[top, 1])),
                clearance=float(np.min(pos[top, 1]) - np.max(pos[~top, 1])))


def _row(label, d):
    ok = d["residual"] < d["accept"] and d["zero_history"] and d["max_overlap"] < d["hertz_5Fy"]
    return (f"{label:<26} {d['residual']:9.2e} {d['accept']:8.0e} {d['max_overlap']:9.2e} "
            f"{d['phi']:7.4f} {d['z']:6.3f} {d['wall_contacts']:5d} {d['rattlers']:5d} "
            f"{d['height']:8.3f} {d['top_mean_y']:8.3f} {d['clearance']:+7.3f} "
            f"{'yes' if ok else 'NO'}")


def large(runs, old_max, compare, old_seeds):
    """Part 1: relax N disks with each dynamics, per step; returns False if a check fails."""
    import numpy as np
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RelaxConfig
    from remote_trigger.pywrap.stages.packing import generate, write_data

    timer = StepTimer()
    rows, states, ok = [], [], True
    for n, seed in runs:
        for dyn in ("fire", "damped"):
            if dyn == "damped" and (n > old_max or (old_seeds and seed not in old_seeds)):
                continue
            work = tempfile.mkdtemp(prefix=f"bench_relax_{n}_{seed}_{dyn}_")
            data = os.path.join(work, "p.data")
            write_data(generate(n, seed=seed), data)
            cfg = RelaxConfig(datafile=data, relax_dynamics=dyn)
            res = stages.relax(cfg, work, quiet=True, log=os.path.join(work, "log.lammps"))
            steps = timer.steps(res.wall_time)
            rows.append((n, seed, dyn, res.wall_time, steps, res.top_attempts))
            d = describe(res.datafile, cfg)
            states.append((f"N={n} s{seed} {dyn}", d))
            print(f"  N = {n} seed {seed} {dyn}: {res.wall_time:.1f} s", file=sys.stderr,
                  flush=True)
    print(f"relax, default protocol, one core: wall time [s] per step "
          f"(summed over the placements of the line)")
    print(f"{'N':>6} {'seed':>4} {'dynamics':>8} {'total':>8} "
          + " ".join(f"{STEP_NAMES[k]:>15}" for k in STEPS) + f" {'placements tried/kept':>22}")
    for n, seed, dyn, wall, steps, att in rows:
        print(f"{n:6d} {seed:4d} {dyn:>8} {wall:8.1f} "
              + " ".join(f"{steps[k]:15.1f}" for k in STEPS)
              + f" {str(steps['tried']) + ' / ' + str(att):>22}")
    # ratio damped / fire per (N, seed); extrapolated damped time above old_max
    damped = {(n, s): w for n, s, dyn, w, _, _ in rows if dyn == "damped"}
    fire = {(n, s): w for n, s, dyn, w, _, _ in rows if dyn == "fire"}
    sizes = sorted({n for n, _ in damped})
    fit = None
    if len(sizes) >= 2:
        t = [np.mean([w for (m, _), w in damped.items() if m == n]) for n in sizes[-2:]]
        alpha = float(np.log(t[1] / t[0]) / np.log(sizes[-1] / sizes[-2]))
        fit = (sizes[-1], t[1], alpha)
    print(f"\n{'N':>6} {'seed':>4} {'damped [s]':>14} {'fire [s]':>9} {'ratio':>8}")
    for (n, s), wf in sorted(fire.items()):
        if (n, s) in damped:
            print(f"{n:6d} {s:4d} {damped[(n, s)]:14.1f} {wf:9.1f} {damped[(n, s)] / wf:8.1f}")
        elif fit is not None and n > fit[0]:
            te = fit[1] * (n / fit[0]) ** fit[2]
            print(f"{n:6d} {s:4d} {'~' + format(te, '.0f') + ' (extrap.)':>14} {wf:9.1f} "
                  f"{'~' + format(te / wf, '.0f'):>8}")
        else:
            print(f"{n:6d} {s:4d} {'-':>14} {wf:9.1f} {'-':>8}")
    if fit is not None:
        print(f"(extrap.: damped time ~ N^{fit[2]:.2f}, from the mean damped times at "
              f"N = {sizes[-2]} and {sizes[-1]}; not measured)")
    if compare and os.path.exists(compare):
        from remote_trigger.pywrap.stages.config import RelaxConfig as RC

        states.append((os.path.basename(compare)[:26], describe(compare, RC(datafile=compare))))
    print(f"\nrelaxed states: exact residual (fresh run 0) below the acceptance level, zero "
          f"history, largest overlap < Hertz overlap at 5 F_y (ok); clear > 0: every top "
          f"centre above every bulk centre (the protocol keeps the best of its placements)")
    print(f"{'state':<26} {'residual':>9} {'accept':>8} {'overlap':>9} {'phi':>7} {'z':>6} "
          f"{'wall':>5} {'ratt':>5} {'height':>8} {'top y':>8} {'clear':>7} ok")
    for label, d in states:
        print(_row(label, d))
        ok = ok and d["residual"] < d["accept"] and d["zero_history"] \
            and d["max_overlap"] < d["hertz_5Fy"]
    return ok


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="N = 200 in part 1")
    ap.add_argument("--runs", nargs="+", default=None, metavar="N:SEED",
                    help="part 1 packings (default 400:1; --quick 200:1)")
    ap.add_argument("--old-max", dest="old_max", type=int, default=1600,
                    help="run the damped path only up to this N")
    ap.add_argument("--old-seeds", dest="old_seeds", type=int, nargs="*", default=None,
                    help="run the damped path only for these seeds (default all)")
    ap.add_argument("--compare", default=os.path.join(os.path.dirname(__file__), "data",
                                                      "relaxed_N1600_seed1.data"),
                    help="a stored relaxed data file to describe alongside ('' = none)")
    ap.add_argument("--skip-reequilibration", action="store_true", help="part 1 only")
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--dF-x", dest="dF_x", type=float, default=1e-4)
    ap.add_argument("--target", type=float, default=1e-10)
    ap.add_argument("--max-damped-steps", dest="max_damped_steps", type=int,
                    default=300_000, help="cap of the damped-only run")
    args = ap.parse_args(argv)
    runs = args.runs or (["200:1"] if args.quick else ["400:1"])
    try:
        runs = [tuple(int(v) for v in r.split(":")) for r in runs]
    except ValueError:
        raise SystemExit(f"bench_relax: --runs expects N:SEED items, got {args.runs!r}")

    from mpi4py import MPI  # noqa: F401  (libmpi before liblammps)
    import numpy as np
    from remote_trigger.pywrap.stages import equilibrium as eq
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RelaxConfig
    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.stages.packing import generate, write_data

    ok = large(runs, args.old_max, args.compare, args.old_seeds)
    if args.skip_reequilibration:
        return 0 if ok else 1
    print()
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
    return 0 if np.isfinite(ratio) and ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
