"""Output files and folders: every result is written atomically.

A result file is only ever *replaced*, never modified in place: the new
version is written completely under ``<path>.tmp<pid>`` (same folder, so the
rename never crosses file systems) and renamed over ``<path>`` with
:func:`os.replace`, atomic on POSIX. A reader, or the next run, finds at
``<path>`` the previous complete file or the new complete one, whatever
moment the writer was killed at (also ``kill -9``). If writing fails, the
temporary file is removed and the exception propagates; a process killed in
the middle leaves its ``<path>.tmp<pid>``, never read as a result (removed by
the next write through :func:`remote_trigger.pywrap.runtime.results.clean_stale_tmp`).

:func:`atomic_path` is the one implementation; the writers below (text,
JSON, HDF5, ``.npz``, matplotlib figures) and the driver's
(:mod:`remote_trigger.pywrap.runtime.results`) use it. :func:`output_file` and
:func:`output_dir` check an output name before any work; :func:`bracket_text`
prints a bracket (of F_x^c, say) on the lines the commands print.
"""
import contextlib
import json
import os


def tmp_name(path):
    """The temporary name ``<path>.tmp<pid>`` under which ``path`` is written."""
    return f"{os.fspath(path)}.tmp{os.getpid()}"


@contextlib.contextmanager
def atomic_path(path):
    """Context manager: a temporary file name that becomes ``path`` on success.

    Parameters
    ----------
    path : str or os.PathLike
        Destination; an existing file is replaced only when the body of the
        ``with`` block finishes without an exception.

    Yields
    ------
    str
        ``<path>.tmp<pid>``, in the folder of ``path``. Write it completely
        (and close it) inside the block.

    Raises
    ------
    Whatever the body raises; the temporary file is then removed and
    ``path`` is left as it was.

    Examples
    --------
    >>> with atomic_path("out.h5") as tmp:          # doctest: +SKIP
    ...     with h5py.File(tmp, "w") as fh:
    ...         fh["x"] = x
    """
    tmp = tmp_name(path)
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def write_text_atomic(path, text):
    """Write ``text`` (str) to ``path`` atomically (:func:`atomic_path`)."""
    with atomic_path(path) as tmp:
        with open(tmp, "w") as fh:
            fh.write(text)


def write_json_atomic(path, data, **kwargs):
    """``json.dump(data)`` to ``path`` atomically; ``kwargs`` go to :func:`json.dump`."""
    with atomic_path(path) as tmp:
        with open(tmp, "w") as fh:
            json.dump(data, fh, **kwargs)


def savefig_atomic(fig, path, **kwargs):
    """``fig.savefig`` to ``path`` atomically; the format is taken from ``path``'s suffix.

    ``kwargs`` (e.g. ``dpi``) go to :meth:`matplotlib.figure.Figure.savefig`.
    The figure is not closed.
    """
    fmt = os.path.splitext(os.fspath(path))[1].lstrip(".") or None
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=fmt, **kwargs)


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

    with atomic_path(path) as tmp:
        with h5py.File(tmp, "w") as h5:
            for name, data in datasets.items():
                arr = np.asarray(data)
                if arr.dtype.kind == "f":
                    arr = arr.astype(np.float64)
                h5.create_dataset(name, data=arr)
            for key, val in (attrs or {}).items():
                h5.attrs[key] = val


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
    from remote_trigger.analysis.errors import InputError

    text = os.fspath(path)
    if not text:
        raise InputError(f"{option} must name a file, got an empty name")
    if text.endswith(os.sep) or os.path.isdir(text):
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
    from remote_trigger.analysis.errors import InputError

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

    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            np.savez(fh, **arrays)


def bracket_text(lo, hi, digits=6):
    """``'[lo, hi]'`` with at least ``digits`` significant digits, more where
    the two ends would print alike (a bracket 7e-8 wide printed as
    ``[0.0646371, 0.0646371]`` with six).

    Parameters
    ----------
    lo, hi : float
        Ends of the bracket (NaN and inf printed as such).
    digits : int
        Fewest significant digits; at most 17 are used (every float64 apart).
    """
    for d in range(min(int(digits), 17), 18):
        a, b = f"{lo:.{d}g}", f"{hi:.{d}g}"
        if a != b or lo == hi:
            break
    return f"[{a}, {b}]"
