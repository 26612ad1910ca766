"""Seeded generator of the loose initial packing (docs/model.md section 1).

The scene is N bidisperse disks (radii R1 = 0.5 and R2 = 0.7, equal numbers,
mass m = 1 each) in a box periodic in x, above a flat wall at y = 0. The
upper boundary, the group ``top``, is a line of N_top ordinary free disks
placed above the bulk; the decks load them with (F_x + f(t), -F_y).

``dim = 3`` gives the same scene with spheres (docs/model.md section 9): the
box is periodic in x and z with an L x L cross-section, the wall is the
plane y = 0, and ``top`` is a layer instead of a line (below).

Choices (documented in ``docs/driver.md``)
------------------------------------------
* **Width.** L = sqrt(A / phi), A = sum of pi R_i^2 over all N disks and
  phi = 0.82, so that the relaxed packing (height ~ L) is roughly square, as
  the paper's box L^2 (phi = 0.8171 for N = 100).
* **Top line.** N_top = 2 floor(L / 2.4) disks (even, >= 2), alternating
  R2, R1, evenly spaced by L / N_top >= 1.2 = R1 + R2, so neighbouring top
  disks do not overlap and no bulk disk (diameter >= 1) fits through the gaps
  of a line of touching-sized spacing. Equal numbers of each radius are kept
  over all N disks (N must be even): the bulk gets N/2 - N_top/2 of each.
  For N = 100: L = 11.91, N_top = 8.
* **Loose bulk.** Random sequential addition of the bulk disks (large first)
  in [0, L) x [R, H0] with a loose packing fraction phi0 = 0.55, without
  overlaps (periodic in x). The top line sits 0.05 above the highest bulk
  disk. Atom IDs: bulk 1..N - N_top, then the top line.
* **Spheres (dim = 3).** The top layer is an m x m square grid, radii in
  a checkerboard (R2 where the two grid indices have an even sum, so each
  top sphere's four neighbours have the other radius), spacing
  :data:`TOP_SPACING_3D` = 1.25 (a gap of 0.05 between neighbours): its
  holes leave a bulk sphere (R >= 0.5) a clearance of 0.18 only, so the
  bulk cannot flow up through the layer while it presses on it (with the
  2D line's spacing L / m ~ 1.6 a frictionless bulk did, and the layer
  sank to the floor). The width is L = 1.25 m with m the largest even
  integer up to (V / phi)^(1/3) / 1.25, V = sum of 4/3 pi R_i^3, phi = 0.64
  (random close packing of spheres; :data:`PHI_3D`); periodic in x and z,
  L x L cross-section. Loose bulk by random sequential addition at
  phi0 = 0.3 (:data:`PHI_LOOSE_3D`; RSA of spheres jams near 0.38) in
  [0, L) x [R, H0] x [0, L). Default N = 160 (:data:`N_3D`): m = 4,
  L = 5, N_top = 16, relaxed height ~ 10.
* **Top flag.** The membership of ``top`` travels with the data file as the
  integer per-atom property ``i_top`` (section ``topflag``), so that decks
  define the group with ``group top variable istop``.

The data file has ``atom_style sphere`` lines ``id type diameter density x y z``
(density 1; decks then ``set group all mass 1.0``), an empty-history section
``hist`` for ``read_data FILE fix hist NULL hist`` and the ``topflag`` section;
in 3D (z in [0, L)) there is no history section: the 3D deck lets the pair
keep its own history (any number of contacts per sphere; a ``fix
property/atom`` section, whose lines ``read_data`` reads up to 255
characters, holds 8), which starts at zero.
"""
from dataclasses import dataclass
import math

import numpy as np

from remote_trigger.analysis.errors import is_integer
from remote_trigger.analysis.output import write_text_atomic

#: radii of the two disk types (type 1 = small, type 2 = large)
RADII = (0.5, 0.7)
#: contact-history columns per disk (conventions.md section 1)
HISTORY_SLOTS = 8
#: spheres: packing fraction that sets the width, loose fraction of the bulk,
#: default number of spheres
PHI_3D = 0.64
PHI_LOOSE_3D = 0.3
N_3D = 160
#: spacing of the spheres' top layer (R1 + R2 = 1.2 plus a gap of 0.05)
TOP_SPACING_3D = 1.25
#: packing fraction of the width and of the loose bulk, per dimension
PHI = {2: 0.82, 3: PHI_3D}
PHI_LOOSE = {2: 0.55, 3: PHI_LOOSE_3D}


@dataclass(frozen=True)
class Packing:
    """A generated packing, atoms ordered by ascending ID (ID = index + 1).

    Attributes
    ----------
    positions : ndarray, shape (N, 2) or (N, 3)
        Disk centres x, y (spheres: x, y, z), length units, 2 R1 = 1.
    radii : ndarray, shape (N,)
        0.5 or 0.7.
    types : ndarray of int, shape (N,)
        LAMMPS atom types, 1 = small, 2 = large.
    top : ndarray of bool, shape (N,)
        True for the disks of the upper boundary line.
    width : float
        Periodic box length L along x (and along z for spheres).
    ylo, yhi : float
        Box bounds along y (fixed boundary); the wall is at y = 0.
    seed : int
        Seed used.
    """

    positions: np.ndarray
    radii: np.ndarray
    types: np.ndarray
    top: np.ndarray
    width: float
    ylo: float
    yhi: float
    seed: int

    @property
    def n(self):
        """Number of disks N."""
        return int(self.radii.size)

    @property
    def dim(self):
        """2 for disks, 3 for spheres."""
        return int(self.positions.shape[1])

    @property
    def n_top(self):
        """Number of disks of the ``top`` group."""
        return int(np.count_nonzero(self.top))


def placement_offsets(state, attempts):
    """Shifts along x of the ``top`` line for its placements (``top_attempts``).

    The relax protocol's placement k (k = 0 .. attempts - 1) shifts the
    line, from where :func:`~remote_trigger.pywrap.stages.relax.place_top`
    left it, by k/attempts of its spacing L/m: m = N_top disks per line, or
    m = sqrt(N_top) spheres per row of an m x m layer. ``in.relax`` and
    ``in.relax3d`` compute the same shifts (their ``place`` sections) and
    print them.

    Parameters
    ----------
    state : gathered state (``Engine.gather_state``)
        Needs ``top``, ``dim``, ``box_lo`` and ``box_hi``.
    attempts : int
        Placements, >= 1.

    Returns
    -------
    list of float
        ``attempts`` shifts (lj length units), the first 0.0.
    """
    per_row = max(1, int(np.count_nonzero(state.top)))
    if state.dim == 3:                 # an m x m layer: m spheres per row along x
        per_row = max(1, int(round(np.sqrt(per_row))))
    spacing = float(state.box_hi[0] - state.box_lo[0]) / per_row
    return [k * spacing / attempts for k in range(attempts)]


def box_width(n, phi=0.82, radii=RADII, dim=2):
    """Periodic width L such that N disks at packing fraction phi fill an L x L box.

    Parameters
    ----------
    n : int
        Total number of disks (half of each radius).
    phi : float
        Target packing fraction.
    dim : {2, 3}
        3: spheres; L is then a multiple of the top layer's spacing.

    Returns
    -------
    float
        L = sqrt(N pi (R1^2 + R2^2) / 2 / phi); spheres: L = 1.25 m, m the
        largest even integer (>= 2) up to L3 / 1.25, L3 = (N 4/3 pi (R1^3 + R2^3)
        / 2 / phi)^(1/3) the edge of a cube at phi.
    """
    if dim == 3:
        vol = n * (4.0 / 3.0) * math.pi * (radii[0] ** 3 + radii[1] ** 3) / 2.0
        m = max(2, 2 * int((vol / phi) ** (1.0 / 3.0) // (2.0 * TOP_SPACING_3D)))
        return TOP_SPACING_3D * m
    return math.sqrt(n * math.pi * (radii[0] ** 2 + radii[1] ** 2) / 2.0 / phi)


def smallest_n(phi, radii, dim):
    """'the smallest n that works at phi = ... is ...' for :func:`generate`'s errors."""
    for m in range(6, 10 ** 6, 2):
        width = box_width(m, phi, radii, dim)
        if width > 4.0 * radii[1] and top_count(width, radii, dim) < m - 2:
            return f"the smallest n that works at phi = {phi:g} is {m}"
    return "no n up to 10^6 works at this phi"


def top_count(width, radii=RADII, dim=2):
    """Number of top disks for a box of width L.

    2D: a line of m = 2 floor(L / (2 (R1 + R2))) >= 2 disks; 3D: an m x m
    layer of spacing :data:`TOP_SPACING_3D`, m = L / 1.25 (rounded).
    """
    if dim == 3:
        return int(round(width / TOP_SPACING_3D)) ** 2
    return max(2, 2 * int(width // (2.0 * (radii[0] + radii[1]))))


def _top_layer(width, n_top, y_line, radii, dim):
    """Centres (n_top, dim) and radii of the top line (2D) or checkerboard layer (3D)."""
    r1, r2 = radii
    if dim == 2:
        top_r = np.array([r2 if k % 2 == 0 else r1 for k in range(n_top)])
        tx = (np.arange(n_top) + 0.5) * width / n_top
        return np.column_stack([tx, np.full(n_top, y_line)]), top_r
    m = int(round(math.sqrt(n_top)))
    a, b = np.divmod(np.arange(n_top), m)
    top_r = np.where((a + b) % 2 == 0, r2, r1)
    return np.column_stack([(a + 0.5) * width / m, np.full(n_top, y_line),
                            (b + 0.5) * width / m]), top_r


def generate(n, seed=0, phi=None, phi_loose=None, max_tries=200000, radii=RADII, dim=2):
    """Generate a loose, non-overlapping bidisperse packing with a top line.

    Parameters
    ----------
    n : int
        Total number of disks, even, >= 6 (bulk plus top line); spheres: even
        and larger than the top layer + 2. The periodic width L must exceed
        4 R2, so that no particle can touch two periodic images of another
        (spheres at the default phi: n >= 82, L = 5).
    seed : int
        Seed of :func:`numpy.random.default_rng`; the same seed gives the same
        packing bit for bit.
    phi : float, optional
        Packing fraction used to choose the width L (see :func:`box_width`);
        default 0.82 (disks), :data:`PHI_3D` (spheres); in (0.1, 0.91)
        for disks, (0.1, 0.74) for spheres.
    phi_loose : float, optional
        Packing fraction of the random loose bulk, in (0.05, 0.6] (spheres:
        (0.05, 0.35]); default 0.55 (disks), :data:`PHI_LOOSE_3D` (spheres).
    max_tries : int
        Random trials per disk before giving up.
    radii : tuple of float
        (R1, R2), 0 < R1 < R2; default (0.5, 0.7) (docs/model.md section 1).
    dim : {2, 3}
        2: disks (box periodic in x); 3: spheres (periodic in x and z).

    Returns
    -------
    Packing

    Raises
    ------
    ValueError
        If ``n`` is odd or too small (top line, or L <= 4 R2), ``seed`` is
        not an integer >= 0, ``dim`` is not 2 or 3, a fraction is outside its
        range, or the random placement fails.
    """
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, got dim = {dim!r}")
    phi = PHI[dim] if phi is None else phi
    phi_loose = PHI_LOOSE[dim] if phi_loose is None else phi_loose
    if isinstance(n, bool) or int(n) != n:
        raise ValueError(f"n must be an integer, got n = {n!r}")
    n = int(n)
    if not is_integer(seed) or seed < 0:
        # (numpy's "expected non-negative integer", or a TypeError, named no seed)
        raise ValueError(f"seed must be an integer >= 0, got seed = {seed!r}")
    r1, r2 = (float(r) for r in radii)
    if not (np.isfinite(r1) and np.isfinite(r2) and 0 < r1 < r2):
        raise ValueError(f"radii must satisfy 0 < R1 < R2, got radii = {tuple(radii)!r}")
    phi_max, loose_max = (0.91, 0.6) if dim == 2 else (0.74, 0.35)
    if not 0.1 < phi < phi_max:
        raise ValueError(f"phi must be in (0.1, {phi_max}) for dim = {dim}, got phi = {phi}")
    if n < 6 or n % 2:
        hint = f" ({smallest_n(phi, (r1, r2), dim)})" if n < 6 else ""
        raise ValueError(f"n must be an even number >= 6 (equal numbers of both radii), "
                         f"got n = {n}{hint}")
    if not 0.05 < phi_loose <= loose_max:
        raise ValueError(f"phi_loose must be in (0.05, {loose_max}] for dim = {dim}, got "
                         f"phi_loose = {phi_loose}")
    rng = np.random.default_rng(seed)
    width = box_width(n, phi, (r1, r2), dim)
    n_top = top_count(width, (r1, r2), dim)
    if n_top >= n - 2:
        raise ValueError(f"n = {n} is too small for a top {'layer' if dim == 3 else 'line'} "
                         f"of {n_top} {'spheres' if dim == 3 else 'disks'} "
                         f"({smallest_n(phi, (r1, r2), dim)})")
    if width <= 4.0 * r2:
        # the pair style refuses a contact with two periodic images of one partner
        raise ValueError(f"n = {n} is too small: the periodic width L = {width:.4g} is not "
                         f"above 4 R2 = {4.0 * r2:g}, so a {'sphere' if dim == 3 else 'disk'} "
                         f"could touch two periodic images of another "
                         f"({smallest_n(phi, (r1, r2), dim)})")
    n_bulk_each = n // 2 - n_top // 2
    bulk_r = np.array([r2] * n_bulk_each + [r1] * n_bulk_each)
    if dim == 2:
        height = float(np.sum(np.pi * bulk_r ** 2)) / (phi_loose * width)
    else:
        height = float(np.sum(4.0 / 3.0 * np.pi * bulk_r ** 3)) / (phi_loose * width ** 2)

    if dim == 2:      # overlaps tested on a cell grid: the packing of the all-pairs test
        xs, ys = _random_sequential_addition(bulk_r, width, height, rng, max_tries,
                                             phi_loose)
        zs = [0.0] * len(xs)
    else:             # spheres: every draw tested against all spheres placed
        xs, ys, zs = [], [], []
        for r in bulk_r:       # large first: random sequential addition
            for _ in range(max_tries):
                x = rng.uniform(0.0, width)
                y = rng.uniform(r, r + height)
                z = rng.uniform(0.0, width)
                if xs:
                    dx = x - np.asarray(xs)
                    dx -= width * np.round(dx / width)
                    dy = y - np.asarray(ys)
                    rr = bulk_r[:len(xs)] + r
                    dz = z - np.asarray(zs)
                    dz -= width * np.round(dz / width)
                    d2 = dx * dx + dy * dy + dz * dz
                    if np.any(d2 < rr * rr):
                        continue
                xs.append(x)
                ys.append(y)
                zs.append(z)
                break
            else:
                raise ValueError(f"could not place {len(bulk_r)} loose spheres at "
                                 f"phi_loose = {phi_loose} (placed {len(xs)})")
    order = rng.permutation(len(bulk_r))       # mix types among IDs
    bulk = np.column_stack([xs, ys, zs][:dim])[order]
    br = bulk_r[order]

    y_line = float(np.max(bulk[:, 1] + br)) + 0.05 + r2
    tpos, top_r = _top_layer(width, n_top, y_line, (r1, r2), dim)

    radius = np.concatenate([br, top_r])
    typ = np.where(radius == r1, 1, 2).astype(np.int64)
    top = np.concatenate([np.zeros(br.size, bool), np.ones(n_top, bool)])
    return Packing(positions=np.concatenate([bulk, tpos]), radii=radius, types=typ, top=top,
                   width=float(width),
                   ylo=-1.0, yhi=float(y_line + r2 + width), seed=int(seed))



def _random_sequential_addition(radii, width, height, rng, max_tries, phi_loose):
    """Centres of disks ``radii`` placed one by one at random in [0, L) x [R, R + H), no overlaps.

    Each disk draws (x, y) uniformly until it overlaps no disk placed before it
    (periodic in x), at most ``max_tries`` draws. The overlap test of a draw
    is ``dx^2 + dy^2 < (R_i + R_j)^2`` with dx the minimum image, evaluated
    only for the disks of the 3 x 3 cells around it on a grid of cells wider
    than the largest contact distance 2 max(R): a disk it overlaps lies in
    one of them, so every draw is accepted or rejected exactly as by the test
    against all disks (the same expression, the same draws, the same packing
    bit for bit) at a cost per draw independent of the number placed (the
    full test made N = 6400 take minutes).

    Returns
    -------
    xs, ys : list of float

    Raises
    ------
    ValueError
        If a disk finds no place within ``max_tries`` draws.
    """
    reach = 2.0 * float(np.max(radii)) * (1.0 + 1e-9) + 1e-12
    ncx = int(width // reach)
    ncx = ncx if ncx >= 3 else 1          # narrower: one column, every disk is a neighbour
    cx = width / ncx
    cy = reach
    ncy = int((float(np.max(radii)) + height) // cy) + 1
    cells = [[] for _ in range(ncx * ncy)]
    cols = (0,) if ncx == 1 else (-1, 0, 1)
    rad = [float(r) for r in radii]
    xs, ys = [], []
    for k, r in enumerate(rad):
        for _ in range(max_tries):
            x = rng.uniform(0.0, width)
            y = rng.uniform(r, r + height)
            ix = min(int(x / cx), ncx - 1)
            iy = min(int(y / cy), ncy - 1)
            if _overlaps(x, y, r, ix, iy, cells, cols, ncx, ncy, xs, ys, rad, width):
                continue
            xs.append(x)
            ys.append(y)
            cells[iy * ncx + ix].append(k)
            break
        else:
            raise ValueError(f"could not place {len(radii)} loose disks at "
                             f"phi_loose = {phi_loose} (placed {len(xs)})")
    return xs, ys


def _overlaps(x, y, r, ix, iy, cells, cols, ncx, ncy, xs, ys, rad, width):
    """Whether a disk (x, y, r) in cell (ix, iy) overlaps a placed disk of the 3 x 3 cells.

    Scalar double arithmetic, operation for operation the vectorised test
    ``dx -= L round(dx / L); dx^2 + dy^2 < (r + R_j)^2`` (round half to even
    in both), so the decisions are the same bit for bit.
    """
    for di in (-1, 0, 1):
        row = iy + di
        if not 0 <= row < ncy:
            continue
        for dj in cols:
            for j in cells[row * ncx + (ix + dj) % ncx]:
                dx = x - xs[j]
                dx -= width * round(dx / width)
                dy = y - ys[j]
                rr = rad[j] + r
                if dx * dx + dy * dy < rr * rr:
                    return True
    return False


def write_data(packing, path):
    """Write a packing as a LAMMPS data file (atom_style sphere, 2D or 3D).

    Read it with::

        fix hist all property/atom i2_mindlin_partner 8 d2_mindlin_t 8 d_mindlin_wall_t ghost no
        fix topflag all property/atom i_top ghost no
        read_data FILE fix hist NULL hist fix topflag NULL topflag
        set group all mass 1.0

    and spheres (``dimension 3``, no history section: the pair and the wall
    fix keep their own, starting from zero) with::

        fix topflag all property/atom i_top ghost no
        read_data FILE fix topflag NULL topflag

    Parameters
    ----------
    packing : Packing
    path : str or os.PathLike
        Output file; written to a temporary name and renamed (atomic; the
        temporary file is removed if writing or renaming fails).
    """
    p = packing
    dim3 = p.dim == 3
    lines = [
        f"LAMMPS data file: remote-trigger packing, N = {p.n}, N_top = {p.n_top}, "
        f"seed = {p.seed}" + (", dimension 3" if dim3 else ""),
        "",
        f"{p.n} atoms",
        "2 atom types",
        "",
        f"0 {p.width!r} xlo xhi",
        f"{p.ylo!r} {p.yhi!r} ylo yhi",
        f"0 {p.width!r} zlo zhi" if dim3 else "-0.5 0.5 zlo zhi",
        "",
        "Atoms # sphere",
        "",
    ]
    for k in range(p.n):
        z = repr(float(p.positions[k, 2])) if dim3 else "0"
        lines.append(f"{k + 1} {int(p.types[k])} {float(2.0 * p.radii[k])!r} 1 "
                     f"{float(p.positions[k, 0])!r} {float(p.positions[k, 1])!r} {z}")
    if not dim3:
        zeros = " ".join(["0"] * (2 * HISTORY_SLOTS + 1))
        lines += ["", "hist # i_mindlin_partner d_mindlin_t d_mindlin_wall_t", ""]
        lines += [f"{k + 1} {zeros}" for k in range(p.n)]
    lines += ["", "topflag # i_top", ""]
    lines += [f"{k + 1} {int(p.top[k])}" for k in range(p.n)]
    write_text_atomic(path, "\n".join(lines) + "\n")
