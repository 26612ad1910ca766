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

from dataclasses import dataclass

import numpy as np

from remote_trigger.analysis.errors import is_integer

__all__ = ["ReducedSystem", "reduced_system"]


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
        here: :func:`~remote_trigger.analysis.stability.residual.check_equilibrium`).
    K : scipy.sparse.csr_matrix, shape (n, n)
        K restricted to the kept dofs, n = ``keep_dofs.size`` (0 x 0 when
        every particle is a rattler).
    mass : ndarray, shape (n,)
        M restricted to the kept dofs.
    """

    state: object
    K_full: object
    mass_full: np.ndarray
    rattlers: object
    residual: np.ndarray
    K: object
    mass: np.ndarray

    @property
    def keep_dofs(self):
        """ndarray of int64, shape (n,): the kept dofs (indices into the d N of the state)."""
        return self.rattlers.keep_dofs

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
    from remote_trigger.analysis.state.state3d import State3D

    if min_contacts is not None and (not is_integer(min_contacts) or min_contacts < 0):
        raise ValueError(f"min_contacts must be an integer >= 0, got min_contacts = "
                         f"{min_contacts!r}")
    if isinstance(state, State3D):
        K = jacobian3d.stiffness_matrix3d(state)
        rat = jacobian3d.find_rattlers3d(state, min_contacts=3 if min_contacts is None
                                         else min_contacts)
        G = jacobian3d.generalized_forces3d(state)
    else:
        K = jacobian.stiffness_matrix(state)
        rat = jacobian.find_rattlers(state, min_contacts=2 if min_contacts is None
                                     else min_contacts)
        G = jacobian.generalized_forces(state)
    mass = state.mass_diagonal()
    Kr, mr = jacobian.remove_dofs(K, mass, rat.keep_dofs)
    return ReducedSystem(state, K, mass, rat, G, Kr, mr)
