"""The relaxed 3D packing of ``bench_pair.py --dim 3`` (spheres).

Bidisperse spheres (R = 0.5 / 0.7 in equal numbers, mass 1) in a box
periodic in x and z, on a flat wall at y = 0 (``fix wall/mindlin/smooth
yplane``), under a downward force per sphere.  The base of ``BASE_N``
spheres is settled once, frictionless (k_t = mu = 0, so the history stays
zero) with viscous damping, then relaxed with stronger damping: a
force-balanced packing with zero history.  Larger N are copies of the base
side by side along x (periodic), as in 2D (``packing_base.py``: the
settling run and the copies, shared with ``packing2d.py``).

Not a benchmark of its own (no ``bench_`` prefix, so ``run_all.py`` does not
run it); the LAMMPS set-up (instance, header commands, constants) is passed
in by ``bench_pair.py`` so that this module never imports it.
"""
import os
import shutil
import tempfile

import packing_base

#: version of the 3D packing recipe; bump to invalidate cached data files
PACKING_VERSION = 1

#: base packing, relaxed once; larger N are periodic copies of it along x
BASE_N = 10000

#: initial lattice: NXZ x NXZ sites per layer, spacing SPACING, odd layers
#: shifted by half a spacing in x and z, jitter +-JITTER (no overlaps:
#: SPACING - 2 JITTER >= 1.4 = the largest diameter)
NXZ = 20
SPACING = 1.6
JITTER = 0.1


def packing_path(cache, n, seed):
    """Cached data file of the N-sphere packing (n = 'base' for the relaxed base)."""
    return os.path.join(cache, f"packing3d_v{PACKING_VERSION}_s{seed}_n{n}.data")


def make_base(cache, seed, setup, verbose=True):
    """Settle the base packing of BASE_N spheres and write it to the cache.

    ``setup`` is a dict with ``new_lammps`` (log path -> instance),
    ``header`` (commands before the box), ``kn``, ``radii`` ({type: R}),
    ``skin``.  Serial.
    """
    import numpy as np

    rng = np.random.default_rng(seed)
    n, radii = BASE_N, setup["radii"]
    per_layer = NXZ * NXZ
    nlayers = -(-n // per_layer)
    width = NXZ * SPACING
    top = 0.8 + SPACING * nlayers
    types = np.where(rng.permutation(n) % 2 == 0, 1, 2)
    k = np.arange(n)
    layer, site = k // per_layer, k % per_layer
    shift = 0.5 * (layer % 2)
    x = (site % NXZ + 0.25 + shift) * SPACING + rng.uniform(-JITTER, JITTER, n)
    z = (site // NXZ + 0.25 + shift) * SPACING + rng.uniform(-JITTER, JITTER, n)
    y = 0.8 + SPACING * layer + rng.uniform(-JITTER, JITTER, n)

    tmp = tempfile.mkdtemp(prefix="bench-pack3d-", dir=cache)
    raw = os.path.join(tmp, "raw.data")
    with open(raw, "w") as fh:
        fh.write(f"bench_pair.py 3D base packing, seed {seed}\n\n{n} atoms\n2 atom types\n\n")
        fh.write(f"0 {width!r} xlo xhi\n-1 {top + 5.0!r} ylo yhi\n0 {width!r} zlo zhi\n\n")
        fh.write("Atoms # sphere\n\n")
        for a in range(n):
            t = int(types[a])
            fh.write(f"{a + 1} {t} {2 * radii[t]!r} 1.0 {float(x[a])!r} {float(y[a])!r} "
                     f"{float(z[a])!r}\n")
    # settle() sets every mass to 1

    try:
        packing_base.settle(setup, raw, tmp, packing_path(cache, "base", seed),
                            ([f"read_data {raw}"],
                             ["fix nve all nve/sphere"]), "3D base packing", verbose)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def make_packing(cache, n, seed, setup, verbose=True):
    """Data file of the N-sphere packing: N/BASE_N copies of the base along x.

    No history section (history starts at zero); small seeded random
    velocities (|v| ~ 1e-3, omega = 0), the same for both styles.
    """
    if n % BASE_N:
        raise ValueError(f"N must be a multiple of {BASE_N}, got {n}")
    base = packing_path(cache, "base", seed)
    if not os.path.exists(base):
        make_base(cache, seed, setup, verbose)
    packing_base.tile(base, packing_path(cache, n, seed), n, BASE_N, seed, 3,
                      "bench_pair.py 3D packing")
