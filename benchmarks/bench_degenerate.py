"""Benchmark: the certified verdict on degenerate spectra (tiled and ordered
packings) against random packings of the same size, dense and sliced, side by
side in one run.

The states (``degenerate.py``, cached), for c = 3, 5 and 11 copies:

* ``tiled<c>_F0`` and ``tiled<c>_F0.0625``: c exact copies of the default
  job's N = 100 packing side by side along x, at F_x = 0 (near-double
  eigenvalues: the Bloch sectors +-k) and at F_x = 0.0625 (the copies
  complex: the sectors split at first order, while the single cell is real);
* ``hex<n_x>x<rows>``: an ordered packing of equal disks on a triangular
  lattice with about as many dofs, relaxed by the default protocol, at F_x = 0
  (it has no equilibrium at the first quasi-static step F_x = 2.5e-4: damped
  dynamics stalls at a residual of 1.5e-5, the rows slide; so no loaded state);
* ``random<100c>`` and ``random<100c>_F0.002``: ``generate --seed 2``,
  relaxed, at F_x = 0 and brought to F_x = 0.002 (below its F_x^c, a skew
  part like a ramp point's): the reference of each size and load.

For each state: the dense decision from dgeev (``classify_spectrum``), the
sliced whole-spectrum verdict (``classify_sliced``) and the sliced verdict
only (``stop_at_complex=True``, what a ramp asks); CPU seconds on one BLAS
thread, the verdict, and the time over that of the random state of the same
size and load (the goal: within 3x). Each call runs in a process of its own,
stopped after ``--timeout`` seconds of wall time (reported as ``>T``). The
sliced column adds its strips (m: count).

    python benchmarks/bench_degenerate.py [--quick] [--copies 3 5 11] [--timeout 900]

``--quick``: 3 copies and N = 300 at F_x = 0.0625 / 0.002 only, a timeout of
120 s (a smoke run: the sliced whole-spectrum scan of the tiled state is
reported as timed out if it takes longer).
"""
import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import json
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import degenerate  # noqa: E402

#: load of the random comparison state (below its F_x^c ~ 0.004 at N = 300 - 500)
FX_RANDOM = 0.002
#: the ordered packing of about 100 c disks: n_x x rows
HEX = {3: (20, 14), 5: (26, 18), 11: (38, 29)}
PATHS = ("dense", "sliced", "verdict")


def measure(name, path):
    """(CPU seconds, verdict label, note) of one path on the state ``name``."""
    from remote_trigger.analysis.stability import eigen
    from remote_trigger.analysis.stability.exceptional import classify_spectrum
    from remote_trigger.analysis.stability.sliced import SlicedStats, classify_sliced

    K, mass, _ = degenerate.matrix(name)
    if path == "dense":
        c0 = time.process_time()
        dec = classify_spectrum(eigen.dynamical_matrix(K, mass).toarray())
        return time.process_time() - c0, dec.decision.label, ""
    st = SlicedStats()
    c0 = time.process_time()
    dec = classify_sliced(K, mass, stats=st, stop_at_complex=path == "verdict")
    big = {m: c for m, c in st.strips.items() if m > 1}
    return (time.process_time() - c0, dec.decision.label,
            f"{st.slices} slices, strips m>1 {big}")


def run_cell(name, path, timeout):
    """``measure`` in a process of its own; (seconds or None if stopped, label, note)."""
    cmd = [sys.executable, os.path.abspath(__file__), "--cell", name, path]
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout,
                             check=True).stdout
    except subprocess.TimeoutExpired:
        return None, "stopped", f"not finished after {timeout:g} s"
    except subprocess.CalledProcessError as exc:
        return None, "failed", exc.stderr.strip().splitlines()[-1][:120]
    t, label, note = json.loads(out.strip().splitlines()[-1])
    return t, label, note


def states(c, quick):
    """(name, reference name) of the states of c copies' size."""
    ref0, ref1 = f"random{100 * c}", f"random{100 * c}_F{FX_RANDOM:g}"
    loaded = [(ref1, ref1), (f"tiled{c}_F{degenerate.FX_LOADED:g}", ref1)]
    if quick:
        return loaded
    nx, rows = HEX[c]
    return [(ref0, ref0), (f"tiled{c}_F0", ref0), (f"hex{nx}x{rows}", ref0)] + loaded


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true",
                    help="3 copies at F_x > 0 only, timeout 120 s")
    ap.add_argument("--copies", type=int, nargs="+", default=[3, 5, 11],
                    choices=sorted(HEX))
    ap.add_argument("--timeout", type=float, default=None,
                    help="wall seconds per call (default 900, --quick 120)")
    ap.add_argument("--cell", nargs=2, metavar=("STATE", "PATH"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.cell:
        print(json.dumps(measure(*args.cell)))
        return 0
    timeout = args.timeout or (120.0 if args.quick else 900.0)
    if not timeout > 0:
        ap.error(f"--timeout must be > 0, got {timeout}")
    copies = [3] if args.quick else args.copies
    rows = []
    for c in copies:
        cells = {}
        for name, ref in states(c, args.quick):
            degenerate.build(name)             # (cached; built outside the timed calls)
            K, _, _ = degenerate.matrix(name)
            cells[name] = {"n": K.shape[0], **{p: run_cell(name, p, timeout) for p in PATHS}}
            rows.append((name, ref, cells))
            print(f"{name} done", file=sys.stderr, flush=True)
    print("certified verdict, degenerate (tiled, ordered) vs random packings; CPU s on one "
          "BLAS thread (x: over the random state of the same size and load)")
    print(f"{'state':>20} {'dofs':>5}  {'dense':>24}  {'sliced (whole)':>24}  "
          f"{'sliced (verdict only)':>24}  sliced strips")
    for name, ref, cells in rows:
        r, out = cells[name], []
        for p in PATHS:
            t, v, _ = r[p]
            t0 = cells[ref][p][0]
            ratio = f"x{t / t0:5.1f}" if t is not None and t0 else "     -"
            out.append(f"{t:8.2f} {v:>9} {ratio}" if t is not None
                       else f"{'>' + format(timeout, 'g'):>8} {v:>9}      -")
        print(f"{name:>20} {r['n']:5d}  " + "  ".join(out) + f"  {r['sliced'][2]}")
    print(f"tiled<c>_F<F_x>: c exact copies of the default job's N = 100 packing "
          f"(generate --seed 1, relaxed, brought to F_x); hex<n_x>x<rows>: equal disks on a "
          f"triangular lattice, relaxed; random<N>[_F{FX_RANDOM:g}]: generate --seed 2 --n N, "
          f"relaxed [and brought to F_x = {FX_RANDOM:g}]")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
