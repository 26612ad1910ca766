"""Is a state an equilibrium of its parameters: its residual and the round-off floor.

A Jacobian and its spectrum describe the linear motion about an
equilibrium; at a state that is not one they describe nothing.
:func:`max_residual` is the largest generalized force of a state,
:func:`roundoff_floor` the residual double precision allows it (the
driver's acceptance level, docs/driver.md), :func:`check_equilibrium`
refuses a state far above that floor (what ``remote-trigger jacobian`` and
``stability_of_dump`` do without ``--allow-residual``).
"""
from __future__ import annotations

import numpy as np

from remote_trigger.analysis.errors import is_real
from remote_trigger.analysis.state.state3d import State3D

__all__ = ["max_residual", "roundoff_floor", "check_equilibrium", "generalized_residual",
           "FAR_ABOVE_FLOOR",
           "FLOOR_MIN", "ROUNDOFF_FACTOR"]

#: a residual this many times the round-off floor is "far above" it: the state
#: is not the equilibrium of the parameters it is analysed with
FAR_ABOVE_FLOOR = 1e3
#: smallest floor used (the driver's smallest acceptance level, 1e-10)
FLOOR_MIN = 1e-10
#: floor = ROUNDOFF_FACTOR eps X k_eff (the driver's acceptance level, docs/driver.md)
ROUNDOFF_FACTOR = 4.0


def generalized_residual(state):
    """G = contact + external forces of a state, as its equilibrium condition sees them.

    (F, T/R) per particle (:func:`~remote_trigger.analysis.stability.jacobian.
    generalized_forces`, ``jacobian3d.generalized_forces3d`` for spheres); a
    rigid top layer (``State3D.rigid_layer``) translates as one body, so each
    of its spheres carries the layer's mean force (what LAMMPS shows under
    ``fix aveforce 0.0 0.0 0.0``; zero at an equilibrium of the layer), and
    its own torque.

    Parameters
    ----------
    state : State or State3D

    Returns
    -------
    ndarray, shape (3 N,) or (6 N,)
        Force units.
    """
    from remote_trigger.analysis.stability import jacobian, jacobian3d

    if not isinstance(state, State3D):
        return jacobian.generalized_forces(state)
    G = jacobian3d.generalized_forces3d(state)
    layer = state.rigid_layer
    if layer is not None and len(layer) > 1:
        G = np.array(G, dtype=np.float64, copy=True).reshape(-1, 6)
        G[layer, :3] = np.mean(G[layer, :3], axis=0)
        G = G.reshape(-1)
    return G


def max_residual(G, spheres=False):
    """r = max_i max(|F_i|, |T_i|/R_i) of generalized forces G.

    Parameters
    ----------
    G : ndarray, shape (3N,) or (6N,)
        (F_x, F_y, T/R) per disk, or (F, T/R) per sphere (force units),
        flat in dof order (as ``generalized_forces`` / ``generalized_forces3d``
        give it), N >= 1, every value finite.
    spheres : bool
        G is that of spheres.

    Returns
    -------
    float

    Raises
    ------
    ValueError
        If ``G`` is not a flat array whose length is a positive multiple of
        3 (disks) or 6 (spheres), or holds a non-finite value.
    """
    per, what = (6, "(F, T/R) per sphere") if spheres else (3, "(F_x, F_y, T/R) per disk")
    try:
        G = np.asarray(G, np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"max_residual needs G, an array of numbers, got "
                         f"{type(G).__name__}") from None
    if G.ndim != 1 or G.size == 0 or G.size % per:
        # (a length-5 G was a raw reshape error, an empty one numpy's "zero-size
        # array to reduction", a (2, 3) array was taken as two disks)
        raise ValueError(f"max_residual needs G of shape ({per}N,) with N >= 1, {what} in "
                         f"dof order, got shape {G.shape}")
    bad = np.flatnonzero(~np.isfinite(G))
    if bad.size:
        # (a NaN gave a residual of nan)
        raise ValueError(f"max_residual needs a finite G, got {bad.size} non-finite "
                         f"value(s), the first {G[bad[0]].item()!r} at dof {int(bad[0])}")
    if spheres:
        G = np.asarray(G).reshape(-1, 6)
        return float(max(np.max(np.linalg.norm(G[:, :3], axis=1)),
                         np.max(np.linalg.norm(G[:, 3:], axis=1))))
    G = np.asarray(G).reshape(-1, 3)
    return float(max(np.max(np.hypot(G[:, 0], G[:, 1])), np.max(np.abs(G[:, 2]))))


def roundoff_floor(state):
    r"""Residual that double precision allows for a state, as the driver accepts it.

    .. math::

        r_\mathrm{floor} = \max(10^{-10},\; 4\,\varepsilon\,X\,k_\mathrm{eff}),
        \quad k_\mathrm{eff} = \tfrac32 k_n^{2/3} F^{1/3},

    X the largest coordinate or box length, F the largest external load per
    disk (or, without loads, the largest contact force of the dump, or 1):
    the driver's acceptance level of a stagnating Newton iteration
    (``remote_trigger.pywrap.stages.equilibrium.accept_level``, docs/driver.md).

    Parameters
    ----------
    state : State or State3D

    Returns
    -------
    float
        Force units.
    """
    X = max(float(np.max(np.abs(state.positions))), float(np.max(state.box_hi - state.box_lo)))
    if isinstance(state, State3D):
        F = float(np.max(np.linalg.norm(state.external, axis=1))) if state.n else 0.0
    else:
        F = float(np.max(np.hypot(state.external[:, 0], state.external[:, 1]))) \
            if state.external.size else 0.0
    cf = getattr(state, "contact_forces", None)
    if not F > 0 and cf is not None and cf.size:
        F = float(np.max(np.hypot(state.contact_forces[:, 0], state.contact_forces[:, 1])))
    if not F > 0:
        F = 1.0
    keff = 1.5 * float(state.params.k_n) ** (2.0 / 3.0) * F ** (1.0 / 3.0)
    return max(FLOOR_MIN, ROUNDOFF_FACTOR * np.finfo(float).eps * X * keff)


def check_equilibrium(state, factor=FAR_ABOVE_FLOOR, what=None):
    """Refuse a state whose residual is far above the round-off floor.

    A Jacobian and its spectrum describe the linear motion about an
    equilibrium; at a state that is not one (wrong k_n, mu or loads in the
    sidecar, a dump written with too few digits, a state in motion) they
    describe nothing, and a "complex pair" found there is meaningless.

    Parameters
    ----------
    state : State or State3D
    factor : float
        Refuse above ``factor`` x :func:`roundoff_floor` (default 1e3).
    what : str, optional
        Name of the state in the message (default its source file).

    Returns
    -------
    ratio : float
        Residual / floor.

    Raises
    ------
    NotEquilibriumError
        An ``InputError`` (``ValueError``), naming the residual, the floor
        and what to check.
    ValueError
        If ``factor`` is not a number > 0.
    """
    from remote_trigger.analysis.errors import NotEquilibriumError

    if not is_real(factor) or not factor > 0:
        raise ValueError(f"factor must be a number > 0, got factor = {factor!r}")

    spheres = isinstance(state, State3D)
    r = max_residual(generalized_residual(state), spheres)
    floor = roundoff_floor(state)
    ratio = r / floor
    if not ratio <= factor:
        name = what or state.source or "the state"
        raise NotEquilibriumError(
            f"{name} is not an equilibrium of its parameters: residual max |G| = {r:.3g} "
            f"is {ratio:.3g} x the round-off floor {floor:.3g} (k_n = {state.params.k_n!r},"
            f" k_t = {state.params.k_t!r}, mu = {state.params.mu!r}, F_x = "
            f"{state.F_x!r}, F_y = {state.F_y!r}); check the sidecar and the "
            f"dump's precision (%.17g)")
    return ratio
