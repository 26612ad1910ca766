"""3D runs: continuation through data and restart files and across MPI ranks
is exact, Hertz-only dynamics match stock ``pair_style granular``, and a
planar configuration reproduces the 2D code.

The continuation tests follow test_reproducibility.py (same runner, with
``dim=3``): spheres settled on a zplane floor and sheared, so that contacts
slide; the reference for a file round trip is the same run split into two
``run`` commands.
"""
import os
import subprocess
import sys

import numpy as np
import pytest

from . import lmputil, runner
from .lmputil import KN, KT, gather, new_lammps

NSTEPS = 600
RADII = {1: 0.5, 2: 0.7}


def assert_same(a, b):
    for key in a:
        assert np.array_equal(a[key], b[key]), \
            f"{key} differs: max |diff| = {np.abs(a[key] - b[key]).max():.3g}"


@pytest.fixture(scope="module")
def start(tmp_path_factory):
    """A settled, sheared packing of 120 spheres written to a data file."""
    d = tmp_path_factory.mktemp("repro3d")
    lmp = new_lammps()
    lmputil.settled_packing_3d(lmp, 120, seed=5, steps=6000, shear=0.3)
    path = str(d / "start.data")
    lmp.command(f"write_data {path} pair ij")
    z = gather(lmp, "x", 3)[:, 2]
    lmp.close()
    return path, float(np.quantile(z, 0.8))


@pytest.fixture(scope="module")
def reference(start):
    path, upper = start
    out = runner.continue_run(path, NSTEPS, upper, dim=3)
    assert np.count_nonzero(out["i2_mindlin_partner"]) > 60
    assert np.abs(out["d2_mindlin_tz"]).max() > 0.0 and np.abs(out["omega"][:, :2]).max() > 0.0
    return out


def test_file_round_trip_continues_identically(start, tmp_path):
    path, upper = start
    ref = runner.continue_run(path, NSTEPS, upper, split=NSTEPS // 2, mode="split", dim=3)
    for mode in ("data", "restart"):
        out = runner.continue_run(path, NSTEPS, upper, split=NSTEPS // 2, mode=mode,
                                  workdir=str(tmp_path), dim=3)
        assert_same(ref, out)


@pytest.mark.mpi
@pytest.mark.parametrize("np_", [1, 2])
def test_mpi_ranks_agree_bitwise(start, reference, np_, tmp_path):
    path, upper = start
    mpirun = os.path.join(os.path.dirname(sys.executable), "mpirun")
    out = str(tmp_path / "state.npz")
    cmd = [mpirun, "-np", str(np_), sys.executable, runner.__file__, path, out,
           str(NSTEPS), repr(upper), "3d"]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-3000:]
    assert_same(reference, dict(np.load(out)))


@pytest.mark.mpi
def test_mpi_ranks_agree_bitwise_with_the_pairs_own_history(tmp_path):
    """No fix property/atom, a frictional floor: the pair's and the wall's own
    history migrate between 2 ranks; np = 2 equals np = 1 bitwise."""
    lmp = new_lammps()
    lmputil.settled_packing_3d(lmp, 120, seed=6, steps=6000, shear=0.3, hist=None)
    path = str(tmp_path / "own.data")
    lmp.command(f"write_data {path} pair ij")
    upper = float(np.quantile(gather(lmp, "x", 3)[:, 2], 0.8))
    lmp.close()
    mpirun = os.path.join(os.path.dirname(sys.executable), "mpirun")
    got = []
    for np_ in (1, 2):
        out = str(tmp_path / f"state{np_}.npz")
        cmd = [mpirun, "-np", str(np_), sys.executable, runner.__file__, path, out,
               str(NSTEPS), repr(upper), "3d", "own"]
        res = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
        assert res.returncode == 0, res.stderr[-3000:]
        got.append(dict(np.load(out)))
    assert np.count_nonzero(got[0]["i2_mindlin_partner"]) > 60
    assert_same(got[0], got[1])


def test_internal_history_restart_is_bitwise(tmp_path):
    """No fix property/atom: the pair's own history (3 columns per contact) and
    the wall's (3 values per sphere) go through a restart file unchanged."""
    rfile = str(tmp_path / "h3.restart")
    keys = ("x", "v", "omega", "f", "torque")

    def tail(lmp):
        lmp.commands_list(["fix push all addforce 1.0 0.5 -5.0", "run 200"])
        out = {k: gather(lmp, k, 3) for k in keys}
        out["t"] = lmputil.history_3d(lmp)
        out["wall"] = np.array(lmp.numpy.extract_fix("wall", 1, 2)[:lmp.get_natoms()])
        return out

    def build():
        lmp = new_lammps()
        lmputil.settled_packing_3d(lmp, 60, seed=2, steps=8000, hist=None)
        lmp.commands_list(["fix push all addforce 1.0 0.5 -5.0", "run 200", "unfix push"])
        return lmp

    lmp = build()
    assert lmp.extract_atom("d2_mindlin_tx") is not None      # the pair's own arrays
    ref = tail(lmp)
    lmp.close()
    lmp = build()
    lmp.command(f"write_restart {rfile}")
    lmp.close()
    lmp = new_lammps()
    lmp.commands_list([f"read_restart {rfile}", "comm_modify vel yes",
                       f"fix wall all wall/mindlin/smooth {KN!r} {KT!r} 1.0 zplane 0.0 NULL",
                       "fix nve all nve/sphere", "timestep 5e-4"])
    out = tail(lmp)
    lmp.close()
    assert np.count_nonzero(ref["t"]) > 50
    assert_same(ref, out)


def test_history_arrays_are_written_back_exactly():
    """The wall's own history is the per-atom array d2_mindlin_wall_t_<ID>
    (equal to the fix's output t after a step); writing it and the pair's
    arrays back (what the driver's Engine.restore does after a rejected
    Newton step) continues bitwise as if nothing had happened in between,
    and without the wall's array the continuation differs."""
    names = ("i2_mindlin_partner", "d2_mindlin_tx", "d2_mindlin_ty", "d2_mindlin_tz",
             "d2_mindlin_wall_t_wall")

    def local(lmp, name):
        n = lmp.extract_global("nlocal")
        return lmp.numpy.extract_atom(name)[:n]

    def save(lmp):
        return {k: np.array(local(lmp, k)) for k in ("x", "v", "omega") + names}

    def put(lmp, saved, skip=()):
        for k, val in saved.items():
            if k in skip:
                continue
            arr = local(lmp, k)
            arr[:, :val.shape[1]] = val
            arr[:, val.shape[1]:] = 0

    def tail(lmp):
        lmp.commands_list(["fix push all addforce 1.0 0.5 -5.0", "run 200", "unfix push"])
        return {k: gather(lmp, k, 3) for k in ("x", "v", "omega", "f", "torque")}

    lmp = new_lammps()
    lmputil.settled_packing_3d(lmp, 60, seed=2, steps=8000, hist=None)
    lmp.command("atom_modify sort 0 0.0")       # the local order stays put (one rank)
    tail(lmp)
    wall = np.array(local(lmp, "d2_mindlin_wall_t_wall"))
    assert np.count_nonzero(wall) > 10
    assert np.array_equal(wall, np.array(lmp.numpy.extract_fix("wall", 1, 2)
                                         [:lmp.extract_global("nlocal"), 4:7]))
    saved = save(lmp)
    ref = tail(lmp)
    got = {}
    for skip in ((), ("d2_mindlin_wall_t_wall",)):
        put(lmp, saved)
        tail(lmp)                                  # moves on: the history changes
        put(lmp, {k: np.zeros_like(v) for k, v in saved.items() if k in skip})
        put(lmp, saved, skip)
        got[skip] = tail(lmp)
    lmp.close()
    assert_same(ref, got[()])
    assert not np.array_equal(ref["f"], got[("d2_mindlin_wall_t_wall",)]["f"])


def test_fix_modify_columns_grows_the_pairs_history():
    lmp = new_lammps()
    lmputil.settled_packing_3d(lmp, 30, seed=3, steps=2000, hist=None)
    before = np.array(lmp.numpy.extract_atom("d2_mindlin_tx")[:30])
    assert before.shape[1] == 8
    lmp.command("fix_modify MINDLIN_HISTORY columns 20")
    after = np.array(lmp.numpy.extract_atom("d2_mindlin_tx")[:30])
    assert after.shape == (30, 20)
    assert np.array_equal(after[:, :8], before) and not np.any(after[:, 8:])
    lmp.command("fix_modify MINDLIN_HISTORY columns 4")       # never shrinks
    assert np.array(lmp.numpy.extract_atom("i2_mindlin_partner")[:30]).shape == (30, 20)
    with pytest.raises(Exception, match="columns must be >= 1"):
        lmp.command("fix_modify MINDLIN_HISTORY columns 0")
    lmp.close()


# ------------------------------------------------- stock granular, k_t = 0

def stock_styles():
    """pair granular hertz with k = k_n / sqrt(R_eff) per type pair, and the
    floor with k = k_n / sqrt(R_i) per type (R_eff of a flat wall is R_i)."""
    cmds = ["pair_style granular"]
    for i, j in [(1, 1), (1, 2), (2, 2)]:
        reff = RADII[i] * RADII[j] / (RADII[i] + RADII[j])
        cmds.append(f"pair_coeff {i} {j} hertz {float(KN / np.sqrt(reff))!r} 0.0 "
                    "tangential linear_nohistory 0.0 0.0 damping viscoelastic")
    for t in (1, 2):
        k = float(KN / np.sqrt(RADII[t]))
        cmds += [f"group t{t} type {t}",
                 f"fix floor{t} t{t} wall/gran granular hertz {k!r} 0.0 tangential "
                 "linear_nohistory 0.0 0.0 damping viscoelastic zplane 0.0 NULL"]
    return cmds


def our_styles():
    return ["pair_style mindlin/smooth", f"pair_coeff * * {KN!r} 0.0 1.0",
            f"fix floor all wall/mindlin/smooth {KN!r} 0.0 1.0 zplane 0.0 NULL"]


@pytest.fixture(scope="module")
def loose(tmp_path_factory):
    """A settled packing of 100 spheres, without history, in a data file."""
    lmp = new_lammps()
    lmputil.settled_packing_3d(lmp, 100, seed=9, steps=4000, hist=None)
    path = str(tmp_path_factory.mktemp("stock3d") / "packing.data")
    lmp.command(f"write_data {path} nocoeff")
    lmp.close()
    return path


def trajectory(path, styles, nsteps, seed=11):
    lmp = new_lammps()
    lmp.commands_list(["units lj", "dimension 3", "atom_style sphere", "atom_modify map array",
                       "boundary p p f", "comm_modify vel yes", f"read_data {path}",
                       "set group all mass 1.0", *styles])
    rng = np.random.default_rng(seed)
    n, nlocal = lmp.get_natoms(), lmp.extract_global("nlocal")
    tag = np.asarray(lmp.numpy.extract_atom("id")[:nlocal])
    lmp.numpy.extract_atom("v")[:nlocal] = rng.normal(0.0, 0.05, size=(n, 3))[tag - 1]
    lmp.numpy.extract_atom("omega")[:nlocal] = rng.normal(0.0, 0.1, size=(n, 3))[tag - 1]
    lmp.commands_list(["fix nve all nve/sphere", "fix load all addforce 0.0 0.0 -2.0",
                       "timestep 2e-4", f"run {nsteps}"])
    out = {k: gather(lmp, k, 3) for k in ("x", "v", "omega", "f", "torque")}
    lmp.close()
    return out


def test_hertz_only_agrees_with_stock_granular_to_round_off(loose):
    a = trajectory(loose, our_styles(), 1000)
    b = trajectory(loose, stock_styles(), 1000)
    assert np.abs(a["f"]).max() > 1.0                       # contacts are loaded
    dv = np.abs(a["v"] - b["v"]).max() / np.abs(a["v"]).max()
    assert dv < 1e-10, dv
    assert np.abs(a["x"] - b["x"]).max() < 1e-12
    assert np.array_equal(a["omega"], b["omega"])             # no torques at all
    assert not np.any(a["torque"]) and not np.any(b["torque"])


# ------------------------------------------------- planar 3D = 2D

def test_planar_configuration_reproduces_the_2d_code():
    """A settled, sheared 2D packing with its history, copied into a 3D box
    (spheres at z = 0, t = xi s with s = (n_y, -n_x)), then 20 more steps
    in both without the floor: forces, torques, motion and history agree to
    round-off, and nothing leaves the plane. (Long runs are compared no
    further: collisions amplify round-off.) Inertia 2/5 m R^2 in both."""
    two = new_lammps()
    lmputil.settled_packing(two, 30, seed=4, steps=20000, shear=0.3)
    n = two.get_natoms()
    x, v, om = (gather(two, k, 3) for k in ("x", "v", "omega"))
    rad, types = gather(two, "radius", 1), gather(two, "type", 1, dtype=0)
    part, xi = gather(two, "i2_mindlin_partner", 8, dtype=0), gather(two, "d2_mindlin_t", 8)
    boxlo, boxhi = two.extract_box()[:2]
    assert np.count_nonzero(part) > 40 and np.count_nonzero(xi) > 20
    t = np.zeros((n, 8, 3))
    for i, k in zip(*np.nonzero(part)):
        d = x[i, :2] - x[part[i, k] - 1, :2]
        d[0] -= np.round(d[0] / (boxhi[0] - boxlo[0])) * (boxhi[0] - boxlo[0])
        nvec = d / np.hypot(*d)
        t[i, k, :2] = xi[i, k] * np.array([nvec[1], -nvec[0]])

    three = new_lammps()
    three.commands_list([
        "units lj", "dimension 3", "atom_style sphere", "atom_modify map array",
        "boundary p f f", "comm_modify vel yes",
        f"region box block {boxlo[0]!r} {boxhi[0]!r} {boxlo[1]!r} {boxhi[1]!r} -0.5 0.5",
        "create_box 2 box", *lmputil.HIST_3D])
    for i in range(n):
        xi_, yi_ = float(x[i, 0]), float(x[i, 1])
        three.command(f"create_atoms {types[i]} single {xi_!r} {yi_!r} 0.0 units box")
        three.command(f"set atom {i + 1} diameter {float(2.0 * rad[i])!r}")
    three.command("set group all mass 1.0")
    for name, arr in [("v", v), ("omega", om), ("i2_mindlin_partner", part)]:
        three.numpy.extract_atom(name)[:n] = arr
    for c, name in enumerate(("d2_mindlin_tx", "d2_mindlin_ty", "d2_mindlin_tz")):
        three.numpy.extract_atom(name)[:n] = t[..., c]
    three.commands_list(["pair_style mindlin/smooth",
                         f"pair_coeff * * {KN!r} {KT!r} {lmputil.MU!r}"])
    two.commands_list(["unfix wall", "unfix 2d", "unfix nve", "fix nve all nve/sphere",
                       "fix 2d all enforce2d"])
    out = {}
    for name, lmp in (("2d", two), ("3d", three)):
        lmp.commands_list(["fix nve all nve/sphere" if name == "3d" else "print ok",
                           "timestep 5e-4", "fix push all addforce 0.5 -5.0 0.0", "run 20"])
        out[name] = {k: gather(lmp, k, 3) for k in ("x", "v", "omega", "f", "torque")}
        out[name]["partner"] = gather(lmp, "i2_mindlin_partner", 8, dtype=0)
    out["2d"]["t"] = gather(two, "d2_mindlin_t", 8)
    out["3d"]["t"] = lmputil.history_3d(three)
    a, b = out["2d"], out["3d"]
    assert not np.any(b["f"][:, 2]) and not np.any(b["torque"][:, :2])
    assert not np.any(b["x"][:, 2]) and not np.any(b["t"][..., 2])
    np.testing.assert_array_equal(a["partner"], b["partner"])
    for key in ("f", "torque", "x", "v", "omega"):
        err = np.abs(b[key] - a[key]).max() / np.abs(a[key]).max()
        assert err < 1e-12, (key, err)
    x = a["x"]
    for i, k in zip(*np.nonzero(a["partner"])):
        d = x[i, :2] - x[a["partner"][i, k] - 1, :2]
        d[0] -= np.round(d[0] / (boxhi[0] - boxlo[0])) * (boxhi[0] - boxlo[0])
        nvec = d / np.hypot(*d)
        np.testing.assert_allclose(b["t"][i, k, :2], a["t"][i, k] * np.array([nvec[1], -nvec[0]]),
                                   rtol=0, atol=1e-12 * np.abs(a["t"]).max())
    two.close()
    three.close()
