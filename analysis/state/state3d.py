r"""A packing of spheres with its contact history, in float64 (3D).

The three-dimensional counterpart of :class:`~remote_trigger.analysis.state.state.State`
for the 3D law of the pair style (docs/model.md section 9): sphere ids,
positions, radii, masses and moments of inertia, the box with its periodic
axes, every sphere-sphere contact with its tangential displacement **vector**
:math:`t_{ij}` (3 components, in the tangent plane, seen from i), and every
contact with a flat wall (its unit normal into the sphere, its offset, its
:math:`t`).

Generalized coordinates per sphere, in ascending atom id (dof 6k + c):

.. math::

    q_k = (x_k, y_k, z_k, \phi_{x,k}, \phi_{y,k}, \phi_{z,k}), \qquad
    \phi_k = R_k\,\theta_k,

where :math:`\theta_k` is the small rotation vector about the equilibrium
orientation; generalized forces :math:`G_k = (F_k, T_k/R_k)`, as
:math:`(x, y, R\theta)` and :math:`(F_x, F_y, T/R)` in 2D.

.. warning::

   :func:`build_state3d` projects each stored :math:`t` onto the tangent
   plane of its contact with its length kept. That is what the pair style
   does to the stored value before every evaluation (so forces do not
   change), and the Jacobian's linearisation assumes :math:`t\cdot n = 0`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from remote_trigger.analysis.state.state import (
    ContactParams, atom_ids, box_bounds, check_options, history_array, shaped)

__all__ = ["SPHERE_INERTIA", "State3D", "build_state3d", "state3d_from_history",
           "minimum_image3", "plane_wall"]

#: solid spheres, as ``fix nve/sphere`` without ``disc``: I = 2/5 m R^2
SPHERE_INERTIA = 0.4


def minimum_image3(d, box_length, periodic):
    """Minimum-image separations in 3D.

    Parameters
    ----------
    d : ndarray, shape (..., 3)
        Raw separations r_i - r_j (length).
    box_length : array_like, shape (3,)
    periodic : sequence of bool, length 3

    Returns
    -------
    ndarray, shape (..., 3)
    """
    d = np.array(d, dtype=np.float64, copy=True)
    for a in range(3):
        if periodic[a]:
            L = float(box_length[a])
            d[..., a] -= L * np.round(d[..., a] / L)
    return d


def plane_wall(axis, side, position):
    """The (normal, offset) of a flat wall, as ``fix wall/mindlin/smooth`` sees it.

    Parameters
    ----------
    axis : {'x', 'y', 'z'}
        ``xplane``, ``yplane`` or ``zplane``.
    side : {'lo', 'hi'}
        A wall at the low end (spheres above it, normal +e) or the high end
        (normal -e).
    position : float
        Coordinate of the plane (length).

    Returns
    -------
    normal : ndarray, shape (3,)
        Unit normal into the spheres.
    offset : float
        n . p for a point p of the plane; the overlap is R - (n . x - offset).

    Raises
    ------
    ValueError
        On an unknown axis or side.
    """
    if axis not in ("x", "y", "z") or side not in ("lo", "hi"):
        raise ValueError(f"wall axis must be x, y or z and side lo or hi, got {axis!r}, "
                         f"{side!r}")
    k = "xyz".index(axis)
    n = np.zeros(3)
    n[k] = 1.0 if side == "lo" else -1.0
    return n, float(n[k] * position)


@dataclass
class State3D:
    """A packing of spheres with its contact history, in float64.

    Attributes
    ----------
    ids : ndarray of int64, shape (N,)
        Atom ids, strictly ascending; index k is the sphere's block of dofs
        6k ... 6k + 5.
    positions : ndarray, shape (N, 3)
        Centres (length).
    radii, masses : ndarray, shape (N,)
        Radius (length) and mass (mass units), > 0.
    inertia : ndarray, shape (N,)
        Moment of inertia I = I0 m R^2 (I0 = 2/5 for solid spheres,
        :data:`SPHERE_INERTIA`).
    box_lo, box_hi : ndarray, shape (3,)
    periodic : tuple of bool, length 3
    params : ContactParams
        k_n, k_t, mu of the pair style and the walls.
    contact_i, contact_j : ndarray of int64, shape (C,)
        Sphere indices of each contact, ``ids[contact_i] < ids[contact_j]``.
    contact_t : ndarray, shape (C, 3)
        Tangential displacement t_ij seen from i (length), t_ij . n = 0 with
        n = (r_i - r_j)/|r_i - r_j| (minimum image); t_ji = -t_ij.
    wall_index : ndarray of int64, shape (W,)
        Sphere of each sphere-wall contact.
    wall_normal : ndarray, shape (W, 3)
        Unit normal of the wall into the sphere.
    wall_offset : ndarray, shape (W,)
        n . p for a point p of the wall; overlap R - (n . x - offset) > 0.
    wall_t : ndarray, shape (W, 3)
        Tangential displacement of the wall contact (length), t . n = 0.
    external : ndarray, shape (N, 3)
        External force on each sphere (force units).
    notes : dict
        ``projected_t``: the largest |t . n| / |t| removed by the projection.
    F_x, F_y : float or None
        The loads of the state, when it comes from a dump (sidecar).
    source : str or None
        The file it was read from.
    rigid_layer : ndarray of int64, shape (L,), or None
        Indices of the spheres that translate as one body (the top layer as
        a rigid plate, ``fix aveforce 0.0 0.0 0.0`` on ``top``; docs/model.md
        section 9.1); None or fewer than 2: no such constraint. Each keeps
        its own rotations.
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
    contact_i: np.ndarray
    contact_j: np.ndarray
    contact_t: np.ndarray
    wall_index: np.ndarray
    wall_normal: np.ndarray
    wall_offset: np.ndarray
    wall_t: np.ndarray
    external: np.ndarray
    notes: dict = field(default_factory=dict)
    F_x: float = None
    F_y: float = None
    source: str = None
    rigid_layer: np.ndarray = None

    @property
    def n(self):
        """Number of spheres N."""
        return int(self.ids.size)

    @property
    def ndof(self):
        """Number of generalized coordinates, 6N."""
        return 6 * self.n

    @property
    def n_contacts(self):
        """Number of sphere-sphere contacts C."""
        return int(self.contact_i.size)

    @property
    def box_length(self):
        """Box lengths, shape (3,)."""
        return self.box_hi - self.box_lo

    def separation(self, i, j):
        """Minimum-image r_i - r_j for index arrays i, j; shape (len(i), 3)."""
        return minimum_image3(self.positions[i] - self.positions[j], self.box_length,
                              self.periodic)

    def wall_delta(self):
        """Overlap R - (n . x - offset) of every wall contact, shape (W,)."""
        w = self.wall_index
        return self.radii[w] - (np.einsum("wa,wa->w", self.wall_normal, self.positions[w])
                                - self.wall_offset)

    def mass_diagonal(self):
        """Diagonal of M = diag(m, m, m, I/R^2, I/R^2, I/R^2) per sphere, shape (6N,).

        The rotational entries are the mass of phi = R theta: I theta'' = T
        gives (I/R^2) phi'' = T/R; with I = I0 m R^2 they are I0 m.
        """
        md = np.empty((self.n, 6))
        md[:, :3] = self.masses[:, None]
        md[:, 3:] = (self.inertia / self.radii**2)[:, None]
        return md.reshape(-1)

    def dof_ids(self):
        """Atom id of every dof (6 per sphere), shape (6N,)."""
        return np.repeat(self.ids, 6)

    def contact_counts(self):
        """Number of contacts of every sphere, walls included, shape (N,)."""
        return (np.bincount(self.contact_i, minlength=self.n)
                + np.bincount(self.contact_j, minlength=self.n)
                + np.bincount(self.wall_index, minlength=self.n))

    def with_t(self, contact_t=None, wall_t=None):
        """Copy with other tangential displacements (same contacts; projected).

        Parameters
        ----------
        contact_t : array_like, shape (C, 3), optional
        wall_t : array_like, shape (W, 3), optional

        Returns
        -------
        State3D
        """
        import dataclasses

        ct = self.contact_t if contact_t is None else np.asarray(contact_t, np.float64)
        wt = self.wall_t if wall_t is None else np.asarray(wall_t, np.float64)
        if ct.shape != self.contact_t.shape or wt.shape != self.wall_t.shape:
            raise ValueError(f"t arrays must have shapes {self.contact_t.shape} and "
                             f"{self.wall_t.shape}, got {ct.shape} and {wt.shape}")
        d = self.separation(self.contact_i, self.contact_j)
        n = d / np.linalg.norm(d, axis=1)[:, None]
        ct, e1 = _project_keep_length(n, ct)
        wt, e2 = _project_keep_length(self.wall_normal, wt)
        notes = dict(self.notes, projected_t=max(e1, e2))
        return dataclasses.replace(self, contact_t=ct, wall_t=wt, notes=notes)


def _project_keep_length(n, t):
    """t <- |t| P t / |P t| row by row (the pair style's rule); largest |t.n|/|t|."""
    t = np.array(t, dtype=np.float64, copy=True).reshape(-1, 3)
    if t.size == 0:
        return t, 0.0
    tn = np.einsum("ca,ca->c", t, n)
    ln = np.linalg.norm(t, axis=1)
    p = t - tn[:, None] * n
    pl = np.linalg.norm(p, axis=1)
    scale = np.divide(ln, pl, out=np.zeros_like(ln), where=pl > 0)
    out = np.where((tn != 0.0)[:, None], p * scale[:, None], t)
    err = float(np.max(np.divide(np.abs(tn), ln, out=np.zeros_like(ln), where=ln > 0)))
    return out, err


def build_state3d(*, ids, positions, radii, masses, box_lo, box_hi, params,
                  periodic=(True, False, True), pairs=(), pair_t=None, walls=(),
                  wall_t=None, external=None, inertia_factor=SPHERE_INERTIA):
    """Build a :class:`State3D` from arrays and an explicit contact list.

    Parameters
    ----------
    ids : array_like of int, shape (N,)
        Atom ids (any order; the state is sorted by id); integer-valued
        floats are taken.
    positions : array_like, shape (N, 3)
    radii, masses : array_like, shape (N,)
    box_lo, box_hi : array_like, shape (3,)
        Finite, box_hi > box_lo.
    params : ContactParams
    periodic : sequence of 3 bool
        Default (True, False, True): periodic in x and z, the driver's scene
        (that of :func:`state3d_from_history`; it was (True, True, False)).
    pairs : array_like of int, shape (C, 2)
        Atom **ids** (a, b) of the sphere-sphere contacts, each once.
    pair_t : array_like, shape (C, 3), optional
        Tangential displacement of each pair seen from a (default zero).
    walls : sequence of (id, normal, offset)
        Sphere-wall contacts (see :func:`plane_wall`); normal of 3 values.
    wall_t : array_like, shape (W, 3), optional
        Their tangential displacements (default zero).
    external : array_like, shape (N, 3), optional
        External forces (zero if None), in the order of ``ids``.
    inertia_factor : float
        I0 in I = I0 m R^2 (default 2/5, solid spheres), finite, > 0.

    Returns
    -------
    State3D
        Contacts ordered by (i, j) with ids[i] < ids[j]; t projected onto the
        tangent planes with lengths kept.

    Raises
    ------
    ValueError
        On non-finite or non-positive values (``inertia_factor`` included),
        ids (in ``ids`` or ``pairs``) that are not integers, duplicate ids,
        an unknown id in ``pairs`` or ``walls``, a contact without overlap;
        wrong shapes (the argument named with the shapes expected and
        given), ``periodic`` not of 3 flags, a box not of 3 finite values
        with box_hi > box_lo. The message names the ids.
    """
    if not isinstance(params, ContactParams):
        raise ValueError(f"params must be a ContactParams, got {type(params).__name__}")
    check_options(inertia_factor=inertia_factor)
    ids = atom_ids(ids)
    n = ids.size
    pos = shaped("positions", positions, (n, 3), "(N, 3)")
    radii = shaped("radii", radii, (n,), "(N,)")
    masses = shaped("masses", masses, (n,), "(N,)")
    box_lo, box_hi, periodic = box_bounds(box_lo, box_hi, 3, periodic)
    for name, arr in (("positions", pos), ("radii", radii), ("masses", masses)):
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} must be finite")
    if np.any(radii <= 0) or np.any(masses <= 0):
        raise ValueError("radii and masses must be > 0")
    order = np.argsort(ids, kind="stable")
    if np.any(np.diff(ids[order]) == 0):
        raise ValueError("atom ids must be unique")
    ids, pos, radii, masses = ids[order], pos[order], radii[order], masses[order]
    ext = (np.zeros((n, 3)) if external is None
           else shaped("external", external, (n, 3), "(N, 3)")[order])
    if not np.all(np.isfinite(ext)):
        raise ValueError(f"external must be finite, got {int(np.sum(~np.isfinite(ext)))} "
                         f"non-finite value(s)")
    index = {int(a): k for k, a in enumerate(ids)}

    def idx(a):
        if int(a) not in index:
            raise ValueError(f"contact names atom id {int(a)}, which is not in ids")
        return index[int(a)]

    if np.size(pairs) == 0:
        pairs = np.zeros((0, 2), np.int64)
    else:
        pairs = shaped("pairs", pairs, np.shape(pairs), "(C, 2)")
        if pairs.ndim != 2 or pairs.shape[1] != 2:
            raise ValueError(f"pairs must have shape (C, 2), got shape {pairs.shape}")
        pairs = atom_ids(pairs.reshape(-1), "pairs").reshape(-1, 2)
    C = pairs.shape[0]
    pt = (np.zeros((C, 3)) if pair_t is None
          else shaped("pair_t", pair_t, (C, 3), "(C, 3)"))
    if not np.all(np.isfinite(pt)):
        raise ValueError(f"pair_t must be finite, got {int(np.sum(~np.isfinite(pt)))} "
                         f"non-finite value(s)")
    ci = np.array([idx(a) for a in pairs[:, 0]], np.int64)
    cj = np.array([idx(b) for b in pairs[:, 1]], np.int64)
    swap = ids[ci] > ids[cj]
    ci, cj = np.where(swap, cj, ci), np.where(swap, ci, cj)
    pt = np.where(swap[:, None], -pt, pt)                  # t_ji = -t_ij
    srt = np.lexsort((cj, ci))
    ci, cj, pt = ci[srt], cj[srt], pt[srt]
    W = len(walls)
    for k, w in enumerate(walls):
        if not (isinstance(w, (tuple, list)) and len(w) == 3 and np.shape(w[1]) == (3,)
                and np.ndim(w[2]) == 0):
            raise ValueError(f"walls[{k}] must be (id, normal of 3 values, offset), got "
                             f"{w!r}")
    widx = np.array([idx(atom_ids([w[0]], f"the id of walls[{k}]")[0])
                     for k, w in enumerate(walls)], np.int64)
    wn = np.array([np.asarray(w[1], np.float64) for w in walls]).reshape(W, 3)
    woff = np.array([float(w[2]) for w in walls], np.float64)
    if W and not np.allclose(np.linalg.norm(wn, axis=1), 1.0, rtol=0, atol=1e-14):
        raise ValueError("wall normals must be unit vectors")
    wt = (np.zeros((W, 3)) if wall_t is None
          else shaped("wall_t", wall_t, (W, 3), "(W, 3), W = len(walls)"))
    if not np.all(np.isfinite(wt)):
        raise ValueError(f"wall_t must be finite, got {int(np.sum(~np.isfinite(wt)))} "
                         f"non-finite value(s)")
    st = State3D(ids=ids, positions=pos, radii=radii, masses=masses,
                 inertia=float(inertia_factor) * masses * radii**2, box_lo=box_lo,
                 box_hi=box_hi, periodic=periodic, params=params,
                 contact_i=ci, contact_j=cj, contact_t=pt, wall_index=widx, wall_normal=wn,
                 wall_offset=woff, wall_t=wt, external=ext)
    d = st.separation(ci, cj)
    delta = radii[ci] + radii[cj] - np.linalg.norm(d, axis=1)
    if not np.all(delta > 0):
        k = int(np.argmin(delta > 0))
        raise ValueError(f"contact {ids[ci[k]]}-{ids[cj[k]]} has overlap {delta[k]!r} <= 0")
    wd = st.wall_delta()
    if not np.all(wd > 0):
        k = int(np.argmin(wd > 0))
        raise ValueError(f"wall contact of atom id {ids[widx[k]]} has overlap {wd[k]!r} <= 0")
    return st.with_t()


def state3d_from_history(*, ids, positions, radii, masses, box_lo, box_hi, params,
                         periodic=(True, False, True), partners=None, partner_t=None,
                         wall_y=0.0, wall_t=None, external=None, mirror_rtol=1e-9,
                         inertia_factor=SPHERE_INERTIA, **extra):
    """A :class:`State3D` from per-atom arrays as LAMMPS holds them (a dump, a gather).

    The contacts are the overlapping pairs (:func:`~remote_trigger.analysis.state.
    contacts.find_contacts`, minimum image along the periodic axes); each takes
    its t from the pair style's history (``i2_mindlin_partner``,
    ``d2_mindlin_tx/ty/tz``; both sides listed, t_ji = -t_ij checked), zero if
    the history does not list it (a contact that has not taken a step yet).
    History of pairs that no longer overlap is dropped. The wall is the plane
    y = ``wall_y`` (``fix wall/mindlin/smooth ... yplane``), normal +y; a sphere
    touches it where R - (y - wall_y) > 0.

    Parameters
    ----------
    ids : array_like of int, shape (N,)
        Integer-valued floats are taken.
    positions : array_like, shape (N, 3)
    radii, masses : array_like, shape (N,)
    box_lo, box_hi : array_like, shape (3,)
    params : ContactParams
    periodic : sequence of 3 bool
        Default periodic in x and z (the driver's scene; the default of
        :func:`build_state3d` too).
    partners : array_like of int, shape (N, K), optional
        Partner ids per slot (0 = empty; shape (N,): one slot).
    partner_t : array_like, shape (N, K, 3), optional
        t of each slot, seen from the atom of the row (length); required
        with ``partners``.
    wall_y : float or None
        Height of the floor; None: no wall.
    wall_t : array_like, shape (N, 3), optional
        t of each sphere's wall contact (zero where it has none).
    external : array_like, shape (N, 3), optional
        Loads (force).
    mirror_rtol : float
        Tolerance of the mirror check, relative to max(t*, |t|, the largest
        t* of the snapshot) (see ``read_dump``); finite, >= 0.
    inertia_factor : float
        I0 (default 2/5); finite, > 0.
    **extra
        ``F_x``, ``F_y``, ``source``: stored on the state; ``rigid_layer``:
        a boolean mask of shape (N,) in the order of ``ids`` as given (the
        spheres that translate as one body), stored as their indices.

    Returns
    -------
    State3D

    Raises
    ------
    ValueError
        ``mirror_rtol`` < 0 or ``inertia_factor`` <= 0 (or either not
        finite); an array of another shape than the one above (named, with
        the shapes expected and given), ids that are not integers,
        ``periodic`` not of 3 flags, a box not of 3 finite values with
        box_hi > box_lo, ``partners`` without ``partner_t``; a history entry
        that names an unknown atom or lacks its mirror, two sides that
        disagree, a centre inside another sphere or at or below the wall.
    """
    import dataclasses

    from remote_trigger.analysis.state.contacts import history_pairs, find_contacts

    check_options(mirror_rtol=mirror_rtol, inertia_factor=inertia_factor)
    ids = atom_ids(ids)
    n = ids.size
    order = np.argsort(ids, kind="stable")
    ids_s = ids[order]
    pos = shaped("positions", positions, (n, 3), "(N, 3)")[order]
    rad = shaped("radii", radii, (n,), "(N,)")[order]
    masses = shaped("masses", masses, (n,), "(N,)")
    box_lo, box_hi, per = box_bounds(box_lo, box_hi, 3, periodic)
    if partners is not None:
        if partner_t is None:
            raise ValueError("partners needs partner_t (the tangential displacement of each "
                             "partner), got partner_t = None")
        P = history_array("partners", partners, n)[order]
        K = P.shape[1]
        X = shaped("partner_t", partner_t, (n, K, 3), "(N, K, 3), K that of partners")[order]
    gi, gj, _ = find_contacts(pos, rad, box_lo, box_hi, per, ids=ids_s)
    t = np.zeros((gi.size, 3))
    if partners is not None and gi.size:
        hi_, hj, ht, _ = history_pairs(P, X, ids_s, pos, rad, box_hi - box_lo, per, params,
                                        mirror_rtol)
        known = {(int(a), int(b)): k for k, (a, b) in enumerate(zip(hi_, hj))}
        for c, key in enumerate(zip(gi.tolist(), gj.tolist())):
            if key in known:
                t[c] = ht[known[key]]
    walls, wt = [], []
    if wall_y is not None:
        normal, offset = plane_wall("y", "lo", float(wall_y))
        wt_all = (np.zeros((n, 3)) if wall_t is None
                  else shaped("wall_t", wall_t, (n, 3), "(N, 3)")[order])
        low = pos[:, 1] - float(wall_y)
        if np.any(low <= 0.0):
            k = int(np.argmax(low <= 0.0))
            raise ValueError(f"the centre of atom id {ids_s[k]} (y = {float(pos[k, 1])!r}) is "
                             f"at or below the wall y = {wall_y!r}")
        for k in np.nonzero(rad - low > 0.0)[0]:
            walls.append((int(ids_s[k]), normal, offset))
            wt.append(wt_all[k])
    ext = None if external is None else shaped("external", external, (n, 3), "(N, 3)")[order]
    st = build_state3d(ids=ids_s, positions=pos, radii=rad, masses=masses[order],
                       box_lo=box_lo, box_hi=box_hi, params=params, periodic=per,
                       pairs=np.column_stack([ids_s[gi], ids_s[gj]]), pair_t=t, walls=walls,
                       wall_t=np.array(wt).reshape(-1, 3), external=ext,
                       inertia_factor=inertia_factor)
    keep = {k: extra[k] for k in ("F_x", "F_y", "source") if k in extra}
    if extra.get("rigid_layer") is not None:
        mask = np.asarray(extra["rigid_layer"])
        if mask.shape != (n,) or mask.dtype != bool:
            raise ValueError(f"rigid_layer must be a boolean mask of shape ({n},), got "
                             f"dtype {mask.dtype} and shape {mask.shape}")
        keep["rigid_layer"] = np.nonzero(mask[order])[0].astype(np.int64)
    return dataclasses.replace(st, **keep) if keep else st
