"""HDF5 result files that stay readable whenever the writer dies.

Every result file is only ever *replaced*, never modified in place: the new
version is written completely under ``<path>.tmp<pid>`` (an ordinary HDF5
file, default library format, closed before use) and renamed over ``<path>``
with :func:`os.replace`, which is atomic on POSIX. A reader, or the next run,
therefore always finds at ``<path>`` a complete, closed file -- the previous
version or the new one -- whatever moment the writer was killed at (also
``kill -9``, an uncaught exception, the OOM killer). A plain
``h5py.File(path, 'r')`` opens it; no ``h5clear`` is ever needed.

Two writers, both used on MPI rank 0 only:

* :func:`write_atomic` writes a whole (small) file in one go. Used for
  ``relax.h5`` and the paper's summary files. (``ramp.h5`` is written by
  ``ramp_file.RampLog`` with the same temporary-name-and-rename scheme, on a
  copy of the previous file.)
* :class:`SeriesWriter` records time series (the undamped runs,
  ``perturb_[abc].h5``, ``instability.h5``): rows are kept in memory and the
  file is rewritten atomically at most every ``checkpoint_seconds``
  (default 2 s of wall time) and at :meth:`SeriesWriter.close`. A killed
  run leaves the rows up to its last checkpoint, with ``status`` =
  ``'running'``.

Layout (all files): configuration as root attributes (``config_class`` and
one attribute per field, ``None`` as the string ``'None'``), ``stage``,
``status`` (``'running'`` until the stage finishes), datasets as documented
in docs/driver.md.

.. warning::

   *Why not SWMR.* The former :class:`SeriesWriter` kept the file open in
   HDF5 single-writer/multiple-reader mode (``libver='latest'``) and flushed
   after each row. SWMR keeps the file *consistent*, but a file opened for
   writing with the latest format carries a "file is open for write" flag in
   its superblock, cleared only by a clean close: after ``kill -9``,
   ``h5py.File(path, 'r')`` failed with "file is already open for write (may
   use <h5clear file> to clear file consistency flags)", also when killed
   while :meth:`~SeriesWriter.close` reopened the file to set ``status``.
   The files written here never have an open-for-write state at ``<path>``.

Temporary files. ``<path>.tmp<pid>`` is written only by process ``pid``
and exists only during one write, unless that process was killed in the
middle of it; then it stays behind, possibly incomplete. It is never a
result: every reader opens ``<path>`` itself, and a ``*.h5`` pattern does
not match it. The next write of the same ``<path>`` (on the same host)
removes leftovers whose process no longer exists (:func:`clean_stale_tmp`).

Durability. ``os.replace`` without ``fsync`` survives the death of the
writing *process* (the page cache belongs to the kernel), not a crash of the
machine or a power cut, after which the last checkpoint may be lost.
"""
import os
import re
import time

import numpy as np
from remote_trigger.analysis.output import atomic_path


def _set_attrs(obj, attrs):
    for k, v in (attrs or {}).items():
        if isinstance(v, (list, tuple)):
            v = np.asarray(v)
        obj.attrs[k] = v


def _pid_alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:          # exists, another user's
        return True
    except (OverflowError, ValueError):
        return False
    return True


def clean_stale_tmp(path):
    """Remove ``<path>.tmp<pid>`` files left by processes that no longer exist.

    Parameters
    ----------
    path : str
        A result file (need not exist).

    Returns
    -------
    list of str
        The files removed. A temporary file of a live process (this one, or
        another writer of the same path) is kept. Process ids are those of
        this host: do not write one result path from several hosts at once.
    """
    path = os.fspath(path)
    folder = os.path.dirname(path) or "."
    pat = re.compile(re.escape(os.path.basename(path)) + r"\.tmp(\d+)")
    removed = []
    try:
        names = os.listdir(folder)
    except OSError:
        return removed
    me = os.getpid()
    for name in names:
        m = pat.fullmatch(name)
        if m is None:
            continue
        pid = int(m.group(1))
        if pid == me or _pid_alive(pid):
            continue
        try:
            os.remove(os.path.join(folder, name))
            removed.append(os.path.join(folder, name))
        except OSError:
            pass
    return removed


def _write_replace(path, attrs, datasets):
    """Write ``<path>.tmp<pid>`` completely, close it, rename it over ``path``."""
    import h5py

    with atomic_path(path) as tmp, h5py.File(tmp, "w") as fh:
        _set_attrs(fh, attrs)
        for name, val in datasets.items():
            dattrs = None
            if isinstance(val, dict):
                dattrs = val.get("attrs")
                val = val["data"]
            arr = np.asarray(val)
            if arr.dtype.kind in "UO":
                arr = np.asarray([str(s) for s in arr.reshape(-1)], dtype=object)
                ds = fh.create_dataset(name, data=arr, dtype=h5py.string_dtype())
            else:
                ds = fh.create_dataset(name, data=arr)
            _set_attrs(ds, dattrs)


def write_atomic(path, attrs, datasets):
    """Write an HDF5 file atomically (temporary name, then ``os.replace``).

    Parameters
    ----------
    path : str
        Destination; an existing file is replaced. Stale temporary files of
        ``path`` left by killed processes are removed first.
    attrs : dict
        Root attributes.
    datasets : dict
        ``{'group/name': array_like}``; strings become variable-length UTF-8.
        A value that is a dict ``{'data': ..., 'attrs': {...}}`` also sets
        dataset attributes.
    """
    clean_stale_tmp(path)
    _write_replace(path, attrs, datasets)


class SeriesWriter:
    """Time series in an HDF5 file, checkpointed atomically.

    Rows are collected in memory; the whole file is rewritten under a
    temporary name and renamed over ``path`` (:func:`write_atomic`'s scheme)
    when the constructor returns (no rows, ``status = 'running'``), on the
    first :meth:`append` after each checkpoint interval, and at
    :meth:`close`. So at any moment ``path`` is a complete, closed file
    holding the rows up to the last checkpoint.

    Parameters
    ----------
    path : str
        File to create; an existing file is replaced (at once, by the empty
        series).
    attrs : dict
        Root attributes (configuration); ``status`` is set to ``'running'``.
    columns : sequence of str
        Names of the float64 datasets, one value per row.
    checkpoint_seconds : float, optional
        Wall time between two checkpoints (default 2 s). A positive
        interval is lengthened to 20 times the duration of the last
        rewrite, so that rewriting a long series never takes more than ~5 %
        of the wall time. 0 rewrites the file at every row (quadratic cost;
        for tests).

    Raises
    ------
    ValueError
        No columns, repeated column names, or a negative
        ``checkpoint_seconds``.

    Notes
    -----
    A rewrite costs about its size in bytes at memory speed (4 columns of
    1e5 rows, 3.2 MB: a few ms). The cost per row of :meth:`append` is that
    of storing ``len(columns)`` floats in NumPy buffers (~1.3 µs for 4), measured by
    ``benchmarks/bench_kill.py``. The datasets are contiguous float64 arrays
    of the final length (no longer resizable, chunked SWMR datasets);
    readers that read them whole (``fh['t'][()]``) see no difference.
    """

    #: a rewrite may take at most this fraction of the wall time
    MAX_OVERHEAD = 0.05

    def __init__(self, path, attrs, columns, checkpoint_seconds=2.0):
        self.path = os.fspath(path)
        self.columns = list(columns)
        if not self.columns:
            raise ValueError("SeriesWriter needs at least one column")
        if len(set(self.columns)) != len(self.columns):
            raise ValueError(f"SeriesWriter: repeated column names in {self.columns}")
        checkpoint_seconds = float(checkpoint_seconds)
        if not checkpoint_seconds >= 0:
            raise ValueError(f"SeriesWriter: checkpoint_seconds must be >= 0, got "
                             f"{checkpoint_seconds!r}")
        self.checkpoint_seconds = checkpoint_seconds
        self.attrs = dict(attrs or {}, status="running")
        self._buf = {c: np.empty(1024, dtype=np.float64) for c in self.columns}
        self.n = 0
        self.n_checkpoints = 0
        self.closed = False
        clean_stale_tmp(self.path)
        self.checkpoint()

    def append(self, row):
        """Append one row ``{column: value}``; checkpoint if one is due.

        Raises
        ------
        KeyError
            A column is missing from ``row`` (nothing is appended).
        ValueError
            The writer is closed.
        """
        if self.closed:
            raise ValueError(f"SeriesWriter of {self.path} is closed")
        vals = [float(row[c]) for c in self.columns]
        n = self.n
        if n == self._buf[self.columns[0]].size:
            for c in self.columns:
                self._buf[c] = np.concatenate([self._buf[c], np.empty_like(self._buf[c])])
        for c, v in zip(self.columns, vals):
            self._buf[c][n] = v
        self.n = n + 1
        if time.monotonic() >= self._due:
            self.checkpoint()

    def data(self):
        """The rows so far, ``{column: ndarray}`` (copies)."""
        return {c: self._buf[c][:self.n].copy() for c in self.columns}

    def checkpoint(self):
        """Rewrite the file now with all rows so far (atomically)."""
        t0 = time.monotonic()
        _write_replace(self.path, self.attrs,
                       {c: self._buf[c][:self.n] for c in self.columns})
        t1 = time.monotonic()
        self.n_checkpoints += 1
        every = self.checkpoint_seconds
        self._due = t1 + (max(every, (t1 - t0) / self.MAX_OVERHEAD) if every > 0 else 0.0)

    def close(self, attrs=None, status="complete"):
        """Write the final file: all rows, ``status`` and extra root attributes.

        A second call does nothing.
        """
        if self.closed:
            return
        self.attrs.update(attrs or {})
        self.attrs["status"] = status
        self.checkpoint()
        self.closed = True


def read_all(path):
    """Read a result file: ``(attrs, {name: ndarray})`` for all datasets."""
    import h5py

    out = {}
    with h5py.File(path, "r") as fh:
        attrs = {k: (v.item() if hasattr(v, "item") and np.ndim(v) == 0 else v)
                 for k, v in fh.attrs.items()}

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset):
                data = obj[()]
                if obj.dtype.kind == "O":
                    data = np.asarray([s.decode() if isinstance(s, bytes) else s
                                       for s in np.atleast_1d(data)], dtype=object)
                out[name] = data
        fh.visititems(visit)
    return attrs, out
