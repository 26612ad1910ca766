"""The 3D contact law through LAMMPS: two spheres and a sphere on each kind of
wall, against the formulas of docs/conventions.md written out in numpy.

Motion is imposed without an integrator: positions stay put, the velocities
and spins set on the atoms are those of every step, so after N steps the
tangential displacement is t = N dt slip (capped at t*), with
slip = P[(v_i - v_j) - (R_i om_i + R_j om_j) x n] (v_j = om_j = 0 for a wall).
"""
import numpy as np
import pytest

from .lmputil import (KN, KT, MU, add_sphere, box_commands_3d, gather, history_3d,
                      new_lammps, set_per_atom)

R1, R2 = 0.5, 0.7
DELTA = 1.0e-3
DT = 1.0e-4
N0 = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
E1 = np.cross(N0, [1.0, 0.0, 0.0])
E1 /= np.linalg.norm(E1)
E2 = np.cross(N0, E1)


def law(delta, t, mu=MU):
    """(f_n, t after the cap, F_t) of Eq. (3) with a vector t, in the form
    F_t = -mu f_n u g(u) t/|t|, u = |t|/t*."""
    fn = KN * delta ** 1.5
    ts = mu * KN * delta / KT
    size = np.linalg.norm(t)
    if size == 0.0:
        return fn, t, np.zeros(3)
    if size > ts:
        t, size = t * (ts / size), ts
    u = size / ts
    return fn, t, -mu * fn * u * (1.0 + u - u * u) * t / size


def slip(n, dv, w):
    rel = np.asarray(dv, float) - np.cross(w, n)
    return rel - (rel @ n) * n


def close(actual, desired, rel=1e-12):
    scale = np.abs(desired).max()
    np.testing.assert_allclose(actual, desired, rtol=0, atol=rel * scale)


# --------------------------------------------------------------------- pair

def two_spheres(v1=(0, 0, 0), w1=(0, 0, 0), v2=(0, 0, 0), w2=(0, 0, 0), nsteps=1, mu=MU,
                extra=()):
    lmp = new_lammps()
    lmp.commands_list(box_commands_3d(boundary="p p p"))
    c1 = np.array([5.0, 5.0, 5.0])
    add_sphere(lmp, 1, R1, c1)
    add_sphere(lmp, 2, R2, c1 - (R1 + R2 - DELTA) * N0)
    lmp.commands_list(["pair_style mindlin/smooth", f"pair_coeff * * {KN!r} {KT!r} {mu!r}",
                       f"timestep {DT!r}", *extra])
    for name, atom, val in [("v", 1, v1), ("omega", 1, w1), ("v", 2, v2), ("omega", 2, w2)]:
        set_per_atom(lmp, name, atom, val)
    lmp.command(f"run {nsteps}")
    out = {k: gather(lmp, k, 3) for k in ("x", "f", "torque", "v", "omega")}
    out["t"] = history_3d(lmp)[:, 0]
    out["partner"] = gather(lmp, "i2_mindlin_partner", 8, dtype=0)[:, 0]
    return lmp, out


def expected_pair(out, nsteps, mu=MU):
    x, v, om = out["x"], out["v"], out["omega"]
    d = x[0] - x[1]
    r = np.linalg.norm(d)
    n = d / r
    s = slip(n, v[0] - v[1], R1 * om[0] + R2 * om[1])
    fn, t, ft = law(R1 + R2 - r, nsteps * DT * s, mu)
    f1 = fn * n + ft
    return {"t": t, "f": np.array([f1, -f1]),
            "torque": np.array([-R1 * np.cross(n, ft), -R2 * np.cross(n, ft)])}


PAIR_CASES = {
    "slip e1": dict(v1=0.3 * E1),
    "slip e2": dict(v2=-0.2 * E2),
    "spin x": dict(w1=(2.0, 0.0, 0.0)),
    "spin y": dict(w1=(0.0, -1.5, 0.0), w2=(0.0, 0.4, 0.0)),
    "spin z": dict(w2=(0.0, 0.0, 3.0)),
    "normal": dict(v1=0.5 * N0, v2=-0.1 * N0),
    "mixed": dict(v1=0.2 * E1 + 0.1 * N0, w1=(0.3, -0.2, 0.5), v2=(0.1, 0.0, -0.3),
                  w2=(-0.4, 0.1, 0.2)),
}


@pytest.mark.parametrize("case", PAIR_CASES)
@pytest.mark.parametrize("nsteps", [1, 300])      # 300 steps: beyond the Coulomb limit
def test_two_spheres_forces_torques_history(case, nsteps):
    lmp, out = two_spheres(nsteps=nsteps, **PAIR_CASES[case])
    ref = expected_pair(out, nsteps)
    close(out["f"], ref["f"])
    if case != "normal":
        close(out["torque"], ref["torque"])
        close(out["t"][0], ref["t"])
        ts = MU * KN * DELTA / KT
        assert (np.linalg.norm(ref["t"]) == pytest.approx(ts, rel=1e-12)) == (nsteps == 300)
    else:
        # slip along n only: no tangential force beyond round-off
        assert np.abs(out["torque"]).max() < 1e-12 * np.abs(out["f"]).max()
    # Newton's third law and the two sides' history, bitwise
    np.testing.assert_array_equal(out["f"][1], -out["f"][0])
    np.testing.assert_array_equal(out["t"][1], -out["t"][0])
    assert list(out["partner"]) == [2, 1]
    lmp.close()


def test_sliding_force_is_mu_fn_and_follows_fix_adapt():
    """A sliding contact: |F_t| = mu f_n; fix adapt changes mu during the run."""
    adapt = ["variable mu equal 0.4", "fix ad all adapt 1 pair mindlin/smooth mu * * v_mu"]
    lmp, out = two_spheres(v1=0.3 * E1, nsteps=60, extra=adapt)
    ref = expected_pair(out, 60, mu=0.4)       # 60 dt 0.3 = 1.8e-3 > t* = 1.4e-3
    close(out["f"], ref["f"])
    close(out["torque"], ref["torque"])
    ft = out["f"][0] - (out["f"][0] @ N0) * N0
    assert np.linalg.norm(ft) == pytest.approx(0.4 * KN * DELTA ** 1.5, rel=1e-11)
    lmp.close()


def test_history_follows_a_turning_normal():
    """Sphere 2 orbits sphere 1 (fix move rotate, about an axis through c1):
    t is projected onto each step's tangent plane with its length kept, then
    advanced; the same rule stepped in numpy from the positions and
    velocities of every step.  mu = 100 keeps |t| (0.25 after 40 steps, the
    normal turned by 0.5 rad) below t* = 0.35, so the length kept by the
    projection shows (a projection without rescaling ends 1.5e-3 shorter)."""
    lmp = new_lammps()
    lmp.commands_list(box_commands_3d(boundary="p p p"))
    c1 = np.array([5.0, 5.0, 5.0])
    add_sphere(lmp, 1, R1, c1)
    add_sphere(lmp, 2, R2, c1 - (R1 + R2 - DELTA) * N0)
    axis = np.cross(N0, [0.2, 0.9, -0.1])
    lmp.commands_list([
        "pair_style mindlin/smooth", f"pair_coeff * * {KN!r} {KT!r} 100.0",
        f"timestep {DT!r}", "group two id 2",
        "fix spin two move rotate {} {} {} {} {} {} 0.05".format(*c1, *axis),
        "run 0"])
    t = np.zeros(3)
    for _ in range(40):
        lmp.command("run 1 pre no post no")
        x, v, om = (gather(lmp, k, 3) for k in ("x", "v", "omega"))
        d = x[0] - x[1]
        n = d / np.linalg.norm(d)
        if t @ n != 0.0:
            size = np.linalg.norm(t)
            t = t - (t @ n) * n
            t *= size / np.linalg.norm(t)
        t = law(R1 + R2 - np.linalg.norm(d), t + DT * slip(n, v[0] - v[1],
                                                           R1 * om[0] + R2 * om[1]), 100.0)[1]
    stored = history_3d(lmp)[:, 0]
    assert abs(stored[0] @ n) < 1e-15 * np.linalg.norm(stored[0])     # in the plane
    assert np.linalg.norm(t) == pytest.approx(0.2508, abs=1e-4)
    close(stored[0], t, rel=1e-11)
    np.testing.assert_array_equal(stored[1], -stored[0])
    assert np.abs(om[1]).max() > 0.0          # fix move set the spin of sphere 2
    lmp.close()


# --------------------------------------------------------------------- walls

WALLS = {   # wall args, centre of the sphere, inward normal
    "zplane lo": ("zplane -4.0 NULL", [0.3, -0.2, -4.0 + R2 - DELTA], [0, 0, 1.0]),
    "zplane hi": ("zplane NULL 4.0", [0.3, -0.2, 4.0 - R2 + DELTA], [0, 0, -1.0]),
    "xplane lo": ("xplane -4.0 4.0", [-4.0 + R2 - DELTA, 0.1, 0.2], [1.0, 0, 0]),
    "yplane hi": ("yplane -4.0 4.0", [0.1, 4.0 - R2 + DELTA, 0.2], [0, -1.0, 0]),
    "zcylinder": ("zcylinder 4.0", 0.0, None),
}


def sphere_on_wall(wall, v=(0, 0, 0), w=(0, 0, 0), nsteps=1, mu=MU, extra=()):
    args, centre, normal = WALLS[wall]
    if wall == "zcylinder":
        direction = np.array([0.6, -0.8, 0.0])
        centre = (4.0 - R2 + DELTA) * direction + [0.0, 0.0, 1.3]
        normal = -direction
    lmp = new_lammps()
    lmp.commands_list(box_commands_3d(size=10.0, lo=-5.0, boundary="f f f"))
    add_sphere(lmp, 2, R2, centre)
    lmp.commands_list(["pair_style mindlin/smooth", f"pair_coeff * * {KN!r} {KT!r} {mu!r}",
                       f"fix w all wall/mindlin/smooth {KN!r} {KT!r} {mu!r} {args}",
                       f"timestep {DT!r}", *extra])
    set_per_atom(lmp, "v", 1, v)
    set_per_atom(lmp, "omega", 1, w)
    lmp.command(f"run {nsteps}")
    out = {k: gather(lmp, k, 3)[0] for k in ("x", "f", "torque", "v", "omega")}
    out["array"] = np.array(lmp.numpy.extract_fix("w", 1, 2)[0])
    out["vector"] = np.array([lmp.extract_fix("w", 0, 1, k) for k in range(3)])
    return lmp, out, np.asarray(normal, float)


def expected_wall(out, n, nsteps, mu=MU, args=""):
    x = out["x"]
    if n[2] == 0.0 and "cylinder" in args:
        delta = R2 + np.hypot(x[0], x[1]) - 4.0
    else:
        pos = {0: x[0], 1: x[1], 2: x[2]}[int(np.argmax(np.abs(n)))]
        delta = R2 - abs(pos - (-4.0 if n.max() > 0 else 4.0))
    s = slip(n, out["v"], R2 * out["omega"])
    fn, t, ft = law(delta, nsteps * DT * s, mu)
    return {"t": t, "delta": delta, "f": fn * n + ft, "torque": -R2 * np.cross(n, ft)}


WALL_MOTIONS = {
    "slip a": dict(v=(0.3, -0.2, 0.1)),
    "slip b": dict(v=(-0.1, 0.25, 0.2)),
    "spin x": dict(w=(2.0, 0.0, 0.0)),
    "spin y": dict(w=(0.0, -1.5, 0.0)),
    "spin z": dict(w=(0.0, 0.0, 3.0)),
}


@pytest.mark.parametrize("wall", WALLS)
@pytest.mark.parametrize("motion", WALL_MOTIONS)
@pytest.mark.parametrize("nsteps", [1, 80])
def test_sphere_on_wall(wall, motion, nsteps):
    lmp, out, n = sphere_on_wall(wall, nsteps=nsteps, **WALL_MOTIONS[motion])
    ref = expected_wall(out, n, nsteps, args=WALLS[wall][0])
    close(out["f"], ref["f"])
    tangential = np.abs(ref["torque"]).max() > 0.0
    if tangential:
        close(out["torque"], ref["torque"])
        close(out["array"][4:7], ref["t"])
    else:      # a spin about the normal slips nowhere
        assert np.abs(out["torque"]).max() < 1e-12 * np.abs(out["f"]).max()
    close(out["array"][:3], out["f"], rel=0)
    close(out["vector"], out["f"], rel=0)
    assert out["array"][7] == pytest.approx(ref["delta"], rel=1e-12)
    lmp.close()


def test_wall_normal_motion_gives_normal_force_only():
    lmp, out, n = sphere_on_wall("zplane lo", v=(0.0, 0.0, 0.4), nsteps=5)
    close(out["f"], KN * DELTA ** 1.5 * n)
    assert np.all(out["array"][4:7] == 0.0)
    lmp.close()


def test_wall_mu_from_fix_mu_velocity_in_3d():
    """fix mu/velocity sets mu of the pair and the wall in 3D: a sliding sphere
    carries |F_t| = mu(v) f_n, mu(v) = mu0 (B exp(-w (v/vss - v0/vss)) + mu_ss)."""
    v = 0.5
    muv = ["fix muv all mu/velocity 1.0 0.1 0.2 0.4 0.8"]
    lmp, out, n = sphere_on_wall("zplane lo", v=(v, 0.0, 0.0), nsteps=80, extra=muv)
    mu = 1.0 * (0.2 * np.exp(-0.4 * (v / 0.1 - 1.0)) + 0.8)
    assert lmp.extract_fix("muv", 0, 1, 0) == pytest.approx(mu, rel=1e-15)
    ref = expected_wall(out, n, 80, mu=mu)
    close(out["f"], ref["f"])
    assert abs(out["f"][0]) == pytest.approx(mu * KN * DELTA ** 1.5, rel=1e-11)
    lmp.close()


def test_single_and_compute_pair_local_in_3d():
    """compute pair/local p1..p7 = F_t,x F_t,y u t_x t_y F_t,z t_z of atom i,
    from the stored history; run 0 changes neither history nor forces."""
    lmp, out = two_spheres(v1=0.3 * E1, w2=(0.0, 0.5, -0.2), nsteps=5)
    lmp.commands_list(["compute pl all pair/local p1 p2 p3 p4 p5 p6 p7 cutoff radius",
                       "run 0", "run 0"])
    np.testing.assert_array_equal(history_3d(lmp)[:, 0], out["t"])
    np.testing.assert_array_equal(gather(lmp, "f", 3), out["f"])
    pl = np.array(lmp.numpy.extract_compute("pl", 2, 2), dtype=np.float64)
    assert pl.shape == (1, 7)
    ref = expected_pair(out, 5)
    ft = ref["f"][0] - (ref["f"][0] @ N0) * N0
    sign = 1.0 if pl[0, 3] * ref["t"][0] > 0 else -1.0     # atom i is 1 or 2
    close(sign * pl[0, [0, 1, 5]], ft)
    close(sign * pl[0, [3, 4, 6]], ref["t"])
    ts = MU * KN * DELTA / KT
    assert pl[0, 2] == pytest.approx(np.linalg.norm(ref["t"]) / ts, rel=1e-12)
    lmp.close()


def test_more_than_eight_contacts_grow_the_history():
    """A sphere with 12 neighbours (fcc shell), history kept by the pair: the
    arrays grow past their 8 starting columns, every contact is recorded on
    both sides as mirror images, and the forces on the centre sum to zero
    by symmetry while each neighbour gets minus its share."""
    dirs = np.array([(a, b, 0) for a in (1, -1) for b in (1, -1)] +
                    [(a, 0, b) for a in (1, -1) for b in (1, -1)] +
                    [(0, a, b) for a in (1, -1) for b in (1, -1)], float) / np.sqrt(2.0)
    lmp = new_lammps()
    lmp.commands_list(box_commands_3d(boundary="p p p"))
    c = np.array([5.0, 5.0, 5.0])
    add_sphere(lmp, 1, R1, c)
    for d in dirs:
        add_sphere(lmp, 1, R1, c + (2 * R1 - DELTA) * d)
    lmp.commands_list(["pair_style mindlin/smooth", f"pair_coeff * * {KN!r} {KT!r} {MU!r}",
                       f"timestep {DT!r}"])
    set_per_atom(lmp, "omega", 1, (0.7, -0.4, 0.9))
    lmp.command("run 3")
    ncol = lmp.numpy.extract_atom("i2_mindlin_partner").shape[1]
    assert ncol >= 12
    part = gather(lmp, "i2_mindlin_partner", ncol, dtype=0)
    assert list(part[0][part[0] > 0]) == list(range(2, 14))
    t = history_3d(lmp, ncol)
    for k, j in enumerate(part[0][:12]):
        row = int(np.nonzero(part[j - 1] == 1)[0][0])
        np.testing.assert_array_equal(t[j - 1, row], -t[0, k])
    f = gather(lmp, "f", 3)
    assert np.abs(f[0]).max() < 1e-12 * np.abs(f[1:]).max()
    lmp.close()
