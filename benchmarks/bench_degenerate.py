"""Benchmark: the certified verdict on degenerate spectra (tiled packings) against
random packings of the same size, dense and sliced, side by side in one run.

The states (``degenerate.py``, cached): c copies of the default job's N = 100
packing side by side along x (exact copies) at F_x = 0 (near-double real
eigenvalues: the Bloch sectors +-k) and at F_x = 0.0625 (the copies complex:
the sectors split at first order, while the single cell is real), and a
random packing of the same size (``generate --seed 2``, relaxed, brought to
F_x = 0.002 below its F_x^c, so that its skew part is a ramp point's).

For each state: the dense decision from dgeev (``classify_spectrum``), the
sliced whole-spectrum verdict (``classify_sliced``) and the sliced verdict
only (``stop_at_complex=True``, what a ramp asks), CPU seconds on one BLAS
thread, the verdict, and the time over that of the random state of the same
size (the goal: within 3x). The sliced column adds its strips (m: count).

    python benchmarks/bench_degenerate.py [--quick] [--copies 3 5]

``--quick``: 3 copies and N = 300 only (about 3 min of CPU, most of it the
sliced whole-spectrum scan of 3 copies at F_x = 0.0625: 279 complex pairs).
"""
import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import degenerate  # noqa: E402

#: load of the random comparison state (below its F_x^c ~ 0.004 at N = 300 - 500)
FX_RANDOM = 0.002


def _verdict(dec):
    return dec.decision.label


def measure(name):
    """CPU seconds and verdicts of the three calls on the state ``name``."""
    from remote_trigger.analysis.stability import eigen
    from remote_trigger.analysis.stability.exceptional import classify_spectrum
    from remote_trigger.analysis.stability.sliced import SlicedStats, classify_sliced

    K, mass, _ = degenerate.matrix(name)
    row = {"name": name, "n": K.shape[0]}
    c0 = time.process_time()
    dec = classify_spectrum(eigen.dynamical_matrix(K, mass).toarray())
    row["dense"] = (time.process_time() - c0, _verdict(dec), "")
    for key, stop in (("sliced", False), ("verdict", True)):
        st = SlicedStats()
        c0 = time.process_time()
        dec = classify_sliced(K, mass, stats=st, stop_at_complex=stop)
        big = {m: c for m, c in st.strips.items() if m > 1}
        row[key] = (time.process_time() - c0, _verdict(dec),
                    f"{st.slices} slices, strips m>1 {big}")
    return row


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="3 copies and N = 300 only")
    ap.add_argument("--copies", type=int, nargs="+", default=[3, 5])
    args = ap.parse_args(argv)
    copies = [3] if args.quick else args.copies
    rows = []
    for c in copies:
        ref = measure(f"random{100 * c}_F{FX_RANDOM:g}")
        rows.append((ref, ref))
        for F_x in (degenerate.FX_LOADED, 0.0):
            rows.append((measure(f"tiled{c}_F{F_x:g}"), ref))
            print(f"{rows[-1][0]['name']} done", file=sys.stderr, flush=True)
    print("certified verdict, degenerate (tiled) vs random packings; CPU s on one BLAS "
          "thread (x: over the random state of the same size)")
    print(f"{'state':>18} {'dofs':>5}  {'dense':>22}  {'sliced (whole)':>22}  "
          f"{'sliced (verdict only)':>22}  sliced strips")
    for r, ref in rows:
        cells = []
        for key in ("dense", "sliced", "verdict"):
            t, v, _ = r[key]
            cells.append(f"{t:7.2f} {v:>9} x{t / ref[key][0]:5.1f}")
        print(f"{r['name']:>18} {r['n']:5d}  " + "  ".join(cells) + f"  {r['sliced'][2]}")
    print(f"tiled<c>_F<F_x>: c exact copies of the default job's N = 100 packing "
          f"(generate --seed 1, relaxed, brought to F_x); random<N>_F{FX_RANDOM:g}: "
          f"generate --seed 2 --n N, relaxed, brought to F_x = {FX_RANDOM:g}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
