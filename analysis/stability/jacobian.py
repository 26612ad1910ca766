r"""The stiffness matrix K = -dG/dq of a frictional packing, and the residual G.

Generalized coordinates per disk (ascending id) are
:math:`q_k = (x_k, y_k, \phi_k = R_k\theta_k)` and generalized forces
:math:`G_k = (F_{x,k}, F_{y,k}, T_k/R_k)` (paper Eq. 42). The stiffness is

.. math::

    K = -\frac{\partial G}{\partial q}, \qquad 3N \times 3N,\ \text{real, not symmetric},

with the derivative taken along the history-update rule that the pair style
integrates (Eq. 14 in the form of ``docs/conventions.md`` section 2): moving
the coordinates changes the tangential displacement by
:math:`d\xi = s\cdot(dr_i - dr_j) + d\phi_i + d\phi_j`, and a contact at the
Coulomb cap stays capped. Per contact (δ' = ∂/∂δ, dr = dr_i − dr_j):

.. math::

    \frac{\partial F_i}{\partial r_i} = -f_n'\, n n^T + \frac{f_n}{\rho} s s^T
        - (\partial_\delta f_t)\, s n^T + (\partial_\xi f_t)\, s s^T
        - \frac{f_t}{\rho}\, n s^T,

    \frac{\partial F_i}{\partial \phi_{i}} = \frac{\partial F_i}{\partial \phi_{j}}
        = (\partial_\xi f_t)\, s, \qquad
    \frac{\partial G^\phi_i}{\partial r_i} = -(\partial_\delta f_t)\, n^T
        + (\partial_\xi f_t)\, s^T, \qquad
    \frac{\partial G^\phi_i}{\partial \phi_{i,j}} = \partial_\xi f_t,

derivatives with respect to :math:`r_j` are minus those with respect to
:math:`r_i`, and the rows of disk j are minus the force rows and plus the
torque row of disk i (:math:`F_j = -F_i`, :math:`T_j/R_j = T_i/R_i = f_t`).
These are Eqs. (18)-(41) of the paper's Appendix C specialised to the scalar
history of 2D. The wall is the same law with n = +y, s = +x and no partner.

Everything is vectorized over contacts; assembly is O(number of contacts).
The per-contact algebra is the same as that of the C++ kernel
``pair_mindlin_smooth/mindlin_smooth_kernel.h`` (which the LAMMPS plugin
runs), and the tests compare the two.

Rattlers
--------
A disk that cannot carry load adds zero (or spurious) modes. For frictional
disks in 2D a disk needs at least **two** contacts (other disks or the wall):
tangential forces let two contacts balance force and torque, whereas one
contact cannot — an unloaded disk with one contact carries no force, and a
loaded (``top``) disk on a single contact can only balance its load with a
purely normal force through its centre, a configuration whose rolling mode
has the destabilising geometric stiffness :math:`-f_n/\rho` (an inverted
pendulum). The frictionless criterion (d + 1 = 3 contacts) would wrongly
remove stable frictional disks. Removal is iterated because removing a disk
lowers its partners' counts. Rattlers are removed by deleting their rows and
columns of K (their contacts still contribute to the diagonal blocks of
their partners, which is the correct linear response when the rattler is
held fixed; at equilibrium a rattler's contact forces vanish anyway).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from remote_trigger.analysis.errors import is_integer
from remote_trigger.analysis.state.contacts import minimum_image
from remote_trigger.analysis.state.state import State

__all__ = ["ContactTerms", "contact_terms", "wall_terms", "contact_blocks", "wall_blocks",
           "stiffness_matrix",
           "generalized_forces", "find_rattlers", "RattlerResult", "remove_dofs",
           "displaced_state"]


@dataclass
class ContactTerms:
    """Response and derivatives of a set of contacts (vectorized).

    Attributes
    ----------
    delta : ndarray, shape (C,)
        Overlap (length).
    xi : ndarray, shape (C,)
        Tangential displacement after the Coulomb cap.
    fn, ft : ndarray, shape (C,)
        Normal force magnitude k_n delta^{3/2} (Eq. 1) and tangential force
        along s on disk i (Eq. 3), force units.
    u : ndarray, shape (C,)
        |xi|/t* after the cap (0 without friction).
    capped : ndarray of bool, shape (C,)
        True where the trial xi exceeded t* (sliding).
    dfn : ndarray, shape (C,)
        d f_n / d delta = (3/2) k_n delta^{1/2}.
    dft_ddelta, dft_dxi : ndarray, shape (C,)
        d f_t / d delta and d f_t / d xi along the cap (zero d/dxi when capped).
    """

    delta: np.ndarray
    xi: np.ndarray
    fn: np.ndarray
    ft: np.ndarray
    u: np.ndarray
    capped: np.ndarray
    dfn: np.ndarray
    dft_ddelta: np.ndarray
    dft_dxi: np.ndarray


def contact_terms(params, delta, xi_trial):
    """Contact law and its partial derivatives for arrays of contacts.

    Parameters
    ----------
    params : ContactParams
    delta : ndarray, shape (C,)
        Overlaps, > 0.
    xi_trial : ndarray, shape (C,)
        Trial tangential displacements (before the cap), length.

    Returns
    -------
    ContactTerms

    Notes
    -----
    f_n = k_n δ^{3/2}; t* = μ k_n δ / k_t; trial ξ with |ξ| > t* is capped to
    sign(ξ) t*; u = |ξ|/t*, f_t = −k_t δ^{1/2} g(u) ξ, g(u) = 1 + u − u²
    (Eqs. 1–3). Below the cap ∂_ξ f_t = −k_t δ^{1/2}(1 + 2u − 3u²) and
    ∂_δ f_t = f_t/(2δ) + k_t ξ u(1 − 2u)/δ^{1/2}; at the cap ∂_ξ f_t = 0 and
    ∂_δ f_t = −(3/2) sign(ξ) μ k_n δ^{1/2}. Both branches agree at u = 1.
    """
    delta = np.asarray(delta, dtype=np.float64)
    xi_trial = np.asarray(xi_trial, dtype=np.float64)
    sqd = np.sqrt(delta)
    fn = params.k_n * delta * sqd
    dfn = 1.5 * params.k_n * sqd
    z = np.zeros_like(delta)
    if not params.frictional:
        return ContactTerms(delta, z.copy(), fn, z.copy(), z.copy(),
                            np.zeros(delta.shape, bool), dfn, z.copy(), z.copy())
    ts = params.mu * params.k_n * delta / params.k_t
    capped = np.abs(xi_trial) > ts
    xi = np.where(capped, np.copysign(ts, xi_trial), xi_trial)
    u = np.abs(xi) / ts
    ft = -params.k_t * sqd * (1.0 + u - u * u) * xi
    dft_dxi = np.where(capped, 0.0, -params.k_t * sqd * (1.0 + 2.0 * u - 3.0 * u * u))
    free_dd = 0.5 * ft / delta + params.k_t * xi * u * (1.0 - 2.0 * u) / sqd
    cap_dd = -np.copysign(1.5 * params.mu * params.k_n * sqd, xi_trial)
    dft_ddelta = np.where(capped, cap_dd, free_dd)
    return ContactTerms(delta, xi, fn, ft, u, capped, dfn, dft_ddelta, dft_dxi)


def _pair_geometry(state, positions=None):
    pos = state.positions if positions is None else positions
    d = minimum_image(pos[state.contact_i] - pos[state.contact_j], state.box_length,
                      state.periodic)
    rho = np.hypot(d[:, 0], d[:, 1])
    n = d / rho[:, None]
    s = np.column_stack([n[:, 1], -n[:, 0]])
    delta = state.radii[state.contact_i] + state.radii[state.contact_j] - rho
    return d, rho, n, s, delta


def wall_terms(state):
    """:class:`ContactTerms` of the wall contacts of ``state`` (n = +y, s = +x)."""
    return contact_terms(state.params, state.wall_delta, state.wall_xi)


def _require_disks(state):
    """A State of disks, else a ValueError naming the type (spheres have jacobian3d)."""
    if not isinstance(state, State):
        raise ValueError(f"expected a State of disks, got {type(state).__name__} (spheres: "
                         f"remote_trigger.analysis.stability.jacobian3d)")


def _check_state(state):
    _require_disks(state)
    if state.n_contacts:
        _, rho, _, _, delta = _pair_geometry(state)
        if np.any(delta <= 0.0):
            k = int(np.argmax(delta <= 0.0))
            raise ValueError(f"contact {state.ids[state.contact_i[k]]}-"
                             f"{state.ids[state.contact_j[k]]} has overlap "
                             f"{float(delta[k])!r} <= 0")


def contact_blocks(state):
    """Per-contact 6 x 6 blocks of K for the disk-disk contacts.

    Parameters
    ----------
    state : State

    Returns
    -------
    blocks : ndarray, shape (C, 6, 6)
        ``blocks[c]`` = -dG/dq restricted to (q_i, q_j) of contact c, rows and
        columns ordered (x_i, y_i, phi_i, x_j, y_j, phi_j); rows 0-2 are those
        of ``kernel.pair_stiffness`` for dx, dy = r_i - r_j.
    dofs : ndarray of int64, shape (C, 6)
        Global dof index of each row/column.
    """
    _require_disks(state)
    C = state.n_contacts
    if C == 0:
        return np.zeros((0, 6, 6)), np.zeros((0, 6), np.int64)
    _, rho, n, s, delta = _pair_geometry(state)
    t = contact_terms(state.params, delta, state.contact_xi)
    nn = n[:, :, None] * n[:, None, :]
    ss = s[:, :, None] * s[:, None, :]
    sn = s[:, :, None] * n[:, None, :]
    ns = n[:, :, None] * s[:, None, :]
    A = (-t.dfn[:, None, None] * nn + (t.fn / rho)[:, None, None] * ss
         - t.dft_ddelta[:, None, None] * sn + t.dft_dxi[:, None, None] * ss
         - (t.ft / rho)[:, None, None] * ns)                           # dF_i/dr_i
    a = t.dft_dxi[:, None] * s                                          # dF_i/dphi_{i,j}
    b = -t.dft_ddelta[:, None] * n + t.dft_dxi[:, None] * s             # dG^phi_i/dr_i
    D = np.empty((C, 6, 6))
    D[:, 0:2, 0:2] = A
    D[:, 0:2, 2] = a
    D[:, 0:2, 3:5] = -A
    D[:, 0:2, 5] = a
    D[:, 2, 0:2] = b
    D[:, 2, 2] = t.dft_dxi
    D[:, 2, 3:5] = -b
    D[:, 2, 5] = t.dft_dxi
    D[:, 3:5, :] = -D[:, 0:2, :]                                        # F_j = -F_i
    D[:, 5, :] = D[:, 2, :]                                             # T_j/R_j = T_i/R_i
    dofs = np.concatenate([3 * state.contact_i[:, None] + np.arange(3),
                           3 * state.contact_j[:, None] + np.arange(3)], axis=1)
    return -D, dofs.astype(np.int64)


def wall_blocks(state):
    """Per-contact 3 x 3 blocks of K for the wall contacts.

    Returns
    -------
    blocks : ndarray, shape (W, 3, 3)
        -dG/dq of the disk on the wall, order (x, y, phi), as
        ``kernel.wall_stiffness``.
    dofs : ndarray of int64, shape (W, 3)
    """
    _require_disks(state)
    W = state.wall_index.size
    if W == 0:
        return np.zeros((0, 3, 3)), np.zeros((0, 3), np.int64)
    t = wall_terms(state)
    D = np.zeros((W, 3, 3))
    D[:, 0, 0] = t.dft_dxi          # d xi/dx = 1
    D[:, 0, 1] = -t.dft_ddelta      # d delta/dy = -1
    D[:, 0, 2] = t.dft_dxi          # d xi/dphi = 1
    D[:, 1, 1] = -t.dfn
    D[:, 2, :] = D[:, 0, :]         # G^phi = f_t = F_x
    dofs = 3 * state.wall_index[:, None] + np.arange(3)
    return -D, dofs.astype(np.int64)


def stiffness_matrix(state, wall=True):
    """Assemble K = -dG/dq (paper Eqs. 44-67, Appendix C) as a sparse matrix.

    Parameters
    ----------
    state : State
        Packing with contacts and tangential displacements.
    wall : bool, optional
        Include the disk-wall contacts (default True).

    Returns
    -------
    scipy.sparse.csr_matrix, shape (3N, 3N), float64
        Row 3k + c is component c of G_k = (F_x, F_y, T/R) of disk k; column
        3l + c' is coordinate c' of q_l = (x, y, R theta). Units force/length.
        Duplicates summed, indices sorted; explicit zeros kept, so the
        pattern is that of the contact network.

    Raises
    ------
    ValueError
        If ``state`` is not a State or a listed contact has no overlap.
    """
    _check_state(state)
    N3 = state.ndof
    data, rows, cols = [], [], []
    parts = [contact_blocks(state)]
    if wall:
        parts.append(wall_blocks(state))
    for B, dofs in parts:
        if B.shape[0] == 0:
            continue
        m = dofs.shape[1]
        data.append(B.reshape(-1))
        rows.append(np.repeat(dofs, m, axis=1).reshape(-1))
        cols.append(np.tile(dofs, (1, m)).reshape(-1))
    if not data:
        return sp.csr_matrix((N3, N3), dtype=np.float64)
    K = sp.csr_matrix((np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(N3, N3), dtype=np.float64)
    K.sum_duplicates()
    K.sort_indices()
    return K


def displaced_state(state, dq):
    """The state after a displacement dq, with the history advanced by Eq. 14.

    The tangential displacement of every contact is incremented as the pair
    style does in one step, ``xi += s(q + dq) . (dr_i - dr_j) + dphi_i +
    dphi_j`` (wall: ``xi += dx + dphi``) and then capped at t*. The contact
    set is frozen: contacts that open get zero force, and no contact forms.

    Parameters
    ----------
    state : State
    dq : array_like, shape (3N,)
        Displacement of the generalized coordinates (x, y, R theta per disk).

    Returns
    -------
    State
        New positions and tangential displacements (capped); same contacts.

    Raises
    ------
    ValueError
        If dq has the wrong shape or is not finite.
    """
    import dataclasses

    _require_disks(state)
    dq = np.asarray(dq, dtype=np.float64)
    if dq.shape != (state.ndof,) or not np.all(np.isfinite(dq)):
        bad = int(np.sum(~np.isfinite(dq))) if dq.shape == (state.ndof,) else 0
        raise ValueError(f"dq must be a finite array of shape ({state.ndof},), got shape "
                         f"{dq.shape}" + (f" with {bad} non-finite value(s)" if bad else ""))
    dq3 = dq.reshape(-1, 3)
    pos = state.positions + dq3[:, :2]
    new = dataclasses.replace(state, positions=pos)
    if state.n_contacts:
        _, _, _, s, delta = _pair_geometry(new)
        ci, cj = state.contact_i, state.contact_j
        dr = dq3[ci, :2] - dq3[cj, :2]
        xi_trial = (state.contact_xi + np.einsum("ca,ca->c", s, dr)
                    + dq3[ci, 2] + dq3[cj, 2])
        ok = delta > 0
        t = contact_terms(state.params, np.where(ok, delta, 1.0), xi_trial)
        new.contact_xi = np.where(ok, t.xi, 0.0)
    if state.wall_index.size:
        w = state.wall_index
        wdelta = state.radii[w] - (pos[w, 1] - state.wall_y)
        xi_trial = state.wall_xi + dq3[w, 0] + dq3[w, 2]
        ok = wdelta > 0
        t = contact_terms(state.params, np.where(ok, wdelta, 1.0), xi_trial)
        new.wall_xi = np.where(ok, t.xi, 0.0)
        new.wall_delta = wdelta
    return new


def generalized_forces(state, dq=None, external=True):
    """Generalized forces G = (F_x, F_y, T/R) per disk (Eqs. 1-3, 31, 42, 44).

    Parameters
    ----------
    state : State
    dq : array_like, shape (3N,), optional
        Evaluate at q + dq with the history advanced by the update rule (see
        :func:`displaced_state`); default: at the state itself (the stored
        tangential displacements, capped as the pair style would).
    external : bool, optional
        Add the external loads (default True), so that G is the residual that
        vanishes at mechanical equilibrium.

    Returns
    -------
    ndarray, shape (3N,)
        G in dof order 3k + c; force units.
    """
    _require_disks(state)
    if dq is not None:
        state = displaced_state(state, dq)
    G = np.zeros((state.n, 3))
    if state.n_contacts:
        _, rho, n, s, delta = _pair_geometry(state)
        ok = delta > 0
        t = contact_terms(state.params, np.where(ok, delta, 1.0), state.contact_xi)
        fn = np.where(ok, t.fn, 0.0)
        ft = np.where(ok, t.ft, 0.0)
        F = fn[:, None] * n + ft[:, None] * s
        for c in range(2):
            G[:, c] += np.bincount(state.contact_i, F[:, c], state.n)
            G[:, c] -= np.bincount(state.contact_j, F[:, c], state.n)
        G[:, 2] += np.bincount(state.contact_i, ft, state.n)
        G[:, 2] += np.bincount(state.contact_j, ft, state.n)
    if state.wall_index.size:
        w = state.wall_index
        wdelta = state.radii[w] - (state.positions[w, 1] - state.wall_y)
        ok = wdelta > 0
        t = contact_terms(state.params, np.where(ok, wdelta, 1.0), state.wall_xi)
        np.add.at(G[:, 0], w, np.where(ok, t.ft, 0.0))
        np.add.at(G[:, 1], w, np.where(ok, t.fn, 0.0))
        np.add.at(G[:, 2], w, np.where(ok, t.ft, 0.0))
    if external:
        G[:, :2] += state.external
    return G.reshape(-1)


@dataclass
class RattlerResult:
    """Outcome of the iterative rattler search.

    Attributes
    ----------
    indices : ndarray of int64
        Disk indices (ascending-id order) that were removed.
    ids : ndarray of int64
        Their atom ids.
    keep_dofs : ndarray of int64
        Degrees of freedom that remain (3 per kept disk), ascending.
    rounds : int
        Number of removal rounds until no disk fell below ``min_contacts``.
    min_contacts : int
        Criterion used.
    """

    indices: np.ndarray
    ids: np.ndarray
    keep_dofs: np.ndarray
    rounds: int
    min_contacts: int


def rattler_rule(n, ci, cj, wall_contacts, min_contacts=2):
    """The rattler rule on a contact list: drop disks with fewer than
    ``min_contacts`` contacts among the kept ones, until none is dropped.

    Parameters
    ----------
    n : int
        Number of disks.
    ci, cj : array_like of int, shape (M,)
        Disk indices of each disk-disk contact.
    wall_contacts : array_like of int, shape (n,)
        Wall contacts per disk (counted, never dropped).
    min_contacts : int, optional

    Returns
    -------
    kept : ndarray of bool, shape (n,)
    rounds : int
        Passes that dropped disks.

    Raises
    ------
    ValueError
        If ``min_contacts`` is not an integer >= 0.
    """
    if not is_integer(min_contacts) \
            or min_contacts < 0:
        raise ValueError(f"min_contacts must be an integer >= 0, got min_contacts = "
                         f"{min_contacts!r}")
    ci, cj = np.asarray(ci, np.int64), np.asarray(cj, np.int64)
    wz = np.asarray(wall_contacts, np.int64)
    alive = np.ones(n, bool)
    rounds = 0
    while True:
        live = alive[ci] & alive[cj]
        z = (np.bincount(ci[live], minlength=n) + np.bincount(cj[live], minlength=n) + wz)
        drop = alive & (z < min_contacts)
        if not np.any(drop):
            break
        alive &= ~drop
        rounds += 1
    return alive, rounds


def find_rattlers(state, min_contacts=2, count_wall=True):
    """Remove, iteratively, disks with fewer than ``min_contacts`` contacts
    (:func:`rattler_rule` on the state's contacts).

    Parameters
    ----------
    state : State
        Or a ``State3D`` (spheres: 6 dofs each in ``keep_dofs``; its own
        default is ``jacobian3d.find_rattlers3d``, 3 contacts).
    min_contacts : int, optional
        A frictional disk needs at least 2 contacts in 2D (module docstring);
        default 2. Use 3 for frictionless disks.
    count_wall : bool, optional
        Count the wall contact (default True).

    Returns
    -------
    RattlerResult

    Raises
    ------
    ValueError
        If ``min_contacts`` is not an integer >= 0, or ``state`` is neither a
        State nor a State3D.
    """
    from remote_trigger.analysis.state.state3d import State3D

    if not isinstance(state, (State, State3D)):
        raise ValueError(f"expected a State or State3D, got {type(state).__name__}")
    n = state.n
    wz = (np.bincount(state.wall_index, minlength=n) if count_wall
          else np.zeros(n, np.int64))
    alive, rounds = rattler_rule(n, state.contact_i, state.contact_j, wz, min_contacts)
    idx = np.nonzero(~alive)[0].astype(np.int64)
    keep = np.nonzero(alive)[0]
    per = state.ndof // n if n else 3            # 3 dofs per disk, 6 per sphere (State3D)
    keep_dofs = (per * keep[:, None] + np.arange(per)).reshape(-1).astype(np.int64)
    return RattlerResult(idx, state.ids[idx], keep_dofs, rounds, int(min_contacts))


def remove_dofs(K, mass, keep_dofs):
    """Restrict K and the mass diagonal to the kept degrees of freedom.

    Parameters
    ----------
    K : sparse matrix or ndarray, shape (n, n)
    mass : ndarray, shape (n,)
    keep_dofs : ndarray of int, shape (m,)

    Returns
    -------
    K_red : same type as K, shape (m, m)
    mass_red : ndarray, shape (m,)

    Raises
    ------
    ValueError
        K not square, ``mass`` not of length n, or ``keep_dofs`` not distinct
        integers in [0, n) (a negative index would wrap around silently).
    """
    shape = K.shape if sp.issparse(K) else np.shape(K)
    if len(shape) != 2 or shape[0] != shape[1]:
        raise ValueError(f"K must be square, got shape {tuple(shape)}")
    n = shape[0]
    if np.shape(mass) != (n,):
        raise ValueError(f"mass must have shape ({n},), got shape {np.shape(mass)}")
    raw = np.asarray(keep_dofs)
    if raw.ndim != 1 or (raw.size and not np.issubdtype(raw.dtype, np.integer)):
        raise ValueError(f"keep_dofs must be a 1-d array of integers, got dtype {raw.dtype} "
                         f"and shape {raw.shape}")
    keep_dofs = raw.astype(np.int64)
    if keep_dofs.size and (keep_dofs.min() < 0 or keep_dofs.max() >= n
                           or np.unique(keep_dofs).size != keep_dofs.size):
        raise ValueError(f"keep_dofs must be distinct indices in [0, {n}), got values in "
                         f"[{keep_dofs.min()}, {keep_dofs.max()}] "
                         f"({keep_dofs.size - np.unique(keep_dofs).size} repeated)")
    if sp.issparse(K):
        Kc = K.tocsr()
        return Kc[keep_dofs][:, keep_dofs].tocsr(), np.asarray(mass)[keep_dofs]
    return np.asarray(K)[np.ix_(keep_dofs, keep_dofs)], np.asarray(mass)[keep_dofs]
