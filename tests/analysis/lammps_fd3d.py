"""Finite differences of the 3D generalized forces *through LAMMPS itself*.

The 3D counterpart of ``lammps_fd``: with no time-integration fix, ``run 1``
computes forces at the current positions after the pair style has advanced
each contact's history by its own rule (t projected onto the current tangent
plane, then + dt P[(v_i - v_j) - (R_i om_i + R_j om_j) x n]). To displace
q_k by h:

* x, y or z: add h to the position and set that velocity component to h / dt;
* phi_a = R theta_a: nothing moves; set omega_a = h / (R dt);

then ``run 1`` and read f and torque / R; positions, velocities, spins and
the pair's history (``i2_mindlin_partner``, ``d2_mindlin_t{x,y,z}``) are
restored before the next displacement. Serial runs only.

The packing is settled on a floor which is then removed: the finite
differences test the sphere-sphere blocks (the wall blocks are tested
against the complex step and, in a plane, against the 2D wall; the wall's
3D history, d2_mindlin_wall_t_<ID>, is writable too, but it is not
restored here).
"""
from mpi4py import MPI  # noqa: F401  (loads libmpi before liblammps)

import numpy as np

from remote_trigger.analysis.state.state import ContactParams
from remote_trigger.analysis.state.state3d import build_state3d

from ..plugin.lmputil import HIST_3D, KN, KT, MU, gather, history_3d, new_lammps
from ..plugin.lmputil import settled_packing_3d

DT = 5e-4
NAMES = ("x", "v", "omega", "i2_mindlin_partner", "d2_mindlin_tx", "d2_mindlin_ty",
         "d2_mindlin_tz")


def sheared_packing_3d(n=27, seed=2, shear=0.4, steps=6000):
    """Settle n spheres on a floor, push the upper ones sideways, remove the
    floor and the integrator; zero velocities. Returns the LAMMPS instance."""
    lmp = new_lammps()
    settled_packing_3d(lmp, n, seed, steps=steps, shear=shear, hist=HIST_3D)
    lmp.commands_list(["unfix wall", "unfix nve", "velocity all set 0.0 0.0 0.0",
                       "set group all omega 0.0 0.0 0.0", f"timestep {DT!r}", "run 0"])
    return lmp


def state_from_lammps(lmp):
    """The :class:`State3D` of the instance: positions, radii, the pair's history
    (each contact from the side with the smaller id; the mirror t_ji = -t_ij
    checked)."""
    ids = gather(lmp, "id", 1, dtype=0).astype(np.int64)
    x, r = gather(lmp, "x", 3), gather(lmp, "radius", 1)
    part = gather(lmp, "i2_mindlin_partner", 8, dtype=0).astype(np.int64)
    t = history_3d(lmp)
    boxlo, boxhi, _, _, _, periodicity, _ = lmp.extract_box()
    index = {int(a): k for k, a in enumerate(ids)}
    pairs, pt = [], []
    for k, a in enumerate(ids):
        for s in range(part.shape[1]):
            b = int(part[k, s])
            if b == 0 or b < a:
                continue
            mirror = np.nonzero(part[index[b]] == a)[0]
            assert mirror.size == 1, (a, b)
            np.testing.assert_allclose(t[index[b], mirror[0]], -t[k, s], rtol=0,
                                       atol=1e-9 * max(1e-300, np.abs(t[k, s]).max()))
            pairs.append((a, b))
            pt.append(t[k, s])
    return build_state3d(ids=ids, positions=x, radii=r, masses=np.ones(ids.size),
                         box_lo=boxlo, box_hi=boxhi, params=ContactParams(KN, KT, MU),
                         periodic=tuple(bool(p) for p in periodicity),
                         pairs=np.array(pairs).reshape(-1, 2), pair_t=np.array(pt).reshape(-1, 3))


class LammpsFD3D:
    """Central differences of G = (F, T/R) per sphere, in ascending-id dof order."""

    def __init__(self, lmp):
        self.lmp = lmp
        self.nl = lmp.extract_global("nlocal")
        tag = np.asarray(lmp.numpy.extract_atom("id"))[:self.nl].copy()
        self.order = np.argsort(tag)
        self.R = np.asarray(lmp.numpy.extract_atom("radius"))[:self.nl].copy()
        self.saved = {nm: np.array(self._arr(nm)[:self.nl]).copy() for nm in NAMES}
        self.saved["v"][:] = 0.0
        self.saved["omega"][:] = 0.0
        self.restore()
        self.lmp.command("run 0")

    def _arr(self, name):
        return self.lmp.numpy.extract_atom(name)

    def restore(self):
        for nm in NAMES:
            self._arr(nm)[:self.nl] = self.saved[nm]

    def forces(self):
        f = np.asarray(self._arr("f"))[:self.nl]
        tq = np.asarray(self._arr("torque"))[:self.nl] / self.R[:, None]
        return np.column_stack([f, tq])[self.order].reshape(-1)

    def evaluate(self, dof=None, h=0.0):
        """G after displacing ``dof`` by h through one step (state restored after)."""
        if dof is not None:
            loc = self.order[dof // 6]
            c = dof % 6
            if c < 3:
                self._arr("x")[loc, c] += h
                self._arr("v")[loc, c] = h / DT
            else:
                self._arr("omega")[loc, c - 3] = h / (self.R[loc] * DT)
        self.lmp.command("run 1 pre no post no")
        g = self.forces()
        self.restore()
        return g

    def jacobian(self, h):
        """K_fd = -dG/dq by central differences with step h (6N x 6N)."""
        n = 6 * self.nl
        D = np.empty((n, n))
        for q in range(n):
            D[:, q] = (self.evaluate(q, h) - self.evaluate(q, -h)) / (2.0 * h)
        return -D
