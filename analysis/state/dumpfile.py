r"""The equilibrium dump and its sidecar: the one format contract of a state.

The driver writes every equilibrium as ``X.data`` (LAMMPS ``write_data``),
``X.dump`` and ``X.dump.json``; the analysis reads the last two. The dump is
a text ``dump custom`` written with ``format float %.17g`` and sorted by id
(docs/conventions.md section 3),

.. code-block:: text

    id type radius mass x y vx vy omegaz fx fy tqz v_fext_x v_fext_y
    i2_mindlin_partner[1..K] d2_mindlin_t[1..K] d_mindlin_wall_t

and the sidecar JSON ``<dump>.json`` holds the model parameters
``k_n, k_t, mu, wall_y, F_x, F_y, dt`` (:data:`PARAM_KEYS`) that a dump
cannot carry. :func:`read_dump` turns one snapshot into a
:class:`~remote_trigger.analysis.state.state.State` (contacts from the history
columns, :func:`~remote_trigger.analysis.state.state.build_state`);
:func:`write_sidecar` / :func:`load_sidecar` write and read the sidecar.

Spheres (docs/model.md section 9) have the columns of
:data:`REQUIRED_COLUMNS_3D` (the vectors in three columns, t in
``d2_mindlin_tx[1..K] d2_mindlin_ty[1..K] d2_mindlin_tz[1..K]``, the wall
contact's t in ``v_wall_tx v_wall_ty v_wall_tz``), the same sidecar, and are
read by :func:`read_dump3d` into a
:class:`~remote_trigger.analysis.state.state3d.State3D`;
:func:`dump_dimension` tells the two apart by the columns.
"""
from __future__ import annotations

import json
import math
import os

import numpy as np

from remote_trigger.analysis.errors import is_integer, is_real
from remote_trigger.analysis.state.contacts import PARTNER, XI
from remote_trigger.analysis.state.state import (
    DISC_INERTIA, ContactParams, build_state, check_options)

__all__ = ["read_dump", "read_dump3d", "read_equilibrium", "read_history3d", "dump_dimension", "load_sidecar", "write_sidecar",
           "PARAM_KEYS", "REQUIRED_COLUMNS", "REQUIRED_COLUMNS_3D"]

#: columns a dump must have (the history columns are checked separately)
REQUIRED_COLUMNS = ("id", "type", "radius", "mass", "x", "y", "fx", "fy", "tqz",
                    "v_fext_x", "v_fext_y", "d_mindlin_wall_t")
OPTIONAL_COLUMNS = ("vx", "vy", "omegaz")
#: columns of a dump of spheres (besides the history columns
#: ``i2_mindlin_partner[*] d2_mindlin_tx[*] d2_mindlin_ty[*] d2_mindlin_tz[*]``)
REQUIRED_COLUMNS_3D = ("id", "type", "radius", "mass", "x", "y", "z", "fx", "fy", "fz",
                       "tqx", "tqy", "tqz", "v_fext_x", "v_fext_y", "v_fext_z",
                       "v_wall_tx", "v_wall_ty", "v_wall_tz")
#: the per-component history columns of spheres
T3_COLUMNS = ("d2_mindlin_tx", "d2_mindlin_ty", "d2_mindlin_tz")
#: the model parameters of the sidecar JSON
PARAM_KEYS = ("k_n", "k_t", "mu", "wall_y", "F_x", "F_y", "dt")
#: the loadings of the top layer (the sidecar's optional key ``top_layer``):
#: ``'free'``, every top particle on its own (the paper's; absent key);
#: ``'rigid'``, spheres only: the layer translates as one body, a rigid plate
#: (``fix aveforce 0.0 0.0 0.0`` on ``top``; docs/model.md section 9.1)
TOP_LAYERS = ("free", "rigid")


#: leading bytes of binary files met where a dump is meant, and what to say
_BINARY_FORMATS = ((b"\x89HDF\r\n\x1a\n", "an HDF5 file: read it with h5py"),
                   (b"PK\x03\x04", "a zip archive, e.g. NumPy's .npz: read it with numpy.load"))


def _read_frames(path):
    """Yield (timestep, natoms, bounds, boxflags, columns, rows) of each snapshot."""
    try:
        with open(path, "r") as fh:
            lines = fh.read().splitlines()
    except UnicodeDecodeError:
        with open(path, "rb") as fh:
            head = fh.read(8)
        # (an .npz or .h5 of the project's own outputs was called compressed)
        what = next((w for magic, w in _BINARY_FORMATS if head.startswith(magic)),
                    "a compressed file? decompress it first")
        raise ValueError(f"{path}: not a text dump ({what})") from None
    k = 0
    nl = len(lines)
    frames = []
    while k < nl:
        if not lines[k].strip():
            k += 1
            continue
        if not lines[k].startswith("ITEM: TIMESTEP"):
            # a data file where a dump is meant (the header line "N atoms")
            data = any(ln.split()[1:2] == ["atoms"] and ln.split()[0].isdigit()
                       for ln in lines[:20] if ln.strip())
            hint = ("; this is a LAMMPS data file: give the dump written beside it "
                    "(equilibrium.dump for equilibrium.data)") if data else ""
            raise ValueError(f"{path}: line {k + 1}: expected 'ITEM: TIMESTEP', got "
                             f"{lines[k][:60]!r}{hint}")
        try:
            step = int(lines[k + 1].split()[0])
            if not lines[k + 2].startswith("ITEM: NUMBER OF ATOMS"):
                raise ValueError(f"line {k + 3}: expected 'ITEM: NUMBER OF ATOMS'")
            natoms = int(lines[k + 3].split()[0])
            head = lines[k + 4]
            if not head.startswith("ITEM: BOX BOUNDS"):
                raise ValueError(f"line {k + 5}: expected 'ITEM: BOX BOUNDS'")
            flags = head.split()[3:]
            if any(f in ("xy", "xz", "yz") for f in flags) or "abc" in head:
                raise ValueError(f"triclinic boxes are not supported: {head!r}")
            bounds = np.array([[float(v) for v in lines[k + 5 + a].split()[:2]]
                               for a in range(3)])
            cols_line = lines[k + 8]
            if not cols_line.startswith("ITEM: ATOMS"):
                raise ValueError(f"line {k + 9}: expected 'ITEM: ATOMS ...'")
        except IndexError:
            raise ValueError(f"{path}: truncated file: snapshot header at line {k + 1} is "
                             f"incomplete") from None
        except ValueError as exc:
            raise ValueError(f"{path}: malformed snapshot header near line {k + 1}: "
                             f"{exc}") from None
        columns = cols_line.split()[2:]
        body = lines[k + 9:k + 9 + natoms]
        if len(body) < natoms:
            raise ValueError(f"{path}: truncated file: snapshot at step {step} declares "
                             f"{natoms} atoms but has {len(body)} atom lines")
        frames.append((step, natoms, bounds, flags, columns, body, k + 10))
        k += 9 + natoms
    if not frames:
        raise ValueError(f"{path}: no snapshot found (empty file?)")
    return frames


def _parse_body(path, columns, body, first_line):
    ncol = len(columns)
    rows = []
    for m, line in enumerate(body):
        parts = line.split()
        if len(parts) != ncol:
            raise ValueError(f"{path}: line {first_line + m}: expected {ncol} values, got "
                             f"{len(parts)} (truncated or corrupt line)")
        rows.append(parts)
    try:
        data = np.array(rows, dtype=np.float64)
    except ValueError as exc:
        raise ValueError(f"{path}: non-numeric value in the atom lines: {exc}") from None
    return data.reshape(len(body), ncol)


def _frame(path, frame):
    """Snapshot ``frame`` of the dump at ``path`` as :func:`_read_frames` gives it.

    Raises FileNotFoundError if the file does not exist, ValueError if
    ``frame`` is not an integer (Python or numpy; bool refused) or the frame
    does not exist (the message names the number of snapshots).
    """
    if not is_integer(frame):
        # (frame = 1.0 was a raw "list indices must be integers")
        raise ValueError(f"frame must be an integer (Python indexing, -1 the last snapshot), "
                         f"got frame = {frame!r}")
    frame = int(frame)
    if not os.path.exists(path):
        raise FileNotFoundError(f"dump file not found: {os.fsdecode(path)}")
    frames = _read_frames(path)
    try:
        return frames[frame]
    except IndexError:
        raise ValueError(f"{path}: frame {frame} does not exist ({len(frames)} "
                         f"snapshots)") from None


def _history_columns(columns, prefix):
    """Indices of prefix[1..K] columns in order (or of the expanded prefix[*])."""
    found = {}
    for c, name in enumerate(columns):
        if name.startswith(prefix + "[") and name.endswith("]"):
            try:
                found[int(name[len(prefix) + 1:-1])] = c
            except ValueError:
                raise ValueError(f"unreadable history column name {name!r}") from None
    if not found:
        return None
    K = max(found)
    missing = [k for k in range(1, K + 1) if k not in found]
    if missing:
        raise ValueError(f"history columns {prefix}{missing} are missing (have "
                         f"{sorted(found)})")
    return [found[k] for k in range(1, K + 1)]


def _sphere_columns(columns):
    """The columns only a dump of spheres has (``z``, ``d2_mindlin_tx[*]``, ``fz`` ...)
    among ``columns``, as named in messages; empty for a dump of disks."""
    hist = [f"{name}[*]" for name in T3_COLUMNS
            if any(c.startswith(name + "[") for c in columns)]
    return ([c for c in ("z",) if c in columns] + hist
            + [c for c in ("fz", "tqx", "tqy", "v_fext_z") if c in columns])


def load_sidecar(path):
    """Read ``<dump>.json``; returns a dict (empty if the file does not exist).

    Raises
    ------
    ValueError
        If the JSON is unreadable, holds a key other than :data:`PARAM_KEYS`
        and ``top_layer`` (a misspelt key would silently fall back to a
        default), a value is not a number (or null for wall_y), or
        ``top_layer`` is not one of :data:`TOP_LAYERS`.
    """
    side = os.fsdecode(path) + ".json"
    if not os.path.exists(side):
        return {}
    try:
        with open(side) as fh:
            data = json.load(fh)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{side}: not valid JSON: {exc}") from None
    if not isinstance(data, dict):
        raise ValueError(f"{side}: expected a JSON object, got {type(data).__name__}")
    unknown = sorted(set(data) - set(PARAM_KEYS) - {"top_layer"})
    if unknown:
        raise ValueError(f"{side}: unknown key(s) {unknown}; the keys are "
                         f"{', '.join(PARAM_KEYS)} and top_layer")
    out = {}
    if "top_layer" in data:
        if data["top_layer"] not in TOP_LAYERS:
            raise ValueError(f"{side}: top_layer must be one of {', '.join(TOP_LAYERS)}, got "
                             f"{data['top_layer']!r}")
        out["top_layer"] = data["top_layer"]
    for key in PARAM_KEYS:
        if key in data:
            val = data[key]
            if val is None and key == "wall_y":
                out[key] = None
                continue
            if isinstance(val, bool) or not isinstance(val, (int, float)):
                raise ValueError(f"{side}: {key} must be a number, got {val!r}")
            out[key] = float(val)
    return out


def write_sidecar(path, values):
    """Write ``<dump>.json`` atomically: the model parameters of a dump.

    The writer of the format :func:`load_sidecar` reads (docs/conventions.md
    section 3); the driver writes every equilibrium's sidecar with it.

    Parameters
    ----------
    path : str
        The dump file (the sidecar is ``path + '.json'``).
    values : dict
        Exactly the keys ``PARAM_KEYS`` (``wall_y`` may be None: no wall);
        numbers are stored as float64 (JSON numbers, exact round trip).
        Optionally ``top_layer`` (one of :data:`TOP_LAYERS`), written only
        when it is not ``'free'``.

    Raises
    ------
    ValueError
        If a key is missing or unknown, a value is not a finite number, or
        ``top_layer`` is not one of :data:`TOP_LAYERS`.
    """
    from remote_trigger.analysis.output import write_json_atomic

    values = dict(values)
    layer = values.pop("top_layer", "free")
    if layer not in TOP_LAYERS:
        raise ValueError(f"sidecar of {path}: top_layer must be one of "
                         f"{', '.join(TOP_LAYERS)}, got {layer!r}")
    keys = set(values)
    if keys != set(PARAM_KEYS):
        raise ValueError(f"sidecar of {path}: keys must be {', '.join(PARAM_KEYS)}; missing "
                         f"{sorted(set(PARAM_KEYS) - keys)}, unknown {sorted(keys - set(PARAM_KEYS))}")
    out = {}
    for key in PARAM_KEYS:
        val = values[key]
        if val is None and key == "wall_y":
            out[key] = None
            continue
        if not is_real(val) \
                or not math.isfinite(float(val)):
            raise ValueError(f"sidecar of {path}: {key} must be a finite number, got {val!r}")
        out[key] = float(val)
    if layer != "free":
        out["top_layer"] = layer
    write_json_atomic(os.fspath(path) + ".json", out)


def _check_finite(path, data, columns, first):
    """Raise ValueError naming the first non-finite value of a snapshot's atom lines."""
    bad = ~np.isfinite(data)
    if np.any(bad):
        r, c = np.argwhere(bad)[0]
        raise ValueError(f"{path}: non-finite value {float(data[r, c])!r} in column "
                         f"{columns[c]!r} of atom line {r + 1} (line {first + r} of the file)")


def _model_parameters(path, no_wall, **given):
    """The model parameters of a dump: each given value, else the sidecar's.

    Returns ``{key: value}`` for :data:`PARAM_KEYS` (None where neither has
    one) and the sidecar's ``top_layer`` (``'free'`` if it has none). Raises
    ValueError if ``k_n``, ``k_t``, ``mu`` or (with a wall) ``wall_y`` is
    missing from both.
    """
    side = load_sidecar(path)
    par = {key: (given[key] if given[key] is not None else side.get(key)) for key in PARAM_KEYS}
    par["top_layer"] = side.get("top_layer", "free")
    lack = [key for key in ("k_n", "k_t", "mu") if par[key] is None]
    if par["wall_y"] is None and not no_wall:
        lack.append("wall_y")
    if lack:
        raise ValueError(f"{path}: model parameters {lack} are neither in the sidecar "
                         f"{path + '.json'} nor given explicitly")
    return par


def read_dump(path, frame=-1, *, k_n=None, k_t=None, mu=None, wall_y=None, F_x=None,
              F_y=None, dt=None, no_wall=False, mirror_rtol=1e-9, require_contacts=True,
              inertia_factor=DISC_INERTIA):
    """Read one snapshot of an equilibrium dump into a :class:`State`.

    Parameters
    ----------
    path : str or os.PathLike
        Text ``dump custom`` file (docs/conventions.md section 3).
    frame : int, optional
        Which snapshot, Python indexing (default the last one); a Python or
        numpy integer.
    k_n, k_t, mu, wall_y, F_x, F_y, dt : float, optional
        Model parameters; each overrides the sidecar ``<path>.json``. k_n, k_t,
        mu and wall_y are required from one of the two sources.
    no_wall : bool, optional
        Read a system without the flat wall (wall_y ignored, wall history must
        be zero).
    mirror_rtol : float, optional
        The two sides of a contact must satisfy
        ``|xi_ij - xi_ji| <= mirror_rtol * max(t*, |xi_ij|, T)``, T the
        largest t* of the snapshot's contacts; the default 1e-9 only absorbs
        round-off (periodic-image rounding; spheres: each side advances its
        own t).
        A finite number >= 0.
    require_contacts : bool, optional
        Raise if the packing has no contact at all (default True).
    inertia_factor : float, optional
        I0 in I = I0 m R^2 (default 1/2, ``fix nve/sphere ... disc``); a
        finite number > 0.

    Returns
    -------
    State

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        ``frame`` not an integer or not a snapshot of the file, ``mirror_rtol``
        negative or not finite, ``inertia_factor`` <= 0 or not finite (these
        three before the file is read); a dump of spheres (the message says
        to use ``read_dump3d``); truncated or malformed file, missing columns,
        NaN/inf values, ids not unique, non-positive radius or mass,
        overlapping centres, history naming an unknown atom, a contact listed
        on one side only or with mirror values that differ, missing
        parameters, or no contacts.
    """
    path = os.fsdecode(path)
    check_options(mirror_rtol=mirror_rtol, inertia_factor=inertia_factor)
    step, natoms, bounds, flags, columns, body, first = _frame(path, frame)
    missing = [c for c in REQUIRED_COLUMNS if c not in columns]
    pcols = _history_columns(columns, PARTNER)
    xcols = _history_columns(columns, XI)
    if pcols is None:
        missing.append(PARTNER + "[*]")
    if xcols is None:
        missing.append(XI + "[*]")
    spheres = _sphere_columns(columns)
    if missing and spheres:
        # (it said only "missing dump columns")
        raise ValueError(f"{path}: a dump of spheres (it has columns {', '.join(spheres[:2])}); "
                         f"read_dump reads disks: use read_dump3d, or read_equilibrium / "
                         f"analyze_dump, which choose by the columns")
    if missing:
        raise ValueError(f"{path}: missing dump columns {missing}; the analyzer needs "
                         f"'{' '.join(REQUIRED_COLUMNS[:-1])} {PARTNER}[*] {XI}[*] "
                         f"d_mindlin_wall_t' (docs/conventions.md section 3)")
    if len(pcols) != len(xcols):
        raise ValueError(f"{path}: {len(pcols)} {PARTNER} columns but {len(xcols)} {XI} "
                         f"columns")
    data = _parse_body(path, columns, body, first)
    if natoms == 0:
        raise ValueError(f"{path}: the snapshot has no atoms")
    col = {name: c for c, name in enumerate(columns)}
    _check_finite(path, data, columns, first)

    ids_f = data[:, col["id"]]
    ids = ids_f.astype(np.int64)
    if np.any(ids != ids_f) or np.any(ids <= 0):
        raise ValueError(f"{path}: atom ids must be positive integers")
    order = np.argsort(ids, kind="stable")
    data = data[order]
    ids = ids[order]
    if np.any(np.diff(ids) == 0):
        dup = ids[np.nonzero(np.diff(ids) == 0)[0][0]]
        raise ValueError(f"{path}: atom id {dup} appears twice")

    par = _model_parameters(path, no_wall, k_n=k_n, k_t=k_t, mu=mu, wall_y=wall_y, F_x=F_x,
                            F_y=F_y, dt=dt)
    params = ContactParams(par["k_n"], par["k_t"], par["mu"])

    lo = bounds[:2, 0].copy()
    hi = bounds[:2, 1].copy()
    periodic = tuple(len(flags) > a and flags[a] == "pp" for a in range(2))
    if np.any(hi <= lo):
        raise ValueError(f"{path}: box bounds must satisfy lo < hi, got {bounds[:2].tolist()}")

    partners = data[:, pcols]
    xis = data[:, xcols]
    wall_t = data[:, col["d_mindlin_wall_t"]]
    extras = {}
    for name in OPTIONAL_COLUMNS:
        extras[name] = data[:, col[name]] if name in col else None
    vel = (np.column_stack([extras["vx"], extras["vy"]])
           if extras["vx"] is not None and extras["vy"] is not None else None)
    return build_state(
        ids=ids, positions=data[:, [col["x"], col["y"]]], radii=data[:, col["radius"]],
        masses=data[:, col["mass"]], box_lo=lo, box_hi=hi, periodic=periodic, params=params,
        wall_y=None if no_wall else float(par["wall_y"]),
        partners=partners, partner_xi=xis, wall_t=wall_t,
        external=data[:, [col["v_fext_x"], col["v_fext_y"]]],
        contact_forces=data[:, [col["fx"], col["fy"], col["tqz"]]],
        velocities=vel, omega=extras["omegaz"], types=data[:, col["type"]].astype(np.int64),
        F_x=par["F_x"], F_y=par["F_y"], dt=par["dt"], timestep=step, source=path,
        mirror_rtol=mirror_rtol, require_contacts=require_contacts,
        inertia_factor=inertia_factor)


def dump_dimension(path, frame=-1):
    """2 for a dump of disks, 3 for one of spheres (it has ``z`` and ``d2_mindlin_tx[1]``).

    Raises
    ------
    FileNotFoundError, ValueError
        A missing or malformed file, or ``frame`` not an integer or not a
        snapshot of the file.
    """
    columns = _frame(os.fsdecode(path), frame)[4]
    return 3 if "z" in columns and _history_columns(columns, T3_COLUMNS[0]) else 2


def read_equilibrium(path, frame=-1):
    """A dump of disks (:func:`read_dump`, contacts not required) or of spheres
    (:func:`read_dump3d`), by :func:`dump_dimension`.

    Returns
    -------
    State or State3D
    """
    if dump_dimension(path, frame) == 3:
        return read_dump3d(path, frame)
    return read_dump(path, frame, require_contacts=False)


def read_dump3d(path, frame=-1, *, k_n=None, k_t=None, mu=None, wall_y=None, F_x=None,
                F_y=None, dt=None, no_wall=False, mirror_rtol=1e-9, require_contacts=False,
                inertia_factor=None):
    """Read one snapshot of an equilibrium dump of spheres into a :class:`State3D`.

    The 3D counterpart of :func:`read_dump`: the same file layout and sidecar,
    the columns of :data:`REQUIRED_COLUMNS_3D` and the history columns; the
    contacts are the overlapping pairs with the history's t
    (:func:`~remote_trigger.analysis.state.state3d.state3d_from_history`), the
    wall the plane y = wall_y. Periodic axes from the box flags (``pp``).

    Parameters
    ----------
    path : str or os.PathLike
    frame : int, optional
        Which snapshot, Python indexing (default the last one); a Python or
        numpy integer.
    k_n, k_t, mu, wall_y, F_x, F_y, dt : float, optional
        Override the sidecar's values; k_n, k_t, mu and wall_y are required
        from one of the two.
    no_wall : bool, optional
        No floor (its history columns must then be zero).
    mirror_rtol : float, optional
        Tolerance of the check t_ji = -t_ij, a finite number >= 0.
    require_contacts : bool, optional
        Raise if the packing has no contact at all (no pair, no wall contact);
        default False.
    inertia_factor : float, optional
        I0 in I = I0 m R^2, a finite number > 0; default (None) 2/5, the solid
        sphere (``fix nve/sphere``).

    Returns
    -------
    State3D
        Masses from the dump, I = I0 m R^2; ``F_x``, ``F_y``, ``source`` set;
        ``rigid_layer`` the loaded spheres (v_fext_y != 0) when the sidecar
        says ``top_layer = 'rigid'``, else None.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        ``frame`` not an integer or not a snapshot of the file, ``mirror_rtol``
        negative or not finite; a dump of disks (the message says to use
        ``read_dump``); truncated or malformed file, missing columns (named),
        non-finite values, duplicate ids, bad history, missing parameters;
        ``inertia_factor`` not a finite number > 0; no contact with
        ``require_contacts``.
    """
    from remote_trigger.analysis.state.state3d import SPHERE_INERTIA, state3d_from_history

    path = os.fsdecode(path)
    if inertia_factor is None:
        inertia_factor = SPHERE_INERTIA
    check_options(mirror_rtol=mirror_rtol, inertia_factor=inertia_factor)
    step, natoms, bounds, flags, columns, body, first = _frame(path, frame)
    missing = [c for c in REQUIRED_COLUMNS_3D if c not in columns]
    hist = {name: _history_columns(columns, name) for name in (PARTNER,) + T3_COLUMNS}
    missing += [f"{name}[*]" for name, cols in hist.items() if cols is None]
    if missing and not _sphere_columns(columns) and (
            "d_mindlin_wall_t" in columns or _history_columns(columns, XI)):
        raise ValueError(f"{path}: a dump of disks (no z column); read_dump3d reads spheres: "
                         f"use read_dump, or read_equilibrium / analyze_dump, which choose "
                         f"by the columns")
    if missing:
        raise ValueError(f"{path}: missing dump columns {missing} of a dump of spheres "
                         f"(docs/conventions.md section 3)")
    if len({len(c) for c in hist.values()}) != 1:
        raise ValueError(f"{path}: the history columns differ in number: "
                         f"{ {k: len(v) for k, v in hist.items()} }")
    if natoms == 0:
        raise ValueError(f"{path}: the snapshot has no atoms")
    data = _parse_body(path, columns, body, first)
    _check_finite(path, data, columns, first)
    col = {name: c for c, name in enumerate(columns)}
    ids_f = data[:, col["id"]]
    ids = ids_f.astype(np.int64)
    if np.any(ids != ids_f) or np.any(ids <= 0):
        raise ValueError(f"{path}: atom ids must be positive integers")
    if np.unique(ids).size != ids.size:
        raise ValueError(f"{path}: an atom id appears twice")
    par = _model_parameters(path, no_wall, k_n=k_n, k_t=k_t, mu=mu, wall_y=wall_y, F_x=F_x,
                            F_y=F_y, dt=dt)
    wall_t = data[:, [col["v_wall_tx"], col["v_wall_ty"], col["v_wall_tz"]]]
    if no_wall and np.any(wall_t != 0.0):
        raise ValueError(f"{path}: wall history is nonzero but no wall is given")
    part = data[:, hist[PARTNER]]
    t = np.stack([data[:, hist[name]] for name in T3_COLUMNS], axis=-1)
    state = state3d_from_history(
        ids=ids, positions=data[:, [col["x"], col["y"], col["z"]]],
        radii=data[:, col["radius"]], masses=data[:, col["mass"]],
        box_lo=bounds[:, 0], box_hi=bounds[:, 1],
        params=ContactParams(par["k_n"], par["k_t"], par["mu"]),
        periodic=tuple(len(flags) > a and flags[a] == "pp" for a in range(3)),
        partners=part, partner_t=t, wall_y=None if no_wall else float(par["wall_y"]),
        wall_t=wall_t,
        external=data[:, [col["v_fext_x"], col["v_fext_y"], col["v_fext_z"]]],
        mirror_rtol=mirror_rtol, inertia_factor=inertia_factor, F_x=par["F_x"],
        F_y=par["F_y"], source=path, rigid_layer=_rigid_layer(path, par["top_layer"], data, col))
    if require_contacts and state.contact_i.size == 0 and state.wall_index.size == 0:
        raise ValueError(f"{path}: the packing has no contact (no overlapping pair, no "
                         f"sphere on the wall)")
    return state


def _rigid_layer(path, top_layer, data, col):
    """The mask of the rigid top layer (the loaded spheres) if the sidecar's
    ``top_layer`` is 'rigid', else None."""
    if top_layer != "rigid":
        return None
    top = data[:, col["v_fext_y"]] != 0.0
    if np.count_nonzero(top) < 2:
        raise ValueError(f"{path}: the sidecar says top_layer = 'rigid' but "
                         f"{np.count_nonzero(top)} sphere(s) carry a load (v_fext_y != 0)")
    return top


def read_history3d(path, frame=-1):
    """The contact history of a dump of spheres, exactly as written, by atom id.

    What a driver needs to put a saved equilibrium back into LAMMPS (the
    data file of spheres has no history; docs/driver.md "Spheres"): the
    pair's partner table and t, and the wall's stored t, unchanged (no
    contact search, no projection).

    Returns
    -------
    dict
        ``ids`` (N,) int64 ascending, ``partner`` (N, K) int64, ``t`` (N, K, 3),
        ``wall_t`` (N, 3).

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        Not a dump of spheres, malformed, or non-finite values (named).
    """
    path = os.fsdecode(path)
    _, _, _, _, columns, body, first = _frame(path, frame)
    hist = {name: _history_columns(columns, name) for name in (PARTNER,) + T3_COLUMNS}
    wall = ("v_wall_tx", "v_wall_ty", "v_wall_tz")
    missing = [f"{k}[*]" for k, v in hist.items() if v is None]
    missing += [c for c in ("id",) + wall if c not in columns]
    if missing:
        raise ValueError(f"{path}: missing dump columns {missing} of a dump of spheres")
    if len({len(c) for c in hist.values()}) != 1:
        raise ValueError(f"{path}: the history columns differ in number")
    data = _parse_body(path, columns, body, first)
    if not np.all(np.isfinite(data)):
        raise ValueError(f"{path}: non-finite value in the atom lines")
    order = np.argsort(data[:, columns.index("id")], kind="stable")
    data = data[order]
    return {"ids": data[:, columns.index("id")].astype(np.int64),
            "partner": data[:, hist[PARTNER]].astype(np.int64),
            "t": np.stack([data[:, hist[name]] for name in T3_COLUMNS], axis=-1),
            "wall_t": data[:, [columns.index(c) for c in wall]]}
