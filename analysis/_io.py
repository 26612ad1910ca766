"""Atomic output: write to a temporary file in the same folder, then rename."""
import os
import tempfile


def write_h5_atomic(path, datasets, attrs=None):
    """Write an HDF5 file so that ``path`` is either the old file or the complete new one.

    Parameters
    ----------
    path : str
        Destination.
    datasets : dict of str -> array_like
        Dataset name (may contain '/') to data; float arrays are stored as float64.
    attrs : dict, optional
        Attributes of the root group (scalars or strings).
    """
    import h5py
    import numpy as np

    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".h5", dir=folder)
    os.close(fd)
    try:
        with h5py.File(tmp, "w") as h5:
            for name, data in datasets.items():
                arr = np.asarray(data)
                if arr.dtype.kind == "f":
                    arr = arr.astype(np.float64)
                h5.create_dataset(name, data=arr)
            for key, val in (attrs or {}).items():
                h5.attrs[key] = val
            h5.flush()
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
