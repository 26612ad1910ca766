"""The relaxed 2D packing of ``bench_pair.py`` (disks).

Bidisperse disks (R = 0.5 / 0.7 in equal numbers, mass 1) in a box periodic
in x, on a flat wall at y = 0 (``fix wall/mindlin/smooth yplane``), under a
downward force per disk.  The base of ``BASE_N`` disks is settled once,
frictionless, with viscous damping: a force-balanced packing with zero
history.  Larger N are copies of the base side by side along x (periodic).

Not a benchmark of its own (no ``bench_`` prefix); as in ``packing3d.py``
the LAMMPS set-up is passed in by ``bench_pair.py``, which this module never
imports.
"""
import os
import shutil
import tempfile
import time

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
    n, radii, kn = BASE_N, setup["radii"], setup["kn"]
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
    # density column is mass/volume for spheres in data files; the mass is
    # reset below with 'set ... mass 1'

    log = os.path.join(tmp, "log.lammps")
    lmp = setup["new_lammps"](log)
    t0 = time.perf_counter()
    try:
        lmp.commands_list(setup["header"] + [
            setup["hist_fix"],
            f"read_data {raw} fix hist NULL hist",
            "set group all mass 1.0",
            f"neighbor {setup['skin']} bin",
            "neigh_modify delay 0 every 1 check yes",
            "pair_style mindlin/smooth",
            f"pair_coeff * * {kn!r} 0.0 0.0",
            f"fix wall all wall/mindlin/smooth {kn!r} 0.0 0.0 yplane 0.0",
            "fix load all addforce 0.0 -1.0 0.0",
            "fix nve all nve/sphere disc",
            "fix 2d all enforce2d",
            "fix damp all viscous 0.5",
            "timestep 1e-3",
            "thermo_style custom step ke f_wall[2]",
            "thermo 2000",
        ])
        # fall: terminal speed 2, about 20 time units for the top to land
        lmp.command("run 25000")
        if verbose:
            print(f"  base packing: fall done, ke/atom = {lmp.get_thermo('ke'):.3g}"
                  f" ({time.perf_counter() - t0:.0f} s)", flush=True)
        lmp.commands_list(["unfix damp", "fix damp all viscous 5.0", "run 10000"])
        ke = lmp.get_thermo("ke")
        if verbose:
            print(f"  base packing: relaxed, ke/atom = {ke:.3g}, wall load "
                  f"{lmp.extract_fix('wall', 0, 1, 1):.6g} (expected {n})"
                  f" ({time.perf_counter() - t0:.0f} s)", flush=True)
        ytop = float(np.max(lmp.numpy.extract_atom("x")[:, 1]))
        lmp.commands_list([
            f"change_box all y final -1.0 {ytop + 3.0!r} units box",
            "velocity all set 0.0 0.0 0.0",
            "set group all omega 0.0 0.0 0.0",
            f"write_data {packing_path(cache, 'base', seed)} nocoeff",
        ])
    finally:
        lmp.close()
    shutil.rmtree(tmp, ignore_errors=True)


def make_packing(cache, n, seed, setup, verbose=True):
    """Data file of the N-disk packing: N/BASE_N copies of the base along x.

    The base is periodic in x, so copies side by side are again a relaxed
    packing.  The file has no history section (history starts at zero) and
    small seeded random velocities (|v| ~ 1e-3, omega = 0), the same for both
    styles, so that the run is not trivially static.
    """
    import numpy as np

    if n % BASE_N:
        raise ValueError(f"N must be a multiple of {BASE_N}, got {n}")
    base = packing_path(cache, "base", seed)
    if not os.path.exists(base):
        make_base(cache, seed, setup, verbose)
    reps = n // BASE_N
    with open(base) as fh:
        lines = fh.read().splitlines()
    xlo, xhi = (float(v) for v in next(s for s in lines if s.endswith("xlo xhi")).split()[:2])
    ylo, yhi = (float(v) for v in next(s for s in lines if s.endswith("ylo yhi")).split()[:2])
    ia = next(k for k, s in enumerate(lines) if s.startswith("Atoms"))
    atoms = []
    for line in lines[ia + 2:ia + 2 + BASE_N]:
        w = line.split()
        # id type diameter density x y z ix iy iz
        atoms.append((int(w[0]), int(w[1]), w[2], w[3], float(w[4]), w[5]))
    atoms.sort()
    width = xhi - xlo
    rng = np.random.default_rng(seed + 1000 * reps)
    vel = rng.normal(0.0, 1e-3, size=(n, 2))
    path = packing_path(cache, n, seed)
    tmp = path + ".tmp"
    with open(tmp, "w") as fh:
        fh.write(f"bench_pair.py packing: {reps} copies along x of the relaxed base "
                 f"packing (seed {seed})\n\n{n} atoms\n2 atom types\n\n")
        fh.write(f"{xlo!r} {xlo + reps * width!r} xlo xhi\n{ylo!r} {yhi!r} ylo yhi\n"
                 "-0.5 0.5 zlo zhi\n\nAtoms # sphere\n\n")
        for c in range(reps):
            for (tag, typ, diam, dens, x, y) in atoms:
                fh.write(f"{tag + c * BASE_N} {typ} {diam} {dens} {x + c * width!r} {y} 0 "
                         "0 0 0\n")
        fh.write("\nVelocities\n\n")
        for k in range(n):
            fh.write(f"{k + 1} {float(vel[k, 0])!r} {float(vel[k, 1])!r} 0 0 0 0\n")
    os.replace(tmp, path)
