"""Synthetic 3D packings for the analyzer tests (no LAMMPS needed)."""
import numpy as np

from remote_trigger.analysis.state.state import ContactParams
from remote_trigger.analysis.state.state3d import build_state3d, minimum_image3, plane_wall

from .builders import KN, KT, MU


def geometric_pairs(pos, radii, box_length, periodic):
    """All overlapping pairs (i < j), in (i, j) order (a k-d tree: any N).

    Periodic axes wrap (positions inside [0, L)); the others are open.
    """
    from scipy.spatial import cKDTree

    pos = np.asarray(pos, np.float64)
    span = np.ptp(pos, axis=0) + 4.0 * float(np.max(radii)) + 1.0
    box = np.where(np.asarray(periodic), np.asarray(box_length, np.float64), 2.0 * span)
    shifted = pos - np.where(np.asarray(periodic), 0.0, pos.min(axis=0))
    cand = cKDTree(shifted, boxsize=box).query_pairs(2.0 * float(np.max(radii)),
                                                     output_type="ndarray")
    if cand.size == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    cand = cand[np.lexsort((cand[:, 1], cand[:, 0]))]
    i, j = cand[:, 0].astype(np.int64), cand[:, 1].astype(np.int64)
    d = minimum_image3(pos[i] - pos[j], box_length, periodic)
    ok = np.linalg.norm(d, axis=1) < radii[i] + radii[j]
    return i[ok], j[ok]


def tangent_t(rng, n, length):
    """Random vectors of the given lengths in the planes normal to the rows of n."""
    v = rng.normal(size=n.shape)
    v -= np.einsum("ca,ca->c", v, n)[:, None] * n
    return v / np.linalg.norm(v, axis=1)[:, None] * np.asarray(length)[:, None]


def draw_u(rng, size, cap_fraction):
    """|t|/t*: 0, uniform in (0.05, 0.95), and with cap_fraction 1, 1 - 1e-9, 1.3."""
    kind = rng.integers(0, 5, size=size)
    u = np.where(kind == 0, 0.0, rng.uniform(0.05, 0.95, size=size))
    capmix = rng.random(size) < cap_fraction
    u = np.where(capmix & (kind == 2), 1.0, u)
    u = np.where(capmix & (kind == 3), 1.0 - 1e-9, u)
    return np.where(capmix & (kind == 4), 1.3, u)


def random_packing3d(seed, nx=3, ny=3, nz=3, mu=MU, kt=KT, kn=KN, cap_fraction=0.4,
                     t_scale=1.0, wall=True):
    """Spheres on a jittered, compressed simple-cubic-like lattice, periodic in x, y.

    Radii 0.5 or 0.7 at random; the bottom layer overlaps a zplane wall at
    z = 0 (normal +z). Tangential displacements point in random directions of
    each tangent plane, with u = |t|/t* from :func:`draw_u`. Returns a State3D.
    """
    rng = np.random.default_rng(seed)
    n = nx * ny * nz
    radii = np.where(rng.random(n) < 0.5, 0.5, 0.7)
    a = 1.05
    L = np.array([nx * a, ny * a, nz * a + 3.0])
    grid = np.stack(np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij"),
                    -1).reshape(-1, 3).astype(float)
    pos = grid * a + np.array([0.5 * a, 0.5 * a, 0.45])
    pos[:, 0] += 0.3 * a * (grid[:, 2] % 2)                # stagger the layers
    pos += rng.uniform(-0.06, 0.06, size=pos.shape)
    pos[:, :2] %= L[:2]
    periodic = (True, True, False)
    ci, cj = geometric_pairs(pos, radii, L, periodic)
    ids = rng.permutation(np.arange(1, n + 1) * 2)       # non-contiguous, unsorted ids
    params = ContactParams(kn, kt, mu)
    d = minimum_image3(pos[ci] - pos[cj], L, periodic)
    rho = np.linalg.norm(d, axis=1)
    delta = radii[ci] + radii[cj] - rho
    ts = mu * kn * delta / kt if kt > 0 else np.ones_like(delta)
    t = tangent_t(rng, d / rho[:, None], t_scale * draw_u(rng, delta.size, cap_fraction) * ts)
    walls, wt = [], np.zeros((0, 3))
    if wall:
        nw, off = plane_wall("z", "lo", 0.0)
        w = np.nonzero(radii - pos[:, 2] > 0)[0]
        walls = [(ids[k], nw, off) for k in w]
        wdelta = radii[w] - pos[w, 2]
        wts = mu * kn * wdelta / kt if kt > 0 else np.ones_like(wdelta)
        wt = tangent_t(rng, np.tile(nw, (w.size, 1)),
                       t_scale * draw_u(rng, w.size, cap_fraction) * wts)
    return build_state3d(ids=ids, positions=pos, radii=radii, masses=np.ones(n),
                         box_lo=np.zeros(3), box_hi=L, params=params, periodic=periodic,
                         pairs=np.column_stack([ids[ci], ids[cj]]), pair_t=t, walls=walls,
                         wall_t=wt)
