"""Checks of a LAMMPS data file before LAMMPS reads it.

LAMMPS reports an empty, truncated or corrupt data file with a long message
(or, for NaN coordinates or two disks at the same place, not at all: the
run produces NaN forces). :func:`check_datafile` reads the file once in
Python and raises a one-line :class:`~remote_trigger.pywrap.config.ConfigError`
naming the file and the problem.
"""
import math
import os

import numpy as np

from .config import ConfigError

#: sections with one line per atom type (or type pair), not per atom
_PER_TYPE = ("Masses", "Pair Coeffs", "PairIJ Coeffs", "Bond Coeffs", "Angle Coeffs",
             "Dihedral Coeffs", "Improper Coeffs")

#: centres closer than this (length units) are coincident
COINCIDENT = 1e-9


def _is_number(word):
    try:
        float(word)
    except ValueError:
        return False
    return True


def check_datafile(path):
    """Refuse a data file that LAMMPS cannot read or that has no valid positions.

    Checks: the file exists and is not empty; the header gives the atom count
    and finite box bounds; every per-atom section has one line per atom; every
    number in the ``Atoms`` section is finite; no two centres coincide
    (closer than :data:`COINCIDENT`, for ``atom_style sphere``: the contact
    normal is undefined).

    Parameters
    ----------
    path : str

    Returns
    -------
    int
        Number of atoms.

    Raises
    ------
    ConfigError
        Naming the file and what is wrong with it.
    """
    path = os.fspath(path)
    try:
        with open(path) as fh:
            lines = fh.read().splitlines()
    except OSError as exc:
        raise ConfigError(f"cannot read the data file {path!r}: {exc.strerror or exc}") \
            from None
    except UnicodeDecodeError:
        raise ConfigError(f"data file {path!r} is not a text file") from None
    if not any(line.strip() for line in lines):
        raise ConfigError(f"data file {path!r} is empty")
    natoms = None
    bounds = {}
    sections = []                       # (name, index of the header line)
    for k, raw in enumerate(lines[1:], start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        words = line.split()
        if not _is_number(words[0]):
            sections.append((raw.strip(), k))
            continue
        if sections:
            continue
        if len(words) == 2 and words[1] == "atoms":
            natoms = int(float(words[0]))
        for ax in ("x", "y", "z"):
            if len(words) == 4 and words[2:] == [f"{ax}lo", f"{ax}hi"]:
                bounds[ax] = (float(words[0]), float(words[1]))
    if natoms is None:
        raise ConfigError(f"data file {path!r} has no 'N atoms' line in its header "
                          f"(not a LAMMPS data file, or truncated)")
    for ax, (lo, hi) in bounds.items():
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ConfigError(f"data file {path!r}: box bounds {ax}lo {ax}hi = {lo!r} {hi!r} "
                              f"must be finite with lo < hi")
    if not any(name.split()[0] == "Atoms" for name, _ in sections):
        raise ConfigError(f"data file {path!r} has no Atoms section (truncated?)")
    atoms = None
    for s, (name, start) in enumerate(sections):
        end = sections[s + 1][1] if s + 1 < len(sections) else len(lines)
        body = [ln.split("#", 1)[0].split() for ln in lines[start + 1:end]]
        body = [w for w in body if w]
        if name.startswith(_PER_TYPE):
            continue
        if len(body) < natoms:
            raise ConfigError(f"data file {path!r} is truncated: section {name.split()[0]!r} "
                              f"has {len(body)} of {natoms} atom lines")
        if name.split()[0] == "Atoms":
            atoms = (name, body[:natoms])
    name, body = atoms
    for words in body:
        for w in words:
            try:
                v = float(w)
            except ValueError:
                raise ConfigError(f"data file {path!r}: non-numeric value {w!r} in the Atoms "
                                  f"line of atom {words[0]}") from None
            if not math.isfinite(v):
                raise ConfigError(f"data file {path!r}: non-finite value {w!r} in the Atoms "
                                  f"line of atom {words[0]}")
    style = name.split("#", 1)[1].strip() if "#" in name else "sphere"
    if style == "sphere" and natoms > 1 and all(len(w) >= 7 for w in body):
        xy = np.array([[float(w[4]), float(w[5])] for w in body])
        ids = [w[0] for w in body]
        _check_coincident(path, xy, ids)
    return natoms


def _check_coincident(path, xy, ids):
    from scipy.spatial import cKDTree

    pairs = cKDTree(xy).query_pairs(COINCIDENT, output_type="ndarray")
    if len(pairs):
        i, j = (int(v) for v in pairs[0])
        raise ConfigError(f"data file {path!r}: atoms {ids[i]} and {ids[j]} are at the same "
                          f"place (x, y) = ({float(xy[i, 0])!r}, {float(xy[i, 1])!r}); their contact has "
                          f"no normal")
