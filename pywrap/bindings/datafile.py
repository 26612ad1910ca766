"""Checks of a LAMMPS data file before LAMMPS reads it.

LAMMPS reports an empty, truncated or corrupt data file with a long message
(or, for NaN coordinates or two disks at the same place, not at all: the
run produces NaN forces). :func:`check_datafile` reads the file once in
Python (:func:`remote_trigger.analysis.state.datafile.read_data`) and raises a
one-line :class:`~remote_trigger.pywrap.config.ConfigError` naming the file
and the problem.
"""
from remote_trigger.analysis.state.datafile import COINCIDENT, DataFile, read_data  # noqa: F401

from remote_trigger.pywrap.config import ConfigError


def data_dimension(path):
    """2 (disks) or 3 (spheres) for a data file (:attr:`DataFile.dimension`).

    Raises
    ------
    ConfigError
        As :func:`check_datafile`.
    """
    return check_datafile(path, full=True).dimension


def check_datafile(path, full=False):
    """Refuse a data file that LAMMPS cannot read or that has no valid positions.

    The checks of :func:`remote_trigger.analysis.state.datafile.read_data`: the
    file exists and is not empty; the header gives the atom count and finite
    box bounds; every per-atom section has one line per atom; every number in
    the ``Atoms`` section is finite; no two centres coincide (closer than
    :data:`COINCIDENT`, for ``atom_style sphere``: the contact normal is
    undefined).

    Parameters
    ----------
    path : str
    full : bool
        Return the :class:`DataFile` instead of its atom count.

    Returns
    -------
    int or DataFile
        Number of atoms (or the file read).

    Raises
    ------
    ConfigError
        Naming the file and what is wrong with it.
    """
    try:
        data = read_data(path)
    except (ValueError, FileNotFoundError) as exc:
        raise ConfigError(str(exc)) from None
    return data if full else data.n
