"""The layout of ``ramp.h5`` (written by ``ramp._RampLog``), and its reader.

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


def read_spectra(h5path, extra=()):
    """(F_x, eigenvalues, decision) of every equilibrium of a ``ramp.h5`` plus ``extra``.

    Parameters
    ----------
    h5path : str
        A ramp file (docs/driver.md). The decision comes from its column
        ``decision`` (1 complex, 0 real, -1 undecided -> None) or, in files
        without it, from ``complex`` (> 0). Bisection points without an
        equilibrium have no spectrum and are skipped.
    extra : sequence of (float, ndarray, bool)
        More points (e.g. the continuation above F_x^c).

    Returns
    -------
    list of (float, ndarray, bool or None)
        The input of :func:`remote_trigger.analysis.eigtrack.track_pair`.
    """
    import h5py

    pts = []
    with h5py.File(h5path, "r") as fh:
        for kind in (STEPS, BISECTION):
            prefix = POINT_PREFIX[kind]
            F = fh[column(kind, "F_x")][()]
            if column(kind, "decision") in fh:
                C = [None if d < 0 else bool(d > 0)
                     for d in fh[column(kind, "decision")][()]]
            else:
                C = [bool(c > 0) for c in fh[column(kind, "complex")][()]]
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
