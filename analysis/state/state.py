r"""Equilibrium states in float64: the :class:`State` and how it is built.

A :class:`State` holds everything the Jacobian needs: disk ids, positions,
radii, masses and moments of inertia, the periodic box, every disk-disk
contact with its signed tangential displacement :math:`\xi_{ij}` and every
disk-wall contact with its :math:`\xi_{iw}` and overlap, plus the external
loads. :func:`build_state` makes one from arrays (the driver's gathered
LAMMPS state, or a dump read by :func:`remote_trigger.analysis.state.dumpfile.read_dump`,
which also holds the dump + sidecar format).

Contacts come from the history (read by
:mod:`remote_trigger.analysis.state.contacts`): atom i lists partner ids in
``i2_mindlin_partner`` and the matching :math:`\xi` (seen from i) in
``d2_mindlin_t``. Each contact is listed on both sides with the same value
(:math:`\xi_{ji} = \xi_{ij}` because :math:`s_{ji} = -s_{ij}`); the builder keeps
the side with the smaller id and checks that the mirror matches.

.. warning::

   The history and the geometry must describe the same instant, which is the
   case for a dump written after a time step (the pair style updates the
   history at every step). A pair that overlaps but has no history entry is
   kept with :math:`\xi = 0` (a contact that forms starts from zero), and a
   history entry whose disks no longer overlap is dropped; both are counted in
   :attr:`State.notes` and reported with a :class:`UserWarning` -- except
   inside the touching band
   (:func:`~remote_trigger.analysis.state.contacts.touch_band`,
   |delta| <= ~1e-12), where
   the pair style lists a pair as its history says: those are counted as
   ``touching_pairs`` without a warning.
"""
# The State (its fields documented, ~150 lines) and its one builder with the
# checks that keep history and geometry consistent; the geometric and recorded
# contacts it merges are found in analysis.state.contacts, the file format is
# in analysis.state.dumpfile.
from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from remote_trigger.analysis.errors import is_real
from remote_trigger.analysis.state.contacts import (
    find_contacts, history_pairs, minimum_image, touch_band, wall_contacts)

__all__ = ["ContactParams", "State", "build_state"]

#: disks of the same moment-of-inertia convention as ``fix nve/sphere ... disc``
DISC_INERTIA = 0.5


@dataclass(frozen=True)
class ContactParams:
    """Contact-law parameters shared by the pair style and the wall.

    Attributes
    ----------
    k_n : float
        Normal stiffness, force/length^{3/2} (Eq. 1), > 0.
    k_t : float
        Tangential stiffness, force/length^{3/2} (Eq. 3), >= 0.
    mu : float
        Coulomb friction coefficient (Eq. 2), >= 0.
    """

    k_n: float
    k_t: float
    mu: float

    def __post_init__(self):
        for name, lo, strict in (("k_n", 0.0, True), ("k_t", 0.0, False), ("mu", 0.0, False)):
            val = getattr(self, name)
            if (not is_real(val)
                    or not np.isfinite(val)):
                raise ValueError(f"contact parameter {name} must be a finite number, got {val!r}")
            if (strict and val <= lo) or (not strict and val < lo):
                raise ValueError(f"contact parameter {name} must be {'>' if strict else '>='} "
                                 f"{lo}, got {val!r}")
            object.__setattr__(self, name, float(val))

    @property
    def frictional(self):
        """True when tangential forces exist (k_t > 0 and mu > 0)."""
        return self.k_t > 0.0 and self.mu > 0.0


@dataclass
class State:
    """A packing of disks with its contact history, in float64.

    Disks are stored in ascending atom id; "index" below means the position
    in that order (0-based), which is also the disk's block in the generalized
    coordinates q = (x_k, y_k, R_k theta_k), dof 3k + c (docs/model.md section 7).

    Attributes
    ----------
    ids : ndarray of int64, shape (N,)
        Atom ids, strictly ascending.
    positions : ndarray, shape (N, 2)
        Centres (x, y), length units.
    radii, masses : ndarray, shape (N,)
        Radius (length) and mass (mass units), > 0.
    inertia : ndarray, shape (N,)
        Moment of inertia I = I0 m R^2 with I0 = 1/2 (solid disk, docs/model.md
        section 1).
    box_lo, box_hi : ndarray, shape (2,)
        Box bounds in x and y.
    periodic : tuple of bool
        Periodicity in (x, y); the model has (True, False).
    params : ContactParams
        k_n, k_t, mu of the pair style and the wall.
    wall_y : float or None
        Height of the flat wall (``yplane``); None means no wall.
    contact_i, contact_j : ndarray of int64, shape (C,)
        Disk indices of each disk-disk contact, ``ids[contact_i] < ids[contact_j]``.
    contact_xi : ndarray, shape (C,)
        Signed tangential displacement xi_ij (length), t_ij = xi_ij s with
        s = (n_y, -n_x), n = (r_i - r_j)/|r_i - r_j| (Eq. 14).
    wall_index : ndarray of int64, shape (W,)
        Disks touching the wall.
    wall_xi, wall_delta : ndarray, shape (W,)
        Tangential displacement (along +x) and overlap R - (y - wall_y) > 0.
    external : ndarray, shape (N, 2)
        External load on each disk (force units); F_x, -F_y on ``top``.
    contact_forces : ndarray, shape (N, 3) or None
        (fx, fy, tqz) of the dump: pair plus wall forces and torque.
    velocities : ndarray, shape (N, 2) or None
    omega : ndarray, shape (N,) or None
    types : ndarray of int64, shape (N,)
    F_x, F_y, dt : float or None
        Loads and time step from the sidecar, informational.
    timestep : int or None
        LAMMPS step of the snapshot.
    source : str or None
        File read.
    notes : dict
        Counts of repaired inconsistencies (``unrecorded_contacts``,
        ``stale_history``, ``stale_wall_history``) and of pairs inside the
        touching band whose listing the history decides (``touching_pairs``).
    """

    ids: np.ndarray
    positions: np.ndarray
    radii: np.ndarray
    masses: np.ndarray
    inertia: np.ndarray
    box_lo: np.ndarray
    box_hi: np.ndarray
    periodic: tuple
    params: ContactParams
    wall_y: float | None
    contact_i: np.ndarray
    contact_j: np.ndarray
    contact_xi: np.ndarray
    wall_index: np.ndarray
    wall_xi: np.ndarray
    wall_delta: np.ndarray
    external: np.ndarray
    contact_forces: np.ndarray | None = None
    velocities: np.ndarray | None = None
    omega: np.ndarray | None = None
    types: np.ndarray | None = None
    F_x: float | None = None
    F_y: float | None = None
    dt: float | None = None
    timestep: int | None = None
    source: str | None = None
    notes: dict = field(default_factory=dict)

    @property
    def n(self):
        """Number of disks N."""
        return int(self.ids.size)

    @property
    def ndof(self):
        """Number of generalized coordinates, 3N."""
        return 3 * self.n

    @property
    def n_contacts(self):
        """Number of disk-disk contacts C."""
        return int(self.contact_i.size)

    @property
    def box_length(self):
        """Box lengths (L_x, L_y), shape (2,)."""
        return self.box_hi - self.box_lo

    def mass_diagonal(self):
        """Diagonal of the mass matrix M = diag(m, m, I/R^2) per disk, shape (3N,).

        The third entry is the mass of phi = R theta: I theta'' = T gives
        (I/R^2) phi'' = T/R (paper Eq. 42).
        """
        md = np.empty(self.ndof)
        md[0::3] = self.masses
        md[1::3] = self.masses
        md[2::3] = self.inertia / self.radii**2
        return md

    def dof_ids(self):
        """Atom id of every degree of freedom (x, y, R theta per disk), shape (3N,)."""
        return np.repeat(self.ids, 3)

    def contact_counts(self):
        """Number of contacts of every disk, wall included, shape (N,)."""
        z = np.bincount(self.contact_i, minlength=self.n) + np.bincount(self.contact_j,
                                                                         minlength=self.n)
        return z + np.bincount(self.wall_index, minlength=self.n)

    def separation(self, i, j):
        """Minimum-image r_i - r_j for index arrays i, j; shape (len(i), 2)."""
        return minimum_image(self.positions[i] - self.positions[j], self.box_length,
                             self.periodic)

    def with_xi(self, contact_xi=None, wall_xi=None):
        """Copy with other tangential displacements (same contacts).

        Parameters
        ----------
        contact_xi : array_like, shape (C,), optional
        wall_xi : array_like, shape (W,), optional

        Returns
        -------
        State
        """
        import dataclasses

        cx = self.contact_xi if contact_xi is None else np.asarray(contact_xi, np.float64)
        wx = self.wall_xi if wall_xi is None else np.asarray(wall_xi, np.float64)
        if cx.shape != self.contact_xi.shape or wx.shape != self.wall_xi.shape:
            raise ValueError(f"xi arrays must have shapes {self.contact_xi.shape} and "
                             f"{self.wall_xi.shape}, got {cx.shape} and {wx.shape}")
        return dataclasses.replace(self, contact_xi=cx.copy(), wall_xi=wx.copy())


def check_options(mirror_rtol=None, inertia_factor=None):
    """A finite ``mirror_rtol`` >= 0 and a finite ``inertia_factor`` > 0 (None: unchecked).

    Raises
    ------
    ValueError
        Naming the argument and its value.
    """
    for name, val, strict in (("mirror_rtol", mirror_rtol, False),
                              ("inertia_factor", inertia_factor, True)):
        if val is None:
            continue
        ok = (not isinstance(val, (bool, np.bool_))
              and isinstance(val, (int, float, np.integer, np.floating)) and np.isfinite(val)
              and (val > 0 if strict else val >= 0))
        if not ok:
            # (a negative mirror_rtol was reported as a history disagreement; an
            # inertia_factor <= 0 gave a state that failed later, in analyze)
            raise ValueError(f"{name} must be a finite number {'>' if strict else '>='} 0, "
                             f"got {name} = {val!r}")


def atom_ids(ids, name="ids"):
    """Atom ids as int64, shape (N,); integer-valued floats are taken.

    Raises
    ------
    ValueError
        Not 1-D, or a value that is not a positive integer (named with its
        index; a float id was truncated before).
    """
    a = np.asarray(ids)
    if a.ndim != 1:
        raise ValueError(f"{name} must have shape (N,), got shape {a.shape}")
    if a.dtype.kind == "f":
        bad = np.flatnonzero(~np.isfinite(a) | (a != np.round(a)))
        if bad.size:
            raise ValueError(f"{name} must be integers, got {float(a[bad[0]])!r} at index "
                             f"{int(bad[0])}")
    elif a.size and a.dtype.kind not in "iu":
        raise ValueError(f"{name} must be integers, got dtype {a.dtype}")
    if np.any(a <= 0):
        # (0 marks an empty history slot, as in LAMMPS, where ids are >= 1)
        k = int(np.argmax(a <= 0))
        raise ValueError(f"{name} must be positive integers (LAMMPS atom ids), got "
                         f"{int(a[k])} at index {k}")
    return a.astype(np.int64)


def shaped(name, a, shape, label, dtype=np.float64):
    """``a`` as an array of exactly ``shape``; ValueError naming ``name``, ``label``
    (the shape in symbols, e.g. ``(N, 2)``) and the shape given."""
    try:
        arr = np.asarray(a, dtype)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be an array of numbers of shape {label}, got "
                         f"{type(a).__name__}") from None
    if arr.shape != tuple(shape):
        # (it was numpy's "cannot reshape array of size ...")
        raise ValueError(f"{name} must have shape {label} = {tuple(shape)}, got shape "
                         f"{arr.shape}")
    return arr


def history_array(name, a, n, k=None):
    """A history array of shape (N, K) (an (N,) array is one slot); with ``k``
    (the slots of ``partners``) K must be k. ValueError naming ``name`` and the
    shapes expected and given."""
    try:
        arr = np.asarray(a, np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be an array of numbers of shape (N, K), got "
                         f"{type(a).__name__}") from None
    given = arr.shape
    if arr.shape == (n,):
        arr = arr.reshape(n, 1)
    if arr.ndim != 2 or arr.shape[0] != n or (k is not None and arr.shape[1] != k):
        want = f"(N, K) = ({n}, {'K' if k is None else k})" + ("" if k is None else
                                                             ", that of partners")
        raise ValueError(f"{name} must have shape {want}, got shape {given}")
    return arr


def box_bounds(box_lo, box_hi, dim, periodic):
    """(box_lo, box_hi) as float64 arrays of ``dim`` values and the periodic flags.

    In 2D a third (z) bound is accepted and dropped (LAMMPS' box has three).

    Raises
    ------
    ValueError
        Wrong lengths, non-finite bounds, hi <= lo, or ``periodic`` not of
        ``dim`` flags.
    """
    axes = "x, y; a z bound is ignored" if dim == 2 else "x, y, z"
    out = []
    for name, b in (("box_lo", box_lo), ("box_hi", box_hi)):
        try:
            b = np.asarray(b, np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"{name} must be {dim} numbers, got {type(b).__name__}") from None
        if b.ndim != 1 or b.size not in ((2, 3) if dim == 2 else (3,)):
            raise ValueError(f"{name} must have {dim} values ({axes}), got shape {b.shape}")
        if not np.all(np.isfinite(b)):
            raise ValueError(f"{name} must be finite, got {b.tolist()}")
        out.append(b[:dim].copy())
    if np.any(out[1] <= out[0]):
        raise ValueError(f"the box must have box_hi > box_lo on every axis, got box_lo = "
                         f"{out[0].tolist()}, box_hi = {out[1].tolist()}")
    if isinstance(periodic, (str, bytes)):
        # (a string's characters were read as flags: "TF" was (True, True))
        raise ValueError(f"periodic must be {dim} flags (booleans), got {periodic!r}")
    try:
        per = tuple(bool(p) for p in periodic)
    except TypeError:
        raise ValueError(f"periodic must be {dim} flags, got {periodic!r}") from None
    if len(per) != dim:
        raise ValueError(f"periodic must be {dim} flags ({'x, y' if dim == 2 else 'x, y, z'}), "
                         f"got {len(per)}: {periodic!r}")
    return out[0], out[1], per


def _check_params(params, wall_y):
    if not isinstance(params, ContactParams):
        raise ValueError(f"params must be a ContactParams, got {type(params).__name__}")
    if wall_y is not None and (not is_real(wall_y) or not np.isfinite(wall_y)):
        raise ValueError(f"wall_y must be a finite number or None, got {wall_y!r}")


def _check_atoms(ids, pos, radii, masses):
    """Finite positions, radii > 0, masses > 0, unique ids; returns the id order.

    Raises
    ------
    ValueError
        Naming the atom id and the bad value.
    """
    for name, arr in (("positions", pos), ("radius", radii), ("mass", masses)):
        if not np.all(np.isfinite(arr)):
            k = int(np.argwhere(~np.isfinite(arr))[0][0])
            raise ValueError(f"{name} of atom id {ids[k]} is not finite: {float(arr[k])!r}")
    if np.any(radii <= 0):
        k = int(np.argmax(radii <= 0))
        raise ValueError(f"radius of atom id {ids[k]} must be > 0, got {float(radii[k])!r}")
    if np.any(masses <= 0):
        k = int(np.argmax(masses <= 0))
        raise ValueError(f"mass of atom id {ids[k]} must be > 0, got {float(masses[k])!r}")
    order = np.argsort(ids, kind="stable")
    if np.any(np.diff(ids[order]) == 0):
        raise ValueError(f"atom id {ids[order][np.argmax(np.diff(ids[order]) == 0)]} "
                         f"appears twice")
    return order


def build_state(*, ids, positions, radii, masses, box_lo, box_hi, params, wall_y,
                partners=None, partner_xi=None, wall_t=None, periodic=(True, False),
                external=None, contact_forces=None, velocities=None, omega=None, types=None,
                F_x=None, F_y=None, dt=None, timestep=None, source=None, mirror_rtol=1e-9,
                require_contacts=True, inertia_factor=DISC_INERTIA):
    """Build a :class:`State` from per-atom arrays in the dump's layout.

    Parameters
    ----------
    ids : array_like of int, shape (N,)
        Atom ids (any order; the state is sorted by id); integer-valued
        floats are taken.
    positions : array_like, shape (N, 2)
    radii, masses : array_like, shape (N,)
    box_lo, box_hi : array_like, shape (2,)
        Finite, box_hi > box_lo; a third (z) value, as LAMMPS gives the box,
        is ignored.
    params : ContactParams
    wall_y : float or None
    partners : array_like of int, shape (N, K), optional
        ``i2_mindlin_partner``: partner ids, 0 for empty slots (shape (N,):
        one slot). None means no history at all (every geometric contact
        gets xi = 0).
    partner_xi : array_like, shape (N, K), optional
        ``d2_mindlin_t``, the shape of ``partners``; required with it.
    wall_t : array_like, shape (N,), optional
        ``d_mindlin_wall_t``.
    periodic : sequence of 2 bool
        Periodicity in (x, y).
    external : array_like, shape (N, 2), optional
        External loads (zero if None).
    mirror_rtol : float
        Tolerance of the mirror check (see
        :func:`~remote_trigger.analysis.state.dumpfile.read_dump`), finite, >= 0.
    require_contacts : bool
    inertia_factor : float
        I0 in I = I0 m R^2, finite, > 0.

    Other parameters are stored as given (see :class:`State`).

    Returns
    -------
    State

    Raises
    ------
    ValueError
        ``mirror_rtol`` < 0 or ``inertia_factor`` <= 0 (or either not
        finite); an array of another shape than the one above (named, with
        the shapes expected and given; also ``contact_forces`` (N, 3),
        ``velocities`` (N, 2), ``omega`` and ``types`` (N,)); ids that are
        not integers; ``periodic`` not of 2 flags; a box of the wrong length,
        not finite or with box_hi <= box_lo; ``partners`` without
        ``partner_xi``; otherwise see
        :func:`~remote_trigger.analysis.state.dumpfile.read_dump`.
    """
    check_options(mirror_rtol=mirror_rtol, inertia_factor=inertia_factor)
    ids = atom_ids(ids)
    n = ids.size
    pos = shaped("positions", positions, (n, 2), "(N, 2)")
    radii = shaped("radii", radii, (n,), "(N,)")
    masses = shaped("masses", masses, (n,), "(N,)")
    _check_params(params, wall_y)
    order = _check_atoms(ids, pos, radii, masses)
    box_lo, box_hi, periodic = box_bounds(box_lo, box_hi, 2, periodic)

    def srt(a, name, shape, label, dtype=np.float64, finite=False):
        if a is None:
            return None
        a = shaped(name, a, shape, label, dtype)
        if finite and not np.all(np.isfinite(a)):
            # (a NaN load gave a NaN residual and a verdict on it)
            raise ValueError(f"{name} must be finite, got {int(np.sum(~np.isfinite(a)))} "
                             f"non-finite value(s)")
        return a[order].copy()

    ids = ids[order]
    pos, radii, masses = pos[order].copy(), radii[order].copy(), masses[order].copy()
    external = (np.zeros((n, 2)) if external is None
                else srt(external, "external", (n, 2), "(N, 2)", finite=True))
    L = box_hi - box_lo

    gi, gj, rho = find_contacts(pos, radii, box_lo, box_hi, periodic, ids=ids)
    notes = {"unrecorded_contacts": 0, "stale_history": 0, "stale_wall_history": 0,
             "touching_pairs": 0}

    # ---- disk-disk history -> (i, j, xi) with the mirror check
    if partners is not None:
        if partner_xi is None:
            raise ValueError("partners needs partner_xi (the tangential displacement of "
                             "each partner), got partner_xi = None")
        P = history_array("partners", partners, n)[order].copy()
        X = srt(history_array("partner_xi", partner_xi, n, P.shape[1]), "partner_xi", P.shape,
                "(N, K)", finite=True)
        hi_, hj, hxi, hdelta = history_pairs(P, X, ids, pos, radii, L, periodic, params,
                                              mirror_rtol)
    else:
        hi_ = hj = np.zeros(0, np.int64)
        hxi = hdelta = np.zeros(0)

    # ---- merge with the geometric contacts
    gkeys = gi * n + gj
    hkeys = hi_ * n + hj
    in_geo = np.isin(hkeys, gkeys)
    # inside the touching band the pair style lists a pair or not as its
    # history says (touch_band): history without overlap and overlap without
    # history are then neither stale nor unrecorded
    touching = ~in_geo & (hdelta >= -touch_band(box_lo, box_hi, radii[hi_] + radii[hj]))
    stale = int((~in_geo & ~touching).sum())
    unrec = ~np.isin(gkeys, hkeys)
    grs = radii[gi] + radii[gj]
    unrec_touching = unrec & (grs - rho <= touch_band(box_lo, box_hi, grs))
    notes["touching_pairs"] = (int(touching.sum()) + int(unrec_touching.sum())
                               if partners is not None else 0)
    notes["stale_history"] = stale
    notes["unrecorded_contacts"] = (int((unrec & ~unrec_touching).sum())
                                    if partners is not None else 0)
    ci = np.concatenate([hi_[in_geo], gi[unrec]])
    cj = np.concatenate([hj[in_geo], gj[unrec]])
    cxi = np.concatenate([hxi[in_geo], np.zeros(int(unrec.sum()))])
    srt_c = np.lexsort((cj, ci))
    ci, cj, cxi = ci[srt_c], cj[srt_c], cxi[srt_c]

    # ---- wall
    wt = (None if (wall_t is None or wall_y is None)
          else srt(wall_t, "wall_t", (n,), "(N,)", finite=True))
    widx, wxi, wdelta, notes["stale_wall_history"] = wall_contacts(ids, pos, radii, wall_y,
                                                                     wt, wall_t)

    if partners is not None and (notes["stale_history"] or notes["unrecorded_contacts"]
                                 or notes["stale_wall_history"]):
        warnings.warn(f"{source or 'state'}: history and geometry disagree: "
                      f"{notes['unrecorded_contacts']} overlapping pairs without history "
                      f"(kept with xi = 0), {notes['stale_history']} history entries without "
                      f"overlap and {notes['stale_wall_history']} stale wall entries "
                      f"(dropped)", UserWarning, stacklevel=3)

    if require_contacts and ci.size == 0 and widx.size == 0:
        raise ValueError(f"{source or 'state'}: no contacts: none of the {n} disks overlaps "
                         f"another disk or the wall, so there is no stiffness to analyse")

    return State(
        ids=ids, positions=pos, radii=radii, masses=masses,
        inertia=float(inertia_factor) * masses * radii**2, box_lo=box_lo, box_hi=box_hi,
        periodic=periodic, params=params, wall_y=None if wall_y is None else float(wall_y),
        contact_i=ci.astype(np.int64), contact_j=cj.astype(np.int64),
        contact_xi=cxi.astype(np.float64), wall_index=widx, wall_xi=wxi.astype(np.float64),
        wall_delta=wdelta.astype(np.float64), external=external,
        contact_forces=srt(contact_forces, "contact_forces", (n, 3), "(N, 3)"),
        velocities=srt(velocities, "velocities", (n, 2), "(N, 2)"),
        omega=srt(omega, "omega", (n,), "(N,)"),
        types=srt(types, "types", (n,), "(N,)", np.int64), F_x=F_x, F_y=F_y, dt=dt,
        timestep=timestep, source=source, notes=notes)
