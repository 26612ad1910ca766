"""The contact history after atoms get new IDs (``delete_atoms``, whose
default ``compress yes`` renumbers the atoms left, ``reset_atoms id``).

The history names each partner by its atom ID. Before the pair made it
follow new IDs, two disks of a contact that survived could read different
histories after ``delete_atoms``: forces that did not sum to zero (a net
force of 45.6 on two disks, momentum not conserved). Now a run after
renumbering gives the forces of the same run without it (``compress no``)
to round-off (the contacts are summed in ascending partner ID, which the
new IDs may order otherwise), with either history storage, in 2D and 3D,
and after a restart file.
"""
import numpy as np
import pytest

from .lmputil import KN, KT, add_disk, add_sphere, new_lammps

BOX_2D = ["units lj", "dimension 2", "atom_style sphere", "atom_modify map array",
          "boundary p p p", "comm_modify vel yes", "region box block 0 12 0 12 -0.5 0.5",
          "create_box 2 box"]
#: the history in a fix property/atom, with room for the big particle's contacts
HIST = {2: "fix hist all property/atom i2_mindlin_partner 16 d2_mindlin_t 16 d_mindlin_wall_t "
           "ghost no",
        3: "fix hist all property/atom i2_mindlin_partner 16 d2_mindlin_tx 16 d2_mindlin_ty 16 "
           "d2_mindlin_tz 16 ghost no"}
BOX_3D = ["units lj", "atom_style sphere", "atom_modify map array", "boundary p p p",
          "comm_modify vel yes", "region box block 0 12 0 12 0 12", "create_box 2 box"]


#: the same in fix property/atom sections that LAMMPS reads back from a data
#: file (one array per section, rows short enough for read_data)
HIST_DATA = {2: ["fix hist all property/atom i2_mindlin_partner 8 d2_mindlin_t 8 "
                 "d_mindlin_wall_t ghost no"],
             3: ["fix hist all property/atom i2_mindlin_partner 8 ghost no"]
             + [f"fix hist{c} all property/atom d2_mindlin_t{c} 8 ghost no" for c in "xyz"]}


def cluster(lmp, dim, hist_fix, nsmall=14, seed=5, hist=None):
    """A big particle with nsmall small ones around it, each overlapping it a
    little, with random velocities: every contact builds a history (in the
    fix property/atom of ``HIST``, or the commands ``hist``, if hist_fix)."""
    lmp.commands_list(BOX_2D if dim == 2 else BOX_3D)
    if hist_fix:
        lmp.commands_list(hist or [HIST[dim]])
    c = np.full(dim, 6.0)
    rbig, rsmall = 2.0, 0.4
    d = rbig + rsmall - 0.004
    (add_disk if dim == 2 else add_sphere)(lmp, 2, rbig, *(c,) if dim == 3 else c)
    rng = np.random.default_rng(seed)
    if dim == 2:
        dirs = [np.array([np.cos(a), np.sin(a)]) for a in 2 * np.pi * np.arange(nsmall) / nsmall]
    else:   # well apart on the sphere: the golden spiral
        k = np.arange(nsmall) + 0.5
        z, phi = 1 - 2 * k / nsmall, np.pi * (1 + 5 ** 0.5) * k
        dirs = [np.array([np.sqrt(1 - zz * zz) * np.cos(p), np.sqrt(1 - zz * zz) * np.sin(p),
                          zz]) for zz, p in zip(z, phi)]
    for u in dirs:
        pos = c + d * u
        if dim == 2:
            add_disk(lmp, 1, rsmall, *pos)
        else:
            add_sphere(lmp, 1, rsmall, pos)
    for k in range(1, nsmall + 2):
        v = [float(u) for u in rng.uniform(-1e-2, 1e-2, 6)]
        if dim == 2:
            lmp.command(f"set atom {k} vx {v[0]!r} vy {v[1]!r} omega 0 0 {v[2]!r}")
        else:
            lmp.command(f"set atom {k} vx {v[0]!r} vy {v[1]!r} vz {v[2]!r} "
                        f"omega {v[3]!r} {v[4]!r} {v[5]!r}")
    lmp.commands_list(["pair_style mindlin/smooth", f"pair_coeff * * {KN!r} {KT!r} 1.0",
                       "fix nve all nve/sphere" + (" disc" if dim == 2 else ""),
                       "timestep 1e-5"] + (["fix 2d all enforce2d"] if dim == 2 else []))


def by_position(lmp):
    """Positions, forces and torques of the atoms, ordered by position (the
    same atoms carry other IDs in the two runs compared)."""
    n = lmp.extract_global("nlocal")
    x = np.array(lmp.numpy.extract_atom("x")[:n])
    f = np.array(lmp.numpy.extract_atom("f")[:n])
    t = np.array(lmp.numpy.extract_atom("torque")[:n])
    order = np.lexsort(x.T[::-1])
    return x[order], f[order], t[order]


def after_delete(dim, hist_fix, compress, restart=None):
    """The cluster run 300 steps, 3 small particles deleted (the first three
    IDs after the big one), then run 0 and run 200; returns what by_position
    gives after each."""
    lmp = new_lammps()
    cluster(lmp, dim, hist_fix)
    lmp.command("run 300")
    if restart is not None:
        lmp.command(f"write_restart {restart}")
        lmp.close()
        lmp = new_lammps()
        lmp.commands_list([f"read_restart {restart}", "comm_modify vel yes"]
                          + ([HIST[dim]] if hist_fix else [])
                          + ["fix nve all nve/sphere" + (" disc" if dim == 2 else ""),
                             "timestep 1e-5"] + (["fix 2d all enforce2d"] if dim == 2 else []))
    lmp.command("group gone id 2 3 4")
    lmp.command(f"delete_atoms group gone compress {compress}")
    lmp.command("run 0")
    first = by_position(lmp)
    lmp.command("run 200")
    second = by_position(lmp)
    lmp.close()
    return first, second


@pytest.mark.parametrize("dim, hist_fix", [(2, False), (2, True), (3, False), (3, True)])
def test_history_follows_new_ids(dim, hist_fix):
    kept, kept_later = after_delete(dim, hist_fix, "no")
    renumbered, renumbered_later = after_delete(dim, hist_fix, "yes")
    for a, b in ((kept, renumbered), (kept_later, renumbered_later)):
        np.testing.assert_allclose(b[0], a[0], rtol=0, atol=1e-12)
        scale = np.abs(a[1]).max()
        assert scale > 1.0
        np.testing.assert_allclose(b[1], a[1], rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(b[2], a[2], rtol=0, atol=1e-12 * scale)
        # Newton's third law: no net force (it was 45.6 on two disks)
        assert np.abs(b[1].sum(axis=0)).max() < 1e-12 * scale


def test_history_follows_new_ids_after_a_restart_file(tmp_path):
    kept, _ = after_delete(3, False, "no")
    renumbered, _ = after_delete(3, False, "yes", restart=str(tmp_path / "c.restart"))
    np.testing.assert_allclose(renumbered[1], kept[1], rtol=0,
                               atol=1e-12 * np.abs(kept[1]).max())


def test_history_follows_reset_atoms_id():
    """reset_atoms id sort yes numbers the atoms by position: the same forces."""
    out = []
    for reset in (False, True):
        lmp = new_lammps()
        cluster(lmp, 3, False)
        lmp.command("run 300")
        if reset:
            lmp.command("reset_atoms id sort yes")
        lmp.command("run 0")
        out.append(by_position(lmp))
        lmp.close()
    scale = np.abs(out[0][1]).max()
    np.testing.assert_allclose(out[1][1], out[0][1], rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(out[1][2], out[0][2], rtol=0, atol=1e-12 * scale)


def _read_after(tmp_path, dim, datafile, between, name):
    """A new LAMMPS reads ``datafile`` with its history, runs the commands
    ``between``, then run 0; returns its log."""
    log = tmp_path / f"log.{name}"
    lmp = new_lammps(log=str(log))
    lmp.commands_list(["units lj", "atom_style sphere", "atom_modify map array",
                       "boundary p p p", "comm_modify vel yes"]
                      + (["dimension 2"] if dim == 2 else [])
                      + HIST_DATA[dim]
                      + [f"read_data {datafile} "
                         + " ".join(f"fix {c.split()[1]} NULL {c.split()[1]}"
                                    for c in HIST_DATA[dim])]
                      + between
                      + ["pair_style mindlin/smooth", f"pair_coeff * * {KN!r} {KT!r} 1.0",
                         "run 0"])
    lmp.close()
    return log.read_text()


@pytest.mark.parametrize("dim", [2, 3])
def test_new_ids_before_the_first_run_are_reported(tmp_path, dim):
    """A history read from a data file has no record of the IDs it names, so
    delete_atoms (compress yes) before the first run cannot be followed: its
    entries then name other atoms, mostly far away. The run's setup counts
    the entries that name an atom that exists but is not a neighbour and
    warns; compress no (the deleted partners name no atom) and no deletion
    give no warning."""
    lmp = new_lammps()
    cluster(lmp, dim, True, nsmall=6, hist=HIST_DATA[dim])
    lmp.command("run 300")
    datafile = tmp_path / "c.data"
    lmp.command(f"write_data {datafile} nocoeff")
    lmp.close()
    warning = "contact-history entries name an atom that exists but is not a neighbour"
    delete = ["group gone id 2 3 4", "delete_atoms group gone compress {}"]
    assert warning not in _read_after(tmp_path, dim, datafile, [], "none")
    assert warning not in _read_after(tmp_path, dim, datafile,
                                      [c.format("no") for c in delete], "no")
    log = _read_after(tmp_path, dim, datafile, [c.format("yes") for c in delete], "yes")
    line, = [ln for ln in log.splitlines() if warning in ln]
    assert line.startswith("WARNING: Pair style mindlin/smooth: ") and "compress no" in line
    assert int(line.split("mindlin/smooth: ")[1].split()[0]) > 0
