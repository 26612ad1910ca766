"""Benchmark: kill -9 at random moments -- readable files, bitwise-equal resumed ramps.

1. Writer: cost per row of ``SeriesWriter.append`` (1e5 rows of the four
   series columns; checkpoints every 2 s, the default, and every 0.1 s),
   against building the row alone and against the former SWMR writer
   (flush per row; re-created here, fewer rows).
2. Ramps: the N = 20 packing (seed 1) is relaxed with the command line, an
   uninterrupted ``remote-trigger ramp`` is the reference, then ``--trials``
   chains: start, SIGKILL at a moment uniform over the reference's wall
   time, check every ``*.h5`` with a plain ``h5py.File(path, 'r')``,
   ``--resume`` (killed again, up to ``--max-kills`` times) until it
   completes, compare ``ramp.h5`` with the reference (F_x^c bracket ``==``,
   eigenvalues and columns bitwise). Trial 1 is first killed before
   ``ramp.h5`` exists. The kill/resume/compare protocol is the one of
   ``tests/driver/test_kill.py`` (imported from there).

    python benchmarks/bench_kill.py [--trials 8] [--max-kills 3] [--seed S] [--quick]

The seed defaults to ``RT_KILL_SEED`` or the clock and is printed; exit
status 1 if any file was unreadable or any resumed ramp differed.
"""
import os

# one BLAS thread next to LAMMPS, as the remote-trigger command line does
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import atexit
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


class _SWMRWriter:
    """The former SeriesWriter (SWMR, libver='latest', flush per row), for timing only."""

    def __init__(self, path, attrs, columns):
        import h5py

        self.columns = list(columns)
        fh = h5py.File(path, "w", libver="latest")
        for k, v in dict(attrs, status="running").items():
            fh.attrs[k] = v
        for c in self.columns:
            fh.create_dataset(c, shape=(0,), maxshape=(None,), dtype="f8", chunks=(1024,))
        fh.close()
        self.path = path
        self.fh = h5py.File(path, "a", libver="latest")
        self.fh.swmr_mode = True
        self.n = 0

    def append(self, row):
        for c in self.columns:
            ds = self.fh[c]
            ds.resize((self.n + 1,))
            ds[self.n] = float(row[c])
        self.n += 1
        self.fh.flush()

    def close(self, status="complete"):
        import h5py

        self.fh.close()
        with h5py.File(self.path, "a", libver="latest") as fh:
            fh.attrs["status"] = status


def _rows(writer, n):
    """Append n rows; returns (seconds of the appends, seconds of close)."""
    t0 = time.perf_counter()
    for i in range(n):
        row = {"t": 0.1 * i, "D": 1e-20 * i, "v_top": 1e-12, "mu": 1.0}
        if writer is not None:
            writer.append(row)
    t1 = time.perf_counter()
    if writer is not None:
        writer.close(status="complete")
    return t1 - t0, time.perf_counter() - t1


def bench_writer(folder, n, n_old, repeat=3):
    from remote_trigger.pywrap.runtime.results import SeriesWriter, read_all

    cols = ["t", "D", "v_top", "mu"]
    path = os.path.join(folder, "series.h5")
    base = min(_rows(None, n)[0] for _ in range(repeat)) / n
    lines = [f"writer: {n} rows x {len(cols)} float64 columns, best of {repeat}; "
             f"building the row dict alone {base * 1e6:.2f} us/row"]
    for every in (2.0, 0.1):
        best = None
        for _ in range(repeat):
            w = SeriesWriter(path, {"stage": "bench"}, cols, checkpoint_seconds=every)
            ta, tc = _rows(w, n)
            if best is None or ta < best[0]:
                best = (ta, tc, w.n_checkpoints)
        ta, tc, nck = best
        assert read_all(path)[1]["t"].size == n
        lines.append(f"  SeriesWriter, checkpoint {every:g} s: append {ta / n * 1e6:.2f} us/row "
                     f"(+{(ta / n - base) * 1e6:.2f} over the row alone), {nck} rewrites "
                     f"incl. the empty file and close, close {tc * 1e3:.1f} ms "
                     f"({os.path.getsize(path) / 1e6:.1f} MB)")
    w = _SWMRWriter(path, {"stage": "bench"}, cols)
    ta, tc = _rows(w, n_old)
    lines.append(f"  former SWMR writer (flush per row), {n_old} rows: "
                 f"{ta / n_old * 1e6:.0f} us/row")
    return lines


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=8,
                    help="kill/resume chains (default 8: the whole benchmark < 60 s)")
    ap.add_argument("--max-kills", dest="max_kills", type=int, default=3,
                    help="kills per trial (default 3)")
    ap.add_argument("--seed", type=int, default=None,
                    help="random moments (default RT_KILL_SEED or the clock)")
    ap.add_argument("--n", type=int, default=20, help="disks (default 20)")
    ap.add_argument("--rows", type=int, default=100000, help="writer rows (1e5)")
    ap.add_argument("--quick", action="store_true", help="3 trials, 2e4 writer rows")
    ap.add_argument("--out", default=None, help="keep outputs here (default: temp dir)")
    args = ap.parse_args(argv)
    if args.quick:
        args.trials, args.rows = min(args.trials, 3), min(args.rows, 20000)
    seed = args.seed
    if seed is None:
        seed = int(os.environ.get("RT_KILL_SEED", time.time_ns() % 2**31))

    sys.path.insert(0, ROOT)
    import numpy as np
    from tests.driver import test_kill as K
    from remote_trigger.pywrap.runtime.results import read_all

    t_all = time.perf_counter()
    base = args.out or tempfile.mkdtemp(prefix="bench_kill_")
    if args.out is None:          # (the temporary folder was left behind)
        atexit.register(shutil.rmtree, base, True)
    os.makedirs(base, exist_ok=True)
    print(f"bench_kill: seed {seed} (RT_KILL_SEED={seed} python benchmarks/bench_kill.py "
          f"replays the moments), load average {os.getloadavg()[0]:.2f}")
    for line in bench_writer(base, args.rows, max(1000, args.rows // 50)):
        print(line)

    # ---- packing, relax, reference (all through the command line)
    data = os.path.join(base, "p.data")
    subprocess.run([K.CLI, "generate", "--n", str(args.n), "--seed", "1", "--output", data],
                   check=True, env=K.cli_env(), stdout=subprocess.DEVNULL)
    subprocess.run([K.CLI, "relax", "--datafile", data, "--out", os.path.join(base, "relax"),
                    "--settle-steps", "20000", "--quiet"], check=True, env=K.cli_env(),
                   stdout=subprocess.DEVNULL)
    eq = os.path.join(base, "relax", "relax", "equilibrium.data")
    wall, ra, rd = K.run_reference(eq, os.path.join(base, "reference"))
    ref = (ra, rd)
    neig = sum(k.startswith("eigenvalues/") for k in rd)
    print(f"ramp: N = {args.n}, dF_x = {K.DF:g}, tol = {K.TOL:g}: reference "
          f"{len(rd['steps/F_x'])} steps + {len(rd['bisection/F_x'])} bisections, "
          f"{neig} eigenvalue sets, F_x^c in [{ra['F_x_c_low']!r}, {ra['F_x_c_high']!r}], "
          f"{wall:.2f} s")

    # ---- trials
    print(f"{'trial':>5} {'kills':>5} {'resumes':>7} {'files ok':>8} {'bitwise':>7} "
          f"{'wall[s]':>7}  kill moments [s] after each start (ramp.h5 rows then; - = none)")
    tot = {"kills": 0, "resumes": 0, "files": 0, "bad_files": 0, "mismatch": 0,
           "no_h5": 0, "after_end": 0}
    for trial in range(args.trials):
        rng = np.random.default_rng([seed, trial])
        out = os.path.join(base, f"trial{trial:02d}")
        ctx = f"seed {seed} trial {trial}"
        files_ok, diff = True, []
        try:
            ch = K.ramp_chain(eq, out, rng, wall, max_kills=args.max_kills,
                              first_kill_early=(trial == 0), ctx=ctx)
        except AssertionError as exc:     # an unreadable file or a failed run
            files_ok, ch = False, {"kills": [], "resumes": 0, "files_checked": 0,
                                   "wall": float("nan")}
            print(f"  {exc}")
        if files_ok:
            diff = K.compare_ramp(ref, os.path.join(out, "ramp.h5"), ctx)
        tot["kills"] += len(ch["kills"])
        tot["resumes"] += ch["resumes"]
        tot["files"] += ch["files_checked"]
        tot["bad_files"] += not files_ok
        tot["mismatch"] += bool(diff) or not files_ok
        tot["no_h5"] += sum(1 for k in ch["kills"] if not k[1])
        tot["after_end"] += sum(1 for k in ch["kills"] if k[2] == "complete")
        moments = ", ".join(f"{k[0]:.2f} ({k[3] if k[1] else '-'}"
                            f"{', complete' if k[2] == 'complete' else ''})" for k in ch["kills"])
        print(f"{trial:5d} {len(ch['kills']):5d} {ch['resumes']:7d} "
              f"{'yes' if files_ok else 'NO':>8} {'no' if diff or not files_ok else 'yes':>7} "
              f"{ch['wall']:7.2f}  {moments}")
        for d in diff:
            print(f"      {d}")
    ok = tot["bad_files"] == 0 and tot["mismatch"] == 0
    print(f"total: {args.trials} trials, {tot['kills']} kills ({tot['no_h5']} before ramp.h5 "
          f"existed, {tot['after_end']} after its final write), {tot['resumes']} resumes, "
          f"{tot['files']} file opens (after kills and at the end), "
          f"unreadable files: {tot['bad_files']}, trials differing from the reference: "
          f"{tot['mismatch']}; {'PASS' if ok else 'FAIL'}")
    # the resumed ramps' F_x^c, once more from the files
    fc = {(a["F_x_c_low"], a["F_x_c_high"]) for a, _ in
          (read_all(os.path.join(base, f"trial{t:02d}", "ramp.h5"))
           for t in range(args.trials)
           if os.path.exists(os.path.join(base, f"trial{t:02d}", "ramp.h5")))}
    print(f"distinct F_x^c brackets over the trials: {len(fc)}; total time "
          f"{time.perf_counter() - t_all:.1f} s, load average {os.getloadavg()[0]:.2f}")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
