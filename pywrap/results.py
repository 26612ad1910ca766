"""HDF5 result files, written so that a crash loses at most the last step.

Two writers, both used on MPI rank 0 only:

* :func:`write_atomic` rewrites a whole (small) file: it writes
  ``<path>.tmp<pid>`` and renames it over ``<path>`` (``os.replace`` is
  atomic on POSIX), so the file on disk is always a complete previous or
  new version, even after ``kill -9``. Used for ``relax.h5`` and ``ramp.h5``
  (one rewrite per equilibrium).
* :class:`SeriesWriter` appends rows of time series to resizable datasets
  of a file in HDF5 single-writer/multiple-reader (SWMR) mode and flushes
  after every row: HDF5 orders its metadata writes so that the file stays
  readable after a crash, with all flushed rows. Used for the undamped runs.

Layout (all files): configuration as root attributes (``config_class`` and
one attribute per field, ``None`` as the string ``'None'``), ``stage``,
``status`` (``'running'`` until the stage finishes), datasets as documented
in docs/driver.md.
"""
import os

import numpy as np


def _set_attrs(obj, attrs):
    for k, v in (attrs or {}).items():
        if isinstance(v, (list, tuple)):
            v = np.asarray(v)
        obj.attrs[k] = v


def write_atomic(path, attrs, datasets):
    """Write an HDF5 file atomically.

    Parameters
    ----------
    path : str
        Destination.
    attrs : dict
        Root attributes.
    datasets : dict
        ``{'group/name': array_like}``; strings become variable-length UTF-8.
        A value that is a dict ``{'data': ..., 'attrs': {...}}`` also sets
        dataset attributes.
    """
    import h5py

    tmp = f"{path}.tmp{os.getpid()}"
    with h5py.File(tmp, "w") as fh:
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
        fh.flush()
    os.replace(tmp, path)


class SeriesWriter:
    """Append-only time series in an HDF5 file (SWMR mode, flush per row).

    Parameters
    ----------
    path : str
        File to create (replaced if it exists).
    attrs : dict
        Root attributes (configuration); ``status`` is set to ``'running'``.
    columns : sequence of str
        Names of the float64 datasets, one value per row.

    Notes
    -----
    Attributes cannot be added in SWMR mode; :meth:`close` reopens the file
    once to set ``status`` and the final attributes.
    """

    def __init__(self, path, attrs, columns):
        import h5py

        self.path = path
        self.columns = list(columns)
        tmp = f"{path}.tmp{os.getpid()}"
        fh = h5py.File(tmp, "w", libver="latest")
        _set_attrs(fh, dict(attrs, status="running"))
        for c in self.columns:
            fh.create_dataset(c, shape=(0,), maxshape=(None,), dtype="f8", chunks=(1024,))
        fh.close()
        os.replace(tmp, path)
        self.fh = h5py.File(path, "a", libver="latest")
        self.fh.swmr_mode = True
        self.n = 0

    def append(self, row):
        """Append one row ``{column: value}`` and flush it to disk."""
        for c in self.columns:
            ds = self.fh[c]
            ds.resize((self.n + 1,))
            ds[self.n] = float(row[c])
        self.n += 1
        self.fh.flush()

    def close(self, attrs=None, status="complete"):
        """Close, then set ``status`` and extra root attributes."""
        import h5py

        if self.fh is None:
            return
        self.fh.close()
        self.fh = None
        with h5py.File(self.path, "a", libver="latest") as fh:
            _set_attrs(fh, dict(attrs or {}, status=status))


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
