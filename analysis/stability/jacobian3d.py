r"""The stiffness matrix K = -dG/dq of a frictional packing of spheres (3D).

Six generalized coordinates per sphere (ascending id, dof 6k + c):
:math:`q_k = (r_k, \phi_k)` with :math:`\phi_k = R_k\theta_k` the small
rotation vector about the equilibrium orientation times R; generalized forces
:math:`G_k = (F_k, T_k/R_k)`. :math:`K = -\partial G/\partial q` (6N x 6N,
real, not symmetric) is the derivative along the pair style's own 3D step
(``mindlin_smooth_kernel_3d.h``, docs/model.md section 9): the stored t is
projected onto the new tangent plane with its length kept, then advanced by
the slip :math:`P[dr_i - dr_j - (d\phi_i + d\phi_j)\times n]`, then capped.

Linearisation about a state with stored :math:`t_0 \perp n` (dr = dr_i - dr_j,
ρ = |r_i - r_j|, P = 1 - n nᵀ, :math:`[a]_\times b = a \times b`). The normal
turns by dn = P dr/ρ, the projection keeps |t| to second order, so

.. math::

    dt = \Big(P - \frac{n\,t_0^T}{\rho}\Big) dr + [n]_\times (d\phi_i + d\phi_j),
    \qquad d\delta = -n^T dr .

With :math:`F_t(\delta, t)` and its partials :math:`A = \partial F_t/\partial t`
(3 x 3) and :math:`f_\delta = \partial F_t/\partial\delta`:

* below the cap, u = |t|/t*: :math:`A = h\,1 + b\,\hat t\hat t^T`,
  :math:`h = -k_t\delta^{1/2} g(u)`, :math:`b = -k_t\delta^{1/2}u(1-2u)`,
  :math:`f_\delta = -k_t\delta^{-1/2}(g/2 - u(1-2u))\,t`;
* capped (|t| > t*, :math:`F_t = -\mu k_n\delta^{3/2}\hat t`):
  :math:`A = -\mu k_n\delta^{3/2}(1 - \hat t\hat t^T)/|t|`,
  :math:`f_\delta = -\tfrac32\mu k_n\delta^{1/2}\hat t` — a capped contact
  stays capped, but its force still turns with t inside the tangent plane.

Both branches agree at u = 1 (:math:`A = -k_t\delta^{1/2}(1 - \hat t\hat t^T)`),
so the derivative is unambiguous there, as in 2D. Per contact

.. math::

    \partial F_i/\partial r_i &= -f_n' n n^T + \tfrac{f_n}{\rho} P - f_\delta n^T
        + A\Big(P - \tfrac{n t_0^T}{\rho}\Big), \qquad
    \partial F_i/\partial \phi_{i,j} = A [n]_\times, \\
    \partial G^\phi_i/\partial r_i &= [F_t]_\times \tfrac{P}{\rho}
        - [n]_\times\Big(-f_\delta n^T + A\big(P - \tfrac{n t_0^T}{\rho}\big)\Big),
    \qquad \partial G^\phi_i/\partial\phi_{i,j} = -[n]_\times A [n]_\times,

columns of r_j are minus those of r_i, and the rows of j are minus the force
rows and equal to the torque rows of i (:math:`F_j = -F_i`,
:math:`T_j/R_j = T_i/R_i = -n\times F_t`). A flat wall is the ρ → ∞ limit
with its fixed normal and no j. For motion in a plane these reduce to the 2D
blocks of :mod:`~remote_trigger.analysis.stability.jacobian` on
(x, y, φ_z) (tested). With t = 0 or k_t = 0, K is symmetric.

Mass matrix: M = diag(m, m, m, I/R², I/R², I/R²) per sphere, I = I0 m R² with
I0 = 2/5 (solid spheres, ``fix nve/sphere`` without ``disc``), the inertia
of the dynamics (the 2D analysis uses I0 = 1/2 for the same reason).

Rattlers: spheres with fewer than **3** contacts (walls counted) are removed
iteratively. With no rolling or twisting resistance, a sphere on two contacts
can rotate about the chord through its two contact points, its centre moving
normal to both normals: no slip and no change of overlap at first order, so
only the prestress (the f_n/ρ and projection terms) resists it; one contact
leaves it free as in 2D. Rigid translations along periodic axes are zero
modes only without a frictional wall (a wall pins them, as in 2D).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from remote_trigger.analysis.stability.jacobian import RattlerResult, find_rattlers, rattler_rule
from remote_trigger.analysis.state.state3d import State3D

__all__ = ["ContactTerms3D", "contact_terms3d", "contact_blocks3d", "wall_blocks3d",
           "stiffness_matrix3d", "generalized_forces3d", "find_rattlers3d", "cross_matrix"]


def _require_spheres(state):
    """A State3D, else a ValueError naming the type (disks have jacobian)."""
    if not isinstance(state, State3D):
        raise ValueError(f"expected a State3D of spheres, got {type(state).__name__} (disks: "
                         f"remote_trigger.analysis.stability.jacobian)")


def cross_matrix(a):
    """[a]x with [a]x b = a x b; a of shape (..., 3) -> (..., 3, 3)."""
    a = np.asarray(a, dtype=np.float64)
    z = np.zeros(a.shape[:-1])
    return np.stack([np.stack([z, -a[..., 2], a[..., 1]], -1),
                     np.stack([a[..., 2], z, -a[..., 0]], -1),
                     np.stack([-a[..., 1], a[..., 0], z], -1)], -2)


@dataclass
class ContactTerms3D:
    """Response and partial derivatives of a set of 3D contacts (vectorized).

    Attributes
    ----------
    fn, dfn : ndarray, shape (C,)
        k_n delta^{3/2} and d f_n / d delta (force, force/length).
    ft : ndarray, shape (C, 3)
        Tangential force on side i after the cap (force).
    t : ndarray, shape (C, 3)
        Tangential displacement after the cap (length).
    u : ndarray, shape (C,)
        |t|/t* after the cap (0 without friction).
    capped : ndarray of bool, shape (C,)
        True where the trial |t| exceeded t*.
    A : ndarray, shape (C, 3, 3)
        d F_t / d t_trial (force/length).
    f_delta : ndarray, shape (C, 3)
        d F_t / d delta at fixed trial t (force/length).
    """

    fn: np.ndarray
    dfn: np.ndarray
    ft: np.ndarray
    t: np.ndarray
    u: np.ndarray
    capped: np.ndarray
    A: np.ndarray
    f_delta: np.ndarray


def contact_terms3d(params, delta, t_trial):
    """The 3D contact law and its partial derivatives for arrays of contacts.

    Parameters
    ----------
    params : ContactParams
    delta : ndarray, shape (C,)
        Overlaps, > 0 (length).
    t_trial : ndarray, shape (C, 3)
        Trial tangential displacements (before the cap), in the tangent planes.

    Returns
    -------
    ContactTerms3D
        See the module docstring for the formulas of both branches.
    """
    delta = np.asarray(delta, dtype=np.float64)
    tt = np.asarray(t_trial, dtype=np.float64).reshape(-1, 3)
    C = delta.size
    sqd = np.sqrt(delta)
    fn = params.k_n * delta * sqd
    dfn = 1.5 * params.k_n * sqd
    if not params.frictional:
        z3 = np.zeros((C, 3))
        return ContactTerms3D(fn, dfn, z3, z3.copy(), np.zeros(C), np.zeros(C, bool),
                              np.zeros((C, 3, 3)), z3.copy())
    ts = params.mu * params.k_n * delta / params.k_t
    L = np.linalg.norm(tt, axis=1)
    that = np.divide(tt, L[:, None], out=np.zeros_like(tt), where=L[:, None] > 0)
    capped = L > ts
    tthat = that[:, :, None] * that[:, None, :]
    eye = np.broadcast_to(np.eye(3), (C, 3, 3))
    u = np.where(capped, 1.0, L / ts)
    g = 1.0 + u - u * u
    h = -params.k_t * sqd * g
    b = -params.k_t * sqd * u * (1.0 - 2.0 * u)
    A_free = h[:, None, None] * eye + b[:, None, None] * tthat
    fd_free = (-params.k_t / sqd * (0.5 * g - u * (1.0 - 2.0 * u)))[:, None] * tt
    cap_f = params.mu * params.k_n * delta * sqd
    A_cap = (-cap_f / np.where(capped, L, 1.0))[:, None, None] * (eye - tthat)
    fd_cap = (-1.5 * params.mu * params.k_n * sqd)[:, None] * that
    t = np.where(capped[:, None], ts[:, None] * that, tt)
    ft = np.where(capped[:, None], -cap_f[:, None] * that, h[:, None] * tt)
    A = np.where(capped[:, None, None], A_cap, A_free)
    f_delta = np.where(capped[:, None], fd_cap, fd_free)
    return ContactTerms3D(fn, dfn, ft, t, u, capped, A, f_delta)


def _pair_geometry(state):
    d = state.separation(state.contact_i, state.contact_j)
    rho = np.linalg.norm(d, axis=1)
    n = d / rho[:, None]
    delta = state.radii[state.contact_i] + state.radii[state.contact_j] - rho
    return rho, n, delta


def _blocks(n, terms, t0, rho=None):
    """(F-rows, G^phi-rows) x (r, phi) partial blocks of side i; rho None: a wall."""
    nn = n[:, :, None] * n[:, None, :]
    P = np.eye(3) - nn
    nx = cross_matrix(n)
    A = terms.A
    dt_dr = P if rho is None else P - n[:, :, None] * t0[:, None, :] / rho[:, None, None]
    fd_n = terms.f_delta[:, :, None] * n[:, None, :]
    dFt_dr = -fd_n + A @ dt_dr
    Ar = -terms.dfn[:, None, None] * nn + dFt_dr
    Br = -nx @ dFt_dr
    if rho is not None:
        Ar = Ar + (terms.fn / rho)[:, None, None] * P
        Br = Br + cross_matrix(terms.ft) @ P / rho[:, None, None]
    Aphi = A @ nx
    Bphi = -nx @ Aphi
    return Ar, Aphi, Br, Bphi


def contact_blocks3d(state):
    """Per-contact 12 x 12 blocks of K for the sphere-sphere contacts.

    Parameters
    ----------
    state : State3D

    Returns
    -------
    blocks : ndarray, shape (C, 12, 12)
        -dG/dq restricted to (q_i, q_j), rows and columns ordered
        (x_i, y_i, z_i, phi_i (3), x_j, y_j, z_j, phi_j (3)); force/length.
    dofs : ndarray of int64, shape (C, 12)
        Global dof index of each row/column.
    """
    _require_spheres(state)
    C = state.n_contacts
    if C == 0:
        return np.zeros((0, 12, 12)), np.zeros((0, 12), np.int64)
    ii, ij, ji, jj = _sphere_blocks(state)
    D = np.empty((C, 12, 12))
    D[:, :6, :6], D[:, :6, 6:], D[:, 6:, :6], D[:, 6:, 6:] = ii, ij, ji, jj
    dofs = np.concatenate([6 * state.contact_i[:, None] + np.arange(6),
                           6 * state.contact_j[:, None] + np.arange(6)], axis=1)
    return D, dofs.astype(np.int64)


def _sphere_blocks(state):
    """The four 6 x 6 blocks of K of each contact: (i, i), (i, j), (j, i), (j, j).

    Each of shape (C, 6, 6), rows (F, T/R) of the first sphere named, columns
    (r, phi) of the second; F_j = -F_i and T_j/R_j = T_i/R_i.
    """
    rho, n, delta = _pair_geometry(state)
    if np.any(delta <= 0):
        k = int(np.argmax(delta <= 0))
        raise ValueError(f"contact {state.ids[state.contact_i[k]]}-"
                         f"{state.ids[state.contact_j[k]]} has overlap {delta[k]!r} <= 0")
    terms = contact_terms3d(state.params, delta, state.contact_t)
    Ar, Aphi, Br, Bphi = _blocks(n, terms, state.contact_t, rho)
    C = Ar.shape[0]
    out = np.empty((4, C, 6, 6))
    # K = -dG/dq: D(i, i) = [[Ar, Aphi], [Br, Bphi]], D(i, j) = [[-Ar, Aphi], [-Br, Bphi]],
    # D(j, i) = [[-Ar, -Aphi], [Br, Bphi]], D(j, j) = [[Ar, -Aphi], [-Br, Bphi]]
    for k, (sa, sp_, sb) in enumerate(((-1, -1, -1), (1, -1, 1), (1, 1, -1), (-1, 1, 1))):
        out[k, :, :3, :3] = sa * Ar
        out[k, :, :3, 3:] = sp_ * Aphi
        out[k, :, 3:, :3] = sb * Br
        out[k, :, 3:, 3:] = -Bphi
    return out[0], out[1], out[2], out[3]


def wall_blocks3d(state):
    """Per-contact 6 x 6 blocks of K for the sphere-wall contacts.

    Returns
    -------
    blocks : ndarray, shape (W, 6, 6)
        -dG/dq of the sphere on the wall, order (x, y, z, phi_x, phi_y, phi_z).
    dofs : ndarray of int64, shape (W, 6)
    """
    _require_spheres(state)
    W = state.wall_index.size
    if W == 0:
        return np.zeros((0, 6, 6)), np.zeros((0, 6), np.int64)
    delta = state.wall_delta()
    if np.any(delta <= 0):
        k = int(np.argmax(delta <= 0))
        raise ValueError(f"wall contact of atom id {state.ids[state.wall_index[k]]} has "
                         f"overlap {delta[k]!r} <= 0")
    terms = contact_terms3d(state.params, delta, state.wall_t)
    Ar, Aphi, Br, Bphi = _blocks(state.wall_normal, terms, state.wall_t)
    D = np.empty((W, 6, 6))
    D[:, 0:3, 0:3], D[:, 0:3, 3:6], D[:, 3:6, 0:3], D[:, 3:6, 3:6] = Ar, Aphi, Br, Bphi
    dofs = 6 * state.wall_index[:, None] + np.arange(6)
    return -D, dofs.astype(np.int64)


def stiffness_matrix3d(state, wall=True):
    """Assemble K = -dG/dq of a packing of spheres as a sparse matrix.

    Parameters
    ----------
    state : State3D
    wall : bool, optional
        Include the sphere-wall contacts (default True).

    Returns
    -------
    scipy.sparse.csr_matrix, shape (6N, 6N), float64
        Row 6k + c is component c of G_k = (F, T/R) of sphere k; column
        6l + c' is coordinate c' of q_l = (r, R theta). Force/length.

    Raises
    ------
    ValueError
        If ``state`` is not a State3D or a listed contact has no overlap.
    """
    _require_spheres(state)
    N = state.ndof // 6
    diag = np.zeros((N, 36))
    keys, data = [np.arange(N) * (N + 1)], [diag]
    if state.n_contacts:
        ii, ij, ji, jj = _sphere_blocks(state)
        i, j = state.contact_i.astype(np.int64), state.contact_j.astype(np.int64)
        for k, b in ((i, ii), (j, jj)):          # each sphere's own block, summed
            for e in range(36):
                diag[:, e] += np.bincount(k, weights=b.reshape(-1, 36)[:, e], minlength=N)
        keys += [i * N + j, j * N + i]
        data += [ij.reshape(-1, 36), ji.reshape(-1, 36)]
    if wall:
        Bw, dw = wall_blocks3d(state)
        k = dw[:, 0] // 6
        for e in range(36):
            diag[:, e] += np.bincount(k, weights=Bw.reshape(-1, 36)[:, e], minlength=N)
    touched = np.zeros(N, bool)                    # the pattern is the contact network's
    touched[state.contact_i] = touched[state.contact_j] = True
    if wall:
        touched[state.wall_index] = True
    keys[0], data[0] = keys[0][touched], diag[touched]
    keys = np.concatenate(keys)
    order = np.argsort(keys)                       # (row, column); every key once
    blocks = np.concatenate(data)[order].reshape(-1, 6, 6)
    brow, bcol = np.divmod(keys[order], N)
    indptr = np.searchsorted(brow, np.arange(N + 1))
    K = sp.bsr_matrix((blocks, bcol, indptr), shape=(state.ndof, state.ndof),
                      blocksize=(6, 6)).tocsr()
    K.sort_indices()
    return K


def generalized_forces3d(state, external=True):
    """Generalized forces G = (F, T/R) per sphere at the state (Eqs. 1-3, 31).

    The stored t of each contact is evaluated as the pair style does at
    ``run 0`` (projected, not advanced, capped).

    Parameters
    ----------
    state : State3D
    external : bool, optional
        Add the external forces (default True): G is then the residual.

    Returns
    -------
    ndarray, shape (6N,)
        Force units.
    """
    _require_spheres(state)
    G = np.zeros((state.n, 6))
    if state.n_contacts:
        _, n, delta = _pair_geometry(state)
        terms = contact_terms3d(state.params, delta, state.contact_t)
        F = terms.fn[:, None] * n + terms.ft
        tq = -np.cross(n, terms.ft)
        for c in range(3):
            G[:, c] += (np.bincount(state.contact_i, F[:, c], state.n)
                        - np.bincount(state.contact_j, F[:, c], state.n))
            G[:, 3 + c] += (np.bincount(state.contact_i, tq[:, c], state.n)
                            + np.bincount(state.contact_j, tq[:, c], state.n))
    if state.wall_index.size:
        n = state.wall_normal
        terms = contact_terms3d(state.params, state.wall_delta(), state.wall_t)
        F = terms.fn[:, None] * n + terms.ft
        tq = -np.cross(n, terms.ft)
        for c in range(3):
            G[:, c] += np.bincount(state.wall_index, F[:, c], state.n)
            G[:, 3 + c] += np.bincount(state.wall_index, tq[:, c], state.n)
    if external:
        G[:, :3] += state.external
    return G.reshape(-1)


def find_rattlers3d(state, min_contacts=3, count_wall=True):
    """Remove, iteratively, spheres with fewer than ``min_contacts`` contacts.

    A rigid top layer (``state.rigid_layer``) is one body held by all its
    contacts: its spheres are never removed, and the contacts of the others
    with them count. Each of its spheres turns on its own, held only by its
    own contacts: the three rotational dofs of a layer sphere with fewer
    than ``min_contacts`` contacts among the kept spheres (walls counted)
    are removed, as a rattler's are (docs/model.md section 9.1).

    Parameters
    ----------
    state : State3D
    min_contacts : int, optional
        Default 3 for frictional spheres without rolling or twisting
        resistance (module docstring).
    count_wall : bool, optional
        Count wall contacts (default True).

    Returns
    -------
    RattlerResult
        ``keep_dofs`` lists 6 dofs per kept sphere, ascending (3 for a
        layer sphere without its rotations).

    Raises
    ------
    ValueError
        If ``min_contacts`` is not an integer >= 0, or ``state`` is not a State3D.
    """
    _require_spheres(state)
    layer = state.rigid_layer
    if layer is None or len(layer) < 2:
        return find_rattlers(state, min_contacts, count_wall)
    n = state.n
    wz = (np.bincount(state.wall_index, minlength=n) if count_wall
          else np.zeros(n, np.int64))
    held = wz.copy()
    held[layer] += int(min_contacts)          # (the layer is never dropped)
    alive, rounds = rattler_rule(n, state.contact_i, state.contact_j, held, min_contacts)
    ci, cj = state.contact_i, state.contact_j
    live = alive[ci] & alive[cj]
    z = np.bincount(ci[live], minlength=n) + np.bincount(cj[live], minlength=n) + wz
    keep = np.nonzero(alive)[0]
    dofs = 6 * keep[:, None] + np.arange(6)
    loose = np.isin(keep, layer) & (z[keep] < min_contacts)
    keep_dofs = np.concatenate([dofs[~loose].reshape(-1), dofs[loose, :3].reshape(-1)])
    idx = np.nonzero(~alive)[0].astype(np.int64)
    return RattlerResult(idx, state.ids[idx], np.sort(keep_dofs).astype(np.int64), rounds,
                         int(min_contacts))
