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


def output_file(path, option="-o", suffix=None):
    """Check an output file name before any work; returns its absolute path.

    Parameters
    ----------
    path : str
        The file to write.
    option : str
        Name of the option in messages.
    suffix : str, optional
        Required ending (e.g. ``'.npz'``).

    Raises
    ------
    InputError
        If ``path`` is a folder (or ends with a path separator), its folder
        does not exist or is not a folder, or it lacks ``suffix``.
    """
    from .errors import InputError

    text = os.fspath(path)
    if not text or text.endswith(os.sep) or os.path.isdir(text):
        raise InputError(f"{option} must name a file, got a folder: {text!r}")
    if suffix and (not text.endswith(suffix) or os.path.basename(text) == suffix):
        raise InputError(f"{option} must name a {suffix} file, got {text!r}")
    folder = os.path.dirname(os.path.abspath(text))
    if not os.path.isdir(folder):
        what = "is not a folder" if os.path.exists(folder) else "does not exist"
        raise InputError(f"{option} {text!r}: the folder {folder!r} {what}")
    return os.path.abspath(text)


def output_dir(path, option="--out"):
    """Create an output folder (and parents) or raise a one-line error; returns ``path``.

    Raises
    ------
    InputError
        If ``path`` names an existing file, or the folder cannot be created
        or written (the message names the path and the reason).
    """
    from .errors import InputError

    text = os.fspath(path)
    if not text:
        raise InputError(f"{option} must name a folder, got {text!r}")
    if os.path.exists(text) and not os.path.isdir(text):
        raise InputError(f"{option} must name a folder, got a file: {text!r}")
    try:
        os.makedirs(text, exist_ok=True)
    except OSError as exc:
        raise InputError(f"{option} {text!r}: cannot create the folder "
                         f"({exc.strerror or exc})") from None
    if not os.access(text, os.W_OK | os.X_OK):
        raise InputError(f"{option} {text!r}: the folder is not writable")
    return text


def write_npz_atomic(path, arrays):
    """``numpy.savez`` to a temporary file in the same folder, then rename to ``path``."""
    import numpy as np

    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".npz", dir=folder)
    try:
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, **arrays)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
