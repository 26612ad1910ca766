r"""Reference force law for differentiation tests (independent of ``jacobian.py``).

This module recomputes the generalized forces G(q) of a packing straight
from the paper's vector formulas, written separately from the assembly code
and usable with **complex** coordinates, so that the exact derivative follows
from the complex step

.. math::

    \frac{\partial G}{\partial q_k}(q_0) = \frac{\operatorname{Im} G(q_0 + i h e_k)}{h}
    + O(h^2),

with no subtractive cancellation (h = 1e-30 gives machine precision).

The history follows the update rule (Eq. 14): with the reference
configuration q0 and its stored tangential displacements xi0,

.. math::

    \xi(q) = \xi_0 + s(q_0)\cdot[(r_i - r_{i,0}) - (r_j - r_{j,0})]
             + (\phi_i - \phi_{i,0}) + (\phi_j - \phi_{j,0}),

then the Coulomb cap |ξ| ≤ t*(δ(q)) is applied. To first order in q − q0
this is the pair style's increment (it uses s at the new positions, which
differs at second order only). Everything is written to be analytic along
the complex step:

* the distance is ``sqrt(dx**2 + dy**2)`` (complex square root), not ``abs``;
* ``|ξ|`` is ``ξ * sign(Re ξ)``, the analytic continuation of the absolute
  value away from 0 (at ξ = 0 the force is linear in ξ, so either choice of
  the sign gives the right derivative);
* branch decisions (cap or not, contact or not, minimum image) are taken on
  real parts, so the derivative is the one-sided derivative of the branch the
  real configuration is on — the capped branch for a capped contact, which
  is the "stays capped" rule of docs/model.md section 7.

The forces are assembled as vectors: F_n = k_n δ^{3/2} n (Eq. 1),
t = ξ s, F_t = −k_t δ^{1/2} g(u) t (Eq. 3) and the torque from the cross
product T_i = −R_i (n × F_t)·z (Eq. 31), for disk j with n → −n,
F_t → −F_t.
"""
from __future__ import annotations

import numpy as np

__all__ = ["ReferenceSystem", "reference_forces", "complex_step_jacobian"]


class ReferenceSystem:
    """A packing described by plain arrays, for :func:`reference_forces`.

    Parameters
    ----------
    positions : array_like, shape (N, 2)
        Reference centres r_0 (real).
    radii : array_like, shape (N,)
    pairs : array_like of int, shape (C, 2)
        Disk index pairs (i, j) in contact.
    xi0 : array_like, shape (C,)
        Stored tangential displacement of each pair, along s = (n_y, -n_x),
        n = (r_i - r_j)/|r_i - r_j| (length).
    k_n, k_t, mu : float
        Contact parameters (Eqs. 1-3).
    box_x : float or None
        Period in x (None: not periodic).
    wall_y : float or None
        Height of the flat wall.
    wall_disks : array_like of int, shape (W,), optional
        Disks touching the wall.
    wall_xi0 : array_like, shape (W,), optional
        Their stored tangential displacements (along +x).
    """

    def __init__(self, positions, radii, pairs, xi0, k_n, k_t, mu, box_x=None, wall_y=None,
                 wall_disks=(), wall_xi0=()):
        self.r0 = np.array(positions, dtype=np.float64).reshape(-1, 2)
        self.R = np.array(radii, dtype=np.float64).reshape(-1)
        self.pairs = np.array(pairs, dtype=np.int64).reshape(-1, 2)
        self.xi0 = np.array(xi0, dtype=np.float64).reshape(-1)
        self.k_n, self.k_t, self.mu = float(k_n), float(k_t), float(mu)
        self.box_x = None if box_x is None else float(box_x)
        self.wall_y = None if wall_y is None else float(wall_y)
        self.wall_disks = np.array(wall_disks, dtype=np.int64).reshape(-1)
        self.wall_xi0 = np.array(wall_xi0, dtype=np.float64).reshape(-1)
        if self.xi0.size != self.pairs.shape[0]:
            raise ValueError(f"xi0 has {self.xi0.size} entries for {self.pairs.shape[0]} pairs")
        if self.wall_xi0.size != self.wall_disks.size:
            raise ValueError(f"wall_xi0 has {self.wall_xi0.size} entries for "
                             f"{self.wall_disks.size} wall disks")
        # reference geometry (real): periodic shift and the s used by the update rule
        i, j = self.pairs[:, 0], self.pairs[:, 1]
        d0 = self.r0[i] - self.r0[j]
        self.shift = np.zeros(len(i))
        if self.box_x is not None:
            self.shift = -self.box_x * np.round(d0[:, 0] / self.box_x)
            d0 = d0 + np.column_stack([self.shift, np.zeros(len(i))])
        rho0 = np.sqrt(d0[:, 0] ** 2 + d0[:, 1] ** 2)
        self.s0 = np.column_stack([d0[:, 1] / rho0, -d0[:, 0] / rho0])

    @property
    def q0(self):
        """Reference generalized coordinates (x, y, phi = 0) per disk, shape (3N,)."""
        q = np.zeros((self.R.size, 3))
        q[:, :2] = self.r0
        return q.reshape(-1)

    @classmethod
    def from_state(cls, state):
        """Build from a :class:`~remote_trigger.analysis.state.state.State` (its arrays only)."""
        p = state.params
        return cls(state.positions, state.radii,
                   np.column_stack([state.contact_i, state.contact_j]), state.contact_xi,
                   p.k_n, p.k_t, p.mu,
                   box_x=float(state.box_length[0]) if state.periodic[0] else None,
                   wall_y=state.wall_y, wall_disks=state.wall_index, wall_xi0=state.wall_xi)


def _abs_analytic(z):
    """|z| continued analytically along a complex step: z * sign(Re z)."""
    return z * np.sign(np.real(z))


def _tangential(k_n, k_t, mu, delta, xi_trial):
    """(g(u) * xi) * (-k_t delta^{1/2}) after the cap; complex-safe."""
    tstar = mu * k_n * delta / k_t
    over = np.real(_abs_analytic(xi_trial)) > np.real(tstar)
    sgn = np.sign(np.real(xi_trial))
    xi = np.where(over, sgn * tstar, xi_trial)
    u = _abs_analytic(xi) / tstar
    return -k_t * np.sqrt(delta) * (1.0 + u - u ** 2) * xi


def reference_forces(system, q):
    """Generalized forces G(q) = (F_x, F_y, T/R) per disk; complex-safe.

    Parameters
    ----------
    system : ReferenceSystem
    q : array_like, shape (3N,), real or complex
        Generalized coordinates (x, y, phi = R theta) per disk; the history is
        advanced from ``system.q0`` by the update rule (module docstring).

    Returns
    -------
    ndarray, shape (3N,), dtype of q (complex if q is complex)
        Contact forces only (constant external loads do not affect K).
    """
    sysm = system
    q = np.asarray(q)
    dtype = np.result_type(q.dtype, np.float64)
    qq = q.astype(dtype).reshape(-1, 3)
    N = sysm.R.size
    if qq.shape[0] != N:
        raise ValueError(f"q must have 3N = {3 * N} entries, got {q.size}")
    F = np.zeros((N, 2), dtype=dtype)
    T = np.zeros(N, dtype=dtype)
    dq = qq - sysm.q0.reshape(-1, 3)
    frictional = sysm.k_t > 0 and sysm.mu > 0

    if sysm.pairs.shape[0]:
        i, j = sysm.pairs[:, 0], sysm.pairs[:, 1]
        dx = qq[i, 0] - qq[j, 0] + sysm.shift
        dy = qq[i, 1] - qq[j, 1]
        rho = np.sqrt(dx * dx + dy * dy)
        nvec = np.stack([dx / rho, dy / rho], axis=1)
        svec = np.stack([nvec[:, 1], -nvec[:, 0]], axis=1)
        delta = sysm.R[i] + sysm.R[j] - rho
        touching = np.real(delta) > 0
        delta_safe = np.where(touching, delta, 1.0)
        Fn = (sysm.k_n * delta_safe ** 1.5)[:, None] * nvec
        if frictional:
            slip = ((dq[i, 0] - dq[j, 0]) * sysm.s0[:, 0] + (dq[i, 1] - dq[j, 1]) * sysm.s0[:, 1]
                    + dq[i, 2] + dq[j, 2])
            coef = _tangential(sysm.k_n, sysm.k_t, sysm.mu, delta_safe, sysm.xi0 + slip)
            tvec = svec                      # t = xi s; coef already carries xi
            Ft = coef[:, None] * tvec
        else:
            Ft = np.zeros_like(Fn)
        Fi = np.where(touching[:, None], Fn + Ft, 0.0)
        Fti = np.where(touching[:, None], Ft, 0.0)
        # torque: T_i = -R_i (n x F_t)_z ; T_j = -R_j ((-n) x (-F_t))_z
        cross = nvec[:, 0] * Fti[:, 1] - nvec[:, 1] * Fti[:, 0]
        for c in range(2):
            np.add.at(F[:, c], i, Fi[:, c])
            np.add.at(F[:, c], j, -Fi[:, c])
        np.add.at(T, i, -sysm.R[i] * cross)
        np.add.at(T, j, -sysm.R[j] * cross)

    if sysm.wall_disks.size:
        w = sysm.wall_disks
        delta = sysm.R[w] - (qq[w, 1] - sysm.wall_y)
        touching = np.real(delta) > 0
        delta_safe = np.where(touching, delta, 1.0)
        fy = np.where(touching, sysm.k_n * delta_safe ** 1.5, 0.0)
        if frictional:
            coef = _tangential(sysm.k_n, sysm.k_t, sysm.mu, delta_safe,
                               sysm.wall_xi0 + dq[w, 0] + dq[w, 2])
            fx = np.where(touching, coef, 0.0)
        else:
            fx = np.zeros_like(fy)
        np.add.at(F[:, 0], w, fx)
        np.add.at(F[:, 1], w, fy)
        # n = +y, F_t = (fx, 0): T = -R (n x F_t)_z = -R (0*0 - 1*fx) = R fx
        np.add.at(T, w, sysm.R[w] * fx)

    G = np.empty((N, 3), dtype=dtype)
    G[:, :2] = F
    G[:, 2] = T / sysm.R
    return G.reshape(-1)


def complex_step_jacobian(fun, q0, h=1e-30, columns=None):
    """dG/dq by the complex step, column by column.

    Parameters
    ----------
    fun : callable
        Maps q (shape (n,), complex) to G (shape (m,), complex), analytic.
    q0 : array_like, shape (n,)
        Real point of evaluation.
    h : float, optional
        Imaginary step (default 1e-30; any h below ~1e-8 |q| is exact to
        rounding because there is no subtraction).
    columns : iterable of int, optional
        Only these columns (default all).

    Returns
    -------
    ndarray, shape (m, n) (or (m, len(columns)))
        The derivative matrix dG/dq (note: K = -dG/dq).
    """
    q0 = np.asarray(q0, dtype=np.float64)
    cols = range(q0.size) if columns is None else list(columns)
    out = []
    for k in cols:
        q = q0.astype(np.complex128)
        q[k] += 1j * h
        out.append(np.imag(fun(q)) / h)
    return np.column_stack(out)
