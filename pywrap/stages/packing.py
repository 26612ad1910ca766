"""Seeded generator of the loose initial packing (docs/model.md section 1).

The scene is N bidisperse disks (radii R1 = 0.5 and R2 = 0.7, equal numbers,
mass m = 1 each) in a box periodic in x, above a flat wall at y = 0. The
upper boundary, the group ``top``, is a line of N_top ordinary free disks
placed above the bulk; the decks load them with (F_x + f(t), -F_y).

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
* **Top flag.** The membership of ``top`` travels with the data file as the
  integer per-atom property ``i_top`` (section ``topflag``), so that decks
  define the group with ``group top variable istop``.

The data file has ``atom_style sphere`` lines ``id type diameter density x y z``
(density 1; decks then ``set group all mass 1.0``), an empty-history section
``hist`` for ``read_data FILE fix hist NULL hist`` and the ``topflag`` section.
"""
from dataclasses import dataclass
import math

import numpy as np
from remote_trigger.analysis.output import write_text_atomic

#: radii of the two disk types (type 1 = small, type 2 = large)
RADII = (0.5, 0.7)
#: contact-history columns per disk (conventions.md section 1)
HISTORY_SLOTS = 8


@dataclass(frozen=True)
class Packing:
    """A generated packing, atoms ordered by ascending ID (ID = index + 1).

    Attributes
    ----------
    positions : ndarray, shape (N, 2)
        Disk centres x, y (length units, 2 R1 = 1).
    radii : ndarray, shape (N,)
        0.5 or 0.7.
    types : ndarray of int, shape (N,)
        LAMMPS atom types, 1 = small, 2 = large.
    top : ndarray of bool, shape (N,)
        True for the disks of the upper boundary line.
    width : float
        Periodic box length L along x.
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
    def n_top(self):
        """Number of disks of the ``top`` group."""
        return int(np.count_nonzero(self.top))


def box_width(n, phi=0.82, radii=RADII):
    """Periodic width L such that N disks at packing fraction phi fill an L x L box.

    Parameters
    ----------
    n : int
        Total number of disks (half of each radius).
    phi : float
        Target packing fraction.

    Returns
    -------
    float
        L = sqrt(N pi (R1^2 + R2^2) / 2 / phi).
    """
    return math.sqrt(n * math.pi * (radii[0] ** 2 + radii[1] ** 2) / 2.0 / phi)


def top_count(width, radii=RADII):
    """Number of top-line disks for a box of width L: 2 floor(L / (2 (R1 + R2))), >= 2."""
    return max(2, 2 * int(width // (2.0 * (radii[0] + radii[1]))))


def generate(n, seed=0, phi=0.82, phi_loose=0.55, max_tries=200000, radii=RADII):
    """Generate a loose, non-overlapping bidisperse packing with a top line.

    Parameters
    ----------
    n : int
        Total number of disks, even, >= 6 (bulk plus top line).
    seed : int
        Seed of :func:`numpy.random.default_rng`; the same seed gives the same
        packing bit for bit.
    phi : float
        Packing fraction used to choose the width L (see :func:`box_width`).
    phi_loose : float
        Packing fraction of the random loose bulk, in (0, 0.6].
    max_tries : int
        Random trials per disk before giving up.
    radii : tuple of float
        (R1, R2), 0 < R1 < R2; default (0.5, 0.7) (docs/model.md section 1).

    Returns
    -------
    Packing

    Raises
    ------
    ValueError
        If ``n`` is odd or too small, or a fraction is outside its range, or
        the random placement fails.
    """
    if isinstance(n, bool) or int(n) != n:
        raise ValueError(f"n must be an integer, got n = {n!r}")
    n = int(n)
    if n < 6 or n % 2:
        raise ValueError(f"n must be an even number >= 6 (equal numbers of both radii), "
                         f"got n = {n}")
    r1, r2 = (float(r) for r in radii)
    if not (np.isfinite(r1) and np.isfinite(r2) and 0 < r1 < r2):
        raise ValueError(f"radii must satisfy 0 < R1 < R2, got radii = {tuple(radii)!r}")
    if not 0.1 < phi < 0.91:
        raise ValueError(f"phi must be in (0.1, 0.91), got phi = {phi}")
    if not 0.05 < phi_loose <= 0.6:
        raise ValueError(f"phi_loose must be in (0.05, 0.6], got phi_loose = {phi_loose}")
    rng = np.random.default_rng(seed)
    width = box_width(n, phi, (r1, r2))
    n_top = top_count(width, (r1, r2))
    if n_top >= n - 2:
        raise ValueError(f"n = {n} is too small for a top line of {n_top} disks")
    n_bulk_each = n // 2 - n_top // 2
    bulk_r = np.array([r2] * n_bulk_each + [r1] * n_bulk_each)
    area = float(np.sum(np.pi * bulk_r ** 2))
    height = area / (phi_loose * width)

    xs, ys = _random_sequential_addition(bulk_r, width, height, rng, max_tries, phi_loose)
    order = rng.permutation(len(bulk_r))       # mix types among IDs
    bx = np.asarray(xs)[order]
    by = np.asarray(ys)[order]
    br = bulk_r[order]

    top_r = np.array([r2 if k % 2 == 0 else r1 for k in range(n_top)])
    y_line = float(np.max(by + br)) + 0.05 + r2
    tx = (np.arange(n_top) + 0.5) * width / n_top
    ty = np.full(n_top, y_line)

    x = np.concatenate([bx, tx])
    y = np.concatenate([by, ty])
    radius = np.concatenate([br, top_r])
    typ = np.where(radius == r1, 1, 2).astype(np.int64)
    top = np.concatenate([np.zeros(bx.size, bool), np.ones(n_top, bool)])
    return Packing(positions=np.column_stack([x, y]), radii=radius, types=typ, top=top,
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
    """Write a packing as a LAMMPS data file (atom_style sphere, 2D).

    Read it with::

        fix hist all property/atom i2_mindlin_partner 8 d2_mindlin_t 8 d_mindlin_wall_t ghost no
        fix topflag all property/atom i_top ghost no
        read_data FILE fix hist NULL hist fix topflag NULL topflag
        set group all mass 1.0

    Parameters
    ----------
    packing : Packing
    path : str or os.PathLike
        Output file; written to a temporary name and renamed (atomic; the
        temporary file is removed if writing or renaming fails).
    """
    p = packing
    lines = [
        f"LAMMPS data file: remote-trigger packing, N = {p.n}, N_top = {p.n_top}, "
        f"seed = {p.seed}",
        "",
        f"{p.n} atoms",
        "2 atom types",
        "",
        f"0 {p.width!r} xlo xhi",
        f"{p.ylo!r} {p.yhi!r} ylo yhi",
        "-0.5 0.5 zlo zhi",
        "",
        "Atoms # sphere",
        "",
    ]
    for k in range(p.n):
        lines.append(f"{k + 1} {int(p.types[k])} {float(2.0 * p.radii[k])!r} 1 "
                     f"{float(p.positions[k, 0])!r} {float(p.positions[k, 1])!r} 0")
    zeros = " ".join(["0"] * (2 * HISTORY_SLOTS + 1))
    lines += ["", "hist # i_mindlin_partner d_mindlin_t d_mindlin_wall_t", ""]
    lines += [f"{k + 1} {zeros}" for k in range(p.n)]
    lines += ["", "topflag # i_top", ""]
    lines += [f"{k + 1} {int(p.top[k])}" for k in range(p.n)]
    write_text_atomic(path, "\n".join(lines) + "\n")
