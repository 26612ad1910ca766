"""fix mu/velocity and fix addforce/oscillating against LAMMPS's own variable routes.

The scene (c) of Fig. 5 (load, forcing f(t), mu(v) of Eq. 4 on every contact
and the wall) built with the plugin fixes must give the same bits as
``fix adapt`` + a ``v_`` wall mu + an equal-style ``fix addforce`` written as
single expressions, and agree to round-off with the former deck's nested
variables (mu_routes.py says why those round). Then: which coefficients the
fix sets, restart, MPI, 3d, and the errors for bad arguments.
"""
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from . import lmputil, mu_routes
from tests.data import unpack

NSTEPS = 1500
P = mu_routes.P


def eq4(v, p=P):
    """Eq. 4 written independently (Python floats)."""
    vt, vt0 = abs(v) / p["vss"], p["v0"] / p["vss"]
    if vt <= vt0:
        return p["mu"]
    return p["mu"] * (p["B"] * math.exp(-p["w"] * (vt - vt0)) + p["muss"])


@pytest.fixture(scope="module")
def datafile(tmp_path_factory):
    return unpack("default_job_mu1_step_00258", tmp_path_factory.mktemp("muv"))


def _route(datafile, route, nsteps=NSTEPS, **kw):
    lmp = mu_routes.open_scene(datafile, route, **kw)
    D, mu = mu_routes.run(lmp, nsteps, route == "native")
    vec = [lmp.extract_fix("muv", 0, 1, i) for i in range(4)] if route == "native" else None
    out = dict(D=D, mu=mu, vec=vec, **mu_routes.state(lmp))
    lmp.close()
    return out


@pytest.fixture(scope="module")
def native(datafile):
    out = _route(datafile, "native")
    # the test means something only if mu(v) switched on, and back off
    assert out["mu"].min() < 0.82 and np.any(out["mu"][1:] == 1.0)
    return out


def test_native_route_is_the_flat_variable_route_bit_for_bit(datafile, native):
    flat = _route(datafile, "flat")
    for key in ("D", "x", "v", "omega", "i2_mindlin_partner", "d2_mindlin_t"):
        assert np.array_equal(native[key], flat[key]), key


def test_nested_variables_agree_to_round_off(datafile, native):
    """The former deck's route rounds v~ and f(t) to 15 digits: measured over
    1500 steps, D within 9e-9 relative, positions within 5e-14."""
    nested = _route(datafile, "nested")
    rel = np.abs(native["D"] - nested["D"]) / native["D"]
    assert rel.max() < 1e-6, rel.max()
    assert np.abs(native["x"] - nested["x"]).max() < 1e-12
    assert not np.array_equal(native["x"], nested["x"])      # a different route


def test_mu_follows_eq4_of_the_mean_velocity(native):
    mu, v, vmax, tswitch = native["vec"]
    assert mu == pytest.approx(eq4(v), rel=1e-15, abs=0)
    assert native["mu"][-1] == mu
    assert vmax >= abs(v) > 0
    # switched before the first record with mu < mu0, after t = 0
    first = (np.argmax(native["mu"] < P["mu"]) + 1) * mu_routes.EVERY * P["dt"]
    assert 0 < tswitch <= first


def test_forcing_vector_is_the_formula(datafile):
    lmp = mu_routes.open_scene(datafile, "native")
    for t_steps in (0, 123, 500, 600):
        lmp.command(f"run {t_steps} post no" if t_steps else "run 0 post no")
        t = lmp.extract_global("ntimestep") * P["dt"]
        env = 0.5 * (1.0 - math.cos(math.pi * t / P["ton"])) if t < P["ton"] else 1.0
        assert lmp.extract_fix("load", 0, 1, 1) == pytest.approx(env, rel=1e-14, abs=1e-300)
        assert lmp.extract_fix("load", 0, 1, 0) == pytest.approx(
            P["a"] * env * math.cos(P["wp"] * t), rel=1e-13, abs=1e-300)
    lmp.close()


@pytest.mark.mpi
def test_two_ranks_native_equals_flat(datafile, tmp_path):
    """Domain decomposition: both routes sum the group per rank, then reduce."""
    mpirun = os.path.join(os.path.dirname(sys.executable), "mpirun")
    got = {}
    for route in ("native", "flat"):
        out = str(tmp_path / f"{route}.npz")
        res = subprocess.run([mpirun, "-np", "2", sys.executable, mu_routes.__file__,
                              datafile, out, route, "600"],
                             capture_output=True, text=True, timeout=300)
        assert res.returncode == 0, res.stderr[-3000:]
        got[route] = dict(np.load(out))
    for key in ("D", "x", "v", "omega", "d2_mindlin_t"):
        assert np.array_equal(got["native"][key], got["flat"][key]), key
    assert got["native"]["mu"].min() < 1.0


# ---------------------------------------------------------------- which mu is set

def _sliding_disk(pair, wall):
    """One disk pushed along the floor hard enough to slide (F_x > 3 mu N)."""
    lmp = lmputil.new_lammps()
    lmp.commands_list(lmputil.box_commands(width=50.0) + lmputil.style_commands())
    lmputil.add_disk(lmp, 1, 0.5, 5.0, 0.4999)
    lmp.commands_list([
        "group disk id 1", "timestep 1e-4",
        f"fix muv disk mu/velocity 1.0 1e-3 0.2 0.4 0.8 vss 0.01 pair {pair} wall {wall}",
        "fix push disk addforce/oscillating 4.0 -1.0 0.0 0.0 0.0",
        "fix nve all nve/sphere disc", "fix 2d all enforce2d", "run 3000"])
    return lmp


@pytest.mark.parametrize("pair, wall", [("yes", "yes"), ("yes", "no"), ("no", "yes")])
def test_fix_sets_mu_of_the_pair_and_the_wall(pair, wall):
    lmp = _sliding_disk(pair, wall)
    mu = lmp.extract_fix("muv", 0, 1, 0)
    assert 0.8 <= mu < 0.81                            # sliding fast: mu -> mu_ss mu0
    pair_mu = np.array(lmp.extract_pair("mu"))[1:, 1:]
    assert np.all(pair_mu == (mu if pair == "yes" else lmputil.MU))
    # sliding on the floor: the wall's tangential force is mu times its normal force
    fx, fy = lmp.extract_fix("wall", 0, 1, 0), lmp.extract_fix("wall", 0, 1, 1)
    assert -fx / fy == pytest.approx(mu if wall == "yes" else lmputil.MU, rel=1e-12)
    lmp.close()


def test_mu_without_pair_or_wall_is_an_error():
    for extra, match in [(["pair_style zero 1.0", "pair_coeff * *"], r"no pair style "
                          r"mindlin/smooth to set mu of; define it or use 'pair no'"),
                         (["pair_style mindlin/smooth", "pair_coeff * * 2e5 5e4 1.0"],
                          r"no fix wall/mindlin/smooth to set mu of")]:
        lmp = lmputil.new_lammps()
        lmp.commands_list(lmputil.box_commands())
        lmputil.add_disk(lmp, 1, 0.5, 5.0, 0.5)
        lmp.commands_list(extra + ["group disk id 1", "fix nve all nve/sphere disc",
                                   "fix muv disk mu/velocity 1.0 1e-3 0.2 0.4 0.8"])
        with pytest.raises(Exception, match=match):
            lmp.command("run 0")
        lmp.close()


def test_wall_with_a_variable_mu_is_named():
    lmp = lmputil.new_lammps()
    lmp.commands_list(lmputil.box_commands() + lmputil.style_commands(wall=False))
    lmputil.add_disk(lmp, 1, 0.5, 5.0, 0.5)
    lmp.commands_list(["variable m equal 0.9",
                       f"fix floor all wall/mindlin/smooth {lmputil.KN} {lmputil.KT} v_m "
                       "yplane 0.0", "group disk id 1", "fix nve all nve/sphere disc",
                       "fix muv disk mu/velocity 1.0 1e-3 0.2 0.4 0.8"])
    with pytest.raises(Exception, match=r"fix floor \(wall/mindlin/smooth\) takes mu from a "
                                         r"variable; give it a number, or use 'wall no'"):
        lmp.command("run 0")
    lmp.close()


# ---------------------------------------------------------------------- restart

def test_restart_continues_bitwise(datafile, tmp_path):
    """Split run (300 + 300 steps) vs the same through write_restart/read_restart;
    the fix's running values (max |v|, switch time) come back from the file."""
    ref = mu_routes.open_scene(datafile, "native")
    ref.command("run 300 post no")
    saved = [ref.extract_fix("muv", 0, 1, i) for i in range(4)]
    rfile = str(tmp_path / "c.restart")
    ref.command(f"write_restart {rfile}")
    ref.command("run 300 post no")
    want = mu_routes.state(ref), [ref.extract_fix("muv", 0, 1, i) for i in range(4)]
    ref.close()
    assert saved[3] > 0                           # mu(v) switched before the restart

    lmp = lmputil.new_lammps()
    lmp.commands_list([f"read_restart {rfile}", "comm_modify vel yes", lmputil.HIST,
                       "fix topflag all property/atom i_top ghost no"]
                      + mu_routes.route_commands("native")
                      + ["fix integ all nve/sphere disc", "fix 2d all enforce2d"])
    assert [lmp.extract_fix("muv", 0, 1, i) for i in range(4)] == saved
    lmp.command("run 300 post no")
    got = mu_routes.state(lmp), [lmp.extract_fix("muv", 0, 1, i) for i in range(4)]
    lmp.close()
    for key in want[0]:
        assert np.array_equal(want[0][key], got[0][key]), key
    assert got[1] == want[1]


# ---------------------------------------------------------------------- 3d

def test_three_dimensions_use_the_x_velocity_only():
    lmp = lmputil.new_lammps()
    lmp.commands_list(["units lj", "atom_style sphere", "region box block 0 10 0 10 0 10",
                       "create_box 1 box", "create_atoms 1 single 2 2 2",
                       "create_atoms 1 single 5 5 5", "set type 1 mass 2.0",
                       "velocity all set 3e-3 0.5 -0.7", "pair_style zero 1.0",
                       "pair_coeff * *",
                       "fix muv all mu/velocity 1.0 1e-3 0.2 0.4 0.8 pair no wall no",
                       "fix nve all nve/sphere", "run 0"])
    assert lmp.extract_fix("muv", 0, 1, 1) == pytest.approx(3e-3, rel=1e-15)
    p = dict(P, v0=1e-3, vss=1e-3)
    assert lmp.extract_fix("muv", 0, 1, 0) == pytest.approx(eq4(3e-3, p), rel=1e-15)
    lmp.close()


# ---------------------------------------------------------------------- bad input

@pytest.mark.parametrize("args, match", [
    ("top mu/velocity 1.0 -1e-6 0.2 0.4 0.8", r"v0 must be >= 0, got -1e-6"),
    ("top mu/velocity 1.0 1e-6 -0.2 0.4 0.8", r"B must be >= 0, got -0\.2"),
    ("top mu/velocity 1.0 1e-6 0.2 -0.4 0.8", r"w must be >= 0, got -0\.4"),
    ("top mu/velocity -1.0 1e-6 0.2 0.4 0.8", r"mu0 must be >= 0, got -1\.0"),
    ("top mu/velocity 1.0 1e-6 0.2 0.4 1.2", r"mu_ss must be <= 1 \(a fraction of mu0\), "
                                             r"got 1\.2"),
    ("top mu/velocity 1.0 1e-6 0.2 0.4 -0.8", r"mu_ss must be >= 0, got -0\.8"),
    ("nosuch mu/velocity 1.0 1e-6 0.2 0.4 0.8", r"Could not find fix group ID nosuch"),
    ("top mu/velocity 1.0 0 0.2 0.4 0.8", r"vss must be > 0, got 0 \(vss defaults to v0"),
    ("top mu/velocity 1.0 1e-6 0.2 0.4 0.8 vss -2", r"vss must be > 0, got -2"),
    ("top mu/velocity 1.0 1e-6 0.2 0.4 0.8 speed 2", r"unknown keyword 'speed'"),
    ("top mu/velocity 1.0 1e-6 0.2 0.4", r"needs 5 values"),
    ("top mu/velocity 1.0 1e-6 0.2 0.4 0.8 pair perhaps", r"instead of 'perhaps'"),
    ("top addforce/oscillating 0.1 -3 0 1e-3 0.01 onset -1", r"onset T must be >= 0, got -1"),
    ("top addforce/oscillating 0.1 -3 0 1e-3", r"needs 5 values and an optional 'onset T'"),
    ("top addforce/oscillating 0.1 -3 0 1e-3 0.01 start 2", r"unknown keyword 'start'"),
    ("top addforce/oscillating 0.1 -3 0 abc 0.01", r"instead of 'abc'"),
])
def test_bad_arguments_name_the_value(args, match):
    lmp = lmputil.new_lammps()
    lmp.commands_list(lmputil.box_commands())
    lmputil.add_disk(lmp, 1, 0.5, 5.0, 0.5)
    lmp.command("group top id 1")
    with pytest.raises(Exception, match=match):
        lmp.command(f"fix f {args}")
    lmp.close()


# ----------------------------------------------------- another fix setting mu

def _log_with(tmp_path, extra, runs=2, options=""):
    """The warnings of fix mu/velocity in the log of the sliding-disk scene
    with ``fix muv ... options`` and ``extra`` commands, run ``runs`` times
    (10 steps each)."""
    log = tmp_path / "log.lammps"
    lmp = lmputil.new_lammps(log=str(log))
    lmp.commands_list(lmputil.box_commands(width=50.0) + lmputil.style_commands())
    lmputil.add_disk(lmp, 1, 0.5, 5.0, 0.4999)
    lmp.commands_list(["group disk id 1", "timestep 1e-4",
                       f"fix muv disk mu/velocity 1.0 1e-3 0.2 0.4 0.8 {options}"] + extra
                      + ["fix nve all nve/sphere disc", "fix 2d all enforce2d"]
                      + ["run 10"] * runs)
    lmp.close()
    return [ln for ln in log.read_text().splitlines() if ln.startswith("WARNING: Fix mu/velocity")]


def test_another_fix_setting_mu_is_warned_once(tmp_path):
    """fix adapt on the pair's mu beside fix mu/velocity: both act in
    pre_force and the later one's mu is the one the forces use, so the
    other is lost silently. One warning naming the other fix, at the first
    run only; none without it, none for fix adapt under 'pair no'."""
    assert _log_with(tmp_path, []) == []
    adapt = ["variable m equal 0.5", "fix vmu all adapt 1 pair mindlin/smooth mu * * v_m"]
    lines = _log_with(tmp_path, adapt)
    assert len(lines) == 1
    assert lines[0].startswith("WARNING: Fix mu/velocity muv: fix vmu (adapt) is defined too;")
    assert "the later of the two fixes sets mu every step" in lines[0]
    assert _log_with(tmp_path, adapt, options="pair no") == []
    second = ["fix muv2 disk mu/velocity 1.0 1e-3 0.2 0.4 0.9"]
    lines = _log_with(tmp_path, second)
    assert sorted(ln.split(":")[1].strip() for ln in lines) == [
        "Fix mu/velocity muv", "Fix mu/velocity muv2"]
    assert all("(mu/velocity) sets mu too" in ln for ln in lines)
    # 'pair no' with 'wall no' sets nothing: neither warns about the other
    quiet = ["fix muv2 disk mu/velocity 1.0 1e-3 0.2 0.4 0.9 pair no wall no"]
    assert _log_with(tmp_path, quiet) == []
