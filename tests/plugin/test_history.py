"""Contact history kept by the pair itself: no fix property/atom, no cap on
contacts per disk, carried through restarts; walls keep one history per wall."""
import numpy as np
import pytest

from .lmputil import KN, KT, add_disk, new_lammps

NO_HIST_BOX = ["units lj", "dimension 2", "atom_style sphere", "atom_modify map array",
               "boundary p f p", "comm_modify vel yes"]


def cluster(lmp, nsmall=20, rbig=2.0, rsmall=0.3, overlap=0.005, seed=3, boundary="p f p"):
    """One big disk with nsmall small disks around it, each overlapping it
    slightly and not touching each other; small random velocities. The box
    is periodic in x unless ``boundary`` says otherwise (side walls need
    'f f p')."""
    lmp.commands_list(NO_HIST_BOX + [f"boundary {boundary}",
                                     "region box block 0 12 0 12 -0.5 0.5",
                                     "create_box 2 box"])
    cx, cy = 6.0, 6.0
    add_disk(lmp, 2, rbig, cx, cy)
    d = rbig + rsmall - overlap
    for k in range(nsmall):
        a = 2 * np.pi * k / nsmall
        add_disk(lmp, 1, rsmall, cx + d * np.cos(a), cy + d * np.sin(a))
    rng = np.random.default_rng(seed)
    for k in range(1, nsmall + 2):
        vx, vy, w = (float(u) for u in rng.uniform(-1e-2, 1e-2, 3))
        lmp.command(f"set atom {k} vx {vx!r} vy {vy!r} omega 0 0 {w!r}")
    lmp.commands_list(["pair_style mindlin/smooth", f"pair_coeff * * {KN!r} {KT!r} 1.0",
                       "fix nve all nve/sphere disc", "fix 2d all enforce2d",
                       "timestep 1e-5"])


def per_atom(lmp, name):
    nlocal = lmp.extract_global("nlocal")
    tag = np.asarray(lmp.numpy.extract_atom("id")[:nlocal])
    arr = np.array(lmp.numpy.extract_atom(name)[:nlocal])
    return arr[np.argsort(tag)]


def test_more_than_eight_contacts_newton_third_law():
    nsmall = 20
    lmp = new_lammps()
    cluster(lmp, nsmall)
    lmp.command("run 200")
    part = per_atom(lmp, "i2_mindlin_partner")
    xi = per_atom(lmp, "d2_mindlin_t")
    f = per_atom(lmp, "f")
    lmp.close()
    # the big disk (ID 1) holds all nsmall contacts, in ascending partner ID
    assert part.shape[1] >= nsmall
    np.testing.assert_array_equal(part[0, :nsmall], np.arange(2, nsmall + 2))
    assert not part[0, nsmall:].any()
    assert np.count_nonzero(xi[0]) == nsmall
    # each small disk has the big one as its only contact, with the same
    # tangential displacement (t_ji = -t_ij, s_ji = -s_ij)
    np.testing.assert_array_equal(part[1:, 0], 1)
    assert not part[1:, 1:].any()
    np.testing.assert_array_equal(xi[1:, 0], xi[0, :nsmall])
    # Newton's third law: the force on the big disk is minus the sum of the others
    scale = np.abs(f).max()
    assert scale > 1.0
    np.testing.assert_allclose(f[0, :2], -f[1:, :2].sum(axis=0), rtol=0, atol=1e-13 * scale)


def walls_and_corner(lmp):
    """Side walls and a floor (two fixes) and a disk in the corner touching both."""
    add_disk(lmp, 1, 0.3, 0.2995, 0.2995)
    lmp.commands_list([
        f"fix side all wall/mindlin/smooth {KN!r} {KT!r} 1.0 xplane 0.0 12.0",
        f"fix floor all wall/mindlin/smooth {KN!r} {KT!r} 1.0 yplane 0.0 NULL",
        "set atom 22 vx 0.01 vy -0.02 omega 0 0 0.3",
        "fix load all addforce 0.0 -1.0 0.0"])


def state(lmp):
    out = {k: per_atom(lmp, k) for k in ("x", "v", "omega", "i2_mindlin_partner",
                                         "d2_mindlin_t")}
    nlocal = lmp.extract_global("nlocal")
    order = np.argsort(np.asarray(lmp.numpy.extract_atom("id")[:nlocal]))
    for wall in ("side", "floor"):    # column 4: tangential displacement at the wall
        out[wall] = np.array(lmp.numpy.extract_fix(wall, 1, 2)[:nlocal, 3])[order]
    return out


def test_restart_round_trip_is_bitwise(tmp_path):
    rfile = str(tmp_path / "hist.restart")
    lmp = new_lammps()
    cluster(lmp, boundary="f f p")       # side walls: x not periodic
    walls_and_corner(lmp)
    lmp.command("run 150")
    lmp.command(f"write_restart {rfile}")
    lmp.command("run 150")
    ref = state(lmp)
    lmp.close()
    assert ref["side"][-1] != 0.0 and ref["floor"][-1] != 0.0    # corner disk, both walls
    assert ref["i2_mindlin_partner"].shape[1] >= 20

    lmp = new_lammps()
    lmp.command(f"read_restart {rfile}")
    lmp.commands_list([
        "comm_modify vel yes",
        f"fix side all wall/mindlin/smooth {KN!r} {KT!r} 1.0 xplane 0.0 12.0",
        f"fix floor all wall/mindlin/smooth {KN!r} {KT!r} 1.0 yplane 0.0 NULL",
        "fix load all addforce 0.0 -1.0 0.0",
        "fix nve all nve/sphere disc", "fix 2d all enforce2d", "timestep 1e-5", "run 150"])
    got = state(lmp)
    lmp.close()
    for key, val in ref.items():
        np.testing.assert_array_equal(got[key], val, err_msg=key)


def test_data_file_without_history_fix_reads_back(tmp_path):
    """write_data of a deck without fix property/atom writes no extra section:
    a plain read_data reads it (the contacts start again with zero history)."""
    dfile = str(tmp_path / "cluster.data")
    lmp = new_lammps()
    cluster(lmp)
    lmp.commands_list(["run 50", f"write_data {dfile}"])
    x = per_atom(lmp, "x")
    lmp.close()
    lmp = new_lammps()
    lmp.commands_list(NO_HIST_BOX + ["pair_style mindlin/smooth", f"read_data {dfile}",
                                     "fix nve all nve/sphere disc", "run 0"])
    np.testing.assert_array_equal(per_atom(lmp, "x"), x)
    assert not per_atom(lmp, "i2_mindlin_partner").any()    # no history in the file
    lmp.commands_list(["timestep 1e-5", "run 1"])
    assert (per_atom(lmp, "i2_mindlin_partner")[0, :20] == np.arange(2, 22)).all()
    lmp.close()


@pytest.mark.parametrize("rc, inside", [(5.0, True), (4.0, False)])
def test_zcylinder_holds_a_disk(rc, inside):
    """zcylinder R: a circle about the origin; a disk pressed outward feels an
    inward normal force and a tangential force with the law's sign."""
    lmp = new_lammps()
    lmp.commands_list(NO_HIST_BOX[:4] + ["boundary f f p", "comm_modify vel yes",
                                         "region box block -6 6 -6 6 -0.5 0.5",
                                         "create_box 1 box"])
    r = 0.5
    d = rc - r + 0.001 if inside else 3.0    # centre distance from the origin
    add_disk(lmp, 1, r, d / np.sqrt(2), d / np.sqrt(2))
    lmp.commands_list([f"fix cyl all wall/mindlin/smooth {KN!r} {KT!r} 1.0 zcylinder {rc}",
                       "fix nve all nve/sphere disc", "fix 2d all enforce2d",
                       "set atom 1 vx -1e-2 vy 1e-2", "timestep 1e-6", "run 10"])
    f = per_atom(lmp, "f")[0]
    tq = per_atom(lmp, "torque")[0]
    x = per_atom(lmp, "x")[0]
    lmp.close()
    if rc == 4.0:
        assert not f[:2].any()
        return
    delta = r + np.hypot(x[0], x[1]) - rc
    n = -x[:2] / np.hypot(x[0], x[1])
    fn = np.dot(f[:2], n)
    assert fn == pytest.approx(KN * delta ** 1.5, rel=1e-12)
    # the disk slides along s = (n_y, -n_x) = (-1, 1)/sqrt(2): friction opposes it
    s = np.array([n[1], -n[0]])
    ft = np.dot(f[:2], s)
    assert ft < 0.0
    assert tq[2] == pytest.approx(r * ft, rel=1e-9)
