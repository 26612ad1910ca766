"""``ramp.h5``: its layout, its writer (:class:`RampLog`) and its reader.

Root attributes: the ramp configuration, ``stage = 'ramp'``, ``status``,
``version``, the bracket ``F_x_c_low``/``F_x_c_high`` and its status
(docs/driver.md), and ``undecided_reasons`` (JSON: point name -> why the
decision left it undecided) once a point is undecided. Groups:

``steps/<column>`` and ``bisection/<column>``
    One row per equilibrium of the ramp (in ramp order) and of the bisection
    (in evaluation order); columns :data:`COLUMNS` (float64) and
    ``datafile`` (UTF-8 strings: the equilibrium's ``.data``; its dump is
    the same name with ``.dump``). In files with the root attribute
    :data:`RELATIVE_PATHS` a file inside the ramp file's folder is named
    relative to that folder (so the folder can be moved or copied and
    resumed there); older files name it as their run was given it
    (absolute, or relative to its working directory). Readers resolve both
    with :func:`point_file`.
``eigenvalues/steps/step_NNNNN``, ``eigenvalues/bisection/bisect_NNN``
    The eigenvalues (complex128) of each equilibrium (:data:`POINT_PREFIX`;
    NNNNN is the row index in ``steps``, NNN in ``bisection``): all
    ``n_dof`` of them, or, where the column ``scanned_below`` is finite (a
    sliced verdict *complex* that stopped at its first complex strip), those
    with real part below it; ``lambda_max`` is the spectrum's top either way.

Readers use these names, never string literals.
"""
import json
import os
import time

import numpy as np

from remote_trigger.analysis.output import atomic_path
from remote_trigger.analysis.stability.decision import Decision

from remote_trigger.pywrap.config import ConfigError, check_lammps_path
from remote_trigger.pywrap.runtime.jobfolder import resolved_path, stored_path
from remote_trigger.pywrap.runtime.results import read_all
from remote_trigger.pywrap.runtime.parallel import on_rank0
from remote_trigger.pywrap.stages.common import (RESULT_VERSION, check_resume_config,
                                                 check_spheres_ramp, equilibrium_dump,
                                                 start_sha256)

#: row groups of ramp.h5
STEPS = "steps"
BISECTION = "bisection"
#: group of the eigenvalue datasets
EIGENVALUES = "eigenvalues"
#: float64 columns of every row group (plus ``datafile``)
COLUMNS = ("F_x", "residual", "complex", "decision", "confidence", "growth_rate",
           "max_imag", "n_rattlers", "wall_time", "damped_time", "newton_steps",
           "from_basis", "n_dof", "lambda_max", "scanned_below", "saddle_escaped",
           "n_negative", "soft_pairs", "eigen_time", "decision_time")
#: the columns that are measured times (seconds), different in every run
TIME_COLUMNS = ("wall_time", "eigen_time", "decision_time")
#: columns added after version 1 files were written, with the value a
#: resumed older file gets for its existing rows (its spectra are whole:
#: ``scanned_below`` = inf; no saddle escape; the rest was not kept)
LATER_COLUMNS = {"from_basis": 0.0, "n_dof": float("nan"), "lambda_max": float("nan"),
                 "scanned_below": float("inf"), "saddle_escaped": 0.0,
                 "n_negative": float("nan"), "soft_pairs": float("nan"),
                 "eigen_time": float("nan"), "decision_time": float("nan")}
DATAFILE = "datafile"
#: root attribute (True): the ``datafile`` entries inside the file's folder are
#: relative to it (:func:`point_file`)
RELATIVE_PATHS = "datafile_relative"
#: root attribute: the start file's absolute path (the root ``datafile`` is as
#: given, relative to the folder the ramp began in): ``ramp --resume`` without
#: ``--datafile`` finds it from any working folder
DATAFILE_ABSPATH = "datafile_abspath"
#: root attribute: why each undecided point is undecided (JSON object, point
#: name -> the decision's reason, e.g. the strip and where)
UNDECIDED_REASONS = "undecided_reasons"

#: name prefix of a point's eigenvalue dataset (and of its equilibrium files)
POINT_PREFIX = {STEPS: "step_", BISECTION: "bisect_"}
#: digits of the row index in those names
POINT_DIGITS = {STEPS: 5, BISECTION: 3}


def point_name(kind, index):
    """``point_name(STEPS, 12)`` -> ``'step_00012'``; ``(BISECTION, 3)`` -> ``'bisect_003'``."""
    return f"{POINT_PREFIX[kind]}{index:0{POINT_DIGITS[kind]}d}"


def column(kind, name):
    """HDF5 path of a column: ``column(STEPS, 'F_x')`` -> ``'steps/F_x'``."""
    return f"{kind}/{name}"


def _text(x):
    return x.decode() if isinstance(x, bytes) else str(x)


def point_file(h5, stored, attrs):
    """The path of an equilibrium file as a ``ramp.h5`` stores it, usable from here.

    Parameters
    ----------
    h5 : str
        Path of the ramp file.
    stored : str or bytes
        A ``datafile`` entry.
    attrs : mapping
        The file's root attributes: with :data:`RELATIVE_PATHS` true, a
        relative entry is relative to the ramp file's folder; without (files
        of older versions) it is taken as written (absolute, or relative to
        the working directory of the run that wrote it).

    Returns
    -------
    str
    """
    stored = _text(stored)
    if not bool(attrs.get(RELATIVE_PATHS, False)):
        return stored
    return resolved_path(os.path.dirname(h5), stored)


def read_points(h5, kind=STEPS):
    """Loads and equilibrium files of one row group of a ``ramp.h5``.

    Parameters
    ----------
    h5 : str
        Path of ``ramp.h5``.
    kind : {STEPS, BISECTION}

    Returns
    -------
    F_x : ndarray of float64, shape (n,)
    datafiles : list of str, length n
        Both empty if the group does not exist (a ramp without bisection).
    """
    import h5py

    with h5py.File(h5, "r") as fh:
        if kind not in fh:
            return np.zeros(0), []
        F = np.asarray(fh[column(kind, "F_x")][()], dtype=np.float64)
        files = [point_file(h5, x, fh.attrs) for x in fh[column(kind, DATAFILE)][()]]
    return F, files


def read_spectra(h5path, extra=()):
    """(F_x, eigenvalues, decision) of every equilibrium of a ``ramp.h5`` plus ``extra``.

    Parameters
    ----------
    h5path : str
        A ramp file (docs/driver.md). The decision comes from its column
        ``decision`` (the codes of
        :class:`~remote_trigger.analysis.stability.decision.Decision`) or, in
        files without it, from ``complex`` (> 0: COMPLEX, else REAL).
        Bisection points without an equilibrium have no spectrum and are
        skipped.
    extra : sequence of (float, ndarray, Decision)
        More points (e.g. the continuation above F_x^c).

    Returns
    -------
    list of (float, ndarray, Decision)
        The input of :func:`remote_trigger.analysis.stability.eigtrack.track_pair`.
    """
    import h5py

    pts = []
    with h5py.File(h5path, "r") as fh:
        for kind in (STEPS, BISECTION):
            prefix = POINT_PREFIX[kind]
            F = fh[column(kind, "F_x")][()]
            if column(kind, "decision") in fh:
                C = [Decision.of(d) for d in fh[column(kind, "decision")][()]]
            else:
                C = [Decision.certified(c > 0) for c in fh[column(kind, "complex")][()]]
            grp = fh.get(f"{EIGENVALUES}/{kind}")
            if grp is None:
                continue
            names = sorted(k for k in grp.keys() if k.startswith(prefix))
            for name in names:
                idx = int(name[len(prefix):])
                if idx < len(F):
                    pts.append((float(F[idx]), grp[name][()], C[idx]))
    pts.extend((float(F), np.asarray(lam, complex), c) for F, lam, c in extra)
    return pts


#: seconds between two checkpoints of ramp.h5 while a ramp runs (a write costs
#: ~30 ms, a ramp step at N = 100 ~0.1 s); results and status changes are
#: always written at once
CHECKPOINT_SECONDS = 5.0


def undecided_reasons(attrs):
    """Point name -> reason, from a ramp file's (or a RampLog's) root attributes."""
    return json.loads(attrs.get(UNDECIDED_REASONS, "{}"))


class RampLog:
    """In-memory copy of ramp.h5, written atomically at checkpoints.

    Rows are added in memory; :meth:`write` brings the file up to date when the
    status is final, when ``force`` is given, or while running when
    :data:`CHECKPOINT_SECONDS` have passed since the last write. A job killed
    between checkpoints loses the equilibria since the last one: ``resume``
    redoes them from the last recorded equilibrium (each point is a function
    of its start file and load only, so the redone points are the same).
    """

    COLS = COLUMNS

    def __init__(self, cfg, path):
        self.cfg = cfg
        self.path = path
        self.rows = {k: {c: [] for c in self.COLS} for k in (STEPS, BISECTION)}
        self.files = {STEPS: [], BISECTION: []}
        self.eig = {}
        self.attrs = {}
        self.dirty = False          # rows added since the last write

    def add(self, kind, name, datafile, values, eigenvalues, reason=""):
        """One row; ``reason``: why its decision is undecided (kept in the
        attribute :data:`UNDECIDED_REASONS`, a JSON object by point name)."""
        for c in self.COLS:
            self.rows[kind][c].append(values[c])
        self.files[kind].append(datafile)
        self.eig[f"{kind}/{name}"] = np.asarray(eigenvalues, complex)
        if reason:
            why = undecided_reasons(self.attrs)
            why[name] = str(reason)
            self.attrs[UNDECIDED_REASONS] = json.dumps(why)
        self.dirty = True

    def write(self, status, force=False, before=None, **attrs):
        """Bring ramp.h5 up to date, atomically (at a checkpoint, see the class).

        ``before``: called (no arguments) just before the file is written,
        not when the checkpoint interval skips the write.

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
        now = time.monotonic()
        if (status == "running" and not force and getattr(self, "_synced", False)
                and now - self._written < CHECKPOINT_SECONDS):
            return
        self._written = now
        if before is not None:
            before()
        a = dict(self.cfg.to_attrs(), stage="ramp", status=status, version=RESULT_VERSION,
                 **{RELATIVE_PATHS: True}, **self.attrs)
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
                for kind in (STEPS, BISECTION):
                    cols = {c: np.asarray(self.rows[kind][c], dtype=np.float64)
                            for c in self.COLS}
                    cols[DATAFILE] = np.asarray(
                        [stored_path(os.path.dirname(self.path), f) for f in self.files[kind]],
                        dtype=object)
                    for c, arr in cols.items():
                        name = column(kind, c)
                        if name not in fh:
                            kw = {"dtype": h5py.string_dtype()} if c == DATAFILE else {}
                            fh.create_dataset(name, data=arr, maxshape=(None,),
                                              chunks=(256,), **kw)
                            continue
                        ds = fh[name]
                        old = ds.shape[0]
                        if arr.shape[0] != old:
                            ds.resize((arr.shape[0],))
                            ds[old:] = arr[old:]
                for k, v in self.eig.items():
                    name = f"{EIGENVALUES}/{k}"
                    if name not in fh:
                        fh.create_dataset(name, data=v)
                fh.flush()
        self._synced = True
        self.dirty = False
        if not getattr(self, "_cleaned", False):     # temp files of killed runs
            from remote_trigger.pywrap.runtime.results import clean_stale_tmp

            clean_stale_tmp(self.path)
            self._cleaned = True

    @classmethod
    def load(cls, cfg, path):
        """The ramp log of ``path`` (an existing ramp.h5) for ``--resume``.

        Raises
        ------
        ConfigError
            ``path`` is not a readable HDF5 file, or ramps from another start
            file (or one whose contents changed) than ``cfg.datafile``, with
            another configuration, or lacks a dataset (each named).
        """
        try:
            attrs, data = read_all(path)
        except OSError as exc:
            raise _unreadable(path, exc) from None
        old_file = attrs.get("datafile")
        if isinstance(old_file, bytes):
            old_file = old_file.decode()
        old_sha = attrs.get("datafile_sha256")
        if isinstance(old_sha, bytes):
            old_sha = old_sha.decode()
        same = (start_sha256(cfg.datafile) == str(old_sha)) if old_sha is not None else (
            old_file is not None and os.path.abspath(str(old_file))
            == os.path.abspath(cfg.datafile))
        if not same:
            if old_file is not None and os.path.abspath(str(old_file)) == \
                    os.path.abspath(cfg.datafile):
                # the same path: its contents changed since the ramp began
                from remote_trigger.pywrap.bindings.datafile import data_dimension

                what = (f"{cfg.datafile!r} (or another dump beside it: "
                        f"{equilibrium_dump(cfg.datafile)!r})" if
                        data_dimension(cfg.datafile) == 3 else f"{cfg.datafile!r}")
                raise ConfigError(f"cannot resume {path}: the start file {what} differs "
                                  "from the one the ramp began with (nothing was changed)")
            other = "with other contents " if old_sha is not None else ""
            raise ConfigError(f"cannot resume {path}: it ramps from datafile = {old_file!r}, "
                              f"this run gives datafile = {cfg.datafile!r} {other}"
                              f"(nothing was changed)")
        # keeping the equilibria or not changes no number: either may resume
        check_resume_config(path, cfg, attrs, skip=("keep_equilibria",))
        log = cls(cfg, path)
        for kind in (STEPS, BISECTION):
            for c in cls.COLS:
                key = column(kind, c)
                if key not in data and c in LATER_COLUMNS:
                    n_rows = len(data.get(column(kind, "F_x"), []))
                    log.rows[kind][c] = [LATER_COLUMNS[c]] * n_rows
                    continue
                if key not in data:
                    raise ConfigError(f"cannot resume: {path} lacks dataset {key}")
                log.rows[kind][c] = [float(x) for x in data[key]]
            log.files[kind] = [point_file(path, s, attrs) for s in
                               data.get(column(kind, DATAFILE), [])]
        eig = EIGENVALUES + "/"
        for k, v in data.items():
            if k.startswith(eig):
                log.eig[k[len(eig):]] = v
        log.attrs = {k: v for k, v in attrs.items()
                     if k in ("F_x_c_low", "F_x_c_high", "F_x_c_width", "tol_reached",
                              "n_undecided", "message", "dt_used", "datafile_sha256",
                              DATAFILE_ABSPATH, UNDECIDED_REASONS)}
        log.status = attrs.get("status", "running")
        log._synced = False          # rewrite in full once (older files: fixed-size)
        return log


def _unreadable(path, exc):
    return ConfigError(f"cannot resume: {path} is not a readable HDF5 file ({exc})")


def recorded_start(path):
    """The start file a ``ramp.h5`` names: its absolute path
    (:data:`DATAFILE_ABSPATH`; None in files of older versions) and the
    ``datafile`` as given when the ramp began.

    Raises
    ------
    ConfigError
        ``path`` is not a readable HDF5 file.
    """
    import h5py

    try:
        with h5py.File(path, "r") as fh:
            names = [fh.attrs.get(k) for k in (DATAFILE_ABSPATH, DATAFILE)]
    except OSError as exc:
        raise _unreadable(path, exc) from None
    return tuple(n.decode() if isinstance(n, bytes) else None if n is None else str(n)
                 for n in names)


def open_ramp_log(eng, cfg, out, h5, resume):
    """The ramp's log (:class:`RampLog`, on every rank): new, or ``ramp.h5`` to
    resume (refused without ``resume``); the start file and ``out`` checked.

    Raises
    ------
    ConfigError
        ``ramp.h5`` exists without ``resume``; a bad start file, output
        folder or file to resume (the message names it).
    """
    exists = eng.comm.bcast(os.path.exists(h5) if eng.rank == 0 else None, root=0)
    if exists and not resume:
        raise ConfigError(f"{h5} exists: use --resume (resume=True) to continue it, or "
                          f"another output folder (nothing was overwritten)")

    def open_log():
        from remote_trigger.analysis.output import output_dir
        from remote_trigger.pywrap.bindings.datafile import check_datafile

        try:
            check_datafile(cfg.datafile)
            check_spheres_ramp(cfg)
            check_lammps_path("out", out)
            output_dir(out, "--out")
            log_ = RampLog.load(cfg, h5) if (resume and exists) else RampLog(cfg, h5)
        except ValueError as exc:
            raise ConfigError(str(exc)) from None
        log_.attrs.setdefault("datafile_sha256", start_sha256(cfg.datafile))
        # (the start of this run: its SHA-256 was checked against the ramp's)
        log_.attrs[DATAFILE_ABSPATH] = os.path.abspath(cfg.datafile)
        log_.attrs["n_ranks"] = eng.size        # of this run, as relax.h5 and the series
        return log_

    return on_rank0(eng.comm, open_log)
