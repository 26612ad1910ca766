"""The layout of ``ramp.h5`` (written by ``stages._RampLog``), and its reader.

Root attributes: the ramp configuration, ``stage = 'ramp'``, ``status``,
``version``, the bracket ``F_x_c_low``/``F_x_c_high`` and its status
(docs/driver.md). Groups:

``steps/<column>`` and ``bisection/<column>``
    One row per equilibrium of the ramp (in ramp order) and of the bisection
    (in evaluation order); columns :data:`COLUMNS` (float64) and
    ``datafile`` (UTF-8 strings: the equilibrium's ``.data``; its dump is
    the same name with ``.dump``).
``eigenvalues/steps/step_NNNNN``, ``eigenvalues/bisection/bisect_NNN``
    The eigenvalues (complex128) of each equilibrium (:data:`POINT_PREFIX`;
    NNNNN is the row index in ``steps``, NNN in ``bisection``).

Readers use these names, never string literals.
"""
import numpy as np

#: row groups of ramp.h5
STEPS = "steps"
BISECTION = "bisection"
#: group of the eigenvalue datasets
EIGENVALUES = "eigenvalues"
#: float64 columns of every row group (plus ``datafile``)
COLUMNS = ("F_x", "residual", "complex", "decision", "confidence", "growth_rate",
           "max_imag", "n_rattlers", "wall_time", "damped_time", "newton_steps")
DATAFILE = "datafile"
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
        files = [_text(x) for x in fh[column(kind, DATAFILE)][()]]
    return F, files
