"""The relaxed 3D packing of ``bench_pair.py --dim 3`` (spheres).

Bidisperse spheres (R = 0.5 / 0.7 in equal numbers, mass 1) in a box
periodic in x and z, on a flat wall at y = 0 (``fix wall/mindlin/smooth
yplane``), under a downward force per sphere.  The base of ``BASE_N``
spheres is settled once, frictionless (k_t = mu = 0, so the history stays
zero) with viscous damping, then relaxed with stronger damping: a
force-balanced packing with zero history.  Larger N are copies of the base
side by side along x (periodic), as in 2D.

Not a benchmark of its own (no ``bench_`` prefix, so ``run_all.py`` does not
run it); the LAMMPS set-up (instance, header commands, constants) is passed
in by ``bench_pair.py`` so that this module never imports it.
"""
import os
import shutil
import tempfile
import time

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
    # the mass is reset below with 'set ... mass 1'

    kn = setup["kn"]
    lmp = setup["new_lammps"](os.path.join(tmp, "log.lammps"))
    t0 = time.perf_counter()
    try:
        lmp.commands_list(setup["header"] + [
            f"read_data {raw}",
            "set group all mass 1.0",
            f"neighbor {setup['skin']} bin",
            "neigh_modify delay 0 every 1 check yes",
            "pair_style mindlin/smooth",
            f"pair_coeff * * {kn!r} 0.0 0.0",
            f"fix wall all wall/mindlin/smooth {kn!r} 0.0 0.0 yplane 0.0",
            "fix load all addforce 0.0 -1.0 0.0",
            "fix nve all nve/sphere",
            "fix damp all viscous 0.5",
            "timestep 1e-3",
            "thermo_style custom step ke f_wall[2]",
            "thermo 2000",
        ])
        # fall: terminal speed 2, about 20 time units for the top to land
        lmp.command("run 25000")
        if verbose:
            print(f"  3D base packing: fall done, ke/atom = {lmp.get_thermo('ke'):.3g}"
                  f" ({time.perf_counter() - t0:.0f} s)", flush=True)
        lmp.commands_list(["unfix damp", "fix damp all viscous 5.0", "run 10000"])
        if verbose:
            print(f"  3D base packing: relaxed, ke/atom = {lmp.get_thermo('ke'):.3g}, wall "
                  f"load {lmp.extract_fix('wall', 0, 1, 1):.6g} (expected {n})"
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
    """Data file of the N-sphere packing: N/BASE_N copies of the base along x.

    No history section (history starts at zero); small seeded random
    velocities (|v| ~ 1e-3, omega = 0), the same for both styles.
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
    bounds = {}
    for ax in "xyz":
        s = next(s for s in lines if s.endswith(f"{ax}lo {ax}hi"))
        bounds[ax] = tuple(float(v) for v in s.split()[:2])
    ia = next(k for k, s in enumerate(lines) if s.startswith("Atoms"))
    atoms = []
    for line in lines[ia + 2:ia + 2 + BASE_N]:
        w = line.split()
        # id type diameter density x y z ix iy iz
        atoms.append((int(w[0]), int(w[1]), w[2], w[3], float(w[4]), w[5], w[6]))
    atoms.sort()
    (xlo, xhi), (ylo, yhi), (zlo, zhi) = bounds["x"], bounds["y"], bounds["z"]
    width = xhi - xlo
    rng = np.random.default_rng(seed + 1000 * reps)
    vel = rng.normal(0.0, 1e-3, size=(n, 3))
    path = packing_path(cache, n, seed)
    tmp = path + ".tmp"
    with open(tmp, "w") as fh:
        fh.write(f"bench_pair.py 3D packing: {reps} copies along x of the relaxed base "
                 f"packing (seed {seed})\n\n{n} atoms\n2 atom types\n\n")
        fh.write(f"{xlo!r} {xlo + reps * width!r} xlo xhi\n{ylo!r} {yhi!r} ylo yhi\n"
                 f"{zlo!r} {zhi!r} zlo zhi\n\nAtoms # sphere\n\n")
        for c in range(reps):
            for (tag, typ, diam, dens, x, y, z) in atoms:
                fh.write(f"{tag + c * BASE_N} {typ} {diam} {dens} {x + c * width!r} {y} {z} "
                         "0 0 0\n")
        fh.write("\nVelocities\n\n")
        for k in range(n):
            v = vel[k]
            fh.write(f"{k + 1} {float(v[0])!r} {float(v[1])!r} {float(v[2])!r} 0 0 0\n")
    os.replace(tmp, path)
