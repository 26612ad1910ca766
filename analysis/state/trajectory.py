"""Trajectories: LAMMPS dump files read with MDAnalysis, and D(t) (Eq. 8) from them.

The driver's runs record D(t) with LAMMPS' ``compute msd`` in float64; a
user's own run may only have a trajectory dump. :func:`open_dump` reads it
with MDAnalysis (``LAMMPSDUMP`` topology and coordinates, image flags
unwrapped) and :class:`DisplacementFromStart` is an MDAnalysis
``AnalysisBase``: D(t) = (1/N) sum_i |r_i(t) - r_i(t_0)|^2 over the disks
(x, y; Eq. 8 of the paper), accumulated in float64.

**Precision.** MDAnalysis holds positions in float32: a coordinate x is
known to its float32 spacing, 2^-23 |x| (6e-7 at |x| = 5), so D below
:func:`float32_floor` (~1e-13 for a packing of size ~10) is round-off of
the reader, not motion: |D_float32 - D| <= 2 sqrt(D E) + E with E =
:func:`float32_floor`. The instability of Fig. 4 starts at D ~ 1e-26 and
Fig. 5's noise is ~1e-25: those decades exist only in the float64 record
(``compute msd``). Measured in tests/driver/test_trajectory.py (N = 20,
E = 2.1e-13): the bound holds on every frame; at D = 1e-8 .. 8e-7 the
relative difference to ``compute msd`` is at most 1.8e-4; where the
float64 D is ~1e-25, MDAnalysis gives 0 or values of order E.
"""
import warnings

import numpy as np
from MDAnalysis.analysis.base import AnalysisBase

__all__ = ["open_dump", "open_universe", "DisplacementFromStart", "float32_floor",
           "touching_pairs", "ContactNumbers"]


def open_dump(path, unwrap=True, dt=None):
    """An MDAnalysis ``Universe`` of a LAMMPS dump trajectory.

    Parameters
    ----------
    path : str
        ``dump custom`` file with columns ``id type x y z`` (and ``ix iy iz``
        to unwrap periodic images).
    unwrap : bool
        Unwrap positions with the image flags (needed for displacements
        across the periodic seam).
    dt : float, optional
        The run's time step: ``ts.time`` = step x dt (LAMMPS time units).
        Default: time = step (a dump carries no time step).

    Returns
    -------
    MDAnalysis.Universe
        Positions in float32, shifted by the box's lower corner (as
        MDAnalysis does for LAMMPS dumps; displacements are unaffected).

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist (named).
    ValueError
        If the first snapshot lacks the coordinate columns ``x y z`` (or
        MDAnalysis' scaled / unwrapped ones) or, with ``unwrap``, the image
        flags ``ix iy iz``: one line naming what it lacks and what to do (an
        equilibrium dump of the driver is opened with :func:`open_universe`);
        from MDAnalysis, for an otherwise unreadable dump.
    """
    import MDAnalysis as mda

    columns = _first_columns(path, "dump")
    coords = [c for c in (("x", "y", "z"), ("xs", "ys", "zs"), ("xu", "yu", "zu"),
                          ("xsu", "ysu", "zsu")) if all(a in columns for a in c)]
    lack = [] if coords else [a for a in ("x", "y", "z") if a not in columns]
    lack += [a for a in ("ix", "iy", "iz") if unwrap and a not in columns]
    if lack:
        # (MDAnalysis said "Trajectory must have image flag in order to unwrap.")
        if _is_equilibrium_dump(path):
            todo = ("it is an equilibrium dump (it has a .json sidecar): open it with "
                    "open_universe(path), or read_dump for float64 positions")
        elif coords:
            todo = ("add them to the dump (dump custom ... ix iy iz), or pass unwrap=False "
                    "(displacements across the periodic seam are then wrong)")
        else:
            todo = "write the dump with columns id type x y z ix iy iz (dump custom)"
        raise ValueError(f"{path}: the dump lacks the column(s) {' '.join(lack)} (open_dump "
                         f"reads id type x y z, and the image flags ix iy iz to unwrap); {todo}")
    with warnings.catch_warnings():
        # masses are guessed (1.0, as in the model: set group all mass 1.0)
        warnings.filterwarnings("ignore", message="Guessed all Masses")
        return mda.Universe(path, topology_format="LAMMPSDUMP", format="LAMMPSDUMP",
                            unwrap_images=unwrap, dt=1.0 if dt is None else float(dt))


_SPHERES = ("open_universe supports packings of disks only; for spheres use "
            "read_dump3d (float64 state) or MDAnalysis on a dynamics trajectory (open_dump)")


def _require_disks(path):
    """ValueError naming an equilibrium dump of spheres (:data:`_SPHERES`)."""
    from remote_trigger.analysis.state.dumpfile import dump_dimension

    if dump_dimension(path) == 3:
        # (it was read_dump's "missing dump columns" or "use read_dump3d")
        raise ValueError(f"{path}: a dump of spheres: {_SPHERES}")


def _topology(path):
    """(ids, types, radii, masses, top, positions (N, 2), box_lo, box_hi) in id order."""
    from remote_trigger.analysis.state.datafile import read_data
    from remote_trigger.analysis.state.dumpfile import read_dump

    if _is_equilibrium_dump(path):
        _require_disks(path)
        st = read_dump(path, require_contacts=False)
        top = st.external[:, 1] != 0.0          # -F_y on the top line
        return (st.ids, st.types, st.radii, st.masses, top, st.positions,
                np.append(st.box_lo, -0.5), np.append(st.box_hi, 0.5))
    d = read_data(path)
    if d.positions is None:
        raise ValueError(f"{path!r} is not a data file of atom_style sphere (its Atoms "
                         f"section is {d.style!r}): no radii")
    if d.dimension == 3:
        # (its spheres became disks at their x, y)
        raise ValueError(f"{path}: a data file of spheres (z != 0): {_SPHERES}")
    top = np.zeros(d.n, bool) if d.top is None else d.top
    return d.ids, d.types, d.radii, d.masses, top, d.positions, d.box_lo, d.box_hi


def _first_columns(path, what):
    """Column names of a dump's first ``ITEM: ATOMS`` line.

    Raises FileNotFoundError naming ``what`` and the path if the file does
    not exist, ValueError if it holds no snapshot.
    """
    import os

    from MDAnalysis.lib.util import anyopen

    if not os.path.isfile(path):
        raise FileNotFoundError(f"{what} file not found: {path}")
    with anyopen(os.fspath(path)) as fh:          # (compressed dumps as MDAnalysis reads them)
        for line in fh:
            if line.startswith("ITEM: ATOMS"):
                return line.split()[2:]
    raise ValueError(f"{path!r}: no snapshot found (not a LAMMPS dump?)")


def _first_frame_ids(path):
    """Atom ids of a dump's first snapshot, read up to its last atom line only."""
    with open(path) as fh:
        n = col = None
        for line in fh:
            if line.startswith("ITEM: NUMBER OF ATOMS"):
                n = int(next(fh).split()[0])
            elif line.startswith("ITEM: ATOMS"):
                names = line.split()[2:]
                if "id" not in names or n is None:
                    raise ValueError(f"{path!r}: no id column in its first snapshot")
                col = names.index("id")
                return np.array([int(next(fh).split()[col]) for _ in range(n)], np.int64)
    raise ValueError(f"{path!r}: no snapshot found")


def _is_equilibrium_dump(path):
    """True for an equilibrium dump of the driver (its ``.json`` sidecar exists)."""
    import os

    return os.path.exists(os.fspath(path) + ".json")


def open_universe(topology, trajectory=None, dt=None, unwrap=True):
    """Any output of the project as one MDAnalysis ``Universe``.

    Parameters
    ----------
    topology : str
        A data file written by the driver (``relax/equilibrium.data``,
        ``ramp/step_*.data``, ``packing.data``; ``atom_style sphere``) or an
        equilibrium dump with its ``.json`` sidecar (``*.dump``). Gives the
        disks (ids, types, radii, masses), the top line and the first frame.
    trajectory : str or list of str, optional
        Frames: equilibrium dumps of a ramp (``ramp/step_*.dump``, each read
        in float64 by :func:`remote_trigger.analysis.state.dumpfile.read_dump`, then
        held by MDAnalysis' ``MemoryReader``), or ``dump custom`` trajectories
        of a dynamics run with columns ``id type x y z`` (+ ``ix iy iz``),
        read by MDAnalysis' ``LAMMPSDUMP`` reader (several files are
        chained). Default: the topology's own positions, one frame.
    dt : float, optional
        Time step of a dynamics trajectory (``ts.time`` = step x dt).
    unwrap : bool
        Unwrap a dynamics trajectory with its image flags.

    Returns
    -------
    MDAnalysis.Universe
        One residue per disk; segments ``bulk`` and ``top``
        (``u.select_atoms("segid top")`` is the top line); ``radii``,
        ``masses``, ``types``, ``ids`` (atoms in id order). Positions are
        float32 (MDAnalysis), z = 0, shifted by the box's lower corner as
        MDAnalysis does for LAMMPS dumps (here y + 1 for the driver's box);
        ``dimensions`` = box lengths. float32 resolves positions to ~1e-6 of
        the box: enough for contacts and displacements above
        :func:`float32_floor`, not for forces or K (docs/analysis.md).

    Raises
    ------
    FileNotFoundError
        If ``topology`` or a trajectory file does not exist (named).
    ValueError
        A packing of spheres (a dump of spheres or a 3D data file: not
        supported here, disks only), an unreadable or unchecked data file or
        dump (one line naming it), frames with other atom ids than the
        topology, or a list mixing equilibrium dumps and dynamics
        trajectories.
    """
    import os

    import MDAnalysis as mda
    from MDAnalysis.coordinates.memory import MemoryReader

    paths = [] if trajectory is None else (
        [trajectory] if isinstance(trajectory, (str, bytes)) or not hasattr(
            trajectory, "__iter__") else list(trajectory))
    for what, p in [("topology", topology)] + [("trajectory", p) for p in paths]:
        if not os.path.isfile(p):
            # (a missing topology was "cannot read the data file")
            raise FileNotFoundError(f"{what} file not found: {p}")
    ids, types, radii, masses, top, pos, lo, hi = _topology(topology)
    n = ids.size
    u = mda.Universe.empty(n, n_residues=n, n_segments=2, atom_resindex=np.arange(n),
                           residue_segindex=top.astype(np.int64), trajectory=False)
    u.add_TopologyAttr("ids", ids)
    u.add_TopologyAttr("types", [str(t) for t in types])
    u.add_TopologyAttr("radii", radii)
    u.add_TopologyAttr("masses", masses)
    u.add_TopologyAttr("resids", ids)
    u.add_TopologyAttr("segids", ["bulk", "top"])
    lengths = np.where(np.isfinite(hi - lo), hi - lo, 1.0)
    box = np.concatenate([lengths, [90.0, 90.0, 90.0]])
    kinds = {_is_equilibrium_dump(p) for p in paths}
    if len(kinds) > 1:
        raise ValueError("trajectory mixes equilibrium dumps (with a .json sidecar) and "
                         "dynamics trajectories; open them separately")
    if not paths or kinds == {True}:
        frames = [(pos, lo, hi)]
        if paths:
            from remote_trigger.analysis.state.dumpfile import read_dump

            frames = []
            for p in paths:
                _require_disks(p)
                st = read_dump(p, require_contacts=False)
                if not np.array_equal(st.ids, ids):
                    raise ValueError(f"{p!r} holds other atoms than {topology!r}")
                frames.append((st.positions, np.append(st.box_lo, lo[2]),
                               np.append(st.box_hi, hi[2])))
        coords = np.zeros((len(frames), n, 3), np.float32)
        dims = np.zeros((len(frames), 6), np.float32)
        for k, (x, flo, fhi) in enumerate(frames):
            coords[k, :, :2] = x - flo[:2]
            dims[k] = np.concatenate([np.where(np.isfinite(fhi - flo), fhi - flo, 1.0),
                                      [90.0, 90.0, 90.0]])
        u.load_new(coords, format=MemoryReader, dimensions=dims if len(frames) > 1 else box)
        return u
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Reader has no dt information")
        warnings.filterwarnings("ignore", message="Guessed all Masses")
        for p in paths:          # the reader orders atoms by id: they must be these ids
            if not np.array_equal(np.sort(_first_frame_ids(p)), ids):
                raise ValueError(f"{p!r} holds other atoms than {topology!r}")
        u.load_new(paths if len(paths) > 1 else paths[0], format="LAMMPSDUMP",
                   unwrap_images=unwrap, dt=1.0 if dt is None else float(dt))
    return u


def float32_floor(positions):
    """Bound E on the mean-square rounding error of a displacement in float32.

    Each coordinate of a snapshot is rounded by at most h, half its float32
    spacing; a displacement (difference of two snapshots) by at most 2h per
    coordinate. E = mean over disks of (2 h_x)^2 + (2 h_y)^2 bounds the
    mean-square error eps of the displacements, so that (Cauchy-Schwarz)
    |D_float32 - D| <= 2 sqrt(D E) + E: D is resolved only well above E.

    Parameters
    ----------
    positions : ndarray, shape (N, 2) or (N, 3)
        Positions as MDAnalysis holds them (only x, y are used).

    Returns
    -------
    float
    """
    x = np.abs(np.asarray(positions, dtype=np.float32)[:, :2])
    half = 0.5 * np.spacing(x).astype(np.float64)
    return float(np.mean(np.sum((2.0 * half) ** 2, axis=1)))


class DisplacementFromStart(AnalysisBase):
    """D(t) of Eq. 8 from a trajectory, as an MDAnalysis analysis.

    ``DisplacementFromStart(atomgroup).run(start=..., stop=..., step=...)``;
    the first analysed frame is the reference r_i(t_0).

    Attributes
    ----------
    results.step : ndarray of int64, shape (n_frames,)
        LAMMPS time step of each frame.
    results.D : ndarray of float64, shape (n_frames,)
        (1/N) sum_i |r_i - r_i(t_0)|^2 over x, y (length^2).
    results.floor : float
        :func:`float32_floor` of the reference frame: D below it is not
        resolved.
    """

    def __init__(self, atomgroup, **kwargs):
        super().__init__(atomgroup.universe.trajectory, **kwargs)
        self._ag = atomgroup

    def _prepare(self):
        self._x0 = None
        self.results.step = np.zeros(self.n_frames, dtype=np.int64)
        self.results.D = np.zeros(self.n_frames, dtype=np.float64)

    def _single_frame(self):
        x = self._ag.positions[:, :2].astype(np.float64)
        if self._x0 is None:
            self._x0 = x.copy()
            self.results.floor = float32_floor(self._ag.positions)
        self.results.step[self._frame_index] = int(self._ts.data.get("step", self._ts.frame))
        self.results.D[self._frame_index] = float(np.mean(np.sum((x - self._x0) ** 2, axis=1)))


def touching_pairs(positions, radii, box_x, span_y):
    """Touching disks found with ``MDAnalysis.lib.distances.capped_distance``.

    Periodic along x (box length ``box_x``), not along y: the search box is
    made 4 ``span_y`` tall so that no pair meets across it.

    Parameters
    ----------
    positions : array_like, shape (N, 2) or (N, 3)
        Disk centres, y >= 0 (x is wrapped by MDAnalysis).
    radii : array_like, shape (N,)
    box_x : float
        Periodic length along x.
    span_y : float
        Largest y + radius (> 0).

    Returns
    -------
    pairs : ndarray of int64, shape (M, 2)
        i < j, sorted.
    overlap : ndarray, shape (M,)
        R_i + R_j - |r_i - r_j| > 0 (length). MDAnalysis computes distances
        from float32 coordinates: measured 7.5e-9 error at |x| = 5 (float32
        spacing 4.8e-7), so overlaps are resolved to ~1e-6 of the box size,
        enough to find contacts of the model (overlaps 1e-5 .. 1e-2), not to
        feed forces or a Jacobian (float64 only:
        :mod:`~remote_trigger.analysis.state.state`).
    """
    from MDAnalysis.lib.distances import capped_distance

    pos = np.zeros((len(radii), 3))
    pos[:, :2] = np.asarray(positions, dtype=np.float64)[:, :2]
    r = np.asarray(radii, dtype=np.float64)
    box = np.array([float(box_x), 4.0 * float(span_y), 4.0 * float(span_y), 90.0, 90.0, 90.0])
    pairs, dist = capped_distance(pos, pos, max_cutoff=2.0 * float(r.max()), box=box)
    keep = pairs[:, 0] < pairs[:, 1]
    pairs, dist = pairs[keep], dist[keep]
    overlap = r[pairs[:, 0]] + r[pairs[:, 1]] - dist
    touch = overlap > 0.0
    pairs, overlap = pairs[touch].astype(np.int64), overlap[touch]
    order = np.lexsort((pairs[:, 1], pairs[:, 0]))
    return pairs[order], overlap[order]


class ContactNumbers(AnalysisBase):
    """Contacts per frame of a trajectory, as an MDAnalysis analysis.

    ``ContactNumbers(atomgroup, radii, top=None).run()`` counts the touching
    disk pairs of every frame (:func:`touching_pairs`; periodic in x with the
    frame's box length) and gives the mean coordination number and, with a
    ``top`` group, the mean height of the top line.

    Parameters
    ----------
    atomgroup : MDAnalysis.AtomGroup
        The disks (positions shifted as MDAnalysis reads LAMMPS dumps: the
        box's lower corner at 0).
    radii : array_like, shape (N,)
        In the atom group's order (a dump carries no radius).
    top : array_like of bool, shape (N,), optional
        The disks of the top line.

    Attributes
    ----------
    results.step : ndarray of int64, shape (n_frames,)
    results.n_contacts : ndarray of int64, shape (n_frames,)
        Touching disk-disk pairs.
    results.coordination : ndarray, shape (n_frames,)
        Mean contacts per disk, 2 n_contacts / N (disk-disk only).
    results.top_y : ndarray, shape (n_frames,)
        Mean y of the top line (NaN without ``top``).
    """

    def __init__(self, atomgroup, radii, top=None, **kwargs):
        super().__init__(atomgroup.universe.trajectory, **kwargs)
        self._ag = atomgroup
        self._radii = np.asarray(radii, dtype=np.float64)
        if self._radii.shape != (atomgroup.n_atoms,):
            raise ValueError(f"radii must have shape ({atomgroup.n_atoms},), got "
                             f"{self._radii.shape}")
        self._top = None if top is None else np.asarray(top, dtype=bool)

    def _prepare(self):
        self.results.step = np.zeros(self.n_frames, dtype=np.int64)
        self.results.n_contacts = np.zeros(self.n_frames, dtype=np.int64)
        self.results.coordination = np.zeros(self.n_frames)
        self.results.top_y = np.full(self.n_frames, np.nan)

    def _single_frame(self):
        x = self._ag.positions[:, :2].astype(np.float64)
        span = float(np.max(x[:, 1] + self._radii))
        pairs, _ = touching_pairs(x, self._radii, float(self._ts.dimensions[0]), span)
        k = self._frame_index
        self.results.step[k] = int(self._ts.data.get("step", self._ts.frame))
        self.results.n_contacts[k] = len(pairs)
        self.results.coordination[k] = 2.0 * len(pairs) / len(self._radii)
        if self._top is not None:
            self.results.top_y[k] = float(np.mean(x[self._top, 1]))
