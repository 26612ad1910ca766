"""What the 2D and 3D packings of ``bench_pair.py`` share (``packing2d.py``,
``packing3d.py``): the settling run of the base packing and its periodic copies
along x.  Not a benchmark of its own (no ``bench_`` prefix).
"""
import os
import time


def settle(setup, raw, tmp, out, scene, label, verbose=True):
    """Settle the base packing of data file ``raw`` and write it to ``out``.

    It falls under a downward force 1 per particle with viscous damping 0.5,
    frictionless (k_t = mu = 0, so that the history stays zero) for 25000
    steps, is relaxed with damping 5 for 10000 more, and is written with
    v = omega = 0 and the box cut 3 above its top.

    Parameters
    ----------
    setup : dict
        ``new_lammps`` (log path -> instance), ``header`` (commands before
        the box), ``kn``, ``skin`` (from ``bench_pair.py``).
    raw, out : str
        The data file to read and the one to write.
    tmp : str
        Folder of the LAMMPS log.
    scene : (list of str, list of str)
        The commands that read ``raw`` and the integrator's (2D: the history
        fix, ``nve/sphere disc`` and ``enforce2d``).
    label : str
        Name in the progress lines.
    """
    import numpy as np

    read, integrate = scene
    kn = setup["kn"]
    lmp = setup["new_lammps"](os.path.join(tmp, "log.lammps"))
    t0 = time.perf_counter()
    try:
        lmp.commands_list(setup["header"] + read + [
            "set group all mass 1.0",
            f"neighbor {setup['skin']} bin",
            "neigh_modify delay 0 every 1 check yes",
            "pair_style mindlin/smooth",
            f"pair_coeff * * {kn!r} 0.0 0.0",
            f"fix wall all wall/mindlin/smooth {kn!r} 0.0 0.0 yplane 0.0",
            "fix load all addforce 0.0 -1.0 0.0",
        ] + integrate + [
            "fix damp all viscous 0.5",
            "timestep 1e-3",
            "thermo_style custom step ke f_wall[2]",
            "thermo 2000",
        ])
        # fall: terminal speed 2, about 20 time units for the top to land
        lmp.command("run 25000")
        if verbose:
            print(f"  {label}: fall done, ke/atom = {lmp.get_thermo('ke'):.3g}"
                  f" ({time.perf_counter() - t0:.0f} s)", flush=True)
        lmp.commands_list(["unfix damp", "fix damp all viscous 5.0", "run 10000"])
        if verbose:
            print(f"  {label}: relaxed, ke/atom = {lmp.get_thermo('ke'):.3g}, wall load "
                  f"{lmp.extract_fix('wall', 0, 1, 1):.6g} (expected {lmp.get_natoms()})"
                  f" ({time.perf_counter() - t0:.0f} s)", flush=True)
        ytop = float(np.max(lmp.numpy.extract_atom("x")[:, 1]))
        lmp.commands_list([
            f"change_box all y final -1.0 {ytop + 3.0!r} units box",
            "velocity all set 0.0 0.0 0.0",
            "set group all omega 0.0 0.0 0.0",
            f"write_data {out} nocoeff",
        ])
    finally:
        lmp.close()


def tile(base, path, n, base_n, seed, dim, title):
    """Write ``path``: n / base_n copies of the base packing ``base`` along x.

    No history section (history starts at zero); small seeded random
    velocities (|v| ~ 1e-3, omega = 0), the same for both styles, so that the
    run is not trivially static.  The base is periodic in x, so copies side by
    side are again a relaxed packing.  ``title`` heads the file; ``dim`` 2
    writes z = 0 and a box of z in [-0.5, 0.5].
    """
    import numpy as np

    reps = n // base_n
    with open(base) as fh:
        lines = fh.read().splitlines()
    bounds = {}
    for ax in "xyz":
        s = next(s for s in lines if s.endswith(f"{ax}lo {ax}hi"))
        bounds[ax] = tuple(float(v) for v in s.split()[:2])
    ia = next(k for k, s in enumerate(lines) if s.startswith("Atoms"))
    atoms = []
    for line in lines[ia + 2:ia + 2 + base_n]:
        w = line.split()
        # id type diameter density x y z ix iy iz
        atoms.append((int(w[0]), int(w[1]), w[2], w[3], float(w[4]), w[5],
                      w[6] if dim == 3 else "0"))
    atoms.sort()
    (xlo, xhi), (ylo, yhi), (zlo, zhi) = bounds["x"], bounds["y"], bounds["z"]
    width = xhi - xlo
    rng = np.random.default_rng(seed + 1000 * reps)
    vel = rng.normal(0.0, 1e-3, size=(n, dim))
    zbox = f"{zlo!r} {zhi!r}" if dim == 3 else "-0.5 0.5"
    tmp = path + ".tmp"
    with open(tmp, "w") as fh:
        fh.write(f"{title}: {reps} copies along x of the relaxed base "
                 f"packing (seed {seed})\n\n{n} atoms\n2 atom types\n\n")
        fh.write(f"{xlo!r} {xlo + reps * width!r} xlo xhi\n{ylo!r} {yhi!r} ylo yhi\n"
                 f"{zbox} zlo zhi\n\nAtoms # sphere\n\n")
        for c in range(reps):
            for (tag, typ, diam, dens, x, y, z) in atoms:
                fh.write(f"{tag + c * base_n} {typ} {diam} {dens} {x + c * width!r} {y} {z} "
                         "0 0 0\n")
        fh.write("\nVelocities\n\n")
        for k in range(n):
            v = [repr(float(c)) for c in vel[k]] + (["0"] if dim == 2 else [])
            fh.write(f"{k + 1} {' '.join(v)} 0 0 0\n")
    os.replace(tmp, path)
