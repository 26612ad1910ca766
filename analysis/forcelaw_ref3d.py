r"""Reference 3D force law for differentiation tests (independent of ``jacobian3d``).

The generalized forces G(q) of a packing of spheres, written from the vector
formulas of docs/model.md section 9 without the assembly code and usable
with **complex** coordinates, so that the complex step

.. math::

    \frac{\partial G}{\partial q_k}(q_0) = \frac{\operatorname{Im} G(q_0 + i h e_k)}{h}
    + O(h^2)

gives the exact derivative (h = 1e-30; see
:func:`remote_trigger.analysis.forcelaw_ref.complex_step_jacobian`).

Coordinates per sphere: q = (x, y, z, phi_x, phi_y, phi_z), phi = R theta
(small rotation vector times R); G = (F, T/R). The history follows the pair
style's step (``mindlin_smooth_kernel_3d.h``, ``step3``) from the reference
configuration q0 with stored t0, taken as one step that displaces q by
q - q0:

.. math::

    t_p = |t_0|\,\frac{P t_0}{|P t_0|}, \qquad
    t = t_p + P\,[(r_i - r_{i,0}) - (r_j - r_{j,0})
        - ((\phi_i - \phi_{i,0}) + (\phi_j - \phi_{j,0})) \times n],

with n and P = 1 - n nᵀ at q (as the pair style: the slip of a step is
projected with the step's normal), then the Coulomb cap |t| ≤ t*; wall: no
j terms and n fixed. Analytic along the complex step:

* lengths are ``sqrt(v . v)`` (complex square root of the bilinear form,
  not ``abs``);
* branch decisions (cap, contact) are taken on real parts, so a capped
  contact stays capped — the rule of docs/model.md section 7.

Forces (Eqs. 1, 3, 31): F_n = k_n δ^{3/2} n, F_t = −k_t δ^{1/2} g(u) t,
u = |t|/t*, on i; T_i = −R_i n × F_t and T_j = −R_j n × F_t, F_j = −F_i.
"""
from __future__ import annotations

import numpy as np

__all__ = ["ReferenceSystem3D", "reference_forces3d"]


def _dot(a, b):
    return np.sum(a * b, axis=-1)


def _cross(a, b):
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


class ReferenceSystem3D:
    """A packing of spheres described by plain arrays, for :func:`reference_forces3d`.

    Parameters
    ----------
    positions : array_like, shape (N, 3)
        Reference centres r_0 (real, length).
    radii : array_like, shape (N,)
    pairs : array_like of int, shape (C, 2)
        Sphere index pairs (i, j) in contact.
    t0 : array_like, shape (C, 3)
        Stored tangential displacement of each pair, seen from i (length).
    k_n, k_t, mu : float
        Contact parameters (Eqs. 1-3).
    box : array_like, shape (3,), optional
        Periods (None or 0 entries: not periodic along that axis).
    wall_spheres : array_like of int, shape (W,), optional
    wall_normal : array_like, shape (W, 3), optional
        Unit normal of each wall contact's plane, into the sphere.
    wall_offset : array_like, shape (W,), optional
        n . p of a point p on the plane (overlap R - (n . x - offset)).
    wall_t0 : array_like, shape (W, 3), optional
    """

    def __init__(self, positions, radii, pairs, t0, k_n, k_t, mu, box=None, wall_spheres=(),
                 wall_normal=(), wall_offset=(), wall_t0=()):
        self.r0 = np.array(positions, dtype=np.float64).reshape(-1, 3)
        self.R = np.array(radii, dtype=np.float64).reshape(-1)
        self.pairs = np.array(pairs, dtype=np.int64).reshape(-1, 2)
        self.t0 = np.array(t0, dtype=np.float64).reshape(-1, 3)
        self.k_n, self.k_t, self.mu = float(k_n), float(k_t), float(mu)
        self.wall = np.array(wall_spheres, dtype=np.int64).reshape(-1)
        W = self.wall.size
        self.wall_n = np.array(wall_normal, dtype=np.float64).reshape(W, 3)
        self.wall_c = np.array(wall_offset, dtype=np.float64).reshape(W)
        self.wall_t0 = np.array(wall_t0, dtype=np.float64).reshape(W, 3)
        if self.t0.shape[0] != self.pairs.shape[0]:
            raise ValueError(f"t0 has {self.t0.shape[0]} rows for {self.pairs.shape[0]} pairs")
        # the periodic image of each pair, fixed by the reference configuration
        i, j = self.pairs[:, 0], self.pairs[:, 1]
        d0 = self.r0[i] - self.r0[j]
        self.shift = np.zeros_like(d0)
        if box is not None:
            for a, L in enumerate(box):
                if L:
                    self.shift[:, a] = -L * np.round(d0[:, a] / L)

    @property
    def q0(self):
        """Reference coordinates (r_0, phi = 0) per sphere, shape (6N,)."""
        q = np.zeros((self.R.size, 6))
        q[:, :3] = self.r0
        return q.reshape(-1)

    @classmethod
    def from_state(cls, state):
        """Build from a :class:`~remote_trigger.analysis.state.state3d.State3D` (arrays only)."""
        p = state.params
        box = [float(L) if per else None for L, per in zip(state.box_length, state.periodic)]
        return cls(state.positions, state.radii,
                   np.column_stack([state.contact_i, state.contact_j]), state.contact_t,
                   p.k_n, p.k_t, p.mu, box=box, wall_spheres=state.wall_index,
                   wall_normal=state.wall_normal, wall_offset=state.wall_offset,
                   wall_t0=state.wall_t)


def _project_keep_length(n, t0):
    """|t0| P t0 / |P t0| (0 where t0 = 0); n may be complex, t0 real."""
    tn = _dot(t0, n)
    p = t0 - tn[:, None] * n
    len0 = np.sqrt(_dot(t0, t0))
    plen = np.sqrt(_dot(p, p))
    nonzero = np.real(len0) > 0
    scale = len0 / np.where(nonzero, plen, 1.0)
    return np.where(nonzero[:, None], p * scale[:, None], 0.0 * p)


def _tangential_force(k_n, k_t, mu, delta, t):
    """F_t = -k_t delta^{1/2} g(u) t after the Coulomb cap (decided on real parts)."""
    tstar = mu * k_n * delta / k_t
    length = np.sqrt(_dot(t, t))
    over = np.linalg.norm(np.real(t), axis=1) > np.real(tstar)
    t = np.where(over[:, None], t * (tstar / np.where(over, length, 1.0))[:, None], t)
    u = np.where(over, 1.0, np.sqrt(_dot(t, t)) / tstar)
    return (-k_t * np.sqrt(delta) * (1.0 + u - u * u))[:, None] * t


def _contact_force(sysm, n, delta, t_trial):
    """Total force on the i side (F_n + F_t) and F_t; zero where delta <= 0."""
    touching = np.real(delta) > 0
    d = np.where(touching, delta, 1.0)
    Fn = (sysm.k_n * d ** 1.5)[:, None] * n
    if sysm.k_t > 0 and sysm.mu > 0:
        Ft = _tangential_force(sysm.k_n, sysm.k_t, sysm.mu, d, t_trial)
    else:
        Ft = 0.0 * Fn
    return np.where(touching[:, None], Fn + Ft, 0.0), np.where(touching[:, None], Ft, 0.0)


def reference_forces3d(system, q):
    """Generalized forces G(q) = (F, T/R) per sphere; complex-safe.

    Parameters
    ----------
    system : ReferenceSystem3D
    q : array_like, shape (6N,), real or complex
        (x, y, z, phi_x, phi_y, phi_z) per sphere; the history is advanced
        from ``system.q0`` by one step of the pair style's rule (module
        docstring).

    Returns
    -------
    ndarray, shape (6N,), dtype of q (complex if q is complex)
        Contact forces only.
    """
    sysm = system
    q = np.asarray(q)
    dtype = np.result_type(q.dtype, np.float64)
    N = sysm.R.size
    if q.size != 6 * N:
        raise ValueError(f"q must have 6N = {6 * N} entries, got {q.size}")
    qq = q.astype(dtype).reshape(N, 6)
    dq = qq - sysm.q0.reshape(N, 6)
    F = np.zeros((N, 3), dtype=dtype)
    T = np.zeros((N, 3), dtype=dtype)

    if sysm.pairs.shape[0]:
        i, j = sysm.pairs[:, 0], sysm.pairs[:, 1]
        d = qq[i, :3] - qq[j, :3] + sysm.shift
        rho = np.sqrt(_dot(d, d))
        n = d / rho[:, None]
        delta = sysm.R[i] + sysm.R[j] - rho
        rel = (dq[i, :3] - dq[j, :3]) - _cross(dq[i, 3:] + dq[j, 3:], n)
        slip = rel - _dot(rel, n)[:, None] * n
        t = _project_keep_length(n, sysm.t0) + slip
        Fi, Ft = _contact_force(sysm, n, delta, t)
        tq = -_cross(n, Ft)                  # T/R, the same on i and on j
        for c in range(3):
            np.add.at(F[:, c], i, Fi[:, c])
            np.add.at(F[:, c], j, -Fi[:, c])
            np.add.at(T[:, c], i, tq[:, c])
            np.add.at(T[:, c], j, tq[:, c])

    if sysm.wall.size:
        w = sysm.wall
        n = sysm.wall_n.astype(dtype)
        delta = sysm.R[w] - (_dot(n, qq[w, :3]) - sysm.wall_c)
        rel = dq[w, :3] - _cross(dq[w, 3:], n)
        slip = rel - _dot(rel, n)[:, None] * n
        t = _project_keep_length(n, sysm.wall_t0) + slip
        Fw, Ft = _contact_force(sysm, n, delta, t)
        tq = -_cross(n, Ft)
        for c in range(3):
            np.add.at(F[:, c], w, Fw[:, c])
            np.add.at(T[:, c], w, tq[:, c])

    G = np.empty((N, 6), dtype=dtype)
    G[:, :3] = F
    G[:, 3:] = T
    return G.reshape(-1)
