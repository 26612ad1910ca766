"""The relaxed 2D packing of ``bench_pair.py`` (disks).

Bidisperse disks (R = 0.5 / 0.7 in equal numbers, mass 1) in a box periodic
in x, on a flat wall at y = 0 (``fix wall/mindlin/smooth yplane``), under a
downward force per disk.  The base of ``BASE_N`` disks is settled once,
frictionless, with viscous damping: a force-balanced packing with zero
history.  Larger N are copies of the base side by side along x (periodic).
The settling run and the copies are those of ``packing_base.py``, shared
with ``packing3d.py``.

Not a benchmark of its own (no ``bench_`` prefix); as in ``packing3d.py``
the LAMMPS set-up is passed in by ``bench_pair.py``, which this module never
imports.
"""
import os
import shutil
import tempfile

import packing_base

#: version of the packing recipe; bump to invalidate cached data files
PACKING_VERSION = 1

#: base packing, relaxed once; larger N are periodic copies of it along x
BASE_N = 10000


def packing_path(cache, n, seed):
    """Cached data file of the N-disk packing (n = 'base' for the relaxed base)."""
    return os.path.join(cache, f"packing_v{PACKING_VERSION}_s{seed}_n{n}.data")


def make_base(cache, seed, setup, verbose=True):
    """Relax the base packing of BASE_N disks and write it to the cache.

    Disks start on staggered rows (spacing 1.45 x 1.26, no overlaps, jitter
    +-0.01, types shuffled), fall under a downward force 1 with viscous
    damping, frictionless (k_t = 0) so that the final state is a force-balanced
    packing with no tangential history, then are relaxed with stronger
    damping until the kinetic energy is tiny.  ``setup``: as for
    :func:`packing3d.make_base`, with ``hist_fix`` (the fix property/atom
    command of the history).  Serial.
    """
    import numpy as np

    rng = np.random.default_rng(seed)
    n, radii = BASE_N, setup["radii"]
    ncols = 80
    dx, dy = 1.45, 1.26
    width = ncols * dx
    nrows = -(-n // ncols)
    top = 0.75 + dy * nrows
    types = np.where(rng.permutation(n) % 2 == 0, 1, 2)
    k = np.arange(n)
    row, col = k // ncols, k % ncols
    x = (col + 0.5 * (row % 2) + 0.25) * dx + rng.uniform(-0.01, 0.01, n)
    y = 0.75 + dy * row + rng.uniform(-0.01, 0.01, n)

    tmp = tempfile.mkdtemp(prefix="bench-pack-", dir=cache)
    raw = os.path.join(tmp, "raw.data")
    with open(raw, "w") as fh:
        fh.write(f"bench_pair.py base packing, seed {seed}\n\n{n} atoms\n2 atom types\n\n")
        fh.write(f"0 {width!r} xlo xhi\n-1 {top + 5.0!r} ylo yhi\n-0.5 0.5 zlo zhi\n\n")
        fh.write("Atoms # sphere\n\n")
        for a in range(n):
            t = int(types[a])
            fh.write(f"{a + 1} {t} {2 * radii[t]!r} 1.0 {float(x[a])!r} {float(y[a])!r} 0.0\n")
    # density column is mass/volume for spheres in data files; settle() sets
    # every mass to 1

    try:
        packing_base.settle(setup, raw, tmp, packing_path(cache, "base", seed),
                            ([setup["hist_fix"], f"read_data {raw} fix hist NULL hist"],
                             ["fix nve all nve/sphere disc", "fix 2d all enforce2d"]),
                            "base packing", verbose)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def make_packing(cache, n, seed, setup, verbose=True):
    """Data file of the N-disk packing: N/BASE_N copies of the base along x.

    The base is periodic in x, so copies side by side are again a relaxed
    packing.  The file has no history section (history starts at zero) and
    small seeded random velocities (|v| ~ 1e-3, omega = 0), the same for both
    styles, so that the run is not trivially static.
    """
    if n % BASE_N:
        raise ValueError(f"N must be a multiple of {BASE_N}, got {n}")
    base = packing_path(cache, "base", seed)
    if not os.path.exists(base):
        make_base(cache, seed, setup, verbose)
    packing_base.tile(base, packing_path(cache, n, seed), n, BASE_N, seed, 2,
                      "bench_pair.py packing")
