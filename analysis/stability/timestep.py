r"""Stable time step of the undamped dynamics from the contact stiffness.

LAMMPS integrates :math:`M\ddot q = G(q)` with velocity Verlet
(``fix nve/sphere disc``). Linearised about a state, one step maps a mode of
:math:`M^{-1}K` with eigenvalue :math:`\lambda` through
:math:`z^2 - (2 - \lambda\,dt^2) z + 1 = 0`; for real :math:`\lambda > 0`
both roots stay on the unit circle iff :math:`\lambda\,dt^2 < 4`. The
**stability limit** is therefore

.. math::

    dt_{\max} = \frac{2}{\omega_{\max}}, \qquad
    \omega_{\max} = \sqrt{\max_i |\lambda_i(M^{-1}K)|},

with K the stiffness of ``jacobian.stiffness_matrix`` (normal *and*
tangential terms; the rotational coordinate :math:`\phi = R\theta` has mass
:math:`I/R^2 = m/2`, which is where the largest :math:`\omega` usually
comes from once friction is on). Complex eigenvalues are a physical
instability, not a numerical one; their modulus is used.

Three estimates of :math:`\omega_{\max}`:

* ``'eigen'`` -- the largest :math:`|\lambda|` of :math:`M^{-1}K` (LAPACK
  for up to 600 degrees of freedom, else ARPACK ``which='LM'``): the limit
  itself.
* ``'gershgorin'`` -- :math:`\max_i \sum_j |(M^{-1}K)_{ij}|`, a rigorous
  upper bound on every :math:`|\lambda|`, O(contacts); its limit is never
  above the true one (measured 1.17 x below it frictionless, 1.24 x with
  friction, on a compressed lattice).
* :func:`hertz_limit` -- *a priori*, without a state: the per-contact
  stiffness :math:`k_\mathrm{eff} = \tfrac32 k_n\delta^{1/2}` at the overlap
  :math:`\delta = (F/k_n)^{2/3}` of the largest contact force F, the
  tangential stiffness :math:`\tfrac43 k_t\delta^{1/2}` (max of
  :math:`\partial_\xi f_t`), z contacts per disk and the smallest mass
  (:math:`m/2` of the rotation), Gershgorin-style. Conservative.

**Safety factor.** The recommended step is
:data:`SAFETY_FACTOR` :math:`\times\,dt_{\max}` = 0.1 :math:`dt_\max`
(:math:`\omega_{\max} dt = 0.2`). It is chosen from the accuracy table
(``docs/accuracy.md``): at 0.1 dt_max the growth rate of an unstable mode is
within 1 % of the dt -> 0 value (Verlet map: 0.24 %; measured fit: 0.6 %),
the energy of an undamped Hertz run stays within 1.5e-3 relative
(proportional to dt^2, the same for k_n = 2e5 ... 2e9), 1.1 dt_max blows up,
and the nonlinear Hertz stiffness
(:math:`k_\mathrm{eff} \propto \delta^{1/2}` grows when a contact is
squeezed) and contacts that form during a run cannot push the step past the
limit. For the model's defaults (k_n = 2e5, F_y = 3, N = 100) the limit is
about 9.5e-3 and the default dt = 1e-3 is 0.105 of it.

Scaling: at fixed forces :math:`\omega_{\max}\propto k_n^{1/3}`, so
k_n = 2e7 and 2e9 need steps 4.6 and 21.5 x smaller than k_n = 2e5.
"""
from __future__ import annotations

import math

import numpy as np

from remote_trigger.analysis.errors import InputError, is_integer, is_real
from remote_trigger.analysis.state.sidecar import default_k_t

__all__ = ["SAFETY_FACTOR", "TimestepError", "omega_max", "stability_limit",
           "stable_timestep", "hertz_limit", "check_timestep"]

#: recommended dt as a fraction of the stability limit 2/omega_max
SAFETY_FACTOR = 0.1
#: below this many dofs 'eigen' uses dense LAPACK, above ARPACK
_DENSE_LIMIT = 600


class TimestepError(InputError):
    """A time step at or above the stability limit (the message gives the limit).

    A ``ValueError``; command-line exit status 2.
    """


def _dynamical(state):
    """M^-1 K of disks (State) or spheres (State3D)."""
    from remote_trigger.analysis.stability.eigen import dynamical_matrix
    from remote_trigger.analysis.stability.jacobian import stiffness_matrix
    from remote_trigger.analysis.stability.jacobian3d import stiffness_matrix3d
    from remote_trigger.analysis.state.state3d import State3D

    K = (stiffness_matrix3d if isinstance(state, State3D) else stiffness_matrix)(state)
    return dynamical_matrix(K, state.mass_diagonal())


def omega_max(state, method="eigen"):
    """Largest angular frequency sqrt(max |lambda|) of M^-1 K.

    Parameters
    ----------
    state : State or State3D
        Packing of disks or spheres; any state, not only an equilibrium.
    method : {'eigen', 'gershgorin'}
        ``'eigen'``: the largest |lambda| (dense LAPACK up to 600 dofs, else
        ARPACK; falls back to Gershgorin if ARPACK does not converge).
        ``'gershgorin'``: max absolute row sum of M^-1 K, an upper bound.

    Returns
    -------
    float
        omega_max in 1/time; 0 for a state without contacts.

    Raises
    ------
    ValueError
        Unknown method, or a state with non-finite stiffness.
    """
    if method not in ("eigen", "gershgorin"):
        raise ValueError(f"method must be 'eigen' or 'gershgorin', got {method!r}")
    A = _dynamical(state)
    if A.nnz == 0:
        return 0.0
    if not np.all(np.isfinite(A.data)):
        raise ValueError("the stiffness matrix has non-finite entries")
    gersh = float(np.max(np.asarray(abs(A).sum(axis=1)).ravel()))
    if method == "gershgorin":
        return math.sqrt(gersh)
    n = A.shape[0]
    if n <= _DENSE_LIMIT:
        lam = np.linalg.eigvals(A.toarray())
        return math.sqrt(float(np.max(np.abs(lam))))
    import scipy.sparse.linalg as spla

    try:
        # a fixed start vector: ARPACK's own random start depends on its earlier
        # calls in the process, and with it the last bits of the limit (and of
        # every dt derived from it)
        lam = spla.eigs(A, k=1, which="LM", tol=1e-6, return_eigenvectors=False,
                        maxiter=20 * n, v0=np.random.default_rng(0).standard_normal(n))
        return math.sqrt(float(np.max(np.abs(lam))))
    except spla.ArpackNoConvergence:
        return math.sqrt(gersh)


def stability_limit(state, method="eigen"):
    """Velocity-Verlet stability limit dt_max = 2 / omega_max.

    Parameters
    ----------
    state : State
    method : {'eigen', 'gershgorin'}
        See :func:`omega_max`; ``'gershgorin'`` gives a limit that is never
        above the true one.

    Returns
    -------
    float
        dt_max (time units); ``inf`` if the state has no contacts.
    """
    w = omega_max(state, method)
    return math.inf if w == 0.0 else 2.0 / w


def stable_timestep(state, safety=SAFETY_FACTOR, method="eigen"):
    """Recommended time step: ``safety`` x the stability limit.

    Parameters
    ----------
    state : State
        A representative state (e.g. the equilibrium the run starts from).
    safety : float, optional
        Fraction of the limit, 0 < safety < 1 (default :data:`SAFETY_FACTOR`).
    method : {'eigen', 'gershgorin'}

    Returns
    -------
    float

    Raises
    ------
    ValueError
        If safety is not in (0, 1), or the state has no contacts (the contact
        stiffness then sets no time scale).
    """
    if not (0.0 < safety < 1.0):
        raise ValueError(f"safety must be in (0, 1), got {safety!r}")
    lim = stability_limit(state, method)
    if not math.isfinite(lim):
        raise ValueError("no contacts: the contact stiffness sets no time scale, so no "
                         "stable time step can be derived from it")
    return safety * lim


def hertz_limit(k_n, force, k_t=None, mass=1.0, contacts=6, inertia=0.5):
    """A-priori stability limit from the largest contact force, without a state.

    Parameters
    ----------
    k_n : float
        Normal stiffness (force/length^{3/2}), > 0.
    force : float
        Largest contact force expected (e.g. a few times the load F_y), > 0.
    k_t : float, optional
        Tangential stiffness (default 2 k_n / 7); 0 for frictionless.
    mass : float, optional
        Disk mass m (the rotational coordinate has mass I0 m).
    contacts : int, optional
        Contacts per disk z (default 6, dense 2D packing; 12 for spheres).
    inertia : float, optional
        I0 of I = I0 m R^2: 1/2 for disks (default), 2/5 for spheres.

    Returns
    -------
    float
        2 / sqrt(lambda_bound) with lambda_bound = 2 z (k_eff + (4/3) k_t
        delta^{1/2}) / (I0 m), k_eff = (3/2) k_n delta^{1/2},
        delta = (force / k_n)^{2/3}. Never above the eigenvalue limit of a
        packing whose contact forces are below ``force``.

    Raises
    ------
    ValueError
        For k_n, force, mass or inertia not a finite number > 0, k_t not
        one >= 0, or contacts not an integer >= 1.
    """
    def number(name, val, low=0.0):
        if not is_real(val) \
                or not (math.isfinite(val) and val > low):
            raise ValueError(f"{name} must be a finite number > {low:g}, got {name} = {val!r}")

    for name, val in (("k_n", k_n), ("force", force), ("mass", mass), ("inertia", inertia)):
        number(name, val)
    if k_t is None:
        k_t = default_k_t(k_n)
    if not is_real(k_t) \
            or not (math.isfinite(k_t) and k_t >= 0):
        raise ValueError(f"k_t must be a finite number >= 0, got k_t = {k_t!r}")
    if not is_integer(contacts) or contacts < 1:
        raise ValueError(f"contacts must be an integer >= 1, got contacts = {contacts!r}")
    sqd = (force / k_n) ** (1.0 / 3.0)
    lam = 2.0 * contacts * (1.5 * k_n * sqd + (4.0 / 3.0) * k_t * sqd) / (inertia * mass)
    return 2.0 / math.sqrt(lam)


def check_timestep(dt, limit, safety=None, what="dt"):
    """Refuse a time step at or above the stability limit.

    Parameters
    ----------
    dt : float
        Proposed time step.
    limit : float or State
        Stability limit dt_max, > 0 (+inf: no contact sets a limit), or a
        State to compute it from (:func:`stability_limit`, method ``'eigen'``).
    safety : float, optional
        If given, in (0, 1]: also refuse dt above ``safety * limit`` (strict
        mode).
    what : str, optional
        Name of the quantity in the message.

    Returns
    -------
    float
        dt / limit (the fraction of the limit used).

    Raises
    ------
    TimestepError
        If dt is not a positive finite number, dt >= limit, or (strict)
        dt > safety * limit. The message gives the limit, omega_max and the
        recommended step.
    ValueError
        If ``limit`` is not a number > 0 (NaN included) or ``safety`` is not
        in (0, 1].
    """
    if not isinstance(limit, (int, float, np.floating)):
        limit = stability_limit(limit)
    elif isinstance(limit, bool) or not limit > 0:
        raise ValueError(f"limit must be a number > 0 (inf: no limit), got limit = {limit!r}")
    if safety is not None and (not is_real(safety) or not 0.0 < safety <= 1.0):
        raise ValueError(f"safety must be a number in (0, 1], got safety = {safety!r}")
    if not is_real(dt) \
            or not (math.isfinite(dt) and dt > 0):
        raise TimestepError(f"{what} must be a finite number > 0, got {dt!r}")
    if not math.isfinite(limit):
        return 0.0
    rec = SAFETY_FACTOR * limit
    msg = (f"{what} = {dt:.6g} {{}} the velocity-Verlet stability limit "
           f"dt_max = 2/omega_max = {limit:.6g} (omega_max = {2.0 / limit:.6g}); "
           f"use dt <= {rec:.4g} ({SAFETY_FACTOR} x dt_max)")
    if dt >= limit:
        raise TimestepError(msg.format("is at or above"))
    if safety is not None and dt > safety * limit:
        raise TimestepError(msg.format(f"is above {safety} x") )
    return dt / limit
