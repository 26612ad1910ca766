"""Two disks and a disk on the wall, through LAMMPS, against the formulas.

A slip or rotation is imposed by giving the disks velocities v = d/dt with no
time integrator defined, then ``run 1``: the pair style increments the
tangential displacement by dt * (slip rate) and computes forces at the
unchanged positions. Expected values are computed here from Eqs. (1)-(3),
(14), (31) in the form f_t = -mu f_n u g(u) sign(xi).
"""
import numpy as np
import pytest

from .lmputil import (KN, KT, MU, add_disk, box_commands, gather, history, new_lammps,
                      set_per_atom, style_commands)

DT = 1.0e-4
REL = 1e-12


def expected_pair(x1, x2, r1, r2, xi, kn=KN, kt=KT, mu=MU):
    """Force on disk 1, torques on both, capped xi and u (independent of the plugin)."""
    d = x1 - x2
    rho = np.hypot(*d)
    n = d / rho
    s = np.array([n[1], -n[0]])
    delta = r1 + r2 - rho
    fn = kn * delta**1.5
    ts = mu * kn * delta / kt
    xi_c = float(np.clip(xi, -ts, ts))
    u = abs(xi_c) / ts
    ft = -mu * fn * u * (1.0 + u - u * u) * np.sign(xi_c)
    return fn * n + ft * s, r1 * ft, r2 * ft, xi_c, u, s


def two_disk_system(angle=0.3, delta=1e-3, r1=0.5, r2=0.7, mu=MU):
    lmp = new_lammps()
    lmp.commands_list(box_commands())
    lmp.commands_list(style_commands(mu=mu, wall=False))
    rho = r1 + r2 - delta
    x1 = np.array([10.0, 6.0])
    x2 = x1 - rho * np.array([np.cos(angle), np.sin(angle)])
    add_disk(lmp, 1, r1, *x1)
    add_disk(lmp, 2, r2, *x2)
    lmp.command(f"timestep {DT!r}")
    x = gather(lmp, "x", 3)[:, :2]
    return lmp, x


def impose_step(lmp, v1=(0, 0), w1=0.0, v2=(0, 0), w2=0.0):
    set_per_atom(lmp, "v", 1, [v1[0], v1[1], 0.0])
    set_per_atom(lmp, "v", 2, [v2[0], v2[1], 0.0])
    set_per_atom(lmp, "omega", 1, [0.0, 0.0, w1])
    set_per_atom(lmp, "omega", 2, [0.0, 0.0, w2])
    lmp.command("run 1")
    return gather(lmp, "f", 3)[:, :2], gather(lmp, "torque", 3)[:, 2]


def check_pair(f, t, exp, r1=0.5, r2=0.7):
    F1, T1, T2, _, _, _ = exp
    scale = np.abs(F1).max()
    assert np.abs(f[0] - F1).max() <= REL * scale
    assert abs(t[0] - T1) <= REL * max(abs(T1), 1e-300) + 1e-300
    assert abs(t[1] - T2) <= REL * max(abs(T2), 1e-300) + 1e-300
    # Newton's third law exactly, and equal generalized torques T/R
    assert np.array_equal(f[1], -f[0])
    assert t[0] * r2 == pytest.approx(t[1] * r1, rel=1e-15, abs=1e-300)


@pytest.mark.parametrize("angle", [0.0, 0.3, 2.0, -1.1])
@pytest.mark.parametrize("u_target", [0.5, 0.999])
def test_imposed_tangential_slip(angle, u_target):
    lmp, x = two_disk_system(angle=angle)
    _, _, _, _, _, s = expected_pair(x[0], x[1], 0.5, 0.7, 0.0)
    delta = 1.2 - np.hypot(*(x[0] - x[1]))
    xi = u_target * MU * KN * delta / KT
    f, t = impose_step(lmp, v1=xi / DT * s)
    exp = expected_pair(x[0], x[1], 0.5, 0.7, DT * (s @ (xi / DT * s)))
    check_pair(f, t, exp)
    part, hxi, _ = history(lmp)
    # mirror images: each side stores the same xi for its partner
    assert part[0, 0] == 2 and part[1, 0] == 1 and not part[:, 1:].any()
    assert hxi[0, 0] == hxi[1, 0]
    assert hxi[0, 0] == pytest.approx(exp[3], rel=1e-14)
    lmp.close()


def test_imposed_rotation_and_normal_motion():
    lmp, x = two_disk_system(angle=0.7)
    _, _, _, _, _, s = expected_pair(x[0], x[1], 0.5, 0.7, 0.0)
    n = np.array([-s[1], s[0]])
    w1, w2 = 30.0, -10.0
    v2 = 2.0 * n + 1.0 * s     # normal motion must not enter xi
    f, t = impose_step(lmp, w1=w1, w2=w2, v2=v2)
    xi = DT * (s @ (-v2) + 0.5 * w1 + 0.7 * w2)
    exp = expected_pair(x[0], x[1], 0.5, 0.7, xi)
    assert 0.05 < exp[4] < 0.95
    check_pair(f, t, exp)
    lmp.close()


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_sliding_beyond_coulomb_limit(sign):
    lmp, x = two_disk_system(angle=0.3)
    _, _, _, _, _, s = expected_pair(x[0], x[1], 0.5, 0.7, 0.0)
    delta = 1.2 - np.hypot(*(x[0] - x[1]))
    ts = MU * KN * delta / KT
    f, t = impose_step(lmp, v1=sign * 3.0 * ts / DT * s)
    exp = expected_pair(x[0], x[1], 0.5, 0.7, sign * 3.0 * ts)
    check_pair(f, t, exp)
    fn = KN * delta**1.5
    ft = f[0] @ s
    assert abs(ft) == pytest.approx(MU * fn, rel=1e-13)
    _, hxi, _ = history(lmp)
    assert hxi[0, 0] == pytest.approx(sign * ts, rel=1e-14)    # rescaled to t*
    # a second slip step in the same direction keeps it at the limit
    f2, _ = impose_step(lmp, v1=sign * 0.5 * ts / DT * s)
    assert abs(f2[0] @ s) == pytest.approx(MU * fn, rel=1e-13)
    lmp.close()


def test_run0_and_pair_local_do_not_change_history():
    lmp, x = two_disk_system(angle=0.3)
    _, _, _, _, _, s = expected_pair(x[0], x[1], 0.5, 0.7, 0.0)
    f, t = impose_step(lmp, v1=12.0 * s, w2=5.0)
    before = history(lmp)
    lmp.commands_list(["compute pl all pair/local p1 p2 p3 p4 p5 cutoff radius",
                       "run 0", "run 0"])
    after = history(lmp)
    for a, b in zip(before, after):
        assert np.array_equal(a, b)
    # forces recomputed from the stored history equal those of the step
    assert np.array_equal(gather(lmp, "f", 3)[:, :2], f)
    # svector: F_t (x, y), u, t (x, y) on atom i of the listed pair
    pl = np.array(lmp.numpy.extract_compute("pl", 2, 2), dtype=np.float64)
    assert pl.shape == (1, 5)
    xi = before[1][0, 0]
    F1, _, _, _, u, _ = expected_pair(x[0], x[1], 0.5, 0.7, xi)
    fn_vec = KN * (1.2 - np.hypot(*(x[0] - x[1])))**1.5 * np.array([-s[1], s[0]])
    ft_vec = F1 - fn_vec
    sgn = 1.0 if pl[0, 3] * (xi * s[0]) + pl[0, 4] * (xi * s[1]) > 0 else -1.0
    np.testing.assert_allclose(pl[0, :2], sgn * ft_vec, rtol=1e-12, atol=1e-12 * abs(F1).max())
    assert pl[0, 2] == pytest.approx(u, rel=1e-13)
    np.testing.assert_allclose(pl[0, 3:], sgn * xi * s, rtol=1e-13)
    lmp.close()


def wall_system(delta=2e-3, r=0.7, mu=MU, mu_arg=None):
    lmp = new_lammps()
    lmp.commands_list(box_commands())
    cmds = style_commands(mu=mu, wall=False)
    cmds.append(f"fix wall all wall/mindlin/smooth {KN!r} {KT!r} {mu_arg or mu!r} yplane 0.0")
    add_disk(lmp, 2, r, 5.0, r - delta)
    lmp.commands_list(cmds + [f"timestep {DT!r}"])
    return lmp


@pytest.mark.parametrize("slip_u, rot_u", [(0.4, 0.0), (0.0, -0.6), (0.3, 0.3), (2.0, 1.0)])
def test_disk_on_wall(slip_u, rot_u):
    r, delta = 0.7, 2e-3
    lmp = wall_system(delta=delta, r=r)
    ts = MU * KN * delta / KT
    set_per_atom(lmp, "v", 1, [slip_u * ts / DT, 0.0, 0.0])
    set_per_atom(lmp, "omega", 1, [0.0, 0.0, rot_u * ts / (r * DT)])
    lmp.command("run 1")
    y = gather(lmp, "x", 3)[0, 1]
    d = r - y
    fn = KN * d**1.5
    ts = MU * KN * d / KT
    xi = float(np.clip(DT * (slip_u * ts / DT + r * rot_u * ts / (r * DT)), -ts, ts))
    u = abs(xi) / ts
    ft = -MU * fn * u * (1 + u - u * u) * np.sign(xi)
    f = gather(lmp, "f", 3)[0]
    tq = gather(lmp, "torque", 3)[0, 2]
    assert f[0] == pytest.approx(ft, rel=REL, abs=1e-300)
    assert f[1] == pytest.approx(fn, rel=REL)
    assert tq == pytest.approx(r * ft, rel=REL, abs=1e-300)
    _, _, wall = history(lmp)
    assert wall[0] == pytest.approx(xi, rel=1e-14, abs=1e-300)
    # per-atom array: fx fy u t delta; global vector: total wall force
    arr = np.array(lmp.numpy.extract_fix("wall", 1, 2), dtype=np.float64)[0]
    np.testing.assert_allclose(arr, [f[0], f[1], u, xi, d], rtol=1e-13, atol=1e-300)
    assert lmp.extract_fix("wall", 0, 1, 1) == pytest.approx(fn, rel=1e-14)
    assert lmp.extract_fix("wall", 0, 1, 0) == pytest.approx(ft, rel=1e-14, abs=1e-300)
    hist_before = history(lmp)[2].copy()
    lmp.command("run 0")
    assert np.array_equal(history(lmp)[2], hist_before)
    lmp.close()


def test_fix_adapt_changes_friction_of_pair_and_wall():
    lmp, x = two_disk_system(angle=0.3)
    lmp.commands_list([
        "variable mu equal 0.5",
        f"fix wall all wall/mindlin/smooth {KN!r} {KT!r} v_mu yplane 0.0",
        "fix ad all adapt 1 pair mindlin/smooth mu * * v_mu",
    ])
    _, _, _, _, _, s = expected_pair(x[0], x[1], 0.5, 0.7, 0.0)
    delta = 1.2 - np.hypot(*(x[0] - x[1]))
    f, _ = impose_step(lmp, v1=5.0 * MU * KN * delta / KT / DT * s)
    assert abs(f[0] @ s) == pytest.approx(0.5 * KN * delta**1.5, rel=1e-13)
    lmp.command("variable mu equal 0.25")
    f, _ = impose_step(lmp, v1=1e-3 / DT * s)
    assert abs(f[0] @ s) == pytest.approx(0.25 * KN * delta**1.5, rel=1e-13)
    lmp.close()
    # the wall follows the same variable
    lmp = wall_system(mu_arg="v_mu")
    lmp.commands_list(["variable mu equal 0.3"])
    set_per_atom(lmp, "v", 1, [100.0, 0.0, 0.0])
    lmp.command("run 1")
    f = gather(lmp, "f", 3)[0]
    assert abs(f[0]) == pytest.approx(0.3 * f[1], rel=1e-13)
    lmp.close()
