"""A planar packing of spheres through the 3D driver reproduces the 2D ramp.

The driver's N = 20 packing (``relaxed`` of conftest.py) is ramped in 2D
(``stages.ramp``, dF_x = 0.05, tol = 1e-3: 5 steps and 6 bisection points
across F_x^c). Its relaxed equilibrium is lifted to spheres in the plane
z = L/2 of the 3D scene (``in.relax3d``: periodic in x and z with L_z = L
> 2 R_max, so no sphere meets an image across z; the same floor y = 0),
contact history t = xi s with s = (n_y, -n_x, 0), wall t = (xi_w, 0, 0),
and saved as a 3D equilibrium (data file + dump) by the driver's own
``save_equilibrium``. Every point of the 2D ramp is then replayed, from the
same start and in the same order, through the 3D ramp stage's point routine
(``stages.point.ramp_point``: ``load_equilibrium_scene`` of spheres, Newton with
the 3D Jacobian, ``save_equilibrium``, ``stability_of_dump``), and compared
with the 2D point:

* the equilibrium: x, y to round-off, z unchanged, the same contacts, the
  history t = xi s and the wall's (xi_w, 0, 0);
* K = -dG/dq of the 3D dump on (x, y, phi_z) against the 2D K of the 2D
  dump, and no coupling to (z, phi_x, phi_y) (mirror symmetry z -> -z);
* the eigenvalues of M^-1 K on the in-plane block, with the 2D mass (disk
  inertia I0 = 1/2) and the 2D rattlers, against the 2D eigenvalues, and
  its certified decision against the 2D ramp's at every point: the 2D
  certified bracket of F_x^c is reproduced.

What the 3D code itself concludes (docs/results/driver.md, "A planar
packing of spheres"): the out-of-plane block is certified real but has
negative eigenvalues at every load, F_x = 0 included (rolling modes that no
tangential spring resists, destabilised by the compressive prestress: a
pressed layer of spheres buckles out of its plane); it has no complex
pair, so the 3D verdict on the full matrix is the in-plane one computed
with the 3D mass (I0 = 2/5) and the 3D rattler rule (fewer than 3
contacts, which removes the load-bearing top spheres on 2 contacts). Both
lower F_x^c: the 3D ramp of the lifted packing brackets it below the 2D
bracket. Its decision 'real' there means no complex pair, not stability:
its growth rate (sqrt of the most negative eigenvalue) is > 0 at every
point. The LAMMPS level (forces, motion and history of 20 steps) is
tests/plugin/test_runs_3d.py::test_planar_configuration_reproduces_the_2d_code.
"""
import os

import h5py
import numpy as np
import pytest

from remote_trigger.analysis.stability.exceptional import classify_spectrum
from remote_trigger.analysis.stability.jacobian import (
    find_rattlers, remove_dofs, stiffness_matrix)
from remote_trigger.analysis.stability.jacobian3d import find_rattlers3d, stiffness_matrix3d
from remote_trigger.analysis.stability.verdict import stability_of
from remote_trigger.analysis.state.dumpfile import read_dump, read_dump3d
from remote_trigger.pywrap.stages.ramp_file import point_file
from remote_trigger.analysis.stability.decision import Decision

DF = 0.05
TOL = 1e-3
EPS = np.finfo(float).eps


def lift_to_spheres(cfg, datafile, F_x, prefix):
    """The 2D equilibrium ``datafile`` as spheres at z = L/2: ``prefix``.data/.dump/.json."""
    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.stages.common import (
        load_equilibrium_scene, load_relax_scene, save_equilibrium)
    from remote_trigger.pywrap.stages.packing import Packing, write_data

    with Engine() as eng:
        load_equilibrium_scene(eng, cfg, datafile, F_x, 2)
        st = eng.gather_state()
    L = float(st.box_hi[0] - st.box_lo[0])
    assert st.box_lo[0] == 0.0
    pos = np.column_stack([st.positions, np.full(st.n, 0.5 * L)])
    write_data(Packing(pos, st.radii, st.types, st.top, L, float(st.box_lo[1]),
                       float(st.box_hi[1]), 0), prefix + ".lift.data")
    t = np.zeros(st.xi.shape + (3,))
    for i, k in zip(*np.nonzero(st.partner)):
        d = st.positions[i] - st.positions[int(st.partner[i, k]) - 1]
        d[0] -= L * np.round(d[0] / L)
        n = d / np.hypot(d[0], d[1])
        t[i, k, :2] = st.xi[i, k] * np.array([n[1], -n[0]])
    wall_t = np.column_stack([st.wall_xi, np.zeros((st.n, 2))])
    with Engine() as eng:
        load_relax_scene(eng, cfg, prefix + ".lift.data", F_x, deck="in.relax3d")
        eng.unfix("damp", "rdamp", "integ")
        eng.run(0)
        eng.restore_history3d(st.partner, t, wall_t)
        save_equilibrium(eng, cfg, F_x, prefix)
    return prefix + ".data"


def _rows(h5):
    """(kind, F_x, decision, data file) of every point of a ramp.h5, in ramp order."""
    with h5py.File(h5, "r") as fh:
        return [(kind, float(F), float(d), point_file(h5, f, fh.attrs))
                for kind in ("steps", "bisection")
                for F, d, f in zip(fh[kind]["F_x"][()], fh[kind]["decision"][()],
                                   fh[kind]["datafile"][()])]


def _bisection_start(done):
    """The start of a bisection point: the largest load certified real below the
    smallest certified complex (``ramp.ramp_bracket``), from the points so far."""
    hi = min(F for F, d, _ in done if d == 1)
    return max((F, f) for F, d, f in done if d == 0 and F < hi)[1]


@pytest.fixture(scope="module")
def planar(relaxed, tmp_path_factory):
    """The 2D ramp, its replay with spheres, and the 3D ramp of the lifted packing."""
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.stages.config import RampConfig
    from remote_trigger.pywrap.stages.point import ramp_point

    out = tmp_path_factory.mktemp("planar3d")
    cfg = RampConfig(datafile=relaxed.datafile, dF_x=DF, tol=TOL)
    ramp2 = stages.ramp(cfg, str(out / "r2"), quiet=True)
    start3 = lift_to_spheres(cfg, relaxed.datafile, cfg.F_x, str(out / "start3d"))
    cfg3 = cfg.replace(datafile=start3)
    points, done, prev = [], [], start3
    with Engine() as eng:
        for kind, F, d2, file2 in _rows(ramp2.h5):
            start = prev if kind == "steps" else _bisection_start(done)
            prefix = str(out / (os.path.basename(file2)[:-len(".data")] + "_3d"))
            vals, res = ramp_point(eng, cfg3, start, F, prefix, None, 3)
            done.append((F, d2, prefix + ".data"))
            prev = prefix + ".data" if kind == "steps" else prev
            points.append((F, d2, file2[:-len(".data")] + ".dump", prefix + ".dump", vals, res))
    ramp3 = stages.ramp(cfg3, str(out / "r3"), quiet=True)
    return ramp2, points, ramp3


def _inplane(n):
    k = np.arange(n)
    return (np.column_stack([6 * k, 6 * k + 1, 6 * k + 5]).reshape(-1),
            np.column_stack([6 * k + 2, 6 * k + 3, 6 * k + 4]).reshape(-1))


def test_the_2d_ramp_brackets_f_x_c(planar):
    ramp2, points, _ = planar
    assert ramp2.status == "complete" and ramp2.tol_reached, ramp2.message
    assert len(points) >= 8 and ramp2.F_x_c_low > 0
    assert {d for _, d, *_ in points} == {0.0, 1.0}


def test_equilibria_and_history_are_the_2d_ones(planar):
    _, points, _ = planar
    worst = dict(x=0.0, z=0.0, t=0.0, wall=0.0)
    for F, _, dump2, dump3, vals, _ in points:
        a, b = read_dump(dump2), read_dump3d(dump3)
        L = float(a.box_hi[0] - a.box_lo[0])
        assert vals["residual"] < 1e-10 and vals["damped_time"] == 0.0, (F, vals)
        dz = np.abs(b.positions[:, 2] - 0.5 * L).max()        # nothing left the plane
        assert dz <= 4 * EPS * L, (F, dz)
        dx = np.abs(b.positions[:, :2] - a.positions).max()
        assert dx <= 64 * EPS * L, (F, dx)
        assert np.array_equal(b.contact_i, a.contact_i), F
        assert np.array_equal(b.contact_j, a.contact_j), F
        assert np.array_equal(b.wall_index, a.wall_index), F
        d = a.separation(a.contact_i, a.contact_j)
        n = d / np.hypot(d[:, 0], d[:, 1])[:, None]
        t2 = np.column_stack([n[:, 1], -n[:, 0], np.zeros(len(n))]) * a.contact_xi[:, None]
        w2 = np.column_stack([a.wall_xi, np.zeros((a.wall_xi.size, 2))])
        dt, dw = np.abs(b.contact_t - t2).max(), np.abs(b.wall_t - w2).max()
        # t is a sum of position increments: its error is that of the positions
        assert dt <= 64 * EPS * L and dw <= 64 * EPS * L, (F, dt, dw)
        worst = dict(x=max(worst["x"], dx / L), z=max(worst["z"], dz / L),
                     t=max(worst["t"], dt / L),
                     wall=max(worst["wall"], dw / L))
    print(f"planar 3D vs 2D, {len(points)} equilibria: max |dx|/L {worst['x']:.2g}, "
          f"|dz|/L {worst['z']:.2g}, "
          f"|dt|/L {worst['t']:.2g}, |dt_wall|/L {worst['wall']:.2g}")


def test_in_plane_k_eigenvalues_and_decisions_are_the_2d_ones(planar):
    _, points, _ = planar
    worst = dict(K=0.0, coupling=0.0, lam=0.0)
    for F, d2, dump2, dump3, _, _ in points:
        a, b = read_dump(dump2), read_dump3d(dump3)
        K2, K3 = stiffness_matrix(a).toarray(), stiffness_matrix3d(b).toarray()
        inp, outp = _inplane(b.n)
        scale = np.abs(K2).max()
        dK = np.abs(K3[np.ix_(inp, inp)] - K2).max() / scale
        cpl = max(np.abs(K3[np.ix_(inp, outp)]).max(), np.abs(K3[np.ix_(outp, inp)]).max())
        assert dK <= 1e-10 and cpl <= 1e-15 * scale, (F, dK, cpl)
        # the in-plane block with the 2D mass (I0 = 1/2) and the 2D rattlers
        keep = find_rattlers(a).keep_dofs
        Kr, mr = remove_dofs(stiffness_matrix(a), a.mass_diagonal(), keep)
        lam2 = np.sort_complex(np.linalg.eigvals(Kr.toarray() / mr[:, None]))
        A = K3[np.ix_(inp, inp)][np.ix_(keep, keep)] / mr[:, None]
        dec = classify_spectrum(A)
        lam3 = np.sort_complex(np.asarray(dec.eigenvalues, complex))
        dlam = np.abs(lam3 - lam2).max() / np.abs(lam2).max()
        assert dlam <= 1e-10, (F, dlam)
        # certified, and the 2D ramp's decision: the same bracket of F_x^c
        assert dec.decision is not Decision.UNDECIDED and dec.confidence > 1, F
        assert float(dec.decision) == d2, (F, dec.decision, d2)
        worst = dict(K=max(worst["K"], dK), coupling=max(worst["coupling"], cpl / scale),
                     lam=max(worst["lam"], dlam))
    print(f"planar 3D vs 2D: max |dK|/max|K| {worst['K']:.2g} (coupling to z, phi_x, "
          f"phi_y {worst['coupling']:.2g}), max |d lambda|/max|lambda| {worst['lam']:.2g}; "
          f"in-plane decisions = the 2D ramp's at all {len(points)} loads")


def test_out_of_plane_buckles_and_the_3d_verdict_is_the_in_plane_one(planar):
    """The 3D verdict on the full matrix (sphere inertia, 3D rattlers) is the
    in-plane block's with the same mass and rattlers: the out-of-plane block
    is certified real but indefinite at every load."""
    _, points, _ = planar
    summary = []
    for F, _, _, dump3, vals, res in points:
        b = read_dump3d(dump3)
        K3, m3 = stiffness_matrix3d(b).toarray(), b.mass_diagonal()
        rat = find_rattlers3d(b)
        kept = np.setdiff1d(np.arange(b.n), np.searchsorted(b.ids, rat.ids))
        inp, outp = (np.column_stack([6 * kept + c for c in cs]).reshape(-1)
                     for cs in ((0, 1, 5), (2, 3, 4)))
        out = classify_spectrum(K3[np.ix_(outp, outp)] / m3[outp][:, None])
        lam_out = np.asarray(out.eigenvalues, complex)
        inn = classify_spectrum(K3[np.ix_(inp, inp)] / m3[inp][:, None])
        assert out.decision is Decision.REAL and out.confidence > 1, F
        assert np.all(lam_out.imag == 0) and lam_out.real.min() < 0, F
        assert res.decision is inn.decision, F
        assert res.eigenvalues.size == lam_out.size + np.asarray(inn.eigenvalues).size
        g_static = np.sqrt(-lam_out.real.min())
        assert res.growth_rate >= g_static * (1 - 1e-9), (F, res.growth_rate, g_static)
        summary.append((F, res.decision, int(np.sum(lam_out.real < 0)), lam_out.real.min(),
                        res.n_rattlers))
    print("planar 3D verdict (F_x, full decision, negative out-of-plane eigenvalues, min, "
          "rattlers): " + "; ".join(f"{F:.6g} {d} {k} {m:.3g} {r}" for F, d, k, m, r in summary))


def test_3d_ramp_of_the_planar_packing(planar):
    """``stages.ramp`` of the lifted packing (the code of ``ramp --dim 3``): its
    steps are the 2D steps' equilibria; its bracket of F_x^c (sphere inertia,
    3D rattlers) lies below the 2D one; growth rate > 0 at every 'real' step."""
    ramp2, points, ramp3 = planar
    assert ramp3.status == "complete" and ramp3.tol_reached, ramp3.message
    np.testing.assert_array_equal(ramp3.F_x, ramp2.F_x)
    with h5py.File(ramp3.h5, "r") as fh:
        files3 = [point_file(ramp3.h5, f, fh.attrs) for f in fh["steps"]["datafile"][()]]
    for F, file3 in zip(ramp3.F_x, files3):
        a = read_dump([p[2] for p in points if p[0] == F][0])
        b = read_dump3d(file3[:-len(".data")] + ".dump")
        assert np.abs(b.positions[:, :2] - a.positions).max() <= 64 * EPS * b.box_length[0]
    assert ramp3.F_x_c_high < ramp2.F_x_c_low
    assert np.all(ramp3.growth_rate > 0)
    print(f"3D ramp of the planar packing: F_x^c in [{ramp3.F_x_c_low:.9g}, "
          f"{ramp3.F_x_c_high:.9g}], 2D [{ramp2.F_x_c_low:.9g}, {ramp2.F_x_c_high:.9g}]; "
          f"growth rate at the steps {ramp3.growth_rate.min():.4g}-"
          f"{ramp3.growth_rate.max():.4g}")
