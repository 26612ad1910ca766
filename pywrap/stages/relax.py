"""The relax stage: the default protocol (frictionless-then-friction) and its steps.

Part of :mod:`remote_trigger.pywrap.stages`; the LAMMPS commands of the
protocol are sections of ``lammps_inputs/in.relax`` (docs/driver.md, "Decks"),
for spheres of ``in.relax3d`` (same section names; docs/driver.md,
"Spheres"): the same steps, with FIRE for the frictionless relaxation and
the 3D Jacobian for Newton.
"""
from dataclasses import dataclass, field
import os
import time

import numpy as np

from remote_trigger.pywrap.config import ConfigError
from remote_trigger.pywrap.stages.config import RELAX_DYNAMICS_AUTO_N, RelaxConfig
from remote_trigger.pywrap.bindings.engine import Engine
from remote_trigger.pywrap.stages import equilibrium as eq
from remote_trigger.pywrap.stages.newton_solve import stiffness
from remote_trigger.pywrap.stages.packing import placement_offsets
from remote_trigger.pywrap.runtime.results import write_atomic
from remote_trigger.pywrap.stages.common import (
    PLATE_FIX, RESULT_VERSION, ensure_dir, equilibrium_files, hold_layer, progress_bar,
    load_relax_scene, packing_fraction, prepare_out, save_equilibrium, start_timestep)


@dataclass
class RelaxResult:
    """Outcome of :func:`relax`.

    Attributes
    ----------
    residual : float
        r = max_i max(|F_i|, |T_i|/R_i) reached (exact, ``run 0``), with the
        friction of ``cfg.mu`` on.
    converged : bool
        r < f_min (else r is the round-off floor, < f_accept).
    wall_time : float
        Seconds.
    damped_time : float
        Simulated time of over-damped dynamics (lj units), compaction excluded.
    newton_iterations : int
        Accepted Newton steps.
    packing_fraction : float
        phi = sum pi R^2 / (L h), h = max(y + R), all disks (top included).
    history : RelaxRecord
    datafile, dumpfile, h5 : str
        Outputs.
    protocol : str
        Protocol used (``cfg.protocol``).
    antisymmetry : float
        ||K - K^T||_F / ||K||_F of the final equilibrium (0 when every
        tangential displacement is zero).
    top_clearance : float
        Clearance of the final state by the rule of :func:`clearance_rule`
        (:func:`top_clearance`; > 0: clear).
    clearance_rule : str
        That rule, ``'all'`` or ``'local'`` (relax.h5 attribute
        ``clearance_rule``).
    compaction_time : float
        Wall seconds of the compaction (and piston) phases.
    top_attempts : int
        Placements of the ``top`` line tried (default protocol).
    timestep : dict
        The time-step decision (:class:`~remote_trigger.pywrap.stages.timestep.TimestepInfo`:
        ``dt_used``, ``dt_max``, ``dt_fraction``, ``dt_limit_source``,
        ``dt_auto``) plus ``dt_max_equilibrium`` and
        ``dt_fraction_equilibrium``, the eigenvalue limit of the final
        equilibrium.
    """

    residual: float
    converged: bool
    wall_time: float
    damped_time: float
    newton_iterations: int
    packing_fraction: float
    history: object
    datafile: str
    dumpfile: str
    h5: str
    protocol: str = "frictionless-then-friction"
    antisymmetry: float = float("nan")
    top_clearance: float = float("nan")
    clearance_rule: str = ""
    compaction_time: float = 0.0
    top_attempts: int = 0
    timestep: dict = field(default_factory=dict)


def set_friction(eng, mu):
    """Set the friction coefficient of the pair style and the wall to ``mu``.

    Runs the ``friction`` section of ``in.relax`` (its wall uses
    ``v_mu_now``) with the string variable ``mu_set`` = ``repr(mu)`` (the
    exact double); needs that scene loaded.
    """
    eng.command(f"variable mu_set string {float(mu)!r}")
    eng.run_section("friction")


def compact_bulk(eng):
    """Protocol step (i): frictionless compaction of the bulk under gravity.

    The ``compact`` section of ``in.relax``: the ``top`` disks are not
    integrated (held where they are, above the bulk); the bulk disks move
    with the damped dynamics and gravity ``g_settle`` for ``settle_steps``
    steps (the deck variables, from the configuration). Friction must
    already be off. Ends with v = omega = 0 and the integrator restored on
    all disks.
    """
    eng.run_section("compact")


def place_top(eng, gap):
    """Protocol step (ii): move the ``top`` line rigidly (along y) onto the bulk.

    The ``lower`` section of ``in.relax``: after the move the lowest point of
    the line, min over top of (y - R), is ``gap`` (the deck's ``top_gap``)
    above the highest bulk point, max over bulk of (y + R): no top disk touches
    the bulk, and each falls onto the bulk surface under F_y.

    Returns
    -------
    float
        The displacement applied (negative = down).

    Raises
    ------
    ValueError
        If there are no top or no bulk disks, or the moved line would leave
        the box (checked before the move).
    """
    st = eng.gather_state()
    top = st.top
    if not np.any(top) or np.all(top):
        raise ValueError(f"place_top needs top and bulk disks, got {int(top.sum())} top "
                         f"disks of {st.n}")
    # the deck's lower_measure section, on the gathered positions (no run 0)
    y, R = st.positions[:, 1], st.radii
    dy = float(np.max(y[~top] + R[~top]) + gap - np.min(y[top] - R[top]))
    if np.max(y[top] + R[top]) + dy >= st.box_hi[1]:
        raise ValueError(f"the top line does not fit below the box top ylo/yhi = "
                         f"{st.box_hi[1]!r} after a move by dy = {dy!r}")
    eng.command(f"variable dy string {dy!r}")
    eng.run_section("lower")
    return dy


def press_top(eng, F_x):
    """Protocol step (iii a): the ``top`` line as a rigid piston on the bulk.

    The ``press`` section of ``in.relax``: ``fix aveforce`` (defined after
    the loads and the damping, so that it averages the total force) gives
    every top disk the mean force of the line: the line translates rigidly,
    pressing on the frictionless bulk with the loads, so no bulk disk can
    squeeze between two top disks while the surface layer rearranges.
    Damped dynamics in runs of ``check`` steps until the largest speed is
    below ``v_stop``, at most ``press_steps`` steps (deck variables); then
    the ``press_end`` section removes the constraint and sets v = omega = 0.

    Returns
    -------
    int
        Steps run.
    """
    eng.command(f"variable load_x equal {float(F_x)!r}")
    if not eng.has_fix("integ"):
        eng.run_section("damped")
    check = int(eng.equal("check_v"))
    max_steps = int(eng.equal("press_steps_v"))
    v_stop = eng.equal("v_stop_v")
    eng.run_section("press")
    steps = 0
    try:                               # the loop of the deck's press_loop section
        while steps < max_steps:
            eng.run(check, pre=(steps == 0))
            steps += check
            v = eng.gather("v")
            speed = (np.hypot(v[:, 0], v[:, 1]) if eng.dimension == 2
                     else np.linalg.norm(v, axis=1))
            if float(np.max(speed)) < v_stop:
                break
        eng.run_section("press_end")
    finally:
        eng.unfix("piston")
    return steps


#: ``relax_dynamics = 'fire'``: FIRE stops once the largest force on any disk is
#: below FIRE_FTOL x F_y (Newton then polishes to the acceptance level)
FIRE_FTOL = 1e-6


def relax_dynamics(cfg, n, dim=2):
    """The dynamics of the frictionless steps (iii) for ``n`` disks: 'damped' or 'fire'.

    ``cfg.relax_dynamics`` unless it is ``'auto'``: then ``'damped'`` for
    n <= :data:`~remote_trigger.pywrap.stages.config.RELAX_DYNAMICS_AUTO_N`
    (400), ``'fire'`` above; always ``'fire'`` for spheres (``dim`` = 3).
    """
    if cfg.relax_dynamics != "auto":
        return cfg.relax_dynamics
    return "damped" if n <= RELAX_DYNAMICS_AUTO_N and dim == 2 else "fire"


def check_spheres_config(cfg):
    """Refuse the options of ``relax`` that are 2D only, for a packing of spheres.

    Spheres relax with the default protocol, FIRE and Newton: damped
    dynamics do not bring a loaded 3D packing to rest (1e5 steps), and the
    frictional protocol compacts with friction by damped dynamics.

    Raises
    ------
    ConfigError
        ``protocol = 'frictional'``, ``relax_dynamics = 'damped'`` or
        ``newton = False`` (``--no-newton``), naming the value.
    """
    bad = [(k, v, why) for k, v, ok, why in (
        ("protocol", cfg.protocol, "frictionless-then-friction",
         "it compacts with friction by damped dynamics, which do not bring a loaded 3D "
         "packing to rest"),
        ("relax_dynamics", cfg.relax_dynamics, ("auto", "fire"),
         "damped dynamics do not bring a loaded 3D packing to rest"),
        ("newton", cfg.newton, True, "damped dynamics alone do not reach equilibrium"))
        if not (v in ok if isinstance(ok, tuple) else v == ok)]
    if bad:
        k, v, why = bad[0]
        raise ConfigError(f"{k} = {v!r} is 2D only: {cfg.datafile} holds spheres "
                          f"(dimension 3), and {why} (docs/driver.md, 'Spheres')")


def fire_minimize(eng, cfg, ftol=None, max_steps=None):
    """FIRE energy minimization of the loaded frictionless scene (section ``fire``).

    The ``fire`` section of ``in.relax``: LAMMPS's ``min_style fire`` with
    the forces of the pair, the wall, the loads and of any constraint
    defined (the piston of :func:`press_top`), until the largest force on a
    disk is below ``ftol`` (default :data:`FIRE_FTOL` x F_y) or after
    ``max_steps`` (default ``cfg.max_steps``) iterations; then v = omega = 0. The damping and
    integrator fixes are removed first (``fix viscous`` would act on FIRE's
    velocities); :func:`~remote_trigger.pywrap.stages.equilibrium.equilibrate`
    re-adds them if it needs damped dynamics. Friction must be off (the
    plugin refuses minimize with friction).

    Returns
    -------
    int
        FIRE iterations.
    """
    ftol = FIRE_FTOL * cfg.F_y if ftol is None else ftol
    eng.unfix(*eq.DAMPING_FIXES, *eq.INTEGRATOR_FIXES)
    eng.command(f"variable fire_ftol string {float(ftol)!r}")
    max_steps = cfg.max_steps if max_steps is None else max_steps
    eng.command(f"variable fire_steps string {int(max_steps)}")
    step0 = eng.step()
    eng.run_section("fire")
    return eng.step() - step0


def press_top_fire(eng, cfg):
    """Protocol step (iii a) with ``relax_dynamics = 'fire'``: the piston by FIRE.

    The same rigid piston as :func:`press_top` (section ``press``), relaxed
    by :func:`fire_minimize` instead of damped dynamics; then the
    ``press_end`` section.

    Returns
    -------
    int
        FIRE iterations.
    """
    eng.command(f"variable load_x equal {float(cfg.F_x)!r}")
    eng.run_section("press")
    try:
        steps = fire_minimize(eng, cfg)
        eng.run_section("press_end")
    finally:
        eng.unfix("piston")
    return steps


def clearance_rule(cfg, n, dim=2):
    """The clearance test of a placement for ``n`` disks: 'all' or 'local'.

    ``cfg.clearance`` unless it is ``'auto'``: then ``'all'`` for n <=
    :data:`~remote_trigger.pywrap.stages.config.RELAX_DYNAMICS_AUTO_N` (400)
    disks, ``'local'`` above and for spheres (``dim`` = 3).
    """
    if cfg.clearance != "auto":
        return cfg.clearance
    return "all" if n <= RELAX_DYNAMICS_AUTO_N and dim == 2 else "local"


def top_clearance(state, rule=None):
    """Clearance of the top line (or layer) above the bulk; > 0: clear.

    ``rule = 'all'``: min over top disks of y minus max over bulk disks of y
    (centres). ``rule = 'local'``: min over bulk disks b of (the highest
    top centre within a horizontal distance :data:`~remote_trigger.pywrap.
    stages.packing.TOP_SPACING_3D` (1.25) of b, minus y_b), minimum images
    along the periodic x (and z); > 0 when no bulk disk has come up through
    or over the line, whatever the line's height does along the box; -inf
    where the line has opened (no top centre within that distance).
    Default (None): 'all' for disks, 'local' for spheres (a layer's height
    varies across the box more than a line's).
    """
    from remote_trigger.analysis.state.contacts import minimum_image
    from remote_trigger.pywrap.stages.packing import TOP_SPACING_3D

    rule = rule or ("all" if state.dim == 2 else "local")
    y = state.positions[:, 1]
    if rule == "all":
        return float(np.min(y[state.top]) - np.max(y[~state.top]))
    if rule != "local":
        raise ValueError(f"rule must be 'all' or 'local', got rule = {rule!r}")
    cols = [0] if state.dim == 2 else [0, 2]
    h = state.positions[:, cols]
    L = (state.box_hi - state.box_lo)[cols]
    d = minimum_image(h[~state.top][:, None, :] - h[state.top][None, :, :], L,
                      (True,) * len(cols))
    dist = np.abs(d[..., 0]) if state.dim == 2 else np.hypot(d[..., 0], d[..., 1])
    near = dist < TOP_SPACING_3D
    above = np.where(near, y[state.top][None, :], -np.inf).max(axis=1)
    return float(np.min(above - y[~state.top]))


def antisymmetry(state, cfg, F_x):
    """||K - K^T||_F / ||K||_F of a gathered state (K: analysis Jacobian)."""
    K = stiffness(state, cfg.k_n, cfg.k_t, cfg.mu, F_x, cfg.F_y)
    if hasattr(K, "tocsr"):          # above DENSE_NEWTON_MAX dof
        import scipy.sparse.linalg as spla

        nrm = float(spla.norm(K))
        return float(spla.norm(K - K.T) / nrm) if nrm > 0 else 0.0
    nrm = float(np.linalg.norm(K))
    return float(np.linalg.norm(K - K.T) / nrm) if nrm > 0 else 0.0


#: ``relax_dynamics = 'fire'``: while Newton stops above the acceptance level
#: after FIRE, FIRE runs again with its force tolerance divided by this factor
#: (not below the acceptance level), then Newton again
FIRE_RETRY_FACTOR = 100.0
#: ... at most this many times, each of at most FIRE_RETRY_STEPS iterations; then
#: damped dynamics, as for ``'damped'``
FIRE_RETRIES = 3
FIRE_RETRY_STEPS = 50_000


def _fire_relax(eng, cfg, t0, progress=None):
    """Step (iii b) with FIRE: FIRE, then Newton; FIRE again, tighter, while Newton stalls.

    :func:`fire_minimize` to :data:`FIRE_FTOL` F_y, then Newton polishing
    (:func:`~remote_trigger.pywrap.stages.equilibrium.polish`, modified
    Newton as in ``equilibrate``). If Newton stops above the acceptance level
    (:func:`~remote_trigger.pywrap.stages.equilibrium.accept_level`; at
    N = 10^4 it stagnated after FIRE to 3e-6), FIRE runs again from the
    state Newton reached with its tolerance divided by
    :data:`FIRE_RETRY_FACTOR` (not below the acceptance level), and Newton
    again, at most :data:`FIRE_RETRIES` times (of at most
    :data:`FIRE_RETRY_STEPS` FIRE iterations; measured: 300-2500 at
    N = 1600); only then damped dynamics with Newton (``equilibrate``), the
    former fallback.

    Returns
    -------
    r, t_sim, record
        As :func:`~remote_trigger.pywrap.stages.equilibrium.equilibrate`
        (t_sim = 0 unless the damped fallback ran).

    Raises
    ------
    NoEquilibriumError
        If the ``top`` line slid farther than ``cfg.slide`` along x (FIRE or
        the fallback), as the damped dynamics would.
    """
    eng.command(f"variable load_x equal {float(cfg.F_x)!r}")
    st = eng.gather_state()
    x0 = float(np.mean(st.unwrapped_positions()[st.top, 0]))
    rec = eq.RelaxRecord()
    ftol = FIRE_FTOL * cfg.F_y
    for attempt in range(FIRE_RETRIES + 1):
        fire_minimize(eng, cfg, ftol, None if attempt == 0 else FIRE_RETRY_STEPS)
        st = eng.gather_state()
        dx = float(np.mean(st.unwrapped_positions()[st.top, 0])) - x0
        if abs(dx) > cfg.slide:
            raise eq.NoEquilibriumError(f"no equilibrium at F_x = {cfg.F_x!r}: the top layer "
                                        f"slid {dx:.3g} (> slide = {cfg.slide}) under FIRE")
        rec.add(0.0, eq.residual_of(st)[1], "fire", t0)
        if not cfg.newton:
            break
        accept = eq.accept_level(cfg, st)
        r, stop = eq.polish(eng, cfg, cfg.F_x, rec, t0, 0.0, chord_below=accept)
        if progress is not None:
            progress(r)
        if r < cfg.f_min or (stop and r < accept):
            return r, 0.0, rec
        if ftol <= accept:
            break
        ftol = max(ftol / FIRE_RETRY_FACTOR, accept)
    return eq.equilibrate(eng, cfg, cfg.F_x, record=rec, progress=progress)


def _frictionless_then_friction(eng, cfg, prog, t0):
    """Steps (i)-(iv) of the default protocol (see :func:`relax`).

    Returns (r, t_sim, record, compaction wall time, attempts).
    """
    cfg0 = cfg.replace(mu=0.0)
    load_relax_scene(eng, cfg0, cfg.datafile, cfg.F_x)
    fire = relax_dynamics(cfg, eng.natoms, eng.dimension) == "fire"
    rule = clearance_rule(cfg, eng.natoms, eng.dimension)
    t_comp = 0.0
    offsets = [0.0]
    if cfg.settle_steps > 0:
        tc = time.perf_counter()
        compact_bulk(eng)
        place_top(eng, cfg.top_gap)
        t_comp = time.perf_counter() - tc
        offsets = placement_offsets(eng.gather_state(), cfg.top_attempts)
    start = eng.gather_state()
    best = None
    for k, dx in enumerate(offsets):
        eng.unfix(PLATE_FIX)           # (a placement's plate is not the next piston's)
        if k > 0:                      # same compacted bulk, line shifted along x
            eng.restore(start)
            eng.command(f"variable dx string {dx!r}")
            eng.run_section("shift")
        if cfg.settle_steps > 0:
            tc = time.perf_counter()
            if fire:
                press_top_fire(eng, cfg0)
            else:
                press_top(eng, cfg.F_x)
            t_comp += time.perf_counter() - tc
        hold_layer(eng, cfg)
        try:
            if fire:       # FIRE, Newton; FIRE again tighter while Newton stalls
                r, t_sim, rec = _fire_relax(eng, cfg0, t0, prog)
            else:
                r, t_sim, rec = eq.equilibrate(eng, cfg0, cfg.F_x, progress=prog)
        except eq.NoEquilibriumError as exc:
            if k + 1 < len(offsets):
                continue
            if best is not None:
                break
            raise eq.NoEquilibriumError(
                f"frictionless stage of protocol {cfg.protocol!r}: {exc}") from None
        st = eng.gather_state()
        clear = top_clearance(st, rule)
        if best is None or clear > best[0]:
            best = (clear, st, r, t_sim, rec, k)
        if clear > 0:
            break
    clear, st, r, t_sim, rec, k = best
    if k != len(offsets) - 1 or not clear > 0:
        eng.restore(st)
    eng.unfix(*eq.DAMPING_FIXES, *eq.INTEGRATOR_FIXES)
    # (iv) friction on; xi = 0 on every contact, so the forces are unchanged
    set_friction(eng, cfg.mu)
    st, _, r = eq.exact_residual(eng)
    if np.any(st.xi != 0.0) or np.any(st.wall_xi != 0.0):
        raise RuntimeError("friction switched on with nonzero contact history "
                           f"(max |xi| = {float(np.max(np.abs(st.xi))):.3g})")
    rec.add(t_sim, r, "friction-on", t0)
    if not r < eq.accept_level(cfg, st):   # (not expected: xi = 0) polish with friction
        r, t_sim, rec = eq.equilibrate(eng, cfg, cfg.F_x, record=rec, progress=prog,
                                       newton_first=True)
    return r, t_sim, rec, t_comp, k + 1


def relax(cfg, out, comm=None, quiet=False, log="none", overwrite=False):
    """Relax a packing to mechanical equilibrium at load (F_x, -F_y).

    ``cfg.protocol = 'frictionless-then-friction'`` (default; docs/driver.md):
    frictionless compaction of the bulk under gravity with the ``top`` line
    held (:func:`compact_bulk`, skipped if ``settle_steps`` = 0), the line
    lowered onto the bulk (:func:`place_top`), frictionless relaxation under
    the loads (over-damped + Newton), then friction ``cfg.mu`` switched on
    with zero history (still an equilibrium: the residual is re-evaluated,
    and polished with friction if it is not below ``f_accept``). The piston
    and the frictionless relaxation come to rest by damped dynamics or, with
    ``cfg.relax_dynamics`` = ``'fire'`` (default above 400 disks,
    :func:`relax_dynamics`), by FIRE minimization (:func:`press_top_fire`,
    :func:`fire_minimize`) before the same Newton polish.
    ``'frictional'``: compaction of all disks with ``mu_settle``, then
    relaxation with friction.

    Parameters
    ----------
    cfg : RelaxConfig
    out : str
        Output folder: writes ``relax.h5`` and ``relax/equilibrium.*``.
    comm : mpi4py communicator, optional
    quiet : bool
        No progress bar.
    log : str
        LAMMPS log file.
    overwrite : bool
        Replace the results of an earlier relax in ``out`` (default: refuse).

    Returns
    -------
    RelaxResult

    Raises
    ------
    ConfigError
        ``out`` is not a writable folder or holds relax results (unless
        ``overwrite``); the data file is empty, truncated, has non-finite
        values or coincident disks.
    NoEquilibriumError
        If the top layer slides away or no equilibrium is reached; at once,
        before any dynamics, for ``F_x != 0`` under the default protocol
        (its frictionless step (iii) has no equilibrium under a horizontal
        load).
    """
    if not isinstance(cfg, RelaxConfig):
        raise ConfigError(f"relax needs a RelaxConfig, got {type(cfg).__name__}")
    if cfg.protocol == "frictionless-then-friction" and cfg.F_x != 0.0:
        # (iii): the flat wall's force is along y; the packing would drift
        raise eq.NoEquilibriumError(
            f"no equilibrium at F_x = {cfg.F_x!r} in the frictionless step (iii) of "
            "protocol 'frictionless-then-friction' (mu = 0 on every contact and on the "
            "wall: nothing balances a horizontal load); relax at F_x = 0 and ramp to the "
            "load (remote-trigger ramp), or use protocol 'frictional'")
    t0 = time.perf_counter()
    with Engine(comm=comm, log=log) as eng:
        cfg_in = cfg
        cfg, dtinfo = start_timestep(eng, cfg, cfg.datafile, cfg.F_x, "relax",
                                     a_priori=cfg.settle_steps > 0)
        if eng.dimension == 3:
            check_spheres_config(cfg)
        elif cfg.top_layer != "free":
            raise ConfigError(f"top_layer = {cfg.top_layer!r} is for spheres: {cfg.datafile} "
                              f"holds disks (dimension 2), whose top line is free "
                              f"(docs/model.md)")
        prepare_out(eng, out, ["relax.h5"] + equilibrium_files("relax"), overwrite, "relax")
        ensure_dir(eng, os.path.join(out, "relax"))
        bar = progress_bar(None, "relax", quiet, eng.rank, unit=" checks")

        def prog(r):
            bar.update(1)
            bar.set_postfix_str(f"residual {r:.2e}")

        t_comp, attempts = 0.0, 0
        try:
            if cfg.protocol == "frictionless-then-friction":
                r, t_sim, rec, t_comp, attempts = _frictionless_then_friction(
                    eng, cfg, prog, t0)
            else:
                load_relax_scene(eng, cfg, cfg.datafile, cfg.F_x)
                if cfg.settle_steps > 0:
                    tc = time.perf_counter()
                    set_friction(eng, cfg.mu_settle)
                    eng.commands(f"fix grav all gravity {cfg.g_settle!r} vector 0 -1 0\n"
                                 f"run {cfg.settle_steps}\nunfix grav\n")
                    set_friction(eng, cfg.mu)
                    t_comp = time.perf_counter() - tc
                r, t_sim, rec = eq.equilibrate(eng, cfg, cfg.F_x, progress=prog)
            bar.set_postfix_str(f"residual {r:.2e}")     # the result's (after Newton)
        finally:
            bar.close()
        prefix = os.path.join(out, "relax", "equilibrium")
        save_equilibrium(eng, cfg, cfg.F_x, prefix)
        state = eng.gather_state()
        phi = packing_fraction(state)
        asym = antisymmetry(state, cfg, cfg.F_x) if eng.rank == 0 else None
        asym = eng.comm.bcast(asym, root=0)
        rule = clearance_rule(cfg, state.n, state.dim)
        clear = top_clearance(state, rule)
        wall = time.perf_counter() - t0
        nnewton = max(0, sum(1 for p in rec.phase if p == "newton") - 1)
        h5 = os.path.join(out, "relax.h5")
        if eng.rank == 0:
            from remote_trigger.pywrap.stages.timestep import limit_of

            lim_eq, _ = limit_of(state, cfg, cfg.F_x)
            dtinfo.update(dt_max_equilibrium=lim_eq,
                          dt_fraction_equilibrium=cfg.dt / lim_eq if lim_eq < np.inf else 0.0)
        dtinfo = eng.comm.bcast(dtinfo, root=0)
        if eng.rank == 0:
            attrs = dict(cfg_in.to_attrs(), **dtinfo, stage="relax", status="complete",
                         version=RESULT_VERSION, residual=r, converged=bool(r < cfg.f_min),
                         wall_time=wall, damped_time=t_sim, packing_fraction=phi,
                         antisymmetry=asym, top_clearance=clear, clearance_rule=rule,
                         compaction_time=t_comp, top_attempts=attempts,
                         n_ranks=eng.size, datafile_out=prefix + ".data",
                         dumpfile=prefix + ".dump")
            write_atomic(h5, attrs, {
                "history/time": np.asarray(rec.time), "history/residual":
                np.asarray(rec.residual), "history/phase": np.asarray(rec.phase, object),
                "history/wall_time": np.asarray(rec.wall)})
        eng.comm.Barrier()
    return RelaxResult(r, bool(r < cfg.f_min), wall, t_sim, nnewton, phi, rec,
                       prefix + ".data", prefix + ".dump", h5, protocol=cfg.protocol,
                       antisymmetry=asym, top_clearance=clear, clearance_rule=rule,
                       compaction_time=t_comp,
                       top_attempts=attempts, timestep=dict(dtinfo))


# --------------------------------------------------------------------------- ramp
