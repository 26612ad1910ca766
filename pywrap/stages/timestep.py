r"""Time step of a driver stage: ``dt = 'auto'`` and the refusal of unstable steps.

Every stage (relax, ramp, perturb, instability) calls :func:`resolve` once,
after loading its starting data file and before running any step. It

1. estimates the velocity-Verlet stability limit :math:`dt_{\max}` of the
   run (:mod:`remote_trigger.analysis.stability.timestep`);
2. refuses ``cfg.dt`` at or above that limit with a
   :class:`~remote_trigger.analysis.stability.timestep.TimestepError` (a
   ``ValueError``; the command line prints it and exits with status 2)
   whose message gives the limit, omega_max and the recommended step;
3. replaces ``dt = 'auto'`` by ``SAFETY_FACTOR`` :math:`\times dt_{\max}`
   (0.1, chosen from the accuracy table, docs/accuracy.md).

Which limit (**choice**, docs/driver.md):

* **From an equilibrium** (ramp, perturb, instability; relax with
  ``settle_steps = 0`` of a data file that has contacts): the limit of the
  starting state itself, ``2 / sqrt(max |lambda(M^-1 K)|)`` with the analytic
  stiffness including friction (``'eigen'``: LAPACK up to 600 dofs, else
  ARPACK). The loads change the contact forces little along a stage, so
  this is the limit of the whole run (measured: the limits of all the
  equilibria of a ramp up to F_x^c are within 0.4 % of the first one's,
  N = 20, 31 equilibria; 0.2 %, N = 100, 23 equilibria).
* **Relax with compaction** (``settle_steps > 0``, a loose packing with few or
  no contacts): no state to measure yet. The a-priori Hertz bound
  :func:`~remote_trigger.analysis.stability.timestep.hertz_limit` is used, with the
  largest contact force estimated as :data:`FORCE_FACTOR` times the load of
  one column, ``max(|(F_x, F_y)|, g_settle m_max N_bulk / N_top)``
  (measured: the largest contact force of relaxed packings, N = 20-400, is
  2.2-3.9 times the column load F_y), and the limit of the start state if it
  has contacts, whichever is smaller. This estimate is conservative: on
  the relaxed packings (N = 20-400, 3 seeds each) their eigenvalue limit is
  2.5-2.8 times the Hertz bound at their real largest force. ``relax.h5``
  records the eigenvalue limit of the final equilibrium as well.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["FORCE_FACTOR", "TimestepInfo", "relax_force_estimate", "limit_of", "resolve"]

#: largest contact force of a compaction = FORCE_FACTOR x the load of one column
FORCE_FACTOR = 5.0


class TimestepInfo(dict):
    """What :func:`resolve` decided; written as HDF5 attributes of the stage.

    Keys: ``dt_used`` (float), ``dt_max`` (the limit, ``inf`` without
    contacts), ``dt_fraction`` (dt_used / dt_max), ``dt_limit_source``
    (``'eigen'`` or ``'hertz a priori'``), ``dt_auto`` (bool).
    """


def relax_force_estimate(cfg, state):
    """Estimated largest contact force of a compaction under gravity and loads.

    Parameters
    ----------
    cfg : RelaxConfig
    state : AtomState
        The loose packing (uses the masses and the ``top`` flags).

    Returns
    -------
    float
        FORCE_FACTOR x max(|(F_x, F_y)|, g_settle m_max N_bulk / N_top).
    """
    n_top = max(1, int(np.count_nonzero(state.top)))
    n_bulk = state.n - n_top
    weight = float(getattr(cfg, "g_settle", 0.0)) * float(np.max(state.masses)) * n_bulk / n_top
    load = math.hypot(float(getattr(cfg, "F_x", 0.0)), float(cfg.F_y))
    return FORCE_FACTOR * max(load, weight)


def limit_of(state, cfg, F_x, a_priori=False):
    """Stability limit for a run of ``cfg`` from a gathered state.

    Parameters
    ----------
    state : AtomState
        Gathered from LAMMPS (:meth:`Engine.gather_state`).
    cfg : StageConfig
        Model (k_n, k_t, mu, F_y; for ``a_priori`` also g_settle).
    F_x : float
        Horizontal load of the run.
    a_priori : bool
        Combine with the a-priori Hertz bound (relax with compaction); a
        state without any contact always gets that bound.

    Returns
    -------
    (float, str)
        dt_max and its source (``'eigen'`` or ``'hertz a priori'``).
    """
    from remote_trigger.analysis.stability import timestep as ts
    from remote_trigger.pywrap.stages.newton_solve import analysis_state

    mu = max(float(cfg.mu), float(getattr(cfg, "mu_settle", 0.0)))
    st = analysis_state(state, cfg.k_n, cfg.k_t, mu, F_x, cfg.F_y)
    lim, src = math.inf, "eigen"
    walls = st.wall_index.size if state.dim == 3 else np.count_nonzero(st.wall_delta > 0)
    if st.n_contacts + walls > 0:
        lim = ts.stability_limit(st, "eigen")
    # no contact yet (a loose packing): the contacts the loads will make are
    # bounded a priori as for a compaction (an infinite limit let any dt through)
    if a_priori or not math.isfinite(lim):
        kt = float(cfg.k_t) if mu > 0 else 0.0
        # spheres: up to 12 contacts, rotational mass 2/5 m
        shape = dict(contacts=12, inertia=0.4) if state.dim == 3 else {}
        bound = ts.hertz_limit(float(cfg.k_n), relax_force_estimate(cfg, state), k_t=kt,
                               mass=float(np.min(state.masses)), **shape)
        if bound < lim:
            lim, src = bound, "hertz a priori"
    return lim, src


def resolve(eng, cfg, F_x, a_priori=False, stage="stage"):
    """Check ``cfg.dt`` against the stability limit; resolve ``'auto'``.

    Call with the stage's starting data file loaded in ``eng`` (all ranks).
    The limit is computed on rank 0 and broadcast.

    Parameters
    ----------
    eng : Engine
    cfg : StageConfig
    F_x : float
    a_priori : bool
        See :func:`limit_of`.
    stage : str
        Name for the messages.

    Returns
    -------
    (StageConfig, TimestepInfo)
        ``cfg`` with a numeric dt (unchanged if it was a number) and the
        decision.

    Raises
    ------
    TimestepError
        If dt >= dt_max, or dt is ``'auto'`` and there is no contact and no
        a-priori bound (nothing sets a time scale).
    ConfigError
        If the start state cannot be analysed (e.g. disks whose centres lie
        inside each other).
    """
    from remote_trigger.analysis.stability.timestep import (
        SAFETY_FACTOR, TimestepError, check_timestep)

    state = eng.gather_state()
    res, err = None, None
    if eng.rank == 0:
        try:
            res = limit_of(state, cfg, F_x, a_priori=a_priori)
        except ValueError as exc:      # the start state is unusable: bad input
            err = ("input", f"{exc}")
        except Exception as exc:  # noqa: BLE001 - re-raised on every rank
            err = ("other", f"{type(exc).__name__}: {exc}")
    res, err = eng.comm.bcast((res, err), root=0)
    if err and err[0] == "input":
        from remote_trigger.pywrap.config import ConfigError

        raise ConfigError(f"{stage}: start state {cfg.datafile}: {err[1]}")
    if err:
        raise RuntimeError(f"{stage}: stability limit of {cfg.datafile}: {err[1]}")
    lim, src = res
    auto = cfg.dt == "auto"
    if auto:
        if not math.isfinite(lim):
            raise TimestepError(f"{stage}: dt = 'auto' needs contacts (or a compaction) "
                                f"to set a time scale; {cfg.datafile} has none: give dt")
        dt = SAFETY_FACTOR * lim
        cfg = cfg.replace(dt=dt)
    else:
        dt = float(cfg.dt)
        try:
            check_timestep(dt, lim, what="dt")
        except TimestepError as exc:
            how = ("a-priori Hertz bound of a compaction (conservative; see "
                   "docs/driver.md)" if src != "eigen" else f"start state {cfg.datafile}")
            raise TimestepError(f"{stage}: {exc}, or dt = 'auto' [limit from the {how}]") \
                from None
    info = TimestepInfo(dt_used=float(dt), dt_max=float(lim),
                        dt_fraction=float(dt / lim) if math.isfinite(lim) else 0.0,
                        dt_limit_source=src, dt_auto=bool(auto))
    return cfg, info
