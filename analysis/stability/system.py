"""The reduced system of an equilibrium: K and M on the degrees of freedom kept.

Every stability question starts here (docs/analysis.md, "The engine"):
assemble K = -dG/dq (paper Appendix C;
:mod:`remote_trigger.analysis.stability.jacobian` for disks,
:mod:`remote_trigger.analysis.stability.jacobian3d` for spheres), remove the rattlers iteratively (fewer
than 2 contacts for frictional disks, 3 for spheres; docs/model.md
section 9.1), and restrict K and the mass diagonal M = diag(m, m, I/R^2)
(disks) or diag(m, m, m, I/R^2 x 3) (spheres) to the kept dofs.
:func:`reduced_system` does it once; the verdict
(:func:`remote_trigger.analysis.stability.verdict.decide`), the analyzer
(:func:`remote_trigger.analysis.stability.analyze.analyze`), the saddle
screen and the mode shapes take its result.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from remote_trigger.analysis.errors import is_integer

__all__ = ["ReducedSystem", "reduced_system", "tie_dofs", "tie_index"]


@dataclass
class ReducedSystem:
    """K and M of one state, whole and restricted to the kept dofs.

    Attributes
    ----------
    state : State or State3D
        The state it was built from.
    K_full : scipy.sparse.csr_matrix, shape (d N, d N)
        K = -dG/dq with the rattlers kept (force/length); d = 3 for disks
        (x, y, R theta), 6 for spheres.
    mass_full : ndarray, shape (d N,)
        Diagonal of M (mass units; I/R^2 on the rotational dofs).
    rattlers : remote_trigger.analysis.stability.jacobian.RattlerResult
        The particles removed (ids, indices) and the kept dofs.
    residual : ndarray, shape (d N,)
        G = contact + external forces (zero at an equilibrium; not checked
        here: :func:`~remote_trigger.analysis.stability.residual.check_equilibrium`);
        a rigid top layer shows its mean force on each of its spheres
        (:func:`~remote_trigger.analysis.stability.residual.generalized_residual`).
    K : scipy.sparse.csr_matrix, shape (n, n)
        K restricted to the kept dofs, n = ``keep_dofs.size`` (0 x 0 when
        every particle is a rattler); with a rigid top layer, P^T K P on
        them (:func:`tie_dofs`).
    mass : ndarray, shape (n,)
        M restricted to the kept dofs (P^T M P: the layer's x, y and z carry
        the sum of its spheres' masses).
    tied : ndarray of int64, shape (2, T)
        Row 0: dofs (indices into the d N) that move with another and are
        not in ``keep_dofs``; row 1: the kept dof each moves with. Empty
        unless the state has a rigid top layer (``state.rigid_layer``).
    """

    state: object
    K_full: object
    mass_full: np.ndarray
    rattlers: object
    residual: np.ndarray
    K: object
    mass: np.ndarray
    tied: np.ndarray = field(default_factory=lambda: np.zeros((2, 0), np.int64))

    @property
    def keep_dofs(self):
        """ndarray of int64, shape (n,): the kept dofs (indices into the d N of the state).

        Ascending; a rigid top layer keeps the x, y and z of its first kept
        sphere for the layer's (``tied``).
        """
        keep = self.rattlers.keep_dofs
        if self.tied.shape[1] == 0:
            return keep
        return keep[~np.isin(keep, self.tied[0])]

    def expand(self, vec):
        """A vector on the kept dofs as one on all d N dofs.

        Parameters
        ----------
        vec : array_like, shape (n,) or (n, k)

        Returns
        -------
        ndarray, shape (d N,) or (d N, k)
            ``vec`` at ``keep_dofs``, each tied dof equal to its kept dof,
            zero on the rattlers.

        Raises
        ------
        ValueError
            If ``vec`` does not have n rows.
        """
        vec = np.asarray(vec)
        if vec.ndim == 0 or vec.shape[0] != self.n:
            raise ValueError(f"expand needs {self.n} rows (the kept dofs), got shape "
                             f"{vec.shape}")
        full = np.zeros((self.mass_full.size,) + vec.shape[1:], vec.dtype)
        full[self.keep_dofs] = vec
        full[self.tied[0]] = full[self.tied[1]]
        return full

    @property
    def n(self):
        """Order of the reduced system (the dofs kept)."""
        return int(self.K.shape[0])

    @property
    def spheres(self):
        """True for a packing of spheres (6 dofs each)."""
        from remote_trigger.analysis.state.state3d import State3D

        return isinstance(self.state, State3D)

    @property
    def max_residual(self):
        """max over particles of max(|F_i|, |T_i|/R_i), loads included (force units)."""
        from remote_trigger.analysis.stability.residual import max_residual

        return max_residual(self.residual, self.spheres)

    def dynamical_matrix(self):
        """M^-1 K on the kept dofs (CSR, 1/time^2; paper Eq. 6: omega = +-sqrt(lambda))."""
        from remote_trigger.analysis.stability.eigen import dynamical_matrix

        return dynamical_matrix(self.K, self.mass)


def reduced_system(state, min_contacts=None):
    """Assemble K, find the rattlers and restrict K and M to the kept dofs.

    Parameters
    ----------
    state : State or State3D
        Disks (3 dofs each) or spheres (6 dofs each).
    min_contacts : int, optional
        Rattler criterion: a particle with fewer contacts among the kept ones
        is removed, until none is (default 2 for frictional disks, 3 for
        spheres; docs/model.md section 9.1).

    Returns
    -------
    ReducedSystem

    Raises
    ------
    ValueError
        If ``min_contacts`` is not an integer >= 0.
    """
    from remote_trigger.analysis.stability import jacobian, jacobian3d
    from remote_trigger.analysis.stability.residual import generalized_residual
    from remote_trigger.analysis.state.state3d import State3D

    if min_contacts is not None and (not is_integer(min_contacts) or min_contacts < 0):
        raise ValueError(f"min_contacts must be an integer >= 0, got min_contacts = "
                         f"{min_contacts!r}")
    if isinstance(state, State3D):
        K = jacobian3d.stiffness_matrix3d(state)
        rat = jacobian3d.find_rattlers3d(state, min_contacts=3 if min_contacts is None
                                         else min_contacts)
    else:
        K = jacobian.stiffness_matrix(state)
        rat = jacobian.find_rattlers(state, min_contacts=2 if min_contacts is None
                                     else min_contacts)
    G = generalized_residual(state)
    mass = state.mass_diagonal()
    Kr, mr = jacobian.remove_dofs(K, mass, rat.keep_dofs)
    layer = getattr(state, "rigid_layer", None)
    if layer is None or len(layer) < 2:
        return ReducedSystem(state, K, mass, rat, G, Kr, mr)
    groups, tied = [], []
    for c in range(3):                  # x, y, z of the layer: one dof each
        dofs = 6 * np.asarray(layer, np.int64) + c
        kept = np.sort(dofs[np.isin(dofs, rat.keep_dofs)])
        if kept.size > 1:
            groups.append(np.searchsorted(rat.keep_dofs, kept))
            tied.append(np.vstack([kept[1:], np.full(kept.size - 1, kept[0])]))
    if not groups:
        return ReducedSystem(state, K, mass, rat, G, Kr, mr)
    Kr, mr = tie_dofs(Kr, mr, groups)
    return ReducedSystem(state, K, mass, rat, G, Kr, mr,
                         np.hstack(tied).astype(np.int64))


def tie_index(n, groups):
    """The map q = P q' of groups of dofs that each move as one.

    Parameters
    ----------
    n : int
        Number of dofs.
    groups : sequence of array_like of int
        Each ascending distinct indices in [0, n), the groups disjoint; the
        first of each is kept.

    Returns
    -------
    col : ndarray of int64, shape (n,)
        The index in q' of every dof (a group's dofs share its first's).
    m : int
        Length of q': n - sum over groups of (size - 1).

    Raises
    ------
    ValueError
        If a group is not ascending distinct indices in [0, n), or two
        groups share an index.
    """
    drop = np.zeros(n, bool)
    seen = np.zeros(n, bool)
    checked = []
    for group in groups:
        g = np.asarray(group, np.int64)
        if g.ndim != 1 or (g.size and (g[0] < 0 or g[-1] >= n or np.any(np.diff(g) <= 0))):
            raise ValueError(f"a group must be ascending distinct indices in [0, {n}), got "
                             f"{g!r}")
        if np.any(seen[g]):
            raise ValueError(f"groups must be disjoint: index {int(g[seen[g]][0])} is in two")
        seen[g] = True
        drop[g[1:]] = True
        checked.append(g)
    col = np.cumsum(~drop) - 1          # the new index of every dof kept
    for g in checked:
        if g.size:
            col[g[1:]] = col[g[0]]
    return col.astype(np.int64), int(np.count_nonzero(~drop))


def tie_dofs(K, mass, groups):
    """Restrict K and the mass diagonal to groups of dofs that each move as one.

    With q = P q' (:func:`tie_index`: every dof of a group takes the value
    of the group's first), K' = P^T K P and M' = P^T M P (diagonal: a
    group's masses summed on its first dof); the other dofs of each group
    are removed. This is the constraint of a rigid body that translates
    without turning (the top layer as a rigid plate, ``fix aveforce 0.0 0.0
    0.0``; one group per axis): its generalized force along an axis is the
    sum of its spheres' forces.

    Parameters
    ----------
    K : sparse matrix or ndarray, shape (n, n)
    mass : ndarray, shape (n,)
    groups : sequence of array_like of int
        As :func:`tie_index`.

    Returns
    -------
    K_tied : scipy.sparse.csr_matrix, shape (m, m)
        m = n - sum over groups of (size - 1).
    mass_tied : ndarray, shape (m,)

    Raises
    ------
    ValueError
        As :func:`tie_index`.
    """
    import scipy.sparse as sp

    n = K.shape[0]
    col, m = tie_index(n, groups)
    P = sp.csr_matrix((np.ones(n), (np.arange(n), col)), shape=(n, m))
    Kt = (P.T @ sp.csr_matrix(K) @ P).tocsr()
    mt = np.asarray(P.T @ np.asarray(mass, np.float64)).ravel()
    return Kt, mt
