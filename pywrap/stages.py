"""The driver stages: relax, ramp, perturb, instability (docs/model.md section 6).

Each stage is one function taking a validated configuration
(:mod:`remote_trigger.pywrap.config`) and an output folder, and returning a
result object. All MPI ranks of the communicator call the function (LAMMPS
runs domain-decomposed); rank 0 writes the files and runs the eigenvalue
analysis, and broadcasts every decision so that all ranks follow the same path.

Files (fixed names under the output folder ``out``; docs/driver.md):

========================  ===================================================
``relax.h5``              relaxation history; ``relax/equilibrium.*``
``ramp.h5``               one row per ramp step and per bisection step;
                          ``ramp/step_NNNNN.*``, ``ramp/bisect_NNN.*``
``perturb_{a,b,c}.h5``    the three undamped runs; ``perturb/equilibrium.*``
``instability.h5``        the undamped run above F_x^c;
                          ``instability/equilibrium.*``
========================  ===================================================

``X.*`` is an equilibrium: ``X.data`` (``write_data``, exact restart),
``X.dump`` and ``X.dump.json`` (docs/conventions.md section 3).
"""
from dataclasses import dataclass, field
import os
import time

import numpy as np

from .config import ConfigError, RelaxConfig, RampConfig, DynamicsConfig
from .engine import Engine, DUMP_COLUMNS
from . import equilibrium as eq
from .results import write_atomic, SeriesWriter, read_all
from .parallel import on_rank0
from . import ramp_file
from remote_trigger.analysis.output import atomic_path
from remote_trigger.analysis.series import growth_fit

RESULT_VERSION = 1


class StableStartError(ConfigError):
    """:func:`instability` asked to start from a linearly stable equilibrium (exit 2)."""


# --------------------------------------------------------------------------- helpers
def _progress(total, desc, quiet, rank, unit="it"):
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, disable=quiet or rank != 0, unit=unit,
                leave=False, dynamic_ncols=True)


#: deck variable <- configuration field, passed when the configuration has it
#: (otherwise the deck's default applies)
_DECK_FIELDS = (("gamma", "gamma"), ("gamma_rot", "gamma_rot"),
                ("settle_steps", "settle_steps"), ("g_settle", "g_settle"),
                ("top_gap", "top_gap"), ("check", "check_every"))


def _deck_vars(cfg, datafile, F_x):
    v = {"datafile": datafile, "kn": float(cfg.k_n), "kt": float(cfg.k_t),
         "mu": float(cfg.mu), "Fx": float(F_x), "Fy": float(cfg.F_y),
         "dt": float(cfg.dt)}
    for var, name in _DECK_FIELDS:
        if hasattr(cfg, name):
            val = getattr(cfg, name)
            v[var] = int(val) if var in ("settle_steps", "check") else float(val)
    return v


def load_relax_scene(eng, cfg, datafile, F_x, deck="in.relax"):
    """Load the scene and the damped dynamics of ``deck`` from a data file."""
    eng.clear()
    eng.load_deck(deck, _deck_vars(cfg, datafile, F_x), ("scene", "damped", "dynamics"))


def save_equilibrium(eng, cfg, F_x, prefix):
    """Write ``prefix.data``, ``prefix.dump`` and ``prefix.dump.json``.

    The state must be an equilibrium with v = 0 and no damping fix. The dump
    holds contact forces only (the loads are switched off for its ``run 0``:
    ``variable loadon equal 0``) and the loads in ``v_fext_x v_fext_y``.
    Each file is written under a temporary name and renamed.
    """
    rank0 = eng.rank == 0
    eng.command("variable loadon equal 0")
    eng.run(0)
    eng.command(f"write_dump all custom {prefix}.dump.part {DUMP_COLUMNS} "
                f"modify sort id format float %.17g")
    eng.command("variable loadon equal 1")
    eng.command(f"write_data {prefix}.data.part nocoeff")
    eng.run(0)
    if rank0:
        from remote_trigger.analysis.state import write_sidecar

        write_sidecar(f"{prefix}.dump", {"k_n": cfg.k_n, "k_t": cfg.k_t, "mu": cfg.mu,
                                         "wall_y": 0.0, "F_x": F_x, "F_y": cfg.F_y,
                                         "dt": cfg.dt})
        os.replace(f"{prefix}.dump.part", f"{prefix}.dump")
        os.replace(f"{prefix}.data.part", f"{prefix}.data")
    eng.comm.Barrier()


def packing_fraction(state):
    """phi = sum pi R^2 / (L h), h = max(y + R) above the wall at y = 0."""
    L = state.box_hi[0] - state.box_lo[0]
    h = float(np.max(state.x[:, 1] + state.radius))
    return float(np.sum(np.pi * state.radius ** 2) / (L * h))


def _analyze(eng, dump):
    """Eigen-analysis of a dump on rank 0, broadcast to all ranks."""
    from remote_trigger.analysis.stability import stability_of_dump

    return on_rank0(eng.comm, stability_of_dump, dump)


def _ensure_dir(eng, path):
    if eng.rank == 0:
        os.makedirs(path, exist_ok=True)
    eng.comm.Barrier()


def prepare_out(eng, out, files, overwrite=False, stage="stage"):
    """Check and create the output folder of a stage, on rank 0, before any run.

    Parameters
    ----------
    eng : Engine
    out : str
        Output folder (created with its parents).
    files : list of str
        The stage's results, relative to ``out``; any that exists is refused
        unless ``overwrite`` (nothing is ever silently replaced).
    overwrite : bool
    stage : str
        Name in messages.

    Raises
    ------
    ConfigError
        ``out`` is a file, cannot be created or written, or holds results of
        the same stage (on every rank).
    """
    from remote_trigger.analysis.output import output_dir

    def check():
        try:
            output_dir(out, "--out")
        except ValueError as exc:
            raise ConfigError(str(exc)) from None
        if not overwrite:
            found = [f for f in files if os.path.exists(os.path.join(out, f))]
            if found:
                raise ConfigError(f"the output folder {out!r} already holds {stage} results "
                                  f"({', '.join(found)}): choose another --out or remove "
                                  f"them (nothing was overwritten)")

    on_rank0(eng.comm, check)


def _equilibrium_files(name):
    return [os.path.join(name, "equilibrium" + ext) for ext in (".data", ".dump", ".dump.json")]


def _relax_cfg(cfg, F_x):
    """A RelaxConfig with the model of ``cfg`` (for equilibrating dynamics stages)."""
    keys = ("datafile", "k_n", "k_t", "mu", "F_y", "dt")
    base = {k: getattr(cfg, k) for k in keys}
    if isinstance(cfg, RelaxConfig):
        base = {k: getattr(cfg, k) for k in RelaxConfig.__dataclass_fields__}
    base["F_x"] = float(F_x)
    return RelaxConfig.from_dict(base)


def start_timestep(eng, cfg, datafile, F_x, stage, a_priori=False):
    """Load ``datafile``, check ``cfg.dt`` against the stability limit, resolve 'auto'.

    Returns ``(cfg with a numeric dt, TimestepInfo)``; see
    :func:`remote_trigger.pywrap.timestep.resolve`. No step is run.
    """
    from .datafile import check_datafile
    from .timestep import resolve

    check_datafile(datafile)
    probe = cfg.replace(dt=1.0) if cfg.dt == "auto" else cfg   # dt unused: no step run
    load_relax_scene(eng, probe, datafile, F_x)
    return resolve(eng, cfg, F_x, a_priori=a_priori, stage=stage)


# --------------------------------------------------------------------------- relax
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
        min over top disks of y minus max over bulk disks of y (> 0: every
        top disk centre is above every bulk disk centre).
    compaction_time : float
        Wall seconds of the compaction (and piston) phases.
    top_attempts : int
        Placements of the ``top`` line tried (default protocol).
    timestep : dict
        The time-step decision (:class:`~remote_trigger.pywrap.timestep.TimestepInfo`:
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
    y, R = st.x[:, 1], st.radius
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
            v = eng.gather("v")[:, :2]
            if float(np.max(np.hypot(v[:, 0], v[:, 1]))) < v_stop:
                break
        eng.run_section("press_end")
    finally:
        eng.unfix("piston")
    return steps


def top_clearance(state):
    """min over top disks of y minus max over bulk disks of y (centres)."""
    y = state.x[:, 1]
    return float(np.min(y[state.top]) - np.max(y[~state.top]))


def antisymmetry(state, cfg, F_x):
    """||K - K^T||_F / ||K||_F of a gathered state (K: analysis Jacobian)."""
    K = eq.stiffness_dense(state, cfg.k_n, cfg.k_t, cfg.mu, F_x, cfg.F_y)
    nrm = float(np.linalg.norm(K))
    return float(np.linalg.norm(K - K.T) / nrm) if nrm > 0 else 0.0


def _frictionless_then_friction(eng, cfg, prog, t0):
    """Steps (i)-(iv) of the default protocol (see :func:`relax`).

    Returns (r, t_sim, record, compaction wall time, attempts).
    """
    cfg0 = cfg.replace(mu=0.0)
    load_relax_scene(eng, cfg0, cfg.datafile, cfg.F_x)
    t_comp = 0.0
    offsets = [0.0]
    if cfg.settle_steps > 0:
        tc = time.perf_counter()
        compact_bulk(eng)
        place_top(eng, cfg.top_gap)
        t_comp = time.perf_counter() - tc
        st = eng.gather_state()
        spacing = float(st.box_hi[0] - st.box_lo[0]) / max(1, int(np.count_nonzero(st.top)))
        offsets = [k * spacing / cfg.top_attempts for k in range(cfg.top_attempts)]
    start = eng.gather_state()
    best = None
    for k, dx in enumerate(offsets):
        if k > 0:                      # same compacted bulk, line shifted along x
            eng.restore(start)
            eng.command(f"displace_atoms top move {dx!r} 0.0 0.0 units box")
        if cfg.settle_steps > 0:
            tc = time.perf_counter()
            press_top(eng, cfg.F_x)
            t_comp += time.perf_counter() - tc
        try:
            r, t_sim, rec = eq.equilibrate(eng, cfg0, cfg.F_x, progress=prog)
        except eq.NoEquilibriumError as exc:
            if k + 1 < len(offsets):
                continue
            if best is not None:
                break
            raise eq.NoEquilibriumError(
                f"frictionless stage of protocol {cfg.protocol!r}: {exc}") from None
        st = eng.gather_state()
        clear = top_clearance(st)
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
    and polished with friction if it is not below ``f_accept``).
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
        If the top layer slides away or no equilibrium is reached.
    """
    if not isinstance(cfg, RelaxConfig):
        raise ConfigError(f"relax needs a RelaxConfig, got {type(cfg).__name__}")
    t0 = time.perf_counter()
    with Engine(comm=comm, log=log) as eng:
        cfg_in = cfg
        cfg, dtinfo = start_timestep(eng, cfg, cfg.datafile, cfg.F_x, "relax",
                                     a_priori=cfg.settle_steps > 0)
        prepare_out(eng, out, ["relax.h5"] + _equilibrium_files("relax"), overwrite, "relax")
        _ensure_dir(eng, os.path.join(out, "relax"))
        bar = _progress(None, "relax", quiet, eng.rank, unit="chk")

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
        finally:
            bar.close()
        prefix = os.path.join(out, "relax", "equilibrium")
        save_equilibrium(eng, cfg, cfg.F_x, prefix)
        state = eng.gather_state()
        phi = packing_fraction(state)
        asym = antisymmetry(state, cfg, cfg.F_x) if eng.rank == 0 else None
        asym = eng.comm.bcast(asym, root=0)
        clear = top_clearance(state)
        wall = time.perf_counter() - t0
        nnewton = max(0, sum(1 for p in rec.phase if p == "newton") - 1)
        h5 = os.path.join(out, "relax.h5")
        if eng.rank == 0:
            from .timestep import limit_of

            lim_eq, _ = limit_of(state, cfg, cfg.F_x)
            dtinfo.update(dt_max_equilibrium=lim_eq,
                          dt_fraction_equilibrium=cfg.dt / lim_eq if lim_eq < np.inf else 0.0)
        dtinfo = eng.comm.bcast(dtinfo, root=0)
        if eng.rank == 0:
            attrs = dict(cfg_in.to_attrs(), **dtinfo, stage="relax", status="complete",
                         version=RESULT_VERSION, residual=r, converged=bool(r < cfg.f_min),
                         wall_time=wall, damped_time=t_sim, packing_fraction=phi,
                         antisymmetry=asym, top_clearance=clear, compaction_time=t_comp,
                         top_attempts=attempts,
                         n_ranks=eng.size, datafile_out=prefix + ".data",
                         dumpfile=prefix + ".dump")
            write_atomic(h5, attrs, {
                "history/time": np.asarray(rec.time), "history/residual":
                np.asarray(rec.residual), "history/phase": np.asarray(rec.phase, object),
                "history/wall_time": np.asarray(rec.wall)})
        eng.comm.Barrier()
    return RelaxResult(r, bool(r < cfg.f_min), wall, t_sim, nnewton, phi, rec,
                       prefix + ".data", prefix + ".dump", h5, protocol=cfg.protocol,
                       antisymmetry=asym, top_clearance=clear, compaction_time=t_comp,
                       top_attempts=attempts, timestep=dict(dtinfo))


# --------------------------------------------------------------------------- ramp
@dataclass
class RampResult:
    """Outcome of :func:`ramp`.

    Attributes
    ----------
    F_x : ndarray
        Loads of the ramp steps.
    residual : ndarray
        Residual reached at each step.
    complex_pair : ndarray of bool
        Certified complex pair (analyzer decision ``'complex'``).
    growth_rate : ndarray
        max Im sqrt(lambda) at each step (0 when stable).
    bisection_F_x, bisection_complex : ndarray
    F_x_c_low, F_x_c_high : float
        Certified bracket of F_x^c: the largest F_x certified real below the
        smallest F_x certified complex (undecided points are neither); NaN
        if not found.
    status : str
        ``'complete'``, ``'no_complex_pair'``, ``'no_equilibrium'`` or
        ``'complex_at_start'``.
    h5 : str
    message : str
        Set when the bracket stayed wider than ``tol`` (the points next to
        F_x^c could not be certified) and for the other statuses.
    decision, confidence : ndarray
        Analyzer decision per ramp step (1 complex, 0 real, -1 undecided)
        and its margin (> 1 certified).
    bisection_decision : ndarray
        Same for the bisection points (NaN where no equilibrium was found).
    tol_reached : bool
        The bracket is at most ``tol`` wide.
    n_undecided : int
        Equilibria (steps and bisection) the analyzer left undecided.
    timestep : dict
        The time-step decision at the start (``dt_used``, ``dt_max``,
        ``dt_fraction``, ``dt_limit_source``, ``dt_auto``; also in ramp.h5).
    """

    F_x: np.ndarray
    residual: np.ndarray
    complex_pair: np.ndarray
    growth_rate: np.ndarray
    bisection_F_x: np.ndarray
    bisection_complex: np.ndarray
    F_x_c_low: float
    F_x_c_high: float
    status: str
    h5: str
    message: str = ""
    decision: np.ndarray = None
    confidence: np.ndarray = None
    bisection_decision: np.ndarray = None
    timestep: dict = field(default_factory=dict)
    tol_reached: bool = False
    n_undecided: int = 0

    @property
    def F_x_c(self):
        """Midpoint of the bracket."""
        return 0.5 * (self.F_x_c_low + self.F_x_c_high)

    @property
    def F_x_c_width(self):
        """Width of the certified bracket, F_x_c_high - F_x_c_low (NaN if none)."""
        return self.F_x_c_high - self.F_x_c_low


class _RampLog:
    """In-memory copy of ramp.h5, rewritten atomically after every row."""

    COLS = ramp_file.COLUMNS

    def __init__(self, cfg, path):
        self.cfg = cfg
        self.path = path
        self.rows = {k: {c: [] for c in self.COLS} for k in (ramp_file.STEPS,
                                                              ramp_file.BISECTION)}
        self.files = {ramp_file.STEPS: [], ramp_file.BISECTION: []}
        self.eig = {}
        self.attrs = {}

    def add(self, kind, name, datafile, values, eigenvalues):
        for c in self.COLS:
            self.rows[kind][c].append(values[c])
        self.files[kind].append(datafile)
        self.eig[f"{kind}/{name}"] = np.asarray(eigenvalues, complex)

    def write(self, status, **attrs):
        """Bring ramp.h5 up to date, atomically.

        The previous file is copied to a temporary name, the new rows are
        appended to its resizable datasets and the new eigenvalue datasets
        added, and the copy is renamed over ramp.h5 (``os.replace``), so the
        file on disk is always complete (old or new), even after ``kill -9``.
        The cost per write no longer grows with the number of stored
        eigenvalue sets (a full rewrite did: 57 s of a 650-step ramp).
        """
        import shutil
        import h5py

        self.attrs.update(attrs)
        a = dict(self.cfg.to_attrs(), stage="ramp", status=status, version=RESULT_VERSION,
                 **self.attrs)
        fresh = not getattr(self, "_synced", False) or not os.path.exists(self.path)
        with atomic_path(self.path) as tmp:
            if fresh:
                mode = "w"
            else:
                shutil.copyfile(self.path, tmp)
                mode = "a"
            with h5py.File(tmp, mode) as fh:
                for k, v in a.items():
                    fh.attrs[k] = v
                for kind in (ramp_file.STEPS, ramp_file.BISECTION):
                    cols = {c: np.asarray(self.rows[kind][c], dtype=np.float64)
                            for c in self.COLS}
                    cols[ramp_file.DATAFILE] = np.asarray([str(f) for f in self.files[kind]],
                                                          dtype=object)
                    for c, arr in cols.items():
                        name = ramp_file.column(kind, c)
                        if name not in fh:
                            kw = ({"dtype": h5py.string_dtype()} if c == ramp_file.DATAFILE
                                  else {})
                            fh.create_dataset(name, data=arr, maxshape=(None,),
                                              chunks=(256,), **kw)
                            continue
                        ds = fh[name]
                        old = ds.shape[0]
                        if arr.shape[0] != old:
                            ds.resize((arr.shape[0],))
                            ds[old:] = arr[old:]
                for k, v in self.eig.items():
                    name = f"{ramp_file.EIGENVALUES}/{k}"
                    if name not in fh:
                        fh.create_dataset(name, data=v)
                fh.flush()
        self._synced = True
        if not getattr(self, "_cleaned", False):     # temp files of killed runs
            from .results import clean_stale_tmp

            clean_stale_tmp(self.path)
            self._cleaned = True

    @classmethod
    def load(cls, cfg, path):
        try:
            attrs, data = read_all(path)
        except OSError as exc:
            raise ConfigError(f"cannot resume: {path} is not a readable HDF5 file "
                              f"({exc})") from None
        old_file = attrs.get("datafile")
        if isinstance(old_file, bytes):
            old_file = old_file.decode()
        old_sha = attrs.get("datafile_sha256")
        if isinstance(old_sha, bytes):
            old_sha = old_sha.decode()
        same = (file_sha256(cfg.datafile) == str(old_sha)) if old_sha is not None else (
            old_file is not None and os.path.abspath(str(old_file))
            == os.path.abspath(cfg.datafile))
        if not same:
            raise ConfigError(f"cannot resume {path}: it ramps from datafile = {old_file!r}, "
                              f"this run gives datafile = {cfg.datafile!r} "
                              f"{'with other contents ' if old_sha is not None else ''}"
                              f"(nothing was changed)")
        for k, v in cfg.to_attrs().items():
            if k == "datafile":
                continue
            old = attrs.get(k)
            if isinstance(old, bytes):
                old = old.decode()
            if old is None or str(old) != str(v):
                raise ConfigError(f"cannot resume {path}: its configuration has {k} = "
                                  f"{old!r}, this run has {k} = {v!r}")
        log = cls(cfg, path)
        for kind in (ramp_file.STEPS, ramp_file.BISECTION):
            for c in cls.COLS:
                key = ramp_file.column(kind, c)
                if key not in data:
                    raise ConfigError(f"cannot resume: {path} lacks dataset {key}")
                log.rows[kind][c] = [float(x) for x in data[key]]
            log.files[kind] = [str(s) for s in
                               data.get(ramp_file.column(kind, ramp_file.DATAFILE), [])]
        eig = ramp_file.EIGENVALUES + "/"
        for k, v in data.items():
            if k.startswith(eig):
                log.eig[k[len(eig):]] = v
        log.attrs = {k: v for k, v in attrs.items()
                     if k in ("F_x_c_low", "F_x_c_high", "F_x_c_width", "tol_reached",
                              "n_undecided", "message", "dt_used", "datafile_sha256")}
        log.status = attrs.get("status", "running")
        log._synced = False          # rewrite in full once (older files: fixed-size)
        return log


def file_sha256(path):
    """SHA-256 (hex) of a file's contents: identifies a ramp's start file on resume."""
    import hashlib

    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def ramp_bracket(rlog):
    """The certified bracket of F_x^c from every row of a ramp (steps and bisection).

    Only certified answers count: ``hi`` is the smallest F_x certified
    complex (decision 1), ``lo`` the largest F_x certified real (decision 0)
    below it. Undecided points (decision -1) and points without an
    equilibrium (``complex`` = 2) are neither stable nor unstable.

    Returns
    -------
    lo, hi : float
        NaN where there is no such point.
    lo_file : str or None
        Data file of the ``lo`` equilibrium (start of the next bisection point).
    unknown : list of float
        Loads strictly inside (lo, hi) without a certified answer.
    """
    F, dec, files = [], [], []
    for kind in ("steps", "bisection"):
        rows = rlog.rows[kind]
        F.extend(rows["F_x"])
        dec.extend(rows["decision"])
        files.extend(rlog.files[kind])
    F, dec = np.asarray(F, float), np.asarray(dec, float)
    cx = F[dec == 1]
    hi = float(cx.min()) if cx.size else float("nan")
    real = np.flatnonzero((dec == 0) & (F < hi)) if cx.size else np.flatnonzero(dec == 0)
    if real.size:
        k = int(real[np.argmax(F[real])])
        lo, lo_file = float(F[k]), files[k]
    else:
        lo, lo_file = float("nan"), None
    unknown = sorted(float(f) for f, d in zip(F, dec)
                     if not (d == 0 or d == 1) and lo < f < hi)
    return lo, hi, lo_file, unknown


def next_bisection_point(lo, hi, unknown, tol):
    """Next load to decide inside the certified bracket, or why there is none.

    Without undecided points inside, the midpoint. With some, they are
    taken to mark the exceptional point's neighbourhood: the larger of the
    two uncertified gaps [lo, min(unknown)] and [max(unknown), hi] is
    halved, until both are at most tol/2.

    Returns
    -------
    F : float or None
    why : str
        ``''`` (F given), ``'tol'`` (hi - lo <= tol), ``'undecided'`` (no
        gap wider than tol/2 is left beside the undecided points) or
        ``'resolution'`` (no float64 number strictly inside the gap).
    """
    if hi - lo <= tol:
        return None, "tol"
    if unknown:
        g_lo, g_hi = unknown[0] - lo, hi - unknown[-1]
        if max(g_lo, g_hi) <= 0.5 * tol:
            return None, "undecided"
        a, b = (lo, unknown[0]) if g_lo >= g_hi else (unknown[-1], hi)
    else:
        a, b = lo, hi
    mid = 0.5 * (a + b)
    if not a < mid < b:
        return None, "resolution"
    return mid, ""


def _bracket_attrs(rlog, lo, hi, tol, why=""):
    """ramp.h5 attributes of the certified bracket; a message when it is wider than tol."""
    n_und = int(sum(np.count_nonzero(np.asarray(rlog.rows[k]["decision"], float) == -1)
                    for k in ("steps", "bisection")))
    width = hi - lo
    attrs = dict(F_x_c_low=lo, F_x_c_high=hi, F_x_c_width=width,
                 tol_reached=bool(width <= tol), n_undecided=n_und)
    if why in ("undecided", "resolution"):
        _, _, _, unknown = ramp_bracket(rlog)
        zone = (f"the loads in [{unknown[0]:.10g}, {unknown[-1]:.10g}] could not be "
                f"certified (closer to the exceptional point than the float64 matrix "
                f"resolves, or no equilibrium)" if unknown else
                "no float64 load is left strictly inside the bracket")
        attrs["message"] = (f"bisection stopped at width {width:.3g} > tol = {tol:.3g}: "
                            f"{zone}; F_x^c is certified only to [{lo:.10g}, {hi:.10g}]")
    return attrs


def _ramp_point(eng, cfg, start_file, F_x, prefix):
    """Equilibrate at F_x from ``start_file``, save ``prefix.*``, analyse.

    Returns (values dict, eigenvalues, StabilityResult).
    """
    t0 = time.perf_counter()
    load_relax_scene(eng, cfg, start_file, F_x, deck="in.ramp_step")
    r, t_sim, rec = eq.equilibrate(eng, cfg, F_x, newton_first=True)
    save_equilibrium(eng, cfg, F_x, prefix)
    res = _analyze(eng, prefix + ".dump")
    vals = {"F_x": F_x, "residual": r, "complex": float(res.complex_pair),
            "decision": float(res.decision_code), "confidence": float(res.confidence),
            "growth_rate": res.growth_rate, "max_imag": res.max_imag,
            "n_rattlers": float(res.n_rattlers), "wall_time": time.perf_counter() - t0,
            "damped_time": t_sim,
            "newton_steps": float(max(0, sum(p == "newton" for p in rec.phase) - 1))}
    return vals, res


def ramp(cfg, out, comm=None, quiet=False, resume=False, log="none", stop_after=None):
    """Ramp F_x until a complex eigenvalue pair appears, then bisect F_x^c.

    Step k has F_x = cfg.F_x + k dF_x (k = 0 re-equilibrates the data file at
    cfg.F_x). Each step starts from the previous equilibrium's data file,
    equilibrates (Newton first, damped dynamics if needed), writes
    ``ramp/step_NNNNN.*`` and is analysed (:mod:`remote_trigger.analysis.stability`) until a step is
    certified complex.

    "Complex" and "real" are the analyzer's certified decisions; an
    ``'undecided'`` point is neither (recorded with ``decision`` = -1 and its
    margin). The bracket of F_x^c is [largest load certified real, smallest
    load certified complex] (:func:`ramp_bracket`); bisection works inside
    it, each point starting from the ``lo`` equilibrium
    (:func:`next_bisection_point`), until it is at most ``cfg.tol`` wide or
    no further point can be certified next to the undecided ones. Then the
    ramp is ``'complete'`` with ``tol_reached`` False and a message giving the
    width reached; nothing narrower than what was certified is reported.
    A bisection point without an equilibrium is no answer either.

    Parameters
    ----------
    cfg : RampConfig
    out : str
        Output folder (``ramp.h5``, ``ramp/``).
    comm : mpi4py communicator, optional
    quiet : bool
    resume : bool
        Continue an interrupted ramp from its last completed equilibrium; the
        configuration must be the same. Without ``resume`` an existing
        ``ramp.h5`` is an error (nothing is overwritten).
    log : str
        LAMMPS log file.
    stop_after : int, optional
        Testing aid: return (status ``'interrupted'``) after this many new
        equilibria, as if killed.

    Returns
    -------
    RampResult

    Raises
    ------
    ConfigError
        Bad configuration, ``ramp.h5`` exists without ``resume``, or the file
        to resume is unreadable or from another configuration.
    """
    if not isinstance(cfg, RampConfig):
        raise ConfigError(f"ramp needs a RampConfig, got {type(cfg).__name__}")
    h5 = os.path.join(out, "ramp.h5")
    folder = os.path.join(out, "ramp")
    with Engine(comm=comm, log=log) as eng:
        exists = eng.comm.bcast(os.path.exists(h5) if eng.rank == 0 else None, root=0)
        if exists and not resume:
            raise ConfigError(f"{h5} exists: use resume (--resume) to continue it, or "
                              f"another output folder (nothing was overwritten)")
        def open_log():
            from remote_trigger.analysis.output import output_dir
            from .datafile import check_datafile

            try:
                check_datafile(cfg.datafile)
                output_dir(out, "--out")
                log_ = _RampLog.load(cfg, h5) if (resume and exists) else _RampLog(cfg, h5)
            except ValueError as exc:
                raise ConfigError(str(exc)) from None
            log_.attrs.setdefault("datafile_sha256", file_sha256(cfg.datafile))
            return log_

        rlog = on_rank0(eng.comm, open_log)
        _ensure_dir(eng, folder)
        rcfg, dtinfo = start_timestep(eng, cfg, cfg.datafile, cfg.F_x, "ramp")
        if "dt_used" in rlog.attrs and cfg.dt == "auto":   # resume: the same step
            rcfg = cfg.replace(dt=float(rlog.attrs["dt_used"]))
            dtinfo.update(dt_used=rcfg.dt, dt_fraction=rcfg.dt / dtinfo["dt_max"])
        rlog.attrs.update(dtinfo)
        status = getattr(rlog, "status", "running")
        if status in ("complete", "no_complex_pair", "no_equilibrium", "complex_at_start"):
            return _ramp_result(rlog, status)
        new = 0
        steps = rlog.rows["steps"]
        bar = _progress(None, "ramp", quiet, eng.rank, unit="step")
        try:
            # ---- ramp
            while not (steps["complex"] and steps["complex"][-1] > 0):
                k = len(steps["F_x"])
                F = cfg.F_x + k * cfg.dF_x
                if F > cfg.F_x_max:
                    n_und = int(np.count_nonzero(np.asarray(steps["decision"], float) == -1))
                    rlog.attrs["message"] = (f"no complex pair certified up to F_x_max = "
                                             f"{cfg.F_x_max}" + (f" ({n_und} steps undecided)"
                                                                 if n_und else ""))
                    if eng.rank == 0:
                        rlog.write("no_complex_pair")
                    return _ramp_result(rlog, "no_complex_pair")
                start = cfg.datafile if k == 0 else rlog.files["steps"][-1]
                prefix = os.path.join(folder, ramp_file.point_name(ramp_file.STEPS, k))
                try:
                    vals, res = _ramp_point(eng, rcfg, start, F, prefix)
                except eq.NoEquilibriumError as exc:
                    rlog.attrs["message"] = str(exc)
                    if eng.rank == 0:
                        rlog.write("no_equilibrium")
                    return _ramp_result(rlog, "no_equilibrium")
                rlog.add(ramp_file.STEPS, ramp_file.point_name(ramp_file.STEPS, k), prefix + ".data", vals, res.eigenvalues)
                if eng.rank == 0:
                    rlog.write("running")
                bar.update(1)
                bar.set_postfix_str(f"F_x {F:.6g} r {vals['residual']:.1e} "
                                    f"complex {bool(vals['complex'])}")
                new += 1
                if stop_after is not None and new >= stop_after:
                    return _ramp_result(rlog, "interrupted")
            lo, hi, lo_file, unknown = ramp_bracket(rlog)
            if lo_file is None:
                rlog.attrs["message"] = (
                    "complex pair already at the start value of F_x" if len(steps["F_x"]) == 1
                    else f"no equilibrium certified real below the first certified complex "
                         f"one (F_x = {hi:.10g}); the steps before it are undecided")
                rlog.attrs.update(F_x_c_high=hi)
                if eng.rank == 0:
                    rlog.write("complex_at_start")
                return _ramp_result(rlog, "complex_at_start")
            # ---- bisection, on certified answers only (docs/driver.md)
            bis = rlog.rows["bisection"]
            while True:
                lo, hi, lo_file, unknown = ramp_bracket(rlog)
                mid, why = next_bisection_point(lo, hi, unknown, cfg.tol)
                if mid is None:
                    break
                j = len(bis["F_x"])
                prefix = os.path.join(folder, ramp_file.point_name(ramp_file.BISECTION, j))
                try:
                    vals, res = _ramp_point(eng, rcfg, lo_file, mid, prefix)
                except eq.NoEquilibriumError:
                    vals = {c: np.nan for c in _RampLog.COLS}
                    vals.update(F_x=mid, complex=2.0)   # no equilibrium: no answer
                    res = None
                rlog.add(ramp_file.BISECTION, ramp_file.point_name(ramp_file.BISECTION, j), prefix + ".data", vals,
                         [] if res is None else res.eigenvalues)
                lo, hi, _, _ = ramp_bracket(rlog)
                rlog.attrs.update(_bracket_attrs(rlog, lo, hi, cfg.tol))
                if eng.rank == 0:
                    rlog.write("running")
                bar.update(1)
                bar.set_postfix_str(f"F_x^c in [{lo:.9g}, {hi:.9g}]")
                new += 1
                if stop_after is not None and new >= stop_after:
                    return _ramp_result(rlog, "interrupted")
            rlog.attrs.update(_bracket_attrs(rlog, lo, hi, cfg.tol, why))
            if eng.rank == 0:
                rlog.write("complete")
            return _ramp_result(rlog, "complete")
        finally:
            bar.close()


def _ramp_result(rlog, status):
    s, b = rlog.rows["steps"], rlog.rows["bisection"]
    return RampResult(
        F_x=np.asarray(s["F_x"]), residual=np.asarray(s["residual"]),
        complex_pair=np.asarray(s["complex"]) > 0, growth_rate=np.asarray(s["growth_rate"]),
        bisection_F_x=np.asarray(b["F_x"]), bisection_complex=np.asarray(b["complex"]) == 1,
        F_x_c_low=float(rlog.attrs.get("F_x_c_low", np.nan)),
        F_x_c_high=float(rlog.attrs.get("F_x_c_high", np.nan)), status=status,
        h5=rlog.path, message=str(rlog.attrs.get("message", "")),
        decision=np.asarray(s["decision"]), confidence=np.asarray(s["confidence"]),
        bisection_decision=np.asarray(b["decision"]),
        timestep={k: v for k, v in rlog.attrs.items() if k.startswith("dt_")},
        tol_reached=bool(rlog.attrs.get("tol_reached", False)),
        n_undecided=int(sum(np.count_nonzero(np.asarray(rlog.rows[k]["decision"], float) == -1)
                            for k in ("steps", "bisection"))))


# --------------------------------------------------------------------------- undamped
@dataclass
class SeriesResult:
    """Time series of one undamped run.

    Attributes
    ----------
    t, D, v_top, mu : ndarray
        Time, MSD D(t) (Eq. 8, from the starting equilibrium), mean x-velocity
        of ``top`` (signed), friction coefficient in force.
    h5 : str
    extra : dict
        Stage-specific numbers (e.g. ``v0``, ``growth_rate``).
    """

    t: np.ndarray
    D: np.ndarray
    v_top: np.ndarray
    mu: np.ndarray
    h5: str
    extra: dict = field(default_factory=dict)


def _undamped_run(eng, cfg, datafile, h5, variables, desc, quiet, stop=None, attrs=None):
    """Run ``in.perturb``'s scene from ``datafile`` and record every record_every steps."""
    eng.clear()
    v = _deck_vars(cfg, datafile, cfg.F_x)
    for var, _ in _DECK_FIELDS:        # the relaxing decks' variables
        v.pop(var, None)
    v.update(ton=float(cfg.t_on), visc=0.0 if cfg.tau is None else 1.0 / float(cfg.tau))
    v.update(variables)
    eng.load_deck("in.perturb", v, ("scene", "dynamics"))
    n = cfg.record_every
    # fix vmax: running max of |v_top| over EVERY step (ave/histo's global
    # vector [4] is the max of all inputs; 'ave running' keeps it over the run)
    eng.commands("compute msd all msd\n"
                 f"fix rec all ave/time {n} 1 {n} c_msd[4] v_vtop v_mu_now\n"
                 "variable absvtop equal abs(v_vtop)\n"
                 f"fix vmax all ave/histo 1 {n} {n} 0.0 1.0 1 v_absvtop mode scalar "
                 "ave running\n")
    nsteps = int(round(cfg.t_max / cfg.dt))
    nrec = max(1, nsteps // n)
    # v_top_max: running max of |v_top| over every step up to the record
    cols = ("t", "D", "v_top", "mu", "v_top_max")
    writer = None
    if eng.rank == 0:
        writer = SeriesWriter(h5, dict(cfg.to_attrs(), **(attrs or {}),
                                       version=RESULT_VERSION, n_ranks=eng.size), cols)
    out = {c: [] for c in cols}

    def add(row):
        for c in cols:
            out[c].append(row[c])
        if writer is not None:
            writer.append(row)

    add({"t": 0.0, "D": 0.0, "v_top": 0.0, "mu": eng.equal("mu_now"), "v_top_max": 0.0})
    bar = _progress(nrec, desc, quiet, eng.rank, unit="rec")
    status = "failed"               # until the loop ends normally
    vmax = 0.0
    try:
        for k in range(nrec):
            eng.run(n, pre=(k == 0))
            vals = [eng.lmp.extract_fix("rec", 0, 1, i) for i in range(3)]
            vmax = float(eng.lmp.extract_fix("vmax", 0, 1, 3))
            add({"t": (k + 1) * n * cfg.dt, "D": vals[0], "v_top": vals[1], "mu": vals[2],
                 "v_top_max": vmax})
            bar.update(1)
            if stop is not None and stop(out):
                status = "stopped"
                break
        else:
            status = "complete"
    finally:
        bar.close()
        if writer is not None:
            writer.close(attrs={"v_top_max": vmax}, status=status)
    return SeriesResult(*(np.asarray(out[c]) for c in cols[:4]), h5=h5,
                        extra={"v_top_max": vmax, "v_top_running_max": np.asarray(out[cols[4]])})


def _equilibrium_for(eng, cfg, out, name, quiet):
    """Equilibrate cfg.datafile at cfg.F_x; save ``out/name/equilibrium.*``."""
    folder = os.path.join(out, name)
    _ensure_dir(eng, folder)
    rcfg = _relax_cfg(cfg, cfg.F_x)
    load_relax_scene(eng, rcfg, cfg.datafile, cfg.F_x)
    r, _, _ = eq.equilibrate(eng, rcfg, cfg.F_x, newton_first=True)
    prefix = os.path.join(folder, "equilibrium")
    save_equilibrium(eng, rcfg, cfg.F_x, prefix)
    return prefix, r


#: the runs of :func:`perturb`
PERTURB_RUNS = "abc"


def check_runs(runs):
    """Validate the ``runs`` of :func:`perturb`; returns them in the order a, b, c.

    Raises
    ------
    ConfigError
        ``runs`` is empty or has a letter other than a, b, c (named).
    """
    if not isinstance(runs, str) or not runs:
        raise ConfigError(f"runs must be a non-empty subset of 'abc', got runs = {runs!r}")
    bad = sorted(set(runs) - set(PERTURB_RUNS))
    if bad:
        raise ConfigError(f"runs: unknown run letter(s) {', '.join(map(repr, bad))} in "
                          f"runs = {runs!r} (the runs are a, b, c)")
    return "".join(r for r in PERTURB_RUNS if r in runs)


def _perturb_resume_state(cfg, out, sha):
    """What an interrupted ``perturb`` in ``out`` left that this one may keep (rank 0).

    Returns
    -------
    residual : float or None
        Residual of the kept equilibrium ``out/perturb/equilibrium.*``; None
        if it is to be recomputed (then no run is kept either).
    complete : dict
        ``{run: SeriesResult}`` of the runs finished with this configuration.

    Raises
    ------
    ConfigError
        A run file in ``out`` was made with another configuration or from a
        data file with other contents (its key and both values named).
    """
    residual, complete = None, {}
    for run in PERTURB_RUNS:
        path = os.path.join(out, f"perturb_{run}.h5")
        if not os.path.exists(path):
            continue
        try:
            attrs, data = read_all(path)
        except OSError:                 # unreadable: redone
            continue
        if attrs.get("datafile_sha256") != sha:
            raise ConfigError(f"cannot resume {path}: it ran from a data file with other "
                              f"contents than datafile = {cfg.datafile!r} (nothing was "
                              f"changed)")
        for k, v in cfg.to_attrs().items():
            if k == "datafile" or (run == "c" and k in ("v0", "v_ss") and v == "None"):
                continue
            old = attrs.get(k)
            if isinstance(old, bytes):
                old = old.decode()
            if old is None or str(old) != str(v):
                raise ConfigError(f"cannot resume {path}: its configuration has {k} = "
                                  f"{old!r}, this run has {k} = {v!r} (nothing was changed)")
        residual = float(attrs["equilibrium_residual"])
        if attrs.get("status") == "complete":
            complete[run] = SeriesResult(
                data["t"], data["D"], data["v_top"], data["mu"], h5=path,
                extra={"v_top_max": float(attrs["v_top_max"]),
                       "v_top_running_max": data["v_top_max"]})
    if residual is None or not all(os.path.exists(os.path.join(out, f))
                                   for f in _equilibrium_files("perturb")):
        return None, {}
    return residual, complete


def perturb(cfg, out, comm=None, quiet=False, log="none", runs="abc", overwrite=False,
            resume=False):
    """The three undamped runs of Fig. 5 from the equilibrium at cfg.F_x.

    (a) unperturbed; (b) f(t) = a cos(omega_p t) added to F_x on ``top``;
    (c) like (b) with mu(v) (Eq. 4) on every contact and the wall; v0 is the
    largest |v_top| of run (a) over every step (``fix ave/histo``'s running
    max, not only the recorded steps: mu(v) is evaluated every step) unless
    ``cfg.v0`` is given, v_ss = v0 unless
    ``cfg.v_ss`` is given.

    Parameters
    ----------
    cfg : DynamicsConfig
    out : str
        Output folder: ``perturb_{a,b,c}.h5`` and ``perturb/equilibrium.*``.
    comm : mpi4py communicator, optional
    quiet : bool
    log : str
    runs : str
        Subset of ``'abc'`` (run (a) is also done when ``cfg.v0`` is None
        and (c) is asked for: it measures v0).
    overwrite : bool
        Replace earlier perturb results in ``out`` (default: refuse).
    resume : bool
        Continue an interrupted perturb in ``out`` with the same
        configuration and data file (compared with the run files'
        attributes, ``datafile_sha256`` included): its equilibrium and the
        runs finished (status ``'complete'``) are kept, the others are run
        again from the same equilibrium data file, so the results are
        bitwise those of an uninterrupted perturb. A folder without a run
        file starts anew.

    Returns
    -------
    dict
        ``{'a': SeriesResult, 'b': ..., 'c': ...}`` for the runs done;
        ``extra`` holds ``residual`` (of the equilibrium), ``v0`` and ``v_ss``.

    Raises
    ------
    ConfigError
        Unknown run letters, ``out`` not a writable folder or holding
        perturb results (unless ``overwrite`` or ``resume``), a bad data
        file, or a ``resume`` whose configuration or data file differs.
    """
    if not isinstance(cfg, DynamicsConfig):
        raise ConfigError(f"perturb needs a DynamicsConfig, got {type(cfg).__name__}")
    runs = check_runs(runs)
    results = {}
    with Engine(comm=comm, log=log) as eng:
        cfg, dtinfo = start_timestep(eng, cfg, cfg.datafile, cfg.F_x, "perturb")
        prepare_out(eng, out, _equilibrium_files("perturb")
                    + [f"perturb_{k}.h5" for k in PERTURB_RUNS], overwrite or resume,
                    "perturb")

        def resume_state():
            sha_ = file_sha256(cfg.datafile)
            r_, done_ = _perturb_resume_state(cfg, out, sha_) if resume else (None, {})
            return sha_, r_, done_

        sha, r, done = on_rank0(eng.comm, resume_state)
        if r is None:
            prefix, r = _equilibrium_for(eng, cfg, out, "perturb", quiet)
        else:
            prefix = os.path.join(out, "perturb", "equilibrium")
        data = prefix + ".data"
        v0 = cfg.v0
        base = {"equilibrium": data, "equilibrium_residual": r, "stage": "perturb",
                "datafile_sha256": str(sha), **dtinfo}
        if "a" in runs or v0 is None:
            res = done.get("a") or _undamped_run(
                eng, cfg, data, os.path.join(out, "perturb_a.h5"), {"a": 0.0, "muv": 0},
                "perturb (a)", quiet, attrs=dict(base, run="a"))
            results["a"] = res
            if v0 is None:              # max |v_top| over every step, not only records
                v0 = float(res.extra["v_top_max"])
                if not v0 > 0:
                    v0 = np.finfo(float).tiny
        vss = cfg.v_ss if cfg.v_ss is not None else v0
        if "b" in runs:
            results["b"] = done.get("b") or _undamped_run(
                eng, cfg, data, os.path.join(out, "perturb_b.h5"),
                {"a": float(cfg.a), "wp": float(cfg.omega_p), "muv": 0}, "perturb (b)", quiet,
                attrs=dict(base, run="b"))
        if "c" in runs:
            results["c"] = done.get("c") or _undamped_run(
                eng, cfg, data, os.path.join(out, "perturb_c.h5"),
                {"a": float(cfg.a), "wp": float(cfg.omega_p), "muv": 1, "v0": float(v0),
                 "vss": float(vss), "B": float(cfg.B), "w": float(cfg.w),
                 "muss": float(cfg.mu_ss)}, "perturb (c)", quiet,
                attrs=dict(base, run="c", v0=v0, v_ss=vss))
        for res in results.values():
            res.extra.update(residual=r, v0=v0, v_ss=vss, timestep=dict(dtinfo))
    return results


def instability(cfg, out, comm=None, quiet=False, log="none", overwrite=False,
                allow_stable=True):
    """Undamped run from the equilibrium at F_x > F_x^c until D(t) saturates.

    Stops when D exceeds ``cfg.d_sat`` or at ``cfg.t_max``. Also analyses the
    starting equilibrium (predicted growth rate max Im sqrt(lambda), Eq. 6)
    and fits the measured rate of D ~ exp(2 g t).

    Parameters
    ----------
    cfg : DynamicsConfig
    out : str
        Output folder: ``instability.h5`` and ``instability/equilibrium.*``.
    comm : mpi4py communicator, optional
    quiet : bool
    log : str
    overwrite : bool
        Replace earlier instability results in ``out`` (default: refuse).
    allow_stable : bool
        Run also from an equilibrium without a certified complex pair (D
        then stays at the noise level). False: refuse it
        (:class:`StableStartError`, the equilibrium files are removed).

    Returns
    -------
    SeriesResult
        ``extra``: ``predicted_growth_rate``, ``measured_growth_rate``,
        ``complex_pair``, ``decision``, ``residual``, ``saturated``.

    Raises
    ------
    ConfigError
        ``out`` not a writable folder or holding instability results, a bad
        data file.
    StableStartError
        The equilibrium has no certified complex pair and ``allow_stable``
        is False.
    """
    if not isinstance(cfg, DynamicsConfig):
        raise ConfigError(f"instability needs a DynamicsConfig, got {type(cfg).__name__}")
    with Engine(comm=comm, log=log) as eng:
        cfg, dtinfo = start_timestep(eng, cfg, cfg.datafile, cfg.F_x, "instability")
        prepare_out(eng, out, ["instability.h5"] + _equilibrium_files("instability"),
                    overwrite, "instability")
        prefix, r = _equilibrium_for(eng, cfg, out, "instability", quiet)
        st = _analyze(eng, prefix + ".dump")
        if not st.complex_pair and not allow_stable:
            if eng.rank == 0:
                for f in _equilibrium_files("instability"):
                    os.remove(os.path.join(out, f))
                try:
                    os.rmdir(os.path.join(out, "instability"))
                except OSError:
                    pass
            eng.comm.Barrier()
            what = ("every eigenvalue certified real" if st.decision == "real" else
                    f"the complex-pair test is {st.decision}")
            raise StableStartError(
                f"the equilibrium at F_x = {cfg.F_x!r} is linearly stable "
                f"({what}, margin {st.confidence:.3g}): D(t) would stay at the noise level "
                f"and there is no growth rate to measure; start from a state above F_x^c "
                f"(a ramp step at or after the first complex one) or use perturb "
                f"(--allow-stable runs it anyway; nothing was written)")
        res = _undamped_run(
            eng, cfg, prefix + ".data", os.path.join(out, "instability.h5"),
            {"a": 0.0, "muv": 0}, "instability", quiet,
            stop=lambda o: o["D"][-1] > cfg.d_sat,
            attrs={"stage": "instability", "equilibrium": prefix + ".data",
                   "equilibrium_residual": r, "predicted_growth_rate": st.growth_rate,
                   "complex_pair": st.complex_pair, **dtinfo})
        res.extra.update(predicted_growth_rate=st.growth_rate, complex_pair=st.complex_pair,
                         decision=st.decision,
                         residual=r, saturated=bool(res.D[-1] > cfg.d_sat),
                         timestep=dict(dtinfo),
                         measured_growth_rate=growth_fit(res.t, res.D, hi=cfg.d_sat / 1e2))
    return res
