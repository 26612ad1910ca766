r"""Mechanical equilibrium: over-damped dynamics and Newton polishing.

The residual of disk i is its generalized force (paper Eq. 42)

.. math::

    G_i = (F_{x,i},\ F_{y,i},\ T_i / R_i), \qquad
    r = \max_i \max(|F_i|, |T_i|/R_i),

contact forces plus the external loads on ``top``. Equilibrium means
r < f_min (paper: 1e-15).

Newton polishing
----------------
With K = -dG/dq the analytic stiffness (``remote_trigger.analysis.stability.jacobian``,
paper Appendix C), one Newton step solves K dq = G
(:mod:`remote_trigger.pywrap.stages.newton_solve`) and applies dq *as a
displacement that advances the contact history by the same increment rule as
the dynamics* (Eq. 14): with no integrator fix defined, the driver sets
x += dq_xy, v = dq_xy / dt and omega = dphi / (R dt), runs one step (the pair
style and the wall fix add dt (s.(v_i - v_j) + R_i w_i + R_j w_j) = d xi to
the history; nothing moves the atoms), then zeroes the velocities. A step is
accepted only if it lowers r; otherwise the previous state is restored and
polishing stops, so the residual history is monotone once polishing starts.
The iteration is a modified Newton method (:func:`polish`): a factorised K
is reused while it contracts the residual by 1e-2 or more, or once r is below
the acceptance level; a reused K that fails above that level is replaced and
the step repeated. From a neighbouring equilibrium (a ramp step) one
factorisation reaches the round-off floor.

.. warning::

   Double precision bounds the residual that any method can reach: a
   position x carries an error ~ eps |x| and a contact of stiffness
   k_eff = (3/2) k_n delta^(1/2) (~ 7e3 at the default loads) turns it into
   a force error ~ k_eff eps |x| ~ 1e-12 -- 1e-11 for |x| ~ 5 -- 10. The
   paper's f_min = 1e-15 is therefore below round-off for its own packing;
   the driver reports the residual it reached and accepts a stagnating
   Newton iteration below ``f_accept``.
"""
from dataclasses import dataclass, field
import math
import time

import numpy as np

from remote_trigger.analysis.errors import RemoteTriggerError, EXIT_NO_EQUILIBRIUM
from remote_trigger.pywrap.stages.common import PLATE_FIX
from remote_trigger.pywrap.stages.newton_solve import newton_solver, stiffness

DAMPING_FIXES = ("damp", "rdamp")
#: largest displacement (length) one Newton step may apply; longer steps are
#: scaled down (and accepted only if they lower the residual)
MAX_NEWTON_STEP = 0.02
INTEGRATOR_FIXES = ("integ",)


class NoEquilibriumError(RemoteTriggerError, RuntimeError):
    """No mechanical equilibrium: the top layer slides away (or never settles).

    A ``RuntimeError``; command-line exit status 3.
    """

    exit_status = EXIT_NO_EQUILIBRIUM


@dataclass
class RelaxRecord:
    """History of one relaxation (all lists have one entry per check).

    Attributes
    ----------
    time : list of float
        Simulated time of damped dynamics so far (lj units).
    residual : list of float
        r after that check (damped phase: estimate with the damping force
        removed; Newton phase: exact, v = 0).
    phase : list of str
        ``'damped'`` or ``'newton'``; the relax stage also records
        ``'fire'`` (the residual after FIRE, ``relax_dynamics = 'fire'``)
        and ``'friction-on'``.
    wall : list of float
        Wall-clock seconds since the start.
    """

    time: list = field(default_factory=list)
    residual: list = field(default_factory=list)
    phase: list = field(default_factory=list)
    wall: list = field(default_factory=list)

    def add(self, t, r, phase, t0):
        """Record a check: simulated time ``t``, residual ``r``, ``phase``, and
        the wall time since ``t0`` (a ``time.perf_counter()`` value)."""
        self.time.append(float(t))
        self.residual.append(float(r))
        self.phase.append(phase)
        self.wall.append(time.perf_counter() - t0)


def residual_of(state, damping=None):
    """Generalized residual G (N, 3) and r from a gathered :class:`AtomState`.

    Parameters
    ----------
    state : AtomState
        With ``f`` and ``torque`` of the last force evaluation.
    damping : tuple (gamma, gamma_rot), optional
        Remove the viscous forces -gamma v and torques -gamma_rot omega that
        ``fix viscous`` / ``fix viscous/sphere`` added.

    Returns
    -------
    G : ndarray, shape (N, 3)
        Spheres: (N, 6), (F, T/R); r = max_i max(|F_i|, |T_i|/R_i) with
        Euclidean norms.
    r : float
    """
    f = state.forces.copy()
    tq = state.torques.copy()
    if damping is not None:
        f += damping[0] * state.velocities
        tq += damping[1] * state.omega
    if state.dim == 3:
        G = np.column_stack([f, tq / state.radii[:, None]])
        r = max(float(np.max(np.linalg.norm(f, axis=1))),
                float(np.max(np.linalg.norm(G[:, 3:], axis=1))))
        return G, r
    G = np.column_stack([f, tq / state.radii])
    r = max(float(np.max(np.hypot(G[:, 0], G[:, 1]))), float(np.max(np.abs(G[:, 2]))))
    return G, r


#: smallest acceptance level of a stagnating Newton iteration (``f_accept = None``)
F_ACCEPT_MIN = 1e-10
#: round-off residual floor, measured: r_floor ~ 0.5 eps |x| k_eff; auto level = 4 eps |x| k_eff
ROUNDOFF_FACTOR = 4.0


def accept_level(cfg, state):
    r"""Residual accepted from a stagnating Newton iteration (``cfg.f_accept``).

    ``cfg.f_accept`` if it is a number. If it is None (default): the
    round-off floor of double precision, scaled with the contact stiffness
    and the size of the packing,

    .. math::

        f_\mathrm{accept} = \max(10^{-10},\; 4\,\varepsilon\,X\,k_\mathrm{eff}),
        \quad k_\mathrm{eff} = \tfrac32 k_n^{2/3} F^{1/3},

    with X the largest coordinate or box width, F = max(F_y, |F_x|) and
    epsilon = 2.2e-16: a position carries an error eps X, which a Hertz
    contact of stiffness k_eff (at force F) turns into a force error.
    Measured floors (N = 20, F_y = 3): 6e-12, 9.4e-11 and 1.9e-9 at
    k_n = 2e5, 2e7, 2e9, i.e. ~0.5 eps X k_eff. For the default model
    (k_n = 2e5, N <= 400) this gives 1e-10.

    Parameters
    ----------
    cfg : RelaxConfig
    state : AtomState

    Returns
    -------
    float
    """
    if cfg.f_accept is not None:
        return float(cfg.f_accept)
    X = max(float(np.max(np.abs(state.positions))), float(np.max(state.box_hi - state.box_lo)))
    F = max(float(cfg.F_y), abs(float(getattr(cfg, "F_x", 0.0))))
    keff = 1.5 * float(cfg.k_n) ** (2.0 / 3.0) * F ** (1.0 / 3.0)
    return max(F_ACCEPT_MIN, ROUNDOFF_FACTOR * np.finfo(float).eps * X * keff,
               float(cfg.f_min))


def exact_residual(eng):
    """r of the current state with v = 0 and no damping/integrator fix: ``run 0``."""
    eng.run(0, pre=True)
    st = eng.gather_state()
    G, r = residual_of(st)
    return st, G, r


#: a Newton step that closes a gap is shortened until the Hertz force of the
#: new contact, k_n delta^(3/2), is at most this fraction of the residual
#: (:func:`closing_fraction`)
CLOSING_FORCE = 0.5


def closing_fraction(state, dq, k_n, r, wall_y=0.0):
    """Fraction alpha <= 1 of a Newton step for which no gap closes too far.

    K contains only the contacts of the current state; a gap it does not
    know about closes under the step dq and, if the step overshoots, the new
    contact's force k_n delta^(3/2) exceeds the residual the step was meant
    to remove (measured at N = 1600: gaps of 1e-7 closed to overlaps of
    3e-6, force 1e-3 against r = 5e-5; the step is then rejected). With
    g(alpha) = g0 + alpha (g1 - g0) the gap along the step (disk-disk and
    disk-wall), alpha is the largest fraction at which every closing gap
    has overlap at most delta* = (CLOSING_FORCE r / k_n)^(2/3); 1 if no gap
    closes beyond delta*.

    Parameters
    ----------
    state : AtomState
    dq : ndarray, shape (N, 3) or (N, 6)
        The step (x, y, rotation R theta; spheres x, y, z, R theta); only
        the translations matter.
    k_n : float
        Normal stiffness (Hertz force k_n delta^(3/2)).
    r : float
        Current residual (force).
    wall_y : float, optional
        Height of the flat bottom wall.

    Returns
    -------
    float in (0, 1]
    """
    from remote_trigger.analysis.state.contacts import find_contacts, minimum_image

    dim = state.positions.shape[1]
    d_star = (CLOSING_FORCE * r / k_n) ** (2.0 / 3.0)
    move = float(np.max(np.abs(dq[:, :dim]))) if dq.size else 0.0
    if not move > d_star:
        return 1.0
    R = state.radii
    pos = state.positions
    periodic = (True, False, True)[:dim]
    i, j, rho = find_contacts(pos, R, state.box_lo, state.box_hi, periodic, gap=2.0 * move)
    g0 = np.concatenate([rho - R[i] - R[j], pos[:, 1] - R - wall_y])
    L = state.box_hi[:dim] - state.box_lo[:dim]
    d1 = minimum_image(pos[i] + dq[i, :dim] - pos[j] - dq[j, :dim], L, periodic)
    rho1 = np.hypot(d1[:, 0], d1[:, 1]) if dim == 2 else np.sqrt(np.sum(d1 * d1, axis=1))
    g1 = np.concatenate([rho1 - R[i] - R[j], pos[:, 1] + dq[:, 1] - R - wall_y])
    bad = (g0 > 0.0) & (g1 < -d_star)
    if not np.any(bad):
        return 1.0
    return float(np.min((g0[bad] + d_star) / (g0[bad] - g1[bad])))


#: Newton gives way to damped dynamics after this many accepted steps in a row
#: that each lowered a residual above the acceptance level by less than
#: SLOW_CONTRACTION (see :func:`polish`)
SLOW_STEPS = 3
SLOW_CONTRACTION = 0.5

#: a factorised K is reused for the next Newton step while the last step
#: contracted the residual at least this much (modified Newton, see :func:`polish`)
REUSE_CONTRACTION = 1e-2


def polish(eng, cfg, F_x, record, t0, t_sim, target=None, chord_below=None):
    """Newton iterations on the live LAMMPS state (see module docstring).

    With ``chord_below`` set the iteration is a modified Newton method: the
    factorised K is reused (a chord step) while the last step contracted the
    residual by at least :data:`REUSE_CONTRACTION` or the residual is below
    ``chord_below``. From a nearby equilibrium (a ramp step) K changes
    between iterates by a relative ~1e-4 (displacement / overlap), so a
    chord step contracts about as much as a Newton step and one
    factorisation reaches the round-off floor; at the floor K changes by
    ~1e-9 and a new one buys nothing. A chord step that does not lower a
    residual above ``chord_below`` is undone and repeated with a new K;
    the iteration stops (stagnation) only when a step with a new K, or any
    step below ``chord_below``, does not lower it.

    Two guards for steps that leave the contact set K was built on (both
    measured on the N = 1600 packing of ``make bench``; neither changes the
    default packing's relaxation or ramps, bitwise):

    * a step that would close a gap K does not contain into an overlap
      whose Hertz force exceeds :data:`CLOSING_FORCE` times the residual is
      shortened to the fraction that does not (:func:`closing_fraction`);
      without it such steps were rejected and damped dynamics had to let
      the contact form (4 chunks, 3.3-4.7 s instead of 1.1-1.9 s per point);
    * with ``chord_below`` set, :data:`SLOW_STEPS` accepted steps in a row
      that each lower a residual above ``chord_below`` by less than
      :data:`SLOW_CONTRACTION` end the iteration (``'slow'``; the caller
      goes back to damped dynamics), instead of crawling with shortened
      steps or a singular K (N = 9600: 30 steps of ~5 s for a factor 1.5).

    Parameters
    ----------
    eng : Engine
        Scene loaded, no damping or integrator fix, velocities zero.
    cfg : RelaxConfig
    F_x : float
        Current horizontal load (for the external forces of the Jacobian).
    record : RelaxRecord
        Appended with one ``'newton'`` entry per accepted step.
    t0 : float
        perf_counter at the start of the relaxation.
    t_sim : float
        Simulated damped time so far (for the record).
    target : float, optional
        Stop below this residual (default ``cfg.f_min``).
    chord_below : float, optional
        The acceptance level (:func:`accept_level`); None: a new K at every
        step (Newton's method).

    Returns
    -------
    r : float
        Residual reached (the state in LAMMPS is the best one found).
    stop : str
        Why the iteration ended: ``''`` (below ``target``, or
        ``cfg.newton_iter`` steps), ``'stagnated'`` (the last step did not
        lower the residual) or ``'slow'`` (see above).
    """
    target = cfg.f_min if target is None else target
    state, G, r = exact_residual(eng)
    # a rigid top layer (fix plate): its x, y and z are three dofs
    top = np.nonzero(state.top)[0]
    tie = [6 * top + c for c in range(3)] if eng.has_fix(PLATE_FIX) else None
    record.add(t_sim, r, "newton", t0)
    stop = ""
    solve = None
    reuse = False           # same on every rank: whether the next step may reuse K
    slow = 0                # accepted steps in a row that contracted by < SLOW_CONTRACTION
    for _ in range(cfg.newton_iter):
        if r < target:
            break
        fresh = not reuse
        dq = None
        if eng.rank == 0:   # one solve, broadcast: every rank applies the same step
            if fresh:
                solve = newton_solver(stiffness(state, cfg.k_n, cfg.k_t, cfg.mu, F_x,
                                                cfg.F_y), tie=tie)
            dq = solve(G)
            if np.all(np.isfinite(dq)):
                big = float(np.max(np.abs(dq)))
                if big > MAX_NEWTON_STEP:      # far from the basin: shorten the step
                    dq *= MAX_NEWTON_STEP / big
                # (below the acceptance level, gaps closed by round-off-sized
                # steps carry no force worth a neighbour search: 0.5 ms at N = 100)
                if CLOSING_FORCE and not (chord_below is not None and r < chord_below):
                    dq *= closing_fraction(state, dq, cfg.k_n, r)
        dq = eng.comm.bcast(dq, root=0)
        if not np.all(np.isfinite(dq)):
            if not fresh:
                reuse = False
                continue
            stop = "stagnated"
            break
        _apply_step(eng, state, dq, cfg.dt)
        eng.run(1, pre=True)
        eng.scatter("v", np.zeros((state.n, state.dim)))
        eng.scatter("omega", np.zeros((state.n, 3) if state.dim == 3 else state.n))
        new = eng.gather_state()
        G_new, r_new = residual_of(new)
        below = chord_below is not None and r < chord_below
        if not r_new < r:
            eng.restore(state)
            if not fresh and not below:     # a stale K failed: a new one, same state
                reuse = False
                continue
            state, G, r = exact_residual(eng)
            stop = "stagnated"
            break
        reuse = chord_below is not None and (below or r_new <= REUSE_CONTRACTION * r
                                             or r_new < chord_below)
        slow = slow + 1 if (chord_below is not None and not below
                            and r_new > SLOW_CONTRACTION * r) else 0
        state, G, r = new, G_new, r_new
        record.add(t_sim, r, "newton", t0)
        if slow >= SLOW_STEPS:      # crawling (steps cut short by closing gaps, or
            stop = "slow"           # a singular K): damped dynamics do better
            break
    return r, stop


def _apply_step(eng, state, dq, dt):
    """Set x += dq (translations), v = dq / dt, omega = dphi / (R dt): the next
    ``run 1`` advances the history by the step's increment (module docstring).
    dq of shape (N, 3) (disks) or (N, 6) (spheres: dphi a vector)."""
    d = state.dim
    eng.scatter("x", state.positions + dq[:, :d])
    eng.scatter("v", dq[:, :d] / dt)
    if d == 3:
        eng.scatter("omega", dq[:, 3:] / (state.radii[:, None] * dt))
    else:
        eng.scatter("omega", dq[:, 2] / (state.radii * dt))


def equilibrate(eng, cfg, F_x, record=None, progress=None, newton_first=False):
    """Bring the loaded scene to equilibrium at load F_x.

    Over-damped dynamics in chunks of ``cfg.check_every`` steps; once the
    residual estimate is below ``cfg.newton_start``, Newton polishing; if
    polishing stops above the acceptance level (:func:`accept_level`),
    back to dynamics. A Newton phase that accepted steps and stopped above
    that level at r_end is tried again only once the dynamics are below
    r_end (otherwise Newton phases and damped chunks can cycle near an
    unstable equilibrium: measured on ``ensemble --quick``'s N = 16
    packing, see :func:`polish`).

    Parameters
    ----------
    eng : Engine
        Scene of ``in.relax`` loaded (fix ``2d`` present; damping and
        integrator fixes may or may not be).
    cfg : RelaxConfig
    F_x : float
        Load to equilibrate at (``variable load_x`` is set to it).
    record : RelaxRecord, optional
    progress : callable, optional
        Called as ``progress(residual)`` after each check.
    newton_first : bool
        Try Newton before any dynamics (ramp steps from a nearby equilibrium).

    Returns
    -------
    r : float
        Final residual (LAMMPS holds the equilibrium, v = 0, no damping fixes).
    t_sim : float
        Damped time used.
    record : RelaxRecord

    Raises
    ------
    NoEquilibriumError
        If the top layer slides farther than ``cfg.slide`` or ``cfg.max_steps``
        damped steps do not reach the acceptance level.
    """
    t0 = time.perf_counter()
    record = RelaxRecord() if record is None else record
    eng.command(f"variable load_x equal {F_x!r}")
    st0 = eng.gather_state()
    x0 = float(np.mean(st0.unwrapped_positions()[st0.top, 0]))
    accept = accept_level(cfg, st0)
    t_sim = 0.0
    steps = 0
    # a Newton phase that accepted steps but ended above the acceptance level
    # at r_end is tried again only once the damped dynamics are below r_end:
    # Newton phases pulling the state back towards an unstable equilibrium,
    # alternating with damped chunks that leave it, made a livelock
    # (measured: N = 16, F_x = 0.08, mu = 0.8, r cycling 2.5e-3 -> 1.8e-3)
    newton_below = math.inf

    def newton():
        nonlocal newton_below
        eng.unfix(*DAMPING_FIXES, *INTEGRATOR_FIXES)
        eng.command("velocity all set 0.0 0.0 0.0")
        eng.command("set group all omega 0.0 0.0 0.0")
        n0 = len(record.residual)
        r, stop = polish(eng, cfg, F_x, record, t0, t_sim, chord_below=accept)
        newton_below = r if len(record.residual) > n0 + 1 else math.inf
        return r, stop

    if newton_first and cfg.newton:
        r, stop = newton()
        if r < cfg.f_min or (stop and r < accept):
            return r, t_sim, record
    while True:
        if not eng.has_fix("integ"):
            eng.run_section("damped")
        eng.run(cfg.check_every, pre=True)
        steps += cfg.check_every
        t_sim += cfg.check_every * cfg.dt
        st = eng.gather_state()
        _, r = residual_of(st, (cfg.gamma, cfg.gamma_rot))
        record.add(t_sim, r, "damped", t0)
        if progress is not None:
            progress(r)
        dx = float(np.mean(st.unwrapped_positions()[st.top, 0])) - x0
        if abs(dx) > cfg.slide:
            raise NoEquilibriumError(
                f"no equilibrium at F_x = {F_x!r}: the top layer slid {dx:.3g} "
                f"(> slide = {cfg.slide}) in t = {t_sim:.4g}")
        if cfg.newton and r < cfg.newton_start * cfg.F_y and r < newton_below:
            r, stop = newton()
            if r < cfg.f_min or (stop and r < accept):
                return r, t_sim, record
        elif not cfg.newton and r < max(cfg.f_min, accept):
            # damped dynamics alone stall near the round-off floor, far above
            # the default f_min = 1e-15: they stop at the acceptance level
            eng.unfix(*DAMPING_FIXES, *INTEGRATOR_FIXES)
            eng.command("velocity all set 0.0 0.0 0.0")
            eng.command("set group all omega 0.0 0.0 0.0")
            _, _, r = exact_residual(eng)
            record.add(t_sim, r, "damped", t0)
            return r, t_sim, record
        if steps >= cfg.max_steps:
            raise NoEquilibriumError(
                f"no equilibrium reached at F_x = {F_x!r} within max_steps = "
                f"{cfg.max_steps} (residual {r:.3g} > f_accept = {accept:.3g})")
