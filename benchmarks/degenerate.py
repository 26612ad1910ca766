"""Degenerate test systems of the certified verdict: tiled packings and random ones.

Not a benchmark of its own (no ``bench_`` prefix): ``bench_degenerate.py``
measures on the states built here, and a profile may load them too.

* ``cell``: the default job's packing (``generate --seed 1``, N = 100,
  relaxed by the default protocol), then brought to F_x = ``FX_LOADED`` by
  quasi-static Newton steps of ``DFX_STEP`` (each from the previous
  equilibrium, damped dynamics where Newton stalls, as a ramp step does).
* ``tiled<c>_F<F_x>``: c copies of the cell's equilibrium at that F_x side by
  side along the periodic x axis (``bench_scale.tiled_packing``, jitter 0:
  exact copies), re-equilibrated at the same F_x (Newton; the copies are an
  equilibrium of the wider box force for force, so this only polishes the
  rounding of the shifted coordinates). Its spectrum is the cell's Bloch
  spectrum: at F_x = 0 pairs of eigenvalues equal to rounding (the sectors
  +-k; dgeev's |Im| <= 3e-15 ||A|| at 3 copies), which the verdict mostly
  leaves undecided (docs/results/analysis.md, "Degenerate spectra"), at
  ``FX_LOADED`` complex (the sectors split at first order).
* ``random<N>``: ``generate --seed 2 --n N``, relaxed (F_x = 0): nearly
  symmetric (no tangential history), so both paths have little to do.
* ``random<N>_F<F_x>``: the same brought to F_x by Newton steps of
  ``DFX_RANDOM`` (below its F_x^c: a skew part like a ramp point's).
* ``hex<n_x>x<rows>``: an ordered packing (:func:`hexagonal`: equal disks
  R = 0.5 on a triangular lattice, ``rows`` rows of ``n_x``, the top row the
  ``top`` line), relaxed by the default protocol; ``hex<n_x>x<rows>_F<F_x>``
  brought to F_x as a random packing is.

Every state is an equilibrium dump with its sidecar, kept under the cache
folder (default ``$REMOTE_TRIGGER_BENCH_CACHE`` or
``~/.cache/remote_trigger/degenerate``) and re-used: ``build(name)``
returns its dump path. ``python benchmarks/degenerate.py NAME ...`` builds
them and prints dofs and residuals.
"""
import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import sys

HERE = os.path.dirname(os.path.abspath(__file__))
if HERE not in sys.path:
    sys.path.insert(0, HERE)

#: recipe version: bump to rebuild cached states
VERSION = 1
#: the loaded state of the issue: the cell is certified real there, its copies complex
FX_LOADED = 0.0625
#: quasi-static step from F_x = 0 to FX_LOADED
DFX_STEP = 2.5e-3
#: quasi-static step of a random packing's load (its F_x^c is ~0.004 at N = 400)
DFX_RANDOM = 2.5e-4
CELL_SEED = 1
RANDOM_SEED = 2


def cache_dir():
    d = os.environ.get("REMOTE_TRIGGER_BENCH_CACHE",
                       os.path.join(os.path.expanduser("~"), ".cache", "remote_trigger",
                                    "degenerate"))
    d = os.path.join(d, f"v{VERSION}")
    os.makedirs(d, exist_ok=True)
    return d


def hexagonal(n_x, rows):
    """An ordered packing: ``rows`` rows of ``n_x`` equal disks (R = 0.5, type 1)
    on a triangular lattice of spacing 2R, the first row on the wall, odd rows
    shifted by R, periodic in x (L = 2 R n_x, n_x even); the top row is the
    ``top`` line (a Packing for ``write_data``; seed -1)."""
    import numpy as np

    from remote_trigger.pywrap.stages.packing import RADII, Packing

    if n_x < 2 or n_x % 2 or rows < 2:
        raise ValueError(f"hexagonal: n_x must be even >= 2 and rows >= 2, got "
                         f"n_x = {n_x}, rows = {rows}")
    R = RADII[0]
    j, i = np.divmod(np.arange(n_x * rows), n_x)
    x = (i + 0.5 * (j % 2) + 0.25) * 2 * R
    y = R + j * np.sqrt(3.0) * R
    n = n_x * rows
    return Packing(positions=np.column_stack([x, y]), radii=np.full(n, R),
                   types=np.ones(n, int), top=j == rows - 1, width=2 * R * n_x,
                   ylo=0.0, yhi=float(y.max() + 10 * R), seed=-1)


def _relax(packing, folder):
    """Relax ``packing`` (a ``Packing``) by the default protocol in ``folder``."""
    from mpi4py import MPI

    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RelaxConfig
    from remote_trigger.pywrap.stages.packing import write_data

    os.makedirs(folder, exist_ok=True)
    data = os.path.join(folder, "p.data")
    write_data(packing, data)
    rel = stages.relax(RelaxConfig(datafile=data), folder, comm=MPI.COMM_SELF, quiet=True)
    return rel.datafile


def equilibrate_at(start, loads, prefix):
    """From the equilibrium ``start``, Newton-first equilibria at each F_x of
    ``loads`` in turn, in one engine; the last is saved as ``prefix.*``."""
    from mpi4py import MPI

    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.stages import equilibrium as eq
    from remote_trigger.pywrap.stages.common import load_relax_scene, save_equilibrium
    from remote_trigger.pywrap.stages.config import RampConfig

    cfg = RampConfig(datafile=start, F_x=0.0)
    with Engine(comm=MPI.COMM_SELF) as eng:
        load_relax_scene(eng, cfg, start, loads[0], deck="in.ramp_step")
        for F in loads:
            r, _, _ = eq.equilibrate(eng, cfg, F, newton_first=True)
        save_equilibrium(eng, cfg, loads[-1], prefix)
    return r


def _cell(F_x):
    d = cache_dir()
    prefix = os.path.join(d, f"cell_F{F_x:g}")
    if not os.path.exists(prefix + ".dump"):
        relaxed = os.path.join(d, "cell_relax", "relax", "equilibrium.data")
        if not os.path.exists(relaxed):
            from remote_trigger.pywrap.stages.packing import generate

            relaxed = _relax(generate(100, seed=CELL_SEED), os.path.join(d, "cell_relax"))
        k = int(round(F_x / DFX_STEP))
        loads = [j * DFX_STEP for j in range(k + 1)]
        loads[-1] = F_x
        equilibrate_at(relaxed, loads, prefix)
    return prefix


def build(name):
    """Dump path of the state ``name``: 'cell_F<F_x>', 'tiled<c>_F<F_x>', 'random<N>',
    'random<N>_F<F_x>', 'hex<n_x>x<rows>', 'hex<n_x>x<rows>_F<F_x>'."""
    import re

    d = cache_dir()
    if m := re.fullmatch(r"cell_F([0-9.e-]+)", name):
        return _cell(float(m.group(1))) + ".dump"
    if m := re.fullmatch(r"tiled(\d+)_F([0-9.e-]+)", name):
        from bench_scale import tiled_packing

        c, F_x = int(m.group(1)), float(m.group(2))
        prefix = os.path.join(d, name)
        if not os.path.exists(prefix + ".dump"):
            cell = _cell(F_x)
            tiled_packing(cell + ".data", c, prefix + ".tiled.data", jitter=0.0)
            equilibrate_at(prefix + ".tiled.data", [F_x], prefix)
        return prefix + ".dump"
    if m := re.fullmatch(r"random(\d+)", name):
        folder = os.path.join(d, name)
        dump = os.path.join(folder, "relax", "equilibrium.dump")
        if not os.path.exists(dump):
            from remote_trigger.pywrap.stages.packing import generate

            _relax(generate(int(m.group(1)), seed=RANDOM_SEED), folder)
        return dump
    if m := re.fullmatch(r"hex(\d+)x(\d+)", name):
        folder = os.path.join(d, name)
        dump = os.path.join(folder, "relax", "equilibrium.dump")
        if not os.path.exists(dump):
            _relax(hexagonal(int(m.group(1)), int(m.group(2))), folder)
        return dump
    if m := re.fullmatch(r"(random\d+|hex\d+x\d+)_F([0-9.e-]+)", name):
        F_x = float(m.group(2))
        prefix = os.path.join(d, name)
        if not os.path.exists(prefix + ".dump"):
            start = build(m.group(1))[:-len(".dump")] + ".data"
            k = max(1, int(round(F_x / DFX_RANDOM)))
            equilibrate_at(start, [F_x * j / k for j in range(k + 1)], prefix)
        return prefix + ".dump"
    raise ValueError(f"degenerate.build: unknown state {name!r} (cell_F<F_x>, "
                     f"tiled<c>_F<F_x>, random<N>, random<N>_F<F_x>, hex<n_x>x<rows>, "
                     f"hex<n_x>x<rows>_F<F_x>)")


def matrix(name):
    """(K on the kept dofs (CSR), mass diagonal, residual) of the state ``name``."""
    from remote_trigger.analysis.stability.system import reduced_system
    from remote_trigger.analysis.state.dumpfile import read_dump

    system = reduced_system(read_dump(build(name)))
    return system.K.tocsr(), system.mass, system.max_residual


if __name__ == "__main__":
    for nm in sys.argv[1:]:
        K, m, r = matrix(nm)
        print(f"{nm}: {build(nm)}: {K.shape[0]} dofs, residual {r:.2e}", flush=True)
