"""Bad input to the analysis library's public functions: a clear ValueError naming
the argument, before any result (found by using the Python API as a new user)."""
import os
import re

import numpy as np
import pytest

from remote_trigger.analysis.state.state import build_state
from remote_trigger.analysis.stability.eigen import sparse_eigen
from remote_trigger.analysis.stability.jacobian import (
    find_rattlers, remove_dofs, stiffness_matrix)

from .builders import random_packing


@pytest.fixture(scope="module")
def packing():
    return random_packing(seed=11)


def _rebuilt(st, **kw):
    return build_state(ids=st.ids, positions=st.positions, radii=st.radii, masses=st.masses,
                       box_lo=st.box_lo, box_hi=st.box_hi, params=st.params, wall_y=st.wall_y,
                       **kw)


def test_non_finite_loads_and_history_are_refused(packing):
    """A NaN load gave a NaN residual and a "certified real" verdict on it."""
    n = packing.n
    with pytest.raises(ValueError, match=r"external must be finite, got 4 non-finite"):
        _rebuilt(packing, external=np.where(np.arange(2 * n).reshape(n, 2) < 4, np.nan, 0.0))
    with pytest.raises(ValueError, match="wall_t must be finite"):
        _rebuilt(packing, wall_t=np.full(n, np.inf))
    with pytest.raises(ValueError, match="partners needs partner_xi"):
        _rebuilt(packing, partners=np.zeros((n, 2)))


def test_spheres_non_finite_history_is_refused():
    from remote_trigger.analysis.state.state import ContactParams
    from remote_trigger.analysis.state.state3d import build_state3d

    kw = dict(ids=[1, 2], positions=[[0, 0.5, 0], [0.99, 0.5, 0]], radii=[0.5, 0.5],
              masses=[1.0, 1.0], box_lo=[-5, 0, -5], box_hi=[5, 10, 5],
              params=ContactParams(2e5, 2e5 / 3.5, 1.0), periodic=(True, False, True),
              pairs=[[1, 2]])
    build_state3d(**kw, pair_t=[[0.0, 1e-4, 0.0]])
    with pytest.raises(ValueError, match="pair_t must be finite"):
        build_state3d(**kw, pair_t=[[np.nan, 0.0, 0.0]])


def test_sparse_eigen_arguments(packing):
    """A v0 of another length crashed the interpreter (ARPACK reads n entries);
    k = 2.5 was an internal ARPACK error; sigma = nan was called an eigenvalue."""
    rat = find_rattlers(packing)
    Kr, mr = remove_dofs(stiffness_matrix(packing), packing.mass_diagonal(), rat.keep_dofs)
    n = Kr.shape[0]
    with pytest.raises(ValueError, match=rf"v0 must be a finite array of shape \({n},\), "
                                         r"got shape \(3,\)"):
        sparse_eigen(Kr, mr, sigma=1.0, v0=np.ones(3))
    with pytest.raises(ValueError, match="k must be an integer"):
        sparse_eigen(Kr, mr, k=2.5, sigma=1.0)
    for bad in (np.nan, 1.0 + 2.0j):
        with pytest.raises(ValueError, match="sigma must be a finite real number"):
            sparse_eigen(Kr, mr, sigma=bad)
    assert sparse_eigen(Kr, mr, k=4, sigma=1.0, v0=np.ones(n)).eigenvalues.size == 4


def test_remove_dofs_checks_its_indices(packing):
    """Negative indices wrapped silently, repeats and floats were taken."""
    K, m = stiffness_matrix(packing), packing.mass_diagonal()
    n = K.shape[0]
    for bad, msg in (([-1, 0], r"distinct indices in \[0, "), ([0, 0], "1 repeated"),
                     ([0, n], r"values in \[0, "), ([0.0, 1.0], "integers")):
        with pytest.raises(ValueError, match=msg):
            remove_dofs(K, m, np.asarray(bad))
    with pytest.raises(ValueError, match="mass must have shape"):
        remove_dofs(K, m[:-1], [0, 1])
    with pytest.raises(ValueError, match="K must be square"):
        remove_dofs(K.toarray()[:, :-1], m, [0, 1])
    Kr, mr = remove_dofs(K, m, [2, 0])
    assert Kr.shape == (2, 2) and mr.tolist() == [m[2], m[0]]


@pytest.mark.parametrize("kw, msg", [
    (dict(rel_error=-1.0), r"rel_error must be in \[0, 0.01\)"),
    (dict(window=0.0), "window must be a finite number > 0"),
    (dict(slice_size=0), "slice_size must be an integer >= 2"),
    (dict(checkpoint_seconds=-1.0), "checkpoint_seconds must be a number >= 0"),
    (dict(checkpoint_seconds="a"), "checkpoint_seconds must be a number >= 0"),
])
def test_sliced_verdict_options(packing, kw, msg):
    """rel_error = -1 gave a verdict with a negative backward error, window = 0
    and a checkpoint interval without a folder were taken, slice_size = 0 was
    an ARPACK error."""
    from remote_trigger.analysis.stability.sliced import classify_sliced

    rat = find_rattlers(packing)
    Kr, mr = remove_dofs(stiffness_matrix(packing), packing.mass_diagonal(), rat.keep_dofs)
    with pytest.raises(ValueError, match=msg):
        classify_sliced(Kr, mr, **kw)


def test_analyze_dump_passes_the_readers_keywords(packing, tmp_path):
    """mirror_rtol and inertia_factor went to analyze (TypeError)."""
    from remote_trigger.analysis.stability.analyze import analyze_dump

    from .builders import write_dump

    path = write_dump(tmp_path / "eq.dump", packing)
    a = analyze_dump(str(path), mirror_rtol=1e-6, inertia_factor=0.5, decide=False,
                     allow_residual=True)      # a packing, not an equilibrium
    assert a.state.n == packing.n and a.eigen is not None


def test_disk_functions_name_spheres_and_bad_arguments(packing):
    """generalized_forces of spheres was an AttributeError; negative_modes with a
    negative threshold counted every eigenvalue; the normal form took d = 2 (it
    had a second implementation in ``exceptional``, now gone: one matrix, one
    validation)."""
    from remote_trigger.analysis.dynamics.normal_form import normal_form_matrix
    from remote_trigger.analysis.stability.analyze import negative_modes
    from remote_trigger.analysis.stability.jacobian import displaced_state, generalized_forces

    for f in (generalized_forces, lambda s: displaced_state(s, np.zeros(3))):
        with pytest.raises(ValueError, match="expected a State of disks, got str"):
            f("not a state")
    dq = np.full(packing.ndof, np.nan)
    with pytest.raises(ValueError, match=rf"with {packing.ndof} non-finite value"):
        displaced_state(packing, dq)
    with pytest.raises(ValueError, match="rel_threshold must be a finite number >= 0"):
        negative_modes(packing, rel_threshold=-1.0)
    for d, eps, match in ((0.0, 0.1, r"delta must be in \(0, 1\), got 0.0"),
                          (2.0, 0.1, r"delta must be in \(0, 1\), got 2.0"),
                          (0.5, np.nan, "eps must be a finite number <= 1, got nan")):
        with pytest.raises(ValueError, match=match):
            normal_form_matrix(d, eps)


def _sphere_dump(path):
    """Two touching spheres above the floor, as the driver writes them (sidecar too)."""
    import json

    cols = ("id type radius mass x y z fx fy fz tqx tqy tqz v_fext_x v_fext_y v_fext_z "
            "i2_mindlin_partner[1] d2_mindlin_tx[1] d2_mindlin_ty[1] d2_mindlin_tz[1] "
            "v_wall_tx v_wall_ty v_wall_tz")
    rows = ["1 1 0.5 1 0 0.45 0 " + "0 " * 9 + "2 0 0 0 0 0 0",
            "2 1 0.5 1 0.99 0.45 0 " + "0 " * 9 + "1 0 0 0 0 0 0"]
    path.write_text("\n".join(["ITEM: TIMESTEP", "0", "ITEM: NUMBER OF ATOMS", "2",
                               "ITEM: BOX BOUNDS pp ff pp", "-5 5", "-1 10", "-5 5",
                               "ITEM: ATOMS " + cols] + rows) + "\n")
    (path.parent / (path.name + ".json")).write_text(json.dumps(
        {"k_n": 2e5, "k_t": 2e5 / 3.5, "mu": 1.0, "wall_y": 0.0, "F_x": 0.0, "F_y": 3.0,
         "dt": 1e-3}))
    return str(path)


def test_read_dump_options_and_the_kind_of_dump(packing, tmp_path):
    """frame = 1.0 was a raw 'list indices must be integers'; mirror_rtol = -1 was
    reported as a history disagreement; inertia_factor = 0 was taken (analyze
    failed later); a dump of spheres was only 'missing dump columns'."""
    from remote_trigger.analysis.state.dumpfile import read_dump, read_dump3d
    from remote_trigger.analysis.state.state3d import state3d_from_history

    from .builders import write_dump

    path = str(write_dump(tmp_path / "eq.dump", packing))
    for bad in (1.0, "0", True, None):
        with pytest.raises(ValueError, match=rf"frame must be an integer .*got frame = "
                                             rf"{re.escape(repr(bad))}"):
            read_dump(path, frame=bad)
    for frame in (0, -1, np.int64(0), np.int32(-1)):
        assert read_dump(path, frame=frame).n == packing.n
    with pytest.raises(ValueError, match="frame 1 does not exist"):
        read_dump(path, frame=np.int64(1))
    for bad in (-1.0, np.nan, np.inf, "1e-9"):
        with pytest.raises(ValueError, match=r"mirror_rtol must be a finite number >= 0, got "
                                             r"mirror_rtol = "):
            read_dump(path, mirror_rtol=bad)
    assert read_dump(path, mirror_rtol=0.0).n == packing.n
    for bad in (0, -0.5, np.nan, np.inf):
        with pytest.raises(ValueError, match=r"inertia_factor must be a finite number > 0, "
                                             r"got inertia_factor = "):
            read_dump(path, inertia_factor=bad)
    with pytest.raises(ValueError, match="inertia_factor must be"):
        _rebuilt(packing, inertia_factor=0.0)
    st = read_dump(path, inertia_factor=1)
    assert np.allclose(st.inertia, st.masses * st.radii**2)

    sph = _sphere_dump(tmp_path / "sph.dump")
    with pytest.raises(ValueError, match=r"a dump of spheres \(it has columns z, "
                                         r"d2_mindlin_tx\[\*\].*use read_dump3d"):
        read_dump(sph)
    assert read_dump3d(sph).n_contacts == 1
    with pytest.raises(ValueError, match="mirror_rtol must be a finite number >= 0"):
        read_dump3d(sph, mirror_rtol=-1.0)
    with pytest.raises(ValueError, match="frame must be an integer"):
        read_dump3d(sph, frame=0.5)
    with pytest.raises(ValueError, match=r"a dump of disks \(no z column\).*use read_dump"):
        read_dump3d(path)
    with pytest.raises(ValueError, match="inertia_factor must be a finite number > 0"):
        state3d_from_history(ids=[1], positions=[[0, 0.6, 0]], radii=[0.5], masses=[1.0],
                             box_lo=[-5, 0, -5], box_hi=[5, 10, 5],
                             params=packing.params, inertia_factor=-1.0)


def test_long_wave_fraction_and_pair_mode_arguments(packing):
    """box_length (L_x, L_y) as L_x was 'the truth value of an array is ambiguous';
    m_max = -1 gave 0.0 and m_max = 1.5 the value of m_max = 1; pair_mode of a
    real eigenvalue returned that real mode as a pair's."""
    import warnings

    from remote_trigger.analysis.stability import eigen, jacobian
    from remote_trigger.analysis.stability.analyze import analyze
    from remote_trigger.analysis.stability.modeshape import long_wave_fraction, pair_mode

    from .builders import random_packing

    u = np.random.default_rng(0).standard_normal((packing.n, 2))
    x, L = packing.positions[:, 0], packing.box_length
    with pytest.raises(ValueError, match=r"L_x, one number, got an array of shape \(2,\) "
                                         r".*give L_x = box_length\[0\]"):
        long_wave_fraction(u, x, L)
    for bad in (-1, 1.5, 2.0, True, "3"):
        with pytest.raises(ValueError, match=rf"m_max, an integer >= 0, got m_max = "
                                             rf"{re.escape(repr(bad))}"):
            long_wave_fraction(u, x, L[0], m_max=bad)
    for bad in ("5", True, np.nan):
        with pytest.raises(ValueError, match="needs a positive box length"):
            long_wave_fraction(u, x, bad)
    want = long_wave_fraction(u, x, float(L[0]), m_max=2)
    assert long_wave_fraction(u, x, L[:1], m_max=np.int64(2)) == want
    assert 0 < long_wave_fraction(u, x, L[0], m_max=0) < 1

    for nx, ny in ((4, 3), (12, 10)):                # 36 dofs: dense; 360: ARPACK
        st = random_packing(5, nx=nx, ny=ny, cap_fraction=0.6)
        res = analyze(st, eigenvalues=False, decide=False)
        Kr, mr = jacobian.remove_dofs(res.K, res.mass, res.rattlers.keep_dofs)
        lam = np.linalg.eigvals(eigen.dynamical_matrix(Kr, mr).toarray())
        real = lam[lam.imag == 0].real
        r = real[np.argmax(np.abs(real))]
        with pytest.raises(ValueError, match=r"complex pair \(Im != 0\), got eigenvalue = "):
            pair_mode(st, r)
        with pytest.raises(ValueError, match="complex pair"):
            pair_mode(st, complex(r, 0.0))
        with pytest.warns(UserWarning, match="is real .*no complex pair there"):
            m = pair_mode(st, complex(r, 1e-9 * abs(r)))
        assert m.eigenvalue == pytest.approx(r, rel=1e-12)
        pair = lam[np.argmax(lam.imag)]
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            got = pair_mode(st, pair.conjugate() * (1 + 1e-7)).eigenvalue
        assert got == pytest.approx(pair.conjugate(), rel=1e-10)


def test_series_functions_check_t_and_the_series():
    """growth_window(t, D[:10], noise) returned (None, nan); growth_fit and
    exp_rate of a shorter D were raw broadcasting / indexing errors; a NaN
    time or MSD went into the fits."""
    from remote_trigger.analysis.dynamics import series as ser

    t = np.linspace(0.0, 1000.0, 201)
    D = 1e-20 * np.exp(2 * 0.02 * t)
    mu = np.where(t < 5.0, 1.0, 0.8)
    calls = {
        "noise_level": lambda t, D, mu: ser.noise_level(t, D),
        "exp_rate": lambda t, D, mu: ser.exp_rate(t, D),
        "growth_window": lambda t, D, mu: ser.growth_window(t, D, 1e-20),
        "below_exponential": lambda t, D, mu: ser.below_exponential(t, D, (0, 5), 0.02),
        "growth_over": lambda t, D, mu: ser.growth_over(t, D, 0.0, 1000.0),
        "growth_fit": lambda t, D, mu: ser.growth_fit(t, D),
        "runaway_rate": lambda t, D, mu: ser.runaway_rate(t, D, 1e-5),
        "first_crossing": lambda t, D, mu: ser.first_crossing(t, D, 1e-10),
        "post_switch_level": lambda t, D, mu: ser.post_switch_level(t, D, mu, 1.0),
        "saturated": lambda t, D, mu: ser.saturated(t, D, mu, 1.0),
        "settled_growth": lambda t, D, mu: ser.settled_growth(t, D, mu, 1.0, 0.8, 0.01),
    }
    three = ("post_switch_level", "saturated", "settled_growth")
    for name, f in calls.items():
        f(t, D, mu)                                              # valid input runs
        if name in three:
            msg = (rf"{name}: t, D and mu must be 1-D arrays of one length, got shapes "
                   r"\(201,\), \(10,\) and \(201,\)")
        else:
            msg = (rf"{name}: t and {'x' if name == 'first_crossing' else 'D'} must be 1-D "
                   r"arrays of one length, got shapes \(201,\) and \(10,\)")
        with pytest.raises(ValueError, match=msg):
            f(t, D[:10], mu)
        with pytest.raises(ValueError, match=r"must be 1-D arrays"):
            f(t.reshape(1, -1), D.reshape(1, -1), mu.reshape(1, -1))
        bad = t.copy()
        bad[7] = np.nan
        with pytest.raises(ValueError, match=rf"{name}: t must be finite, got 1 non-finite "
                                             r"value\(s\), the first nan at index 7"):
            f(bad, D, mu)
        # (growth_fit of the records in reverse order was -0.02, not an error)
        with pytest.raises(ValueError, match=rf"{name}: t must be increasing \(records in time "
                                             r"order\), got t\[1\] = 995.0 after t\[0\] = 1000.0"):
            f(t[::-1], D[::-1], mu[::-1])
        same = t.copy()
        same[5] = same[4]
        with pytest.raises(ValueError, match=r"got t\[5\] = 20.0 after t\[4\] = 20.0"):
            f(same, D, mu)
    with pytest.raises(ValueError, match=r"D must be finite, got 2 non-finite"):
        ser.growth_window(t, np.where(t > 990.0, np.inf, D), 1e-20)
    with pytest.raises(ValueError, match=r"t, D and mask must be 1-D arrays of one length, "
                                         r"got shapes \(201,\), \(201,\) and \(3,\)"):
        ser.exp_rate(t, D, mask=[True, True, False])
    for f in (ser.settle_index, ser.friction_switch_time):
        with pytest.raises(ValueError, match=r"t and mu must be 1-D arrays"):
            f(t, mu[:-1], 0.8)
    # lists are taken as before; the same rate as from arrays
    assert ser.exp_rate(list(t), list(D)) == ser.exp_rate(t, D) == pytest.approx(0.02)


def test_open_dump_and_open_universe_name_what_they_cannot_read(packing, tmp_path):
    """open_dump of an equilibrium dump was MDAnalysis' 'Trajectory must have image
    flag in order to unwrap.'; open_universe of a missing file was a ValueError
    (read_dump's is a FileNotFoundError); spheres were misread or refused as
    'missing dump columns'."""
    pytest.importorskip("MDAnalysis")
    from remote_trigger.analysis.state.trajectory import open_dump, open_universe

    from .builders import write_dump

    eq = str(write_dump(tmp_path / "eq.dump", packing))
    with pytest.raises(ValueError, match=r"eq.dump: the dump lacks the column\(s\) z ix iy iz "
                                         r".*equilibrium dump .*open_universe\(path\)"):
        open_dump(eq)
    traj = tmp_path / "run.lammpstrj"
    traj.write_text("ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n2\nITEM: BOX BOUNDS pp pp pp\n"
                    "0 4\n0 4\n-0.5 0.5\nITEM: ATOMS id type x y z\n1 1 1 1 0\n2 1 2 1 0\n")
    with pytest.raises(ValueError, match=r"lacks the column\(s\) ix iy iz .*dump custom "
                                         r"\.\.\. ix iy iz\), or pass unwrap=False"):
        open_dump(str(traj))
    assert open_dump(str(traj), unwrap=False).atoms.n_atoms == 2
    for f, what in ((open_dump, "dump"), (open_universe, "topology")):
        with pytest.raises(FileNotFoundError, match=rf"{what} file not found: .*nope.dump"):
            f(str(tmp_path / "nope.dump"))
    with pytest.raises(FileNotFoundError, match="trajectory file not found: .*nope.dump"):
        open_universe(eq, [eq, str(tmp_path / "nope.dump")])
    assert open_universe(eq).atoms.n_atoms == packing.n

    sph = _sphere_dump(tmp_path / "sph.dump")
    for args in ((sph,), (eq, [eq, sph])):
        with pytest.raises(ValueError, match=r"sph.dump: a dump of spheres: open_universe "
                                             r"supports packings of disks only"):
            open_universe(*args)
    data = tmp_path / "sph.data"
    data.write_text("LAMMPS data file\n\n2 atoms\n1 atom types\n\n-5 5 xlo xhi\n-1 10 ylo yhi\n"
                    "-5 5 zlo zhi\n\nAtoms # sphere\n\n1 1 1.0 1.9 0 0.45 0.2 0 0 0\n"
                    "2 1 1.0 1.9 0.99 0.45 0.2 0 0 0\n")
    with pytest.raises(ValueError, match=r"sph.data: a data file of spheres \(z != 0\): "
                                         r"open_universe supports packings of disks only"):
        open_universe(str(data))


def test_max_residual_checks_g(packing):
    """A length-5 G was a raw reshape error, an empty one numpy's 'zero-size array
    to reduction', a (2, 3) array was taken as two disks, a NaN gave nan."""
    from remote_trigger.analysis.stability.analyze import analyze
    from remote_trigger.analysis.stability.residual import max_residual
    from remote_trigger.analysis.stability.jacobian import generalized_forces

    G = generalized_forces(packing)
    assert max_residual(G) == analyze(packing, eigenvalues=False, decide=False).max_residual
    assert max_residual([3.0, 4.0, -6.0]) == 6.0
    assert max_residual([0, 3, 4, 1, 0, 0], spheres=True) == 5.0
    for bad, spheres, shape in ((np.ones(5), False, r"\(5,\)"), (np.ones(0), False, r"\(0,\)"),
                                (np.ones((2, 3)), False, r"\(2, 3\)"),
                                (np.ones(9), True, r"\(9,\)")):
        per = 6 if spheres else 3
        with pytest.raises(ValueError, match=rf"max_residual needs G of shape \({per}N,\) "
                                             rf"with N >= 1, .* got shape {shape}"):
            max_residual(bad, spheres)
    G[4] = np.nan
    with pytest.raises(ValueError, match=r"needs a finite G, got 1 non-finite value\(s\), "
                                         r"the first nan at dof 4"):
        max_residual(G)
    with pytest.raises(ValueError, match="an array of numbers, got str"):
        max_residual("G")


@pytest.mark.parametrize("kw, msg", [
    (dict(positions=np.zeros((3, 3))), r"positions must have shape \(N, 2\) = \(\d+, 2\), "
                                       r"got shape \(3, 3\)"),
    (dict(radii=[0.5, 0.5]), r"radii must have shape \(N,\) = \(\d+,\), got shape \(2,\)"),
    (dict(masses=np.ones((2, 2))), r"masses must have shape \(N,\) = \(\d+,\), got shape "
                                   r"\(2, 2\)"),
    (dict(periodic=(True,)), r"periodic must be 2 flags \(x, y\), got 1: \(True,\)"),
    (dict(box_lo=[0.0]), r"box_lo must have 2 values \(x, y; .*\), got shape \(1,\)"),
    (dict(box_hi=[1.0, 2.0, 3.0, 4.0]), r"box_hi must have 2 values .* got shape \(4,\)"),
    (dict(box_hi=[np.nan, 10.0]), r"box_hi must be finite"),
    (dict(box_hi=[-100.0, 10.0]), r"box_hi > box_lo on every axis"),
    (dict(external=np.zeros((4, 2))), r"external must have shape \(N, 2\) = \(\d+, 2\), got "
                                      r"shape \(4, 2\)"),
    (dict(wall_t=np.zeros(3)), r"wall_t must have shape \(N,\) = \(\d+,\), got shape \(3,\)"),
    (dict(partners=np.zeros((2, 3)), partner_xi=np.zeros((2, 3))),
     r"partners must have shape \(N, K\) = \(\d+, K\), got shape \(2, 3\)"),
    (dict(partner_xi=np.zeros((1, 1))), r"partners needs partner_xi"),
    (dict(velocities=np.zeros(3)), r"velocities must have shape \(N, 2\)"),
])
def test_build_state_names_bad_shapes(packing, kw, msg):
    """Wrong shapes were numpy's 'cannot reshape array of size ...'; a box of one
    value was broadcast."""
    from .builders import history_arrays

    part, _, _ = history_arrays(packing)
    base = dict(ids=packing.ids, positions=packing.positions, radii=packing.radii,
                masses=packing.masses, box_lo=packing.box_lo, box_hi=packing.box_hi,
                params=packing.params, wall_y=packing.wall_y)
    if "partner_xi" in kw and "partners" not in kw:            # partners without partner_xi
        kw = dict(partners=part, partner_xi=None)
    with pytest.raises(ValueError, match=msg):
        build_state(**dict(base, **kw))


def test_build_state_ids_and_history_shapes(packing):
    """Float ids that are not integers were truncated; a one-slot history of shape
    (N,) is taken as (N, 1); partner_xi must match partners."""
    from .builders import history_arrays

    part, xi, wall = history_arrays(packing)
    kw = dict(positions=packing.positions, radii=packing.radii, masses=packing.masses,
              box_lo=packing.box_lo, box_hi=packing.box_hi, params=packing.params,
              wall_y=packing.wall_y, wall_t=wall)
    ids = packing.ids.astype(float)
    st = build_state(ids=ids, partners=part, partner_xi=xi, **kw)      # integer-valued
    assert st.ids.dtype == np.int64 and np.array_equal(st.ids, packing.ids)
    ids[3] += 0.5
    with pytest.raises(ValueError, match=rf"ids must be integers, got {float(ids[3])!r} at "
                                         r"index 3"):
        build_state(ids=ids, **kw)
    with pytest.raises(ValueError, match=r"ids must have shape \(N,\), got shape "):
        build_state(ids=packing.ids[:, None], **kw)
    with pytest.raises(ValueError, match=r"ids must be integers, got dtype <U"):
        build_state(ids=[str(i) for i in packing.ids], **kw)
    with pytest.raises(ValueError, match=rf"partner_xi must have shape \(N, K\) = "
                                         rf"\({packing.n}, 8\), that of partners, got shape "
                                         rf"\({packing.n}, 7\)"):
        build_state(ids=packing.ids, partners=part, partner_xi=xi[:, :7], **kw)
    two = dict(ids=[1, 2], positions=[[0.0, 2.0], [0.99, 2.0]], radii=[0.5, 0.5],
               masses=[1.0, 1.0], box_lo=[-5.0, -1.0], box_hi=[5.0, 10.0],
               params=packing.params, wall_y=0.0)
    flat = build_state(**two, partners=[2, 1], partner_xi=[1e-5, 1e-5])
    slot = build_state(**two, partners=[[2], [1]], partner_xi=[[1e-5], [1e-5]])
    assert flat.contact_xi.tolist() == slot.contact_xi.tolist() == [1e-5]
    # LAMMPS' box has a z bound: still ignored
    st3 = build_state(ids=packing.ids, partners=part, partner_xi=xi,
                      **dict(kw, box_lo=[*packing.box_lo, -0.5], box_hi=[*packing.box_hi, 0.5]))
    assert np.array_equal(st3.box_lo, packing.box_lo) and st3.n_contacts == packing.n_contacts


def test_build_state3d_shapes_ids_and_its_periodic_default():
    """Wrong shapes were numpy reshape errors, float ids and pair ids were truncated,
    partners without partner_t a reshape error; the default periodic is the
    driver's scene (True, False, True), as state3d_from_history's."""
    import inspect

    from remote_trigger.analysis.state.state import ContactParams
    from remote_trigger.analysis.state.state3d import (
        build_state3d, plane_wall, state3d_from_history)

    params = ContactParams(2e5, 2e5 / 3.5, 1.0)
    # two spheres touching across the periodic seam in z: a contact only with z periodic
    kw = dict(ids=[1, 2], positions=[[0, 0.45, -4.7], [0, 0.45, 4.7]], radii=[0.5, 0.5],
              masses=[1.0, 1.0], box_lo=[-5, 0, -5], box_hi=[5, 10, 5], params=params)
    assert inspect.signature(build_state3d).parameters["periodic"].default == \
        inspect.signature(state3d_from_history).parameters["periodic"].default == \
        (True, False, True)
    st = build_state3d(**kw, pairs=[[1, 2]])
    assert st.periodic == (True, False, True) and st.n_contacts == 1
    with pytest.raises(ValueError, match="has overlap"):            # the former default
        build_state3d(**kw, pairs=[[1, 2]], periodic=(True, True, False))
    assert state3d_from_history(**kw, wall_y=None).n_contacts == 1

    floor = plane_wall("y", "lo", 0.0)
    for bad, msg in (
            (dict(positions=[[0, 0.45, -4.7]]), r"positions must have shape \(N, 3\) = "
                                                r"\(2, 3\), got shape \(1, 3\)"),
            (dict(radii=[0.5]), r"radii must have shape \(N,\) = \(2,\), got shape \(1,\)"),
            (dict(ids=[1.0, 2.5]), r"ids must be integers, got 2.5 at index 1"),
            (dict(pairs=[[1, 2.5]]), r"pairs must be integers, got 2.5 at index 1"),
            (dict(pairs=[1, 2]), r"pairs must have shape \(C, 2\), got shape \(2,\)"),
            (dict(pair_t=[0.0, 1e-4]), r"pair_t must have shape \(C, 3\) = \(1, 3\), got "
                                       r"shape \(2,\)"),
            (dict(periodic=(True, False)), r"periodic must be 3 flags \(x, y, z\), got 2"),
            (dict(box_lo=[-5, 0]), r"box_lo must have 3 values \(x, y, z\), got shape \(2,\)"),
            (dict(external=np.zeros((2, 2))), r"external must have shape \(N, 3\) = \(2, 3\)"),
            (dict(walls=[(1, floor[0][:2], floor[1])]), r"walls\[0\] must be \(id, normal of "
                                                         r"3 values, offset\)"),
            (dict(walls=[(1, *floor)], wall_t=np.zeros((2, 3))),
             r"wall_t must have shape \(W, 3\), W = len\(walls\) = \(1, 3\), got shape "
             r"\(2, 3\)")):
        args = {**kw, "pairs": [[1, 2]], **bad}
        with pytest.raises(ValueError, match=msg):
            build_state3d(**args)
    hist = dict(kw, wall_y=None)
    with pytest.raises(ValueError, match="partners needs partner_t"):
        state3d_from_history(**hist, partners=[[2], [1]])
    with pytest.raises(ValueError, match=r"partner_t must have shape \(N, K, 3\), K that of "
                                         r"partners = \(2, 1, 3\), got shape \(2, 3\)"):
        state3d_from_history(**hist, partners=[[2], [1]], partner_t=np.zeros((2, 3)))
    with pytest.raises(ValueError, match=r"wall_t must have shape \(N, 3\) = \(2, 3\)"):
        state3d_from_history(**dict(kw, wall_y=0.0), wall_t=np.zeros(3))
    t = np.array([[[0.0, 1e-5, 0.0]], [[0.0, -1e-5, 0.0]]])
    st = state3d_from_history(**hist, partners=[[2], [1]], partner_t=t)
    assert np.allclose(st.contact_t, [[0.0, 1e-5, 0.0]])


def test_analyze_dump_passes_inertia_and_contacts_to_either_reader(tmp_path):
    """analyze_dump(sphere dump, inertia_factor=..., require_contacts=...) was a
    TypeError (read_dump3d did not take them); I0 applies to spheres too."""
    from remote_trigger.analysis.stability.analyze import analyze_dump
    from remote_trigger.analysis.state.dumpfile import read_dump3d

    sph = _sphere_dump(tmp_path / "sph.dump")
    st = read_dump3d(sph)
    assert np.allclose(st.inertia, 0.4 * st.masses * st.radii**2)
    st1 = read_dump3d(sph, inertia_factor=1.0, require_contacts=True)
    assert np.allclose(st1.inertia, st1.masses * st1.radii**2)
    with pytest.raises(ValueError, match="inertia_factor must be a finite number > 0"):
        read_dump3d(sph, inertia_factor=0.0)
    # the rotational entries of M are I / R^2 = I0 m (m = 1 here)
    a = analyze_dump(sph, inertia_factor=1.0, require_contacts=True, decide=False,
                     allow_residual=True)
    assert np.allclose(a.mass, 1.0)
    assert sorted(set(np.round(analyze_dump(sph, decide=False, allow_residual=True).mass,
                               12))) == [0.4, 1.0]
    # the same two spheres lifted off the floor and apart: no contact at all
    text = open(sph).read().splitlines()
    text[-2:] = ["1 1 0.5 1 0 3 0 " + "0 " * 9 + "0 0 0 0 0 0 0",
                 "2 1 0.5 1 2.5 3 0 " + "0 " * 9 + "0 0 0 0 0 0 0"]
    free = tmp_path / "free.dump"
    free.write_text("\n".join(text) + "\n")
    (tmp_path / "free.dump.json").write_text(open(sph + ".json").read())
    assert read_dump3d(free).n_contacts == 0
    with pytest.raises(ValueError, match="free.dump: the packing has no contact"):
        read_dump3d(free, require_contacts=True)


@pytest.mark.filterwarnings("ignore:.*history and geometry disagree")
def test_dump_readers_refuse_a_state_that_is_not_an_equilibrium(tmp_path):
    """analyze_dump and stability_of_dump gave a certified verdict on a dump
    rewritten with 6 digits (residual 1e9 x the floor), where remote-trigger
    jacobian refuses it: now they refuse it too, and allow_residual=True (the
    command line's --allow-residual) analyses it anyway."""
    import re

    from remote_trigger.analysis.errors import NotEquilibriumError
    from remote_trigger.analysis.stability.analyze import analyze_dump
    from remote_trigger.analysis.stability.verdict import stability_of_dump
    from tests.data import unpack

    unpack("free_rotation_N400_s5_step_00002.dump.json", str(tmp_path))
    dump = unpack("free_rotation_N400_s5_step_00002", str(tmp_path))
    assert analyze_dump(dump, eigenvalues=False).state.n == 400     # an equilibrium
    low = str(tmp_path / "low.dump")
    with open(dump) as src, open(low, "w") as dst:
        dst.write(re.sub(r"-?\d+\.\d+(?:e[-+]?\d+)?",
                         lambda m: f"{float(m.group()):.6g}", src.read()))
    with open(dump + ".json") as src, open(low + ".json", "w") as dst:
        dst.write(src.read())
    for call in (lambda: analyze_dump(low, eigenvalues=False),
                 lambda: stability_of_dump(low),
                 lambda: analyze_dump(dump, k_n=1e5, eigenvalues=False)):
        with pytest.raises(NotEquilibriumError, match="is not an equilibrium of its parameters"):
            call()
    assert analyze_dump(low, eigenvalues=False, allow_residual=True).state.n == 400


def test_library_bounds_and_decisions_name_the_bad_value(packing):
    """Found by trying the library as a new user: each of these returned a
    number (or None) or raised a bare numpy/Python error."""
    from remote_trigger.analysis.dynamics.normal_form import integrate
    from remote_trigger.analysis.dynamics.series import noise_level
    from remote_trigger.analysis.stability.residual import check_equilibrium
    from remote_trigger.analysis.stability.eigtrack import track_pair
    from remote_trigger.analysis.stability.exceptional import block_discriminant
    from remote_trigger.analysis.stability.jacobian import find_rattlers
    from remote_trigger.analysis.stability.timestep import check_timestep, hertz_limit

    for limit, match in ((float("nan"), "limit must be a number > 0"),       # passed
                         (0.0, "limit must be a number > 0"),                # ZeroDivisionError
                         (-0.01, "limit must be a number > 0")):
        with pytest.raises(ValueError, match=match):
            check_timestep(1e-3, limit)
    assert check_timestep(1e-3, float("inf")) == 0.0                         # no contacts
    with pytest.raises(ValueError, match=r"safety must be a number in \(0, 1\], got safety = -1"):
        check_timestep(5e-3, 0.01, safety=-1)
    for kw, match in (({"inertia": 0.0}, "inertia must be a finite number > 0"),
                      ({"contacts": 2.5}, "contacts must be an integer >= 1"),
                      ({"mass": np.array([1.0, 2.0])}, "mass must be a finite number > 0"),
                      ({"k_t": -1.0}, "k_t must be a finite number >= 0")):
        with pytest.raises(ValueError, match=match):
            hertz_limit(2e5, 3.0, **kw)
    with pytest.raises(ValueError, match="k_n must be a finite number > 0, got k_n = '2e5'"):
        hertz_limit("2e5", 3.0)
    for factor in (-1.0, float("nan")):
        with pytest.raises(ValueError, match="factor must be a number > 0"):
            check_equilibrium(packing, factor=factor)
    lam = np.array([1.0, 2.0], complex)
    with pytest.raises(ValueError, match=r"decision of point 0 \(F_x = 0.0\) must be a "
                                         r"Decision, got 'real'"):
        track_pair([(0.0, lam, "real"), (0.1, lam, "complex")])
    with pytest.raises(ValueError, match=r"decision of point 0 \(F_x = 0.0\) must be a "
                                         r"Decision, got True"):
        track_pair([(0.0, lam, True), (0.1, lam, False)])
    with pytest.raises(ValueError, match=r"point 0 must be \(F_x, eigenvalues, decision\)"):
        track_pair([(0.0, lam)])
    with pytest.raises(ValueError, match=r"needs a 2 x 2 block, got shape \(3, 3\)"):
        block_discriminant(np.eye(3))
    for bad in ("2", 2.5):
        with pytest.raises(ValueError, match="min_contacts must be an integer >= 0"):
            find_rattlers(packing, min_contacts=bad)
    with pytest.raises(ValueError, match=r"frac must be a number in \(0, 1\], got frac = 2"):
        noise_level(np.arange(1.0, 11.0), np.ones(10), frac=2)
    with pytest.raises(ValueError, match="samples_per_period must be an integer >= 2"):
        integrate(0.1, 0.5, samples_per_period=0)


def test_disk_and_sphere_functions_refuse_the_other_kind(packing):
    """find_rattlers3d of disks applied the 3-contact rule silently; the block
    and force builders of one kind raised AttributeError on the other."""
    from remote_trigger.analysis.stability import jacobian as j2
    from remote_trigger.analysis.stability import jacobian3d as j3

    from .builders3d import random_packing3d

    spheres = random_packing3d(seed=2)
    for f in (j3.find_rattlers3d, j3.generalized_forces3d, j3.contact_blocks3d,
              j3.wall_blocks3d, j3.stiffness_matrix3d):
        with pytest.raises(ValueError, match="expected a State3D of spheres, got State"):
            f(packing)
    for f in (j2.contact_blocks, j2.wall_blocks):
        with pytest.raises(ValueError, match="expected a State of disks, got State3D"):
            f(spheres)
    assert j2.find_rattlers(spheres, 3).keep_dofs.size == j3.find_rattlers3d(spheres).keep_dofs.size


def test_state_ids_periodic_and_wall_y_are_checked(packing):
    """ids = 0 (the empty history slot) was accepted, periodic = "TF" read as
    (True, True), wall_y = '0' a numpy TypeError."""
    def built(**kw):
        args = dict(ids=packing.ids, positions=packing.positions, radii=packing.radii,
                    masses=packing.masses, box_lo=packing.box_lo, box_hi=packing.box_hi,
                    params=packing.params, wall_y=packing.wall_y)
        return build_state(**dict(args, **kw))

    assert built().n == packing.n
    with pytest.raises(ValueError, match=r"ids must be positive integers \(LAMMPS atom ids\), "
                                         r"got 0 at index 0"):
        built(ids=packing.ids - packing.ids.min())
    with pytest.raises(ValueError, match="periodic must be 2 flags"):
        built(periodic="TF")
    with pytest.raises(ValueError, match="wall_y must be a finite number or None, got '0'"):
        built(wall_y="0")


def test_pair_mode_takes_re_im(tmp_path):
    """pair_mode(state, [Re, Im]) -- the ensemble's lambda_c -- was a TypeError,
    and a string was accepted."""
    from remote_trigger.analysis.stability.modeshape import pair_mode

    st = random_packing(seed=3, nx=4, ny=3)
    with pytest.raises(ValueError, match=r"needs a complex number or \[Re, Im\], got "
                                         r"eigenvalue = '1\+2j'"):
        pair_mode(st, "1+2j")
    with pytest.raises(ValueError, match=r"needs a complex number or \[Re, Im\]"):
        pair_mode(st, [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match=r"needs an eigenvalue of a complex pair \(Im != 0\)"):
        pair_mode(st, [5.0, 0.0])


def test_sidecar_with_an_unknown_key_is_refused(packing, tmp_path):
    """A misspelt sidecar key ("kn") was ignored and the value silently taken
    from elsewhere (or missing)."""
    import json

    from remote_trigger.analysis.state.dumpfile import read_dump

    from .builders import write_dump

    path = str(write_dump(tmp_path / "eq.dump", packing))
    side = json.load(open(path + ".json"))
    side["kn"] = side.pop("k_n")
    json.dump(side, open(path + ".json", "w"))
    with pytest.raises(ValueError, match=r"eq.dump.json: unknown key\(s\) \['kn'\]; the keys "
                                         r"are k_n, k_t"):
        read_dump(path)


def test_missing_data_file_is_file_not_found(tmp_path):
    """read_data of a missing file raised ValueError, read_dump
    FileNotFoundError: now both FileNotFoundError, naming the file."""
    from remote_trigger.analysis.state.datafile import read_data

    with pytest.raises(FileNotFoundError, match="data file not found: .*nope.data"):
        read_data(str(tmp_path / "nope.data"))


def test_eigen_functions_take_array_likes_and_name_bad_ones(packing):
    """A list K was an AttributeError in dense_eigen, dynamical_matrix and
    damped_growth_rate; a complex K was cast to its real part with a
    ComplexWarning; sigma = None a numpy TypeError; a (1, n) mass and a 2-D
    lam were accepted."""
    from remote_trigger.analysis.stability import eigen
    from remote_trigger.analysis.stability.projected import classify_projected

    K = [[2.0, -1.0], [-1.0, 2.0]]
    np.testing.assert_allclose(np.sort(eigen.dense_eigen(K, [1.0, 1.0]).eigenvalues.real),
                               [1.0, 3.0])
    assert eigen.damped_growth_rate(K, [1.0, 1.0], [0.0, 0.0]) == pytest.approx(0.0, abs=1e-12)
    with pytest.raises(ValueError, match="K must be real"):
        eigen.dynamical_matrix(np.array(K) + 1j, [1.0, 1.0])
    with pytest.raises(ValueError, match=r"mass has shape \(1, 2\), K is 2 x 2: the diagonal "
                                         r"of M must have shape \(2,\)"):
        eigen.dense_eigen(K, [[1.0, 1.0]])
    with pytest.raises(ValueError, match=r"lam must have shape \(k,\)"):
        eigen.frequencies(np.ones((2, 2)))
    Kp = stiffness_matrix(packing)
    with pytest.raises(ValueError, match="sigma must be a finite real number, got sigma = None"):
        sparse_eigen(Kp, packing.mass_diagonal(), k=4, sigma=None)
    A = eigen.dynamical_matrix(Kp, packing.mass_diagonal())
    for kw, match in (({"sigma": None}, "sigma must be a finite real number"),
                      ({"sigma": float("nan")}, "sigma must be a finite real number"),
                      ({"sigma": 1.0, "enrich": -1}, "enrich must be an integer >= 0")):
        with pytest.raises(ValueError, match=match):
            classify_projected(A, **kw)


def test_a_basis_that_is_not_one_is_refused(packing):
    """stability_of(state, basis="x") was an AttributeError; classify_spectrum
    ignored it."""
    from remote_trigger.analysis.stability.exceptional import classify_spectrum
    from remote_trigger.analysis.stability.verdict import stability_of

    with pytest.raises(ValueError, match="basis must be a SpectrumBasis .* got str"):
        stability_of(packing, basis="x")
    with pytest.raises(ValueError, match="basis must be a SpectrumBasis .* got str"):
        classify_spectrum(np.diag([1.0, 2.0, 3.0]), basis="x")


def test_read_dump_takes_bytes_and_paths_and_names_a_compressed_file(packing, tmp_path):
    """read_dump(b"eq.dump") was "can't concat str to bytes"; a gzipped dump a
    UnicodeDecodeError without the file's name."""
    import gzip
    import pathlib

    from remote_trigger.analysis.state.dumpfile import read_dump

    from .builders import write_dump

    path = str(write_dump(tmp_path / "eq.dump", packing))
    n = read_dump(path).n
    assert read_dump(os.fsencode(path)).n == n and read_dump(pathlib.Path(path)).n == n
    gz = tmp_path / "gz.dump"
    gz.write_bytes(gzip.compress(open(path, "rb").read()))
    with pytest.raises(ValueError, match=r"gz.dump: not a text dump \(a compressed file\?"):
        read_dump(str(gz))
    # the project's own binary outputs given where a dump is meant (both were
    # "a compressed file? decompress it first")
    import h5py

    with h5py.File(tmp_path / "r.h5", "w") as fh:
        fh["x"] = np.arange(3.0)
    np.savez(tmp_path / "k.npz", K=np.random.default_rng(0).random(50))
    for name, what in (("r.h5", "an HDF5 file: read it with h5py"),
                       ("k.npz", "a zip archive, e.g. NumPy's .npz: read it with numpy.load")):
        with pytest.raises(ValueError, match=rf"{name}: not a text dump \({what}\)$"):
            read_dump(str(tmp_path / name))


def test_contact_geometry_names_bad_arrays(packing):
    """find_contacts with radii one short was an IndexError, NaN positions
    scipy's "data must be finite", 1-D positions "not enough values to
    unpack", three periodic flags for disks were accepted; minimum_image with
    a short box an IndexError; exp_rate read an index array as a mask."""
    from remote_trigger.analysis.dynamics.series import exp_rate
    from remote_trigger.analysis.state.contacts import find_contacts, minimum_image

    pos, R = packing.positions, packing.radii
    lo, hi = packing.box_lo, packing.box_hi
    assert find_contacts(list(map(list, pos)), R, lo, hi)[0].size > 0     # lists are fine
    bad_pos = pos.copy()
    bad_pos[3, 1] = np.nan
    for args, match in (((pos, R[:-1], lo, hi), r"radii must have shape \(30,\) like positions"),
                        ((bad_pos, R, lo, hi), "positions must be finite, got .* at index 3"),
                        ((pos[:, 0], R, lo, hi), r"positions must have shape \(N, 2\) or \(N, 3\)"),
                        ((pos, R, lo, hi, (True, False, True)), "periodic must have 2 entries")):
        with pytest.raises(ValueError, match=match):
            find_contacts(*args)
    with pytest.raises(ValueError, match="box_length must have 2 entries"):
        minimum_image(np.ones((4, 2)), 10.0, (True, False))
    t = np.arange(10.0)
    with pytest.raises(ValueError, match="mask must be an array of bool"):
        exp_rate(t, np.exp(t), mask=np.arange(10))


def test_merge_model_names_an_unknown_key_and_a_bad_value(tmp_path):
    """merge_model({'Fx': 0.07}, ...) ignored the misspelt key; {'F_x': 'abc'}
    was float()'s bare 'could not convert string to float'."""
    import json

    from remote_trigger.analysis.errors import InputError
    from remote_trigger.analysis.state.sidecar import merge_model

    start = tmp_path / "eq.dump"
    start.write_text("")
    (tmp_path / "eq.dump.json").write_text(json.dumps({"k_n": 2e5, "F_x": 0.07}))
    with pytest.raises(InputError, match=r"^merge_model: unknown key\(s\) 'Fx'; the keys are "):
        merge_model({"Fx": 0.07}, str(start))
    with pytest.raises(InputError, match=r"^merge_model: F_x must be a real number, got "
                                         r"F_x = 'abc'$"):
        merge_model({"F_x": "abc"}, str(start))
    values, source = merge_model({"F_x": np.float64(0.07), "mu": None}, str(start))
    assert values == {"k_n": 2e5, "F_x": 0.07} and source == str(tmp_path / "eq.dump.json")
