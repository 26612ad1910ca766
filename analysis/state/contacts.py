r"""Contacts of a packing: geometric (overlapping disks) and recorded (the history).

:func:`find_contacts` finds every overlapping pair in float64 (k-d tree,
minimum image across the periodic direction, :func:`minimum_image`);
:func:`touch_band` is the band of overlaps inside which the pair style lists
a pair as its history says. :func:`history_pairs` reads the pair style's
per-atom history (partner ids in ``i2_mindlin_partner``, xi in
``d2_mindlin_t``; each contact on both sides, mirror-checked) and
:func:`wall_contacts` the disks touching the wall;
:func:`remote_trigger.analysis.state.state.build_state` merges them into a
:class:`~remote_trigger.analysis.state.state.State`.
"""
from __future__ import annotations

import numpy as np

__all__ = ["find_contacts", "minimum_image", "touch_band", "TOUCH_ULPS", "PARTNER", "XI"]

#: the history columns of the pair style (per-atom partner ids and xi)
PARTNER = "i2_mindlin_partner"
XI = "d2_mindlin_t"


def _check_axes(dim, **given):
    """Each of ``given`` (box_length, box_lo, periodic, ...) has ``dim`` entries
    (``periodic`` exactly, the box arrays at least: a 2D state may carry z)."""
    for name, val in given.items():
        if isinstance(val, (str, bytes)) or np.ndim(val) != 1 or len(val) < dim \
                or (name == "periodic" and len(val) != dim):
            raise ValueError(f"{name} must have {dim} entries (one per axis), got {val!r}")


def minimum_image(d, box_length, periodic):
    """Apply the minimum-image convention to separation vectors.

    Parameters
    ----------
    d : ndarray, shape (..., D)
        Raw separations r_i - r_j: D = 2 (disks) or 3 (spheres), or the
        components of a few axes (D = 1: horizontal distances).
    box_length : array_like, shape (D,)
    periodic : sequence of bool, length D

    Returns
    -------
    ndarray, shape (..., D)

    Raises
    ------
    ValueError
        If ``box_length`` or ``periodic`` does not have D entries.
    """
    d = np.array(d, dtype=np.float64, copy=True)
    _check_axes(d.shape[-1] if d.ndim else 0, box_length=box_length, periodic=periodic)
    for a in range(d.shape[-1]):
        if periodic[a]:
            L = box_length[a]
            d[..., a] -= L * np.round(d[..., a] / L)
    return d


#: half-width of the touching band in ulps of the largest coordinate (the
#: pair style's TOUCH_ULPS, pair_mindlin_smooth/mindlin_smooth_contacts.h)
TOUCH_ULPS = 64.0


def touch_band(box_lo, box_hi, radsum):
    """Half-width tau of the touching band of a pair (docs/model.md, "Touching band").

    Within |delta| <= tau the pair style keeps a pair listed in the history,
    or unlisted, as its history records, with xi = 0 and no tangential
    force (the normal force is k_n delta^(3/2) for delta > 0 as everywhere):
    across a periodic boundary the two disks' overlap tests use each other's
    image x +- L, rounded, and can disagree by a few ulps there.
    tau = 64 eps (max |box bound| + max box length + R_i + R_j), the same on
    both sides of a pair.

    Parameters
    ----------
    box_lo, box_hi : array_like, shape (2,) or (3,)
        Box bounds (x, y used).
    radsum : float or ndarray
        R_i + R_j.

    Returns
    -------
    float or ndarray (length)
    """
    lo, hi = np.asarray(box_lo, float)[:2], np.asarray(box_hi, float)[:2]
    base = max(float(np.max(np.abs(lo))), float(np.max(np.abs(hi)))) + float(np.max(hi - lo))
    return TOUCH_ULPS * np.finfo(float).eps * (base + np.asarray(radsum, float))


def find_contacts(positions, radii, box_lo, box_hi, periodic=(True, False), ids=None,
                  gap=0.0):
    """All overlapping disk pairs (geometric contacts), O(N log N).

    Parameters
    ----------
    positions : ndarray, shape (N, 2) or (N, 3)
        Centres of disks, or of spheres (then ``box_lo``, ``box_hi`` and
        ``periodic`` have 3 entries).
    radii : ndarray, shape (N,)
    box_lo, box_hi : array_like, shape (D,)
    periodic : sequence of bool, length D
    ids : array_like, shape (N,), optional
        Atom ids, only to name disks in error messages.
    gap : float, optional
        Also return the pairs whose surfaces are less than ``gap`` apart
        (delta > -gap; default 0: overlapping pairs only).

    Returns
    -------
    i, j : ndarray of int64, shape (P,)
        Index pairs with i < j and delta = R_i + R_j - |r_i - r_j| > -gap.
    rho : ndarray, shape (P,)
        Centre distances.

    Raises
    ------
    ValueError
        If the centre of a disk lies inside another disk (distance below the
        larger radius), where the contact normal and the Hertz law are
        meaningless (the message names both indices and the distance); if
        ``positions`` is not (N, 2) or (N, 3) and finite, ``radii`` not
        (N,), or a box argument has too few entries.
    """
    from scipy.spatial import cKDTree

    pos = np.asarray(positions, dtype=np.float64)
    if pos.ndim != 2 or pos.shape[1] not in (2, 3):
        raise ValueError(f"positions must have shape (N, 2) or (N, 3), got shape {pos.shape}")
    n, dim = pos.shape
    if not np.all(np.isfinite(pos)):
        k = int(np.argwhere(~np.isfinite(pos))[0][0])
        raise ValueError(f"positions must be finite, got {pos[k].tolist()} at index {k}")
    if np.shape(radii) != (n,):
        raise ValueError(f"radii must have shape ({n},) like positions, got shape "
                         f"{np.shape(radii)}")
    _check_axes(dim, box_lo=box_lo, box_hi=box_hi, periodic=periodic)
    if n < 2:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    box_lo = np.asarray(box_lo, np.float64)[:dim]
    box_hi = np.asarray(box_hi, np.float64)[:dim]
    L = box_hi - box_lo
    shifted = pos - box_lo
    boxsize = np.empty(dim)
    for a in range(dim):
        if periodic[a]:
            shifted[:, a] = np.mod(shifted[:, a], L[a])
            shifted[:, a] = np.where(shifted[:, a] >= L[a], 0.0, shifted[:, a])
            boxsize[a] = L[a]
        else:
            span = shifted[:, a].max() - shifted[:, a].min()
            shifted[:, a] -= shifted[:, a].min()
            boxsize[a] = 4.0 * (span + 4.0 * radii.max()) + 1.0
    cut = 2.0 * float(np.max(radii)) + max(float(gap), 0.0)
    tree = cKDTree(shifted, boxsize=boxsize)
    pairs = tree.query_pairs(cut, output_type="ndarray").astype(np.int64)
    if pairs.size == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    i, j = pairs[:, 0], pairs[:, 1]
    swap = i > j
    i, j = np.where(swap, j, i), np.where(swap, i, j)
    d = minimum_image(pos[i] - pos[j], L, periodic)
    rho = _norm(d)
    bad = rho < np.maximum(radii[i], radii[j])
    if np.any(bad):
        k = int(np.argmax(bad))
        who = (f"atom ids {ids[i[k]]} and {ids[j[k]]}" if ids is not None
               else f"disks at indices {i[k]} and {j[k]}")
        raise ValueError(f"overlapping centres: {who} are "
                         f"{float(rho[k])!r} apart, closer than the larger radius "
                         f"{float(max(radii[i[k]], radii[j[k]]))!r}")
    touch = radii[i] + radii[j] - rho > -max(float(gap), 0.0)
    order = np.lexsort((j[touch], i[touch]))
    return i[touch][order], j[touch][order], rho[touch][order]


def _norm(d):
    """|d| row by row: ``hypot`` for 2-vectors (as the 2D code always did), else the
    Euclidean norm."""
    if d.shape[-1] == 2:
        return np.hypot(d[..., 0], d[..., 1])
    return np.sqrt(np.sum(d * d, axis=-1))


def history_pairs(P, X, ids, pos, radii, L, periodic, params, mirror_rtol):
    """Disk-disk history (sorted by id) -> contacts (i < j, xi), mirror-checked.

    Spheres: ``X`` has shape (N, K, 3) (the vector t per slot), the mirror
    rule is t_ji = -t_ij, and the returned t is that of side i.

    Parameters
    ----------
    P : ndarray, shape (N, K)
        Partner ids (0 = empty slot).
    X : ndarray, shape (N, K) or (N, K, 3)
        Tangential displacements per slot: xi (disks) or t (spheres).
    ids, pos, radii : ndarray
        Sorted by id.
    L : ndarray, shape (2,)
    periodic : tuple of bool
    params : ContactParams
    mirror_rtol : float

    Returns
    -------
    (ndarray, ndarray, ndarray, ndarray)
        Indices i < j, xi (mean of the two sides; spheres: t_ij, shape
        (P, 3)) and the pairs' overlaps delta (negative: apart).

    Raises
    ------
    ValueError
        Non-integer or negative ids, unknown partner, self contact, a partner
        listed twice, a one-sided entry, or two sides that disagree.
    """
    n = ids.size
    if np.any(P != np.round(P)) or np.any(P < 0):
        raise ValueError(f"{PARTNER} must hold non-negative integer atom ids")
    P = P.astype(np.int64)
    rows, slots = np.nonzero(P > 0)
    pid = P[rows, slots]
    pxi = X[rows, slots]
    cidx = np.searchsorted(ids, pid)
    cidx = np.minimum(cidx, n - 1)
    unknown = ids[cidx] != pid
    if np.any(unknown):
        k = int(np.argmax(unknown))
        raise ValueError(f"history of atom id {ids[rows[k]]} names partner id {pid[k]}, "
                         f"which is not in the snapshot")
    self_c = cidx == rows
    if np.any(self_c):
        raise ValueError(f"atom id {ids[rows[np.argmax(self_c)]]} lists itself as a "
                         f"contact partner")
    keys = rows * n + cidx
    ks = np.argsort(keys)
    keys, rows, cidx, pxi = keys[ks], rows[ks], cidx[ks], pxi[ks]
    if np.any(np.diff(keys) == 0):
        k = int(np.argmax(np.diff(keys) == 0))
        raise ValueError(f"atom id {ids[rows[k]]} lists partner id {ids[cidx[k]]} twice")
    # every entry must have its mirror (j lists i)
    mkeys_all = cidx * n + rows
    mpos_all = np.minimum(np.searchsorted(keys, mkeys_all), keys.size - 1)
    lone = keys[mpos_all] != mkeys_all
    if np.any(lone):
        k = int(np.argmax(lone))
        raise ValueError(f"contact {ids[rows[k]]}-{ids[cidx[k]]} is in the history of "
                         f"atom id {ids[rows[k]]} but not in that of atom id "
                         f"{ids[cidx[k]]} (the two sides must mirror each other)")
    prim = rows < cidx
    hi_, hj, hxi = rows[prim], cidx[prim], pxi[prim]
    mxi = pxi[mpos_all[prim]]
    vector = hxi.ndim == 2            # spheres: t_ji = -t_ij
    if vector:
        mxi = -mxi
    # scale of the check: t* of the contact (or |xi| without friction)
    d = minimum_image(pos[hi_] - pos[hj], L, periodic)
    delta_h = radii[hi_] + radii[hj] - _norm(d)
    with np.errstate(divide="ignore", invalid="ignore"):
        ts = (params.mu * params.k_n * np.maximum(delta_h, 0.0) / params.k_t
              if params.k_t > 0 else np.full(delta_h.shape, np.inf))
    size = np.sqrt(np.sum(hxi * hxi, axis=1)) if vector else np.abs(hxi)
    diff = np.sqrt(np.sum((hxi - mxi) ** 2, axis=1)) if vector else np.abs(hxi - mxi)
    ts = np.where(np.isfinite(ts), ts, 0.0)
    # the two sides are advanced separately (and a ghost's periodic image is
    # rounded), so they differ by round-off of the history's own scale: a
    # barely touching contact (tiny t*) is checked against the largest t*
    scale = np.maximum(np.maximum(size, ts), ts.max(initial=0.0))
    mism = diff > mirror_rtol * scale
    if np.any(mism):
        k = int(np.argmax(mism))
        what = ("t" if vector else "xi", "minus " if vector else "",
                "t_ji = -t_ij" if vector else "must be equal")
        raise ValueError(f"contact {ids[hi_[k]]}-{ids[hj[k]]}: the two sides of the "
                         f"history disagree, {what[0]} = {hxi[k].tolist()!r} on atom id "
                         f"{ids[hi_[k]]} and {what[1]}{mxi[k].tolist()!r} on atom id "
                         f"{ids[hj[k]]} ({what[2]})")
    hxi = 0.5 * (hxi + mxi)
    return hi_, hj, hxi, delta_h


def wall_contacts(ids, pos, radii, wall_y, wt, wall_t):
    """Disks touching the floor y = wall_y: (indices, xi, overlap, stale entries).

    ``wt`` is the wall history sorted by id (None: zero); ``wall_t`` the
    history as given (to refuse a nonzero one without a wall).

    Raises
    ------
    ValueError
        A centre at or below the wall; wall history without a wall.
    """
    n = ids.size
    stale_w = 0
    if wall_y is not None:
        wdelta_all = radii - (pos[:, 1] - wall_y)
        widx = np.nonzero(wdelta_all > 0.0)[0].astype(np.int64)
        wt = np.zeros(n) if wt is None else wt
        wxi = wt[widx].copy()
        stale_w = int(np.count_nonzero((wdelta_all <= 0.0) & (wt != 0.0)))
        wdelta = wdelta_all[widx]
        if np.any(wdelta >= radii[widx]):
            k = widx[np.argmax(wdelta >= radii[widx])]
            raise ValueError(f"the centre of atom id {ids[k]} (y = {float(pos[k, 1])!r}) is at or "
                             f"below the wall y = {wall_y!r}")
    else:
        widx = np.zeros(0, np.int64)
        wxi = np.zeros(0)
        wdelta = np.zeros(0)
        if wall_t is not None and np.any(np.asarray(wall_t) != 0.0):
            raise ValueError("wall history d_mindlin_wall_t is nonzero but no wall is given "
                             "(wall_y = None; read_dump's no_wall=True)")
    return widx, wxi, wdelta, stale_w
