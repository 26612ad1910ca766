"""LAMMPS data files as the project writes them, read in float64 (no LAMMPS).

``write_data`` of the driver (``atom_style sphere``) gives a header (atom
count, box bounds), an ``Atoms # sphere`` section (``id type diameter
density x y z ix iy iz``), ``Velocities``, and the sections of the per-atom
fixes (``hist``: contact history, ``topflag # i_top``: the top line).
:func:`read_data` checks the file the way the driver must before LAMMPS
reads it (LAMMPS reports a truncated or corrupt file with a long message,
and NaN coordinates or coincident disks not at all) and returns the atoms
in id order. ``pywrap.datafile.check_datafile`` is this check with the
driver's error type.
"""
from dataclasses import dataclass
import math
import os
import re

import numpy as np

__all__ = ["DataFile", "read_data", "COINCIDENT"]

#: sections with one line per atom type (or type pair), not per atom
_PER_TYPE = ("Masses", "Pair Coeffs", "PairIJ Coeffs", "Bond Coeffs", "Angle Coeffs",
             "Dihedral Coeffs", "Improper Coeffs")

#: centres closer than this (length units) are coincident
COINCIDENT = 1e-9


@dataclass
class DataFile:
    """A data file's atoms, in id order.

    Attributes
    ----------
    path : str
    n : int
        Number of atoms.
    box_lo, box_hi : ndarray, shape (3,)
        Box bounds (NaN where the header has none).
    style : str
        Atom style named in the ``Atoms`` header (``sphere`` if none).
    ids, types : ndarray of int64, shape (n,)
    positions : ndarray, shape (n, 2) or None
        x, y (``sphere`` style; float64, as written).
    radii, masses : ndarray, shape (n,) or None
        ``sphere`` style: R = diameter / 2, m = density 4/3 pi R^3 (how
        LAMMPS turns the density column into a mass, in 2d too).
    images : ndarray of int64, shape (n, 3) or None
    top : ndarray of bool, shape (n,) or None
        The ``topflag`` section (``i_top`` > 0); None without it.
    z : ndarray, shape (n,) or None
        z of each centre (``sphere`` style).
    dimension : int
        3 if some centre has z != 0 (spheres; a 2D LAMMPS data file has
        z = 0 for every atom), else 2. A file with z != 0 and the disks'
        history section (``d_mindlin_t``) is refused (:func:`read_data`).
    pair_coeffs : str
        The name of its ``Pair Coeffs`` or ``PairIJ Coeffs`` section (what
        ``write_data`` without ``nocoeff`` writes), else ``''``.
    """

    path: str
    n: int
    box_lo: np.ndarray
    box_hi: np.ndarray
    style: str
    ids: np.ndarray
    types: np.ndarray
    positions: np.ndarray = None
    radii: np.ndarray = None
    masses: np.ndarray = None
    images: np.ndarray = None
    top: np.ndarray = None
    z: np.ndarray = None
    dimension: int = 2
    pair_coeffs: str = ""


def _is_number(word):
    try:
        float(word)
    except ValueError:
        return False
    return True


def _lines(path):
    try:
        with open(path) as fh:
            lines = fh.read().splitlines()
    except FileNotFoundError:
        # (a ValueError before; a missing dump is a FileNotFoundError too)
        raise FileNotFoundError(f"data file not found: {path}") from None
    except OSError as exc:
        raise ValueError(f"cannot read the data file {path!r}: {exc.strerror or exc}") \
            from None
    except UnicodeDecodeError:
        raise ValueError(f"data file {path!r} is not a text file") from None
    if not any(line.strip() for line in lines):
        raise ValueError(f"data file {path!r} is empty")
    return lines


def _header(path, lines):
    """(natoms, bounds {axis: (lo, hi)}, [(section header, line index)])."""
    natoms = None
    bounds = {}
    sections = []
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
        raise ValueError(f"data file {path!r} has no 'N atoms' line in its header "
                         f"(not a LAMMPS data file, or truncated)")
    for ax, (lo, hi) in bounds.items():
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ValueError(f"data file {path!r}: box bounds {ax}lo {ax}hi = {lo!r} {hi!r} "
                             f"must be finite with lo < hi")
    if not any(name.split()[0] == "Atoms" for name, _ in sections):
        raise ValueError(f"data file {path!r} has no Atoms section (truncated?)")
    return natoms, bounds, sections


def _atoms_values(path, body):
    """The Atoms lines as floats, every value finite."""
    rows = []
    for words in body:
        row = []
        for w in words:
            try:
                v = float(w)
            except ValueError:
                raise ValueError(f"data file {path!r}: non-numeric value {w!r} in the Atoms "
                                 f"line of atom {words[0]}") from None
            if not math.isfinite(v):
                raise ValueError(f"data file {path!r}: non-finite value {w!r} in the Atoms "
                                 f"line of atom {words[0]}")
            row.append(v)
        rows.append(row)
    return rows


def _check_coincident(path, xy, ids):
    from scipy.spatial import cKDTree

    pairs = cKDTree(xy).query_pairs(COINCIDENT, output_type="ndarray")
    if len(pairs):
        i, j = (int(v) for v in pairs[0])
        names = "(x, y)" if xy.shape[1] == 2 else "(x, y, z)"
        where = ", ".join(repr(float(v)) for v in xy[i])
        raise ValueError(f"data file {path!r}: atoms {ids[i]} and {ids[j]} are at the same "
                         f"place {names} = ({where}); their contact has no normal")


def read_data(path):
    """Read and check a LAMMPS data file.

    Checks: the file exists and is not empty; the header gives the atom count
    and finite box bounds; every per-atom section has one line per atom; every
    number in the ``Atoms`` section is finite; no two centres coincide
    (closer than :data:`COINCIDENT`, for ``atom_style sphere``: the contact
    normal is undefined).

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    DataFile

    Raises
    ------
    FileNotFoundError
        If the file does not exist (naming it).
    ValueError
        Naming the file and what is wrong with it (one line); also a file
        whose z (!= 0 somewhere: spheres) contradicts its disks' history
        section.
    """
    path = os.fspath(path)
    lines = _lines(path)
    natoms, bounds, sections = _header(path, lines)
    atoms, per_atom, out_pair = None, {}, ""
    for s, (name, start) in enumerate(sections):
        end = sections[s + 1][1] if s + 1 < len(sections) else len(lines)
        body = [ln.split("#", 1)[0].split() for ln in lines[start + 1:end]]
        body = [w for w in body if w]
        if name.startswith(_PER_TYPE):
            if name.startswith(("Pair Coeffs", "PairIJ Coeffs")):
                out_pair = name.split("#", 1)[0].strip()
            continue
        if len(body) < natoms:
            raise ValueError(f"data file {path!r} is truncated: section {name.split()[0]!r} "
                             f"has {len(body)} of {natoms} atom lines")
        if name.split()[0] == "Atoms":
            atoms = (name, body[:natoms])
        else:
            per_atom[name.split()[0]] = body[:natoms]
    name, body = atoms
    rows = _atoms_values(path, body)
    style = name.split("#", 1)[1].strip() if "#" in name else "sphere"
    lo = np.array([bounds.get(ax, (math.nan, math.nan))[0] for ax in "xyz"])
    hi = np.array([bounds.get(ax, (math.nan, math.nan))[1] for ax in "xyz"])
    ids = np.array([int(r[0]) for r in rows], np.int64)
    order = np.argsort(ids, kind="stable")
    out = DataFile(path, natoms, lo, hi, style, ids[order],
                   np.array([int(r[1]) for r in rows], np.int64)[order])
    out.pair_coeffs = out_pair
    if style == "sphere" and natoms > 0 and all(len(r) >= 7 for r in rows):
        a = np.array([r[:7] for r in rows])
        out.dimension = 3 if np.any(a[:, 6] != 0.0) else 2
        disk_history = [nm.split()[0] for nm, _ in sections
                        if re.search(r"\bd_mindlin_t\b", nm.split("#", 1)[-1])]
        if out.dimension == 3 and disk_history:
            k = int(np.flatnonzero(a[:, 6] != 0.0)[0])
            raise ValueError(f"data file {path!r}: atom {body[k][0]} has z = {float(a[k, 6])!r}, "
                             f"but section {disk_history[0]!r} is the contact history of "
                             "disks (d_mindlin_t): a 2D file has z = 0 for every atom")
        if natoms > 1:
            _check_coincident(path, a[:, 4:4 + out.dimension], [w[0] for w in body])
        a = a[order]
        out.positions = a[:, 4:6].copy()
        out.z = a[:, 6].copy()
        out.radii = 0.5 * a[:, 2]
        out.masses = a[:, 3] * (4.0 / 3.0) * np.pi * out.radii ** 3
        if all(len(r) >= 10 for r in rows):
            out.images = np.array([r[7:10] for r in rows], np.int64)[order]
    if "topflag" in per_atom:
        flags = {int(w[0]): int(float(w[1])) for w in per_atom["topflag"]}
        out.top = np.array([flags.get(int(i), 0) > 0 for i in out.ids])
    return out
