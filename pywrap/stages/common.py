"""What the driver stages share: deck scenes, equilibrium files, output checks, dt.

Part of :mod:`remote_trigger.pywrap.stages` (docs/driver.md).
"""
import math
import os

import numpy as np

from remote_trigger.pywrap.config import ConfigError, check_lammps_path
from remote_trigger.pywrap.stages.config import RelaxConfig
from remote_trigger.pywrap.bindings.engine import DUMP_COLUMNS, DUMP_COLUMNS_3D
from remote_trigger.pywrap.runtime.parallel import on_rank0


RESULT_VERSION = 1


class StableStartError(ConfigError):
    """:func:`instability` asked to start from a linearly stable equilibrium (exit 2)."""


# --------------------------------------------------------------------------- helpers
#: seconds between two progress lines in a log (stderr not a terminal)
LOG_INTERVAL = 10.0


class _LogLines:
    """A stream for tqdm where stderr is not a terminal (a batch job's log):
    the bar's updates become lines of their own, instead of carriage-return
    updates that pile up on one line of the log, at most one per ``interval``
    seconds (the first at once); the last update held back is written when
    the bar closes (its blanking writes nothing else)."""

    def __init__(self, fp, interval=LOG_INTERVAL, clock=None):
        import time

        self.fp, self.interval = fp, float(interval)
        self.clock = clock or time.monotonic
        self.last, self.pending = -math.inf, None

    def _emit(self, s, now):
        self.fp.write(s + "\n")
        self.last, self.pending = now, None

    def write(self, s):
        s = s.replace("\r", "").strip()      # tqdm's "\r" + bar, and its blanking
        if not s:
            if self.pending is not None:     # the bar closes: its last state
                self._emit(self.pending, self.clock())
            return
        now = self.clock()
        if now - self.last >= self.interval:
            self._emit(s, now)
        else:
            self.pending = s

    def flush(self):
        self.fp.flush()


def progress_bar(total, desc, quiet, rank, unit="it", log_interval=None):
    """A tqdm bar on rank 0's stderr (none with ``quiet`` or on other ranks);
    where stderr is not a terminal, a line per update at most every
    ``log_interval`` seconds (default :data:`LOG_INTERVAL`; :class:`_LogLines`),
    the last state written when the bar closes."""
    import sys
    from tqdm import tqdm

    tty = hasattr(sys.stderr, "isatty") and sys.stderr.isatty()
    every = LOG_INTERVAL if log_interval is None else log_interval
    # off a terminal every update reaches _LogLines (mininterval 0), which
    # limits the lines itself and so writes the bar's true last state at the
    # end (with tqdm's own 0.1 s limit, a run's last records were never shown)
    return tqdm(total=total, desc=desc, disable=quiet or rank != 0, unit=unit,
                leave=False, dynamic_ncols=tty, mininterval=0.1 if tty else 0.0,
                file=sys.stderr if tty else _LogLines(sys.stderr, every))


#: deck variable <- configuration field, passed when the configuration has it
#: (otherwise the deck's default applies)
DECK_FIELDS = (("gamma", "gamma"), ("gamma_rot", "gamma_rot"),
                ("settle_steps", "settle_steps"), ("g_settle", "g_settle"),
                ("top_gap", "top_gap"), ("check", "check_every"))


def deck_vars(cfg, datafile, F_x):
    """The index variables of a deck (``-var`` names) for a configuration: the model,
    the loads, dt and the :data:`DECK_FIELDS` the configuration has."""
    v = {"datafile": datafile, "kn": float(cfg.k_n), "kt": float(cfg.k_t),
         "mu": float(cfg.mu), "Fx": float(F_x), "Fy": float(cfg.F_y),
         "dt": float(cfg.dt)}
    for var, name in DECK_FIELDS:
        if hasattr(cfg, name):
            val = getattr(cfg, name)
            v[var] = int(val) if var in ("settle_steps", "check") else float(val)
    if getattr(cfg, "top_layer", "free") != "free":      # (the decks' default: free)
        v["top_layer"] = cfg.top_layer
    return v


#: the relax deck of each dimension (disks, spheres)
RELAX_DECKS = {2: "in.relax", 3: "in.relax3d"}


#: the fix of the rigid top layer (``top_layer = 'rigid'``, the ``plate`` section
#: of ``in.relax3d``)
PLATE_FIX = "plate"


def hold_layer(eng, cfg):
    """The ``top`` layer a rigid plate from now on, if ``cfg.top_layer`` is 'rigid'.

    The ``plate`` section of ``in.relax3d``: ``fix aveforce 0.0 0.0 0.0``
    on ``top`` (defined after the loads, so that it averages the total
    force): the layer translates as one body, each sphere keeping its loads
    and its own rotations. Newton
    (:func:`~remote_trigger.pywrap.stages.equilibrium.polish`) ties the
    layer's x, y and z into three dofs while the fix is defined. Nothing for
    ``'free'``.
    """
    if cfg.top_layer == "rigid" and not eng.has_fix(PLATE_FIX):
        eng.run_section("plate")


def load_relax_scene(eng, cfg, datafile, F_x, deck=None):
    """Load the scene and the damped dynamics of ``deck`` from a data file.

    ``deck`` None: ``in.relax``, or ``in.relax3d`` for a data file of spheres
    (:func:`~remote_trigger.pywrap.bindings.datafile.data_dimension`).
    """
    if deck is None:
        from remote_trigger.pywrap.bindings.datafile import data_dimension

        deck = RELAX_DECKS[data_dimension(datafile)]
    eng.clear()
    eng.load_deck(deck, deck_vars(cfg, datafile, F_x), ("scene", "damped", "dynamics"))


def equilibrium_dump(datafile):
    """The dump written beside an equilibrium data file (``X.data`` -> ``X.dump``)."""
    return (datafile[:-len(".data")] if datafile.endswith(".data") else datafile) + ".dump"


def load_equilibrium_scene(eng, cfg, datafile, F_x, dim):
    """Load an equilibrium saved by :func:`save_equilibrium`, history included.

    Disks (``dim`` = 2): the scene of ``in.ramp_step``, the history in the
    data file. Spheres: the scene of ``in.relax3d`` from the data file (no
    history there), one ``run 0`` (the pair creates its history arrays; a
    setup never advances the history), then the pair's and the wall's t
    exactly as in the equilibrium dump beside it
    (:func:`~remote_trigger.analysis.state.dumpfile.read_history3d`), and
    the rigid top layer if ``cfg.top_layer`` says so (:func:`hold_layer`).

    Raises
    ------
    ConfigError
        Spheres: the dump is missing, unreadable or of other atoms (on every rank).
    """
    if dim == 2:
        load_relax_scene(eng, cfg, datafile, F_x, deck="in.ramp_step")
        return
    load_relax_scene(eng, cfg, datafile, F_x, deck=RELAX_DECKS[3])
    restore_saved_history3d(eng, datafile)
    hold_layer(eng, cfg)


def restore_saved_history3d(eng, datafile):
    """Write the history of the dump beside ``datafile`` into the loaded scene of
    spheres: one ``run 0`` (the pair creates its arrays; a setup advances no
    history), then :meth:`Engine.restore_history3d`.

    Raises
    ------
    ConfigError
        The dump is missing or unreadable, or of other atoms (on every rank).
    """
    hist = on_rank0(eng.comm, lambda: read_saved_history3d(datafile))
    if not np.array_equal(hist["ids"], np.arange(1, eng.natoms + 1)):
        raise ConfigError(f"{equilibrium_dump(datafile)}: its atom ids are not those of "
                          f"{datafile} (1..{eng.natoms})")
    eng.run(0)
    eng.restore_history3d(hist["partner"], hist["t"], hist["wall_t"])


def start_top_layer(datafile):
    """The ``top_layer`` of a start file: its sidecar's, ``'free'`` if it has none.

    Raises
    ------
    ConfigError
        The sidecar is unreadable.
    """
    from remote_trigger.analysis.state.dumpfile import load_sidecar

    try:
        return load_sidecar(equilibrium_dump(datafile)).get("top_layer", "free")
    except ValueError as exc:
        raise ConfigError(str(exc)) from None


def check_top_layer(cfg, datafile, stage):
    """Refuse a start state relaxed with another loading of the top layer than ``cfg``'s.

    ``cfg.top_layer`` (``'free'`` for a configuration without the field: the
    dynamics stages run the free layer only) against the start file's
    sidecar (:func:`start_top_layer`).

    Raises
    ------
    ConfigError
        Naming both values and the sidecar.
    """
    layer = start_top_layer(datafile)
    mine = getattr(cfg, "top_layer", "free")
    if layer == mine:
        return
    fix = (f"give top_layer = {layer!r}" if hasattr(cfg, "top_layer") else
           f"{stage} runs the free layer only")
    raise ConfigError(f"top_layer = {mine!r} differs from the start state's {layer!r} "
                      f"({equilibrium_dump(datafile)}.json): a state is an equilibrium only "
                      f"of the loading it was relaxed with; {fix}")


def check_spheres_ramp(cfg):
    """For a ramp: the start state's ``top_layer``; for spheres also refuse
    ``newton = False`` and a start without its dump.

    The loading of the top layer must be the one the start state was relaxed
    with (:func:`start_top_layer`). Damped dynamics alone do not bring a
    loaded 3D packing to rest, and the history of spheres is in the
    equilibrium dump beside the data file (:func:`read_saved_history3d`).

    Raises
    ------
    ConfigError
    """
    from remote_trigger.pywrap.bindings.datafile import data_dimension

    check_top_layer(cfg, cfg.datafile, "ramp")
    if data_dimension(cfg.datafile) != 3:
        return
    if not cfg.newton:
        raise ConfigError(f"newton = False is 2D only: {cfg.datafile} holds spheres "
                          f"(dimension 3), and damped dynamics alone do not reach "
                          f"equilibrium (docs/driver.md, 'Spheres')")
    read_saved_history3d(cfg.datafile)


def read_saved_history3d(datafile):
    """The history of a saved equilibrium of spheres, from the dump beside its data file.

    Raises
    ------
    ConfigError
        The dump is missing or unreadable (a data file of spheres carries no
        history: a ramp needs the equilibrium files of ``relax`` or ``ramp``).
    """
    from remote_trigger.analysis.state.dumpfile import read_history3d

    dump = equilibrium_dump(datafile)
    try:
        return read_history3d(dump)
    except (OSError, ValueError, IndexError) as exc:
        raise ConfigError(f"{datafile} holds spheres, whose contact history is in the "
                          f"equilibrium dump beside it, and {dump} cannot be read ({exc}); "
                          f"start from the equilibrium.data of relax or a ramp step") from None


def save_equilibrium(eng, cfg, F_x, prefix):
    """Write ``prefix.data``, ``prefix.dump`` and ``prefix.dump.json``.

    The state must be an equilibrium with v = 0 and no damping fix. The dump
    holds contact forces only (the loads are switched off for its ``run 0``:
    ``variable loadon equal 0``, and the layer's ``fix aveforce`` too, so that
    each sphere shows its own) and the loads in ``v_fext_x v_fext_y``; the
    sidecar records ``top_layer`` when it is not ``'free'``.
    Each file is written under a temporary name and renamed.
    """
    rank0 = eng.rank == 0
    columns = DUMP_COLUMNS_3D if eng.dimension == 3 else DUMP_COLUMNS
    plate = eng.has_fix(PLATE_FIX)     # (off for the dump: each sphere's own contact forces)
    eng.unfix(PLATE_FIX)
    eng.command("variable loadon equal 0")
    eng.run(0)
    eng.command(f"write_dump all custom {prefix}.dump.part {columns} "
                f"modify sort id format float %.17g")
    eng.command("variable loadon equal 1")
    eng.command(f"write_data {prefix}.data.part nocoeff")
    if plate:
        hold_layer(eng, cfg)
    eng.run(0)
    if rank0:
        from remote_trigger.analysis.state.dumpfile import write_sidecar

        write_sidecar(f"{prefix}.dump", {"k_n": cfg.k_n, "k_t": cfg.k_t, "mu": cfg.mu,
                                         "wall_y": 0.0, "F_x": F_x, "F_y": cfg.F_y,
                                         "dt": cfg.dt,
                                         "top_layer": getattr(cfg, "top_layer", "free")})
        os.replace(f"{prefix}.dump.part", f"{prefix}.dump")
        os.replace(f"{prefix}.data.part", f"{prefix}.data")
    eng.comm.Barrier()


def packing_fraction(state):
    """phi = sum pi R^2 / (L h), h = max(y + R) above the wall at y = 0.

    Spheres: phi = sum 4/3 pi R^3 / (L_x L_z h). ``state``: the engine's
    gathered state, a ``State`` or a ``State3D`` (the dimension is that of
    the positions).
    """
    L = state.box_hi[0] - state.box_lo[0]
    h = float(np.max(state.positions[:, 1] + state.radii))
    if state.positions.shape[1] == 3:
        Lz = state.box_hi[2] - state.box_lo[2]
        return float(np.sum(4.0 / 3.0 * np.pi * state.radii ** 3) / (L * Lz * h))
    return float(np.sum(np.pi * state.radii ** 2) / (L * h))


def decide_on_rank0(eng, what, options=None, basis=None, progress=None):
    """The engine's verdict (:func:`~remote_trigger.analysis.stability.verdict.decide`)
    on rank 0, broadcast to all ranks.

    Parameters
    ----------
    eng : Engine
    what : str or callable
        An equilibrium dump the driver wrote (read on rank 0; the driver's
        own Newton test accepted it, so the analyzer's residual check is not
        repeated), or a callable returning the
        :class:`~remote_trigger.analysis.stability.system.ReducedSystem` to
        decide (called on rank 0 only).
    options : VerdictOptions, optional
        ``checkpoint_dir`` is written by rank 0. With ``part_size`` every
        rank runs parts of a sliced verdict
        (:func:`~remote_trigger.pywrap.runtime.rankmap.on_rank0_with_ranks`),
        with the same answer as rank 0 alone; so do the free workers of a
        joining task farm when ``eng`` runs on one rank of it
        (:mod:`~remote_trigger.pywrap.runtime.joining`).
    basis : SpectrumBasis, optional
        The previous point's ``StabilityResult.basis`` (rank 0's; ignored
        elsewhere).
    progress : callable, optional
        Called on rank 0 only.

    Returns
    -------
    StabilityResult
        Its ``basis`` is kept on rank 0 only (None on the others: it is an
        n x n pair of matrices, not broadcast).
    """
    from remote_trigger.analysis.stability.verdict import decide, stability_of_dump

    kept = {}

    def run(map_tasks=None):
        if callable(what):
            res = decide(what(), options, basis, progress, map_tasks)
        else:
            res = stability_of_dump(what, options, basis, progress, allow_residual=True,
                                    map_tasks=map_tasks)
        kept["basis"], res.basis = res.basis, None
        return res

    if options is not None and options.part_size is not None:
        from remote_trigger.analysis.stability.sliced.parts import PartsProblem
        from remote_trigger.pywrap.runtime import joining
        from remote_trigger.pywrap.runtime.rankmap import on_rank0_with_ranks

        if joining.active(eng.comm):    # one rank of a farm: its free workers join
            with joining.point_map((PartsProblem,)) as pmap:
                res = run(pmap)
        else:
            res = on_rank0_with_ranks(eng.comm, run, (PartsProblem,))
    else:
        res = on_rank0(eng.comm, run)
    res.basis = kept.get("basis")
    return res


def ensure_dir(eng, path):
    """Create ``path`` (and its parents) on rank 0; every rank waits for it."""
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
        check_lammps_path("out", out)
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


#: the files :func:`save_equilibrium` writes for one equilibrium ``prefix``
EQUILIBRIUM_EXTS = (".data", ".dump", ".dump.json")


def equilibrium_files(name):
    """The files of the equilibrium a stage saves under ``name/equilibrium.*``."""
    return [os.path.join(name, "equilibrium" + ext) for ext in EQUILIBRIUM_EXTS]


def dynamics_relax_config(cfg, F_x):
    """A RelaxConfig with the model of ``cfg`` (for equilibrating dynamics stages)."""
    keys = ("datafile", "k_n", "k_t", "mu", "F_y", "dt")
    base = {k: getattr(cfg, k) for k in keys}
    if isinstance(cfg, RelaxConfig):
        base = {k: getattr(cfg, k) for k in RelaxConfig.__dataclass_fields__}
    base["F_x"] = float(F_x)
    return RelaxConfig.from_dict(base)


def _check_stage_start(data):
    """Refuse a data file the decks cannot start from (``ConfigError``): one
    with pair coefficients (the decks read it before ``pair_style``: LAMMPS
    stopped with "Must define pair_style before PairIJ Coeffs", status 1) or
    without the top line (``relax`` said "place_top needs top and bulk disks,
    got 0 top disks of 100")."""
    where = (f"data file {data.path!r}: the stages start from a packing of `remote-trigger "
             f"generate` or an equilibrium a stage wrote")
    if data.pair_coeffs:
        raise ConfigError(f"{where}; this one holds {data.pair_coeffs!r} (write_data without "
                          f"nocoeff), which the decks read before pair_style")
    if data.top is None or not data.top.any() or data.top.all():
        what = ("no topflag section (the top line, i_top)" if data.top is None else
                f"{int(data.top.sum())} top atoms of {data.n} in its topflag section")
        raise ConfigError(f"{where}, with a top line and a bulk; this one has {what}")


def start_timestep(eng, cfg, datafile, F_x, stage, a_priori=False):
    """Load ``datafile``, check ``cfg.dt`` against the stability limit, resolve 'auto'.

    Returns ``(cfg with a numeric dt, TimestepInfo)``; see
    :func:`remote_trigger.pywrap.stages.timestep.resolve`. No step is run.
    A data file of spheres needs the dump beside it (its history) in every
    stage but ``relax``, and every stage but ``relax`` the loading of the top
    layer its start was relaxed with (:func:`check_top_layer`; ``ConfigError``).
    """
    from remote_trigger.pywrap.bindings.datafile import check_datafile
    from remote_trigger.pywrap.stages.timestep import resolve

    data = check_datafile(datafile, full=True)
    _check_stage_start(data)
    if data.dimension == 3 and stage != "relax":
        read_saved_history3d(datafile)
    if stage != "relax":
        check_top_layer(cfg, datafile, stage)
    probe = cfg.replace(dt=1.0) if cfg.dt == "auto" else cfg   # dt unused: no step run
    load_relax_scene(eng, probe, datafile, F_x)
    return resolve(eng, cfg, F_x, a_priori=a_priori, stage=stage)


# --------------------------------------------------------------------------- relax

def check_resume_config(path, cfg, attrs, skip=(), suffix=""):
    """Refuse to resume ``path`` unless its stored configuration is ``cfg``'s.

    Parameters
    ----------
    path : str
        The result file (named in the message).
    cfg : StageConfig
        This run's configuration (``to_attrs()``; ``datafile`` is compared
        by its contents elsewhere and skipped here). A key of its class's
        ``LATER_FIELDS`` absent from the file has the value given there.
    attrs : dict
        The file's root attributes.
    skip : container of str
        More keys not to compare.
    suffix : str
        Appended to the message.

    Raises
    ------
    ConfigError
        Naming the first differing key with both values.
    """
    for k, v in cfg.to_attrs().items():
        if k == "datafile" or k in skip:
            continue
        old = attrs.get(k, getattr(cfg, "LATER_FIELDS", {}).get(k))
        if isinstance(old, bytes):
            old = old.decode()
        if old is None and v == "None":
            continue     # a key added later whose default (None) is the old behaviour
        if old is None or str(old) != str(v):
            raise ConfigError(f"cannot resume {path}: its configuration has {k} = "
                              f"{old!r}, this run has {k} = {v!r}{suffix}")


def file_sha256(path):
    """SHA-256 (hex) of a file's contents: identifies a ramp's start file on resume."""
    import hashlib

    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def start_sha256(datafile):
    """SHA-256 (hex) of a ramp's start: the data file, and for spheres also the
    equilibrium dump beside it (their history; :func:`read_saved_history3d`)."""
    import hashlib
    from remote_trigger.pywrap.bindings.datafile import data_dimension

    digest = file_sha256(datafile)
    if data_dimension(datafile) != 3:
        return digest
    return hashlib.sha256((digest + file_sha256(equilibrium_dump(datafile))).encode()).hexdigest()
