"""analysis.trajectory (MDAnalysis) against LAMMPS' float64 compute msd on the same run.

A relaxed packing is run undamped (in.perturb's scene) twice, dumping the
trajectory and recording compute msd at the same steps: kicked (a uniform
velocity 1e-2 along x: D grows from 0 to ~1e-6) and quiet (D ~ 1e-25, the
noise of Fig. 5 (a)). Where D is far above the float32 floor the two agree;
in the quiet run MDAnalysis cannot resolve D (its positions are float32).
"""

import numpy as np
import pytest

pytest.importorskip("MDAnalysis")

from remote_trigger.analysis.state.trajectory import (
    DisplacementFromStart, float32_floor, open_dump)


def _run(tmp_path, datafile, kick, name):
    from remote_trigger.pywrap.stages.config import RelaxConfig
    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.stages.common import DECK_FIELDS, deck_vars

    v = deck_vars(RelaxConfig(datafile=datafile), datafile, 0.0)
    for var, _ in DECK_FIELDS:
        v.pop(var, None)
    v.update(a=0.0, muv=0)
    traj, rec = str(tmp_path / f"{name}.lammpstrj"), str(tmp_path / f"{name}_msd.txt")
    with Engine() as eng:
        eng.load_deck("in.perturb", v, ("scene", "dynamics"))
        if kick:
            eng.command(f"velocity all set {kick!r} 0 0 sum yes")
        eng.commands("compute msd all msd\nvariable D equal c_msd[4]\n"
                     f"fix rec all ave/time 100 1 100 v_D file {rec} format ' %.17g'\n"
                     f"dump tr all custom 100 {traj} id type x y z ix iy iz\n"
                     "dump_modify tr format float %.17g sort id\n")
        eng.run(2000)
    lmp = np.loadtxt(rec)
    return traj, lmp[:, 0].astype(np.int64), lmp[:, 1]


def test_mdanalysis_msd_agrees_above_its_float32_floor(tmp_path, relaxed):
    traj, steps, D64 = _run(tmp_path, relaxed.datafile, 1e-2, "kick")
    u = open_dump(traj)
    assert u.atoms.positions.dtype == np.float32 and u.trajectory.n_frames == steps.size
    res = DisplacementFromStart(u.atoms).run()
    np.testing.assert_array_equal(res.results.step, steps)
    E = res.results.floor
    assert E == pytest.approx(float32_floor(u.atoms.positions), rel=0.5)
    assert 1e-15 < E < 1e-11                      # positions of order 1-20
    # the rounding bound |D32 - D| <= 2 sqrt(D E) + E holds on every frame
    err = np.abs(res.results.D - D64)
    assert np.all(err <= 2 * np.sqrt(D64 * E) + E), np.max(err / (2 * np.sqrt(D64 * E) + E))
    ok = D64 > 1e3 * E
    assert ok.sum() >= 15                         # most of the run is resolved
    assert np.max(err[ok] / D64[ok]) < 1e-3       # measured 1.8e-4


def test_mdanalysis_cannot_resolve_the_noise_level(tmp_path, relaxed):
    traj, steps, D64 = _run(tmp_path, relaxed.datafile, 0.0, "quiet")
    assert np.max(D64) < 1e-20                    # the float64 record: noise of a quiet run
    res = DisplacementFromStart(open_dump(traj).atoms).run()
    # float32 positions: D is 0 (no coordinate changed its float32 value) or of the
    # order of the floor -- either way not D; never within 5 decades of the truth
    D32, E = res.results.D[1:], res.results.floor
    assert np.all(D32 <= E)                       # within the rounding bound ...
    assert np.all((D32 == 0) | (D32 > 1e5 * np.maximum(D64[1:], 1e-300)))  # ... not D


def _read_data(path):
    """float64 (ids, positions (N, 2), radii, top) of a LAMMPS data file (atom_style
    sphere, with the topflag section), in id order; box x length and y span."""
    lines = open(path).read().splitlines()
    lx = next(float(s.split()[1]) - float(s.split()[0]) for s in lines if s.endswith("xlo xhi"))
    n = next(int(s.split()[0]) for s in lines if s.endswith(" atoms"))
    a = lines.index(next(s for s in lines if s.startswith("Atoms"))) + 2
    rows = np.array([[float(w) for w in s.split()[:7]] for s in lines[a:a + n]])
    order = np.argsort(rows[:, 0])
    rows = rows[order]
    t = lines.index(next(s for s in lines if s.startswith("topflag"))) + 2
    flags = dict((int(s.split()[0]), int(s.split()[1])) for s in lines[t:t + n])
    ids = rows[:, 0].astype(int)
    top = np.array([flags[i] > 0 for i in ids])
    return ids, rows[:, 4:6], 0.5 * rows[:, 2], top, lx


def test_contact_search_agrees_with_the_float64_one(tmp_path):
    """MDAnalysis' capped_distance (float32 coordinates) finds exactly the contacts
    of the float64 search that feeds the Jacobian (analysis.state.find_contacts), on
    the default job's packing; the smallest overlap is far above float32 round-off."""
    from remote_trigger.analysis.state.contacts import find_contacts
    from remote_trigger.analysis.state.trajectory import touching_pairs
    from tests.data import unpack

    for name in ("default_job_mu1_step_00258", "default_job_mu0.8_step_00234"):
        ids, pos, radii, _, lx = _read_data(unpack(name, tmp_path))
        gi, gj, _ = find_contacts(pos, radii, np.array([0.0, -1.0]), np.array([lx, 100.0]),
                                  (True, False), ids=ids)
        ref = {(int(i), int(j)) for i, j in zip(gi, gj)}
        pairs, overlap = touching_pairs(pos, radii, lx, float(np.max(pos[:, 1] + radii)))
        assert {(int(i), int(j)) for i, j in pairs} == ref and len(ref) > 150, name
        # float32 spacing at |x| ~ 12 is 9.5e-7; the smallest overlap is 9.2e-5 (mu = 1):
        # every contact is decided ~100 spacings above the reader's round-off
        assert overlap.min() > 50 * np.spacing(np.float32(lx)), overlap.min()


def test_contact_numbers_over_a_run(tmp_path, relaxed):
    """ContactNumbers (an MDAnalysis AnalysisBase) on a dump trajectory: frame 0 has
    the contacts of the float64 data file, the top line's mean height is that of the
    data file to float32 precision, and a relaxed packing at rest keeps its contacts."""
    from remote_trigger.analysis.state.contacts import find_contacts
    from remote_trigger.analysis.state.trajectory import ContactNumbers

    traj, _, _ = _run(tmp_path, relaxed.datafile, 0.0, "contacts")
    ids, pos, radii, top, lx = _read_data(relaxed.datafile)
    gi, _, _ = find_contacts(pos, radii, np.array([0.0, -1.0]), np.array([lx, 100.0]),
                             (True, False), ids=ids)
    u = open_dump(traj)
    assert np.array_equal(u.atoms.ids, ids)
    res = ContactNumbers(u.atoms, radii, top=top).run().results
    assert res.n_contacts[0] == len(gi) and np.all(res.n_contacts == len(gi))
    assert np.allclose(res.coordination, 2 * len(gi) / len(ids))
    # MDAnalysis shifts the dump's y by the box's lower corner (an integer here):
    # compare the height up to that shift, and between frames
    dy = res.top_y[0] - np.mean(pos[top, 1])
    assert abs(res.top_y[-1] - res.top_y[0]) < 1e-5 and abs(dy - round(dy)) < 1e-5


# --------------------------------------------------------------------------- open_universe
def test_universe_of_a_data_file(tmp_path):
    """Data file -> Universe: ids, radii, masses, the top line as a segment, float32
    positions shifted by the box's lower corner, box lengths."""
    from remote_trigger.analysis.state.trajectory import open_universe
    from tests.data import unpack

    path = unpack("default_job_mu1_step_00258", tmp_path)
    ids, pos, radii, top, lx = _read_data(path)
    u = open_universe(path)
    assert u.atoms.n_atoms == 100 and np.array_equal(u.atoms.ids, ids)
    np.testing.assert_allclose(u.atoms.radii, radii, rtol=1e-7)
    np.testing.assert_allclose(u.atoms.masses, 1.0, rtol=1e-12)     # set group all mass 1.0
    assert 5 < top.sum() < 20
    assert np.array_equal(u.select_atoms("segid top").ids, ids[top])
    assert u.select_atoms("segid bulk").n_atoms == 100 - top.sum()
    assert u.atoms.positions.dtype == np.float32 and u.trajectory.n_frames == 1
    np.testing.assert_allclose(u.atoms.positions[:, :2], pos + [0.0, 1.0], rtol=0, atol=4e-6)
    assert u.dimensions[0] == pytest.approx(lx, rel=1e-6)


def test_universe_of_ramp_dumps_and_of_a_dynamics_run(tmp_path, relaxed):
    """Equilibrium dumps of a ramp become frames (float64 reader, then MDAnalysis'
    memory); a dump trajectory of a dynamics run is read by MDAnalysis; both carry the
    data file's disks, and ContactNumbers runs on them with the Universe's radii."""
    from remote_trigger.analysis.state.dumpfile import read_dump
    from remote_trigger.analysis.state.trajectory import ContactNumbers, open_universe
    from remote_trigger.pywrap import stages
    from remote_trigger.pywrap.stages.config import RampConfig

    ramp = stages.ramp(RampConfig(datafile=relaxed.datafile, dF_x=0.01, F_x_max=0.025),
                       str(tmp_path / "ramp"), quiet=True)
    dumps = sorted(str(p) for p in (tmp_path / "ramp" / "ramp").glob("step_*.dump"))
    assert ramp.status == "no_complex_pair" and len(dumps) == 3
    u = open_universe(relaxed.datafile, dumps)
    ids, _, radii, top, _ = _read_data(relaxed.datafile)
    assert u.trajectory.n_frames == 3 and np.array_equal(u.atoms.ids, ids)
    assert np.array_equal(u.select_atoms("segid top").ids, ids[top])
    for ts, path in zip(u.trajectory, dumps):
        st = read_dump(path, require_contacts=False)
        np.testing.assert_allclose(u.atoms.positions[:, :2], st.positions - st.box_lo,
                                   rtol=0, atol=4e-6)
    # the dump as topology: the same disks and top line (its external load -F_y)
    v = open_universe(dumps[0])
    assert np.array_equal(v.select_atoms("segid top").ids, ids[top])
    np.testing.assert_allclose(v.atoms.radii, radii, rtol=1e-7)

    traj, steps, _ = _run(tmp_path, relaxed.datafile, 0.0, "universe")
    w = open_universe(relaxed.datafile, traj)
    assert w.trajectory.n_frames == steps.size
    np.testing.assert_array_equal(w.atoms.positions, open_dump(traj).atoms.positions)
    res = ContactNumbers(w.atoms, w.atoms.radii, top=w.atoms.segids == "top").run().results
    assert np.all(res.n_contacts == res.n_contacts[0]) and res.n_contacts[0] > 20
    with pytest.raises(ValueError, match="mixes"):
        open_universe(relaxed.datafile, [dumps[0], traj])
    # a trajectory of other atoms is refused, naming it
    from tests.data import unpack

    other = unpack("default_job_mu1_step_00258", tmp_path)       # N = 100, not 20
    with pytest.raises(ValueError, match="other atoms"):
        open_universe(other, traj)


def test_rattlers_from_mdanalysis_contacts_agree_with_the_float64_ones(tmp_path, relaxed):
    """Rattlers (fewer than 2 contacts, iterated; the wall counts) from the contacts
    MDAnalysis finds (capped_distance, float32) are those of the analysis path:
    find_rattlers on the float64 State of an equilibrium dump, and the float64 search
    on the default job's two packings."""
    from remote_trigger.analysis.stability.jacobian import find_rattlers, rattler_rule
    from remote_trigger.analysis.state.contacts import find_contacts
    from remote_trigger.analysis.state.dumpfile import read_dump
    from remote_trigger.analysis.state.trajectory import touching_pairs
    from tests.data import unpack

    dump = relaxed.datafile[:-len(".data")] + ".dump"
    st = read_dump(dump, require_contacts=False)
    pairs, _ = touching_pairs(st.positions, st.radii, st.box_hi[0] - st.box_lo[0],
                              float(np.max(st.positions[:, 1] + st.radii)))
    wall = np.bincount(st.wall_index, minlength=st.n)
    kept, _ = rattler_rule(st.n, pairs[:, 0], pairs[:, 1], wall)
    ref = find_rattlers(st)
    assert np.array_equal(np.nonzero(~kept)[0], ref.indices)

    counts = []
    for name in ("default_job_mu1_step_00258", "default_job_mu0.8_step_00234"):
        ids, pos, radii, _, lx = _read_data(unpack(name, tmp_path))
        wall = (pos[:, 1] - radii < 0.0).astype(np.int64)        # the wall at y = 0
        gi, gj, _ = find_contacts(pos, radii, np.array([0.0, -1.0]), np.array([lx, 100.0]),
                                  (True, False), ids=ids)
        k64, _ = rattler_rule(len(ids), gi, gj, wall)
        pairs, _ = touching_pairs(pos, radii, lx, float(np.max(pos[:, 1] + radii)))
        k32, _ = rattler_rule(len(ids), pairs[:, 0], pairs[:, 1], wall)
        assert np.array_equal(k32, k64), name
        counts.append(int((~k64).sum()))
    # the default job's ramps analyse 279 and 279 dof: 7 rattlers each
    assert counts == [7, 7], counts


def test_float32_positions_cannot_carry_an_equilibrium(relaxed):
    """Why the float64 reader stays: contact forces from the positions rounded to
    float32 (what MDAnalysis holds) miss the equilibrium by many decades more than
    the float64 residual (default packing, docs/results/analysis.md: 0.016 vs 2.3e-11)."""
    from remote_trigger.analysis.stability.analyze import analyze
    from remote_trigger.analysis.forcelaw_ref import ReferenceSystem, reference_forces
    from remote_trigger.analysis.state.dumpfile import read_dump

    st = read_dump(relaxed.datafile[:-len(".data")] + ".dump", require_contacts=False)
    s64 = ReferenceSystem.from_state(st)
    s32 = ReferenceSystem(st.positions.astype(np.float32).astype(np.float64), st.radii,
                          s64.pairs, s64.xi0, s64.k_n, s64.k_t, s64.mu, box_x=s64.box_x,
                          wall_y=s64.wall_y, wall_disks=s64.wall_disks, wall_xi0=s64.wall_xi0)
    err = np.max(np.abs(reference_forces(s32, s32.q0) - reference_forces(s64, s64.q0)))
    residual = analyze(st, eigenvalues=False, decide=False).max_residual
    assert residual < 1e-10 and err > 1e6 * residual, (err, residual)
