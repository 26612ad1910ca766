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

from remote_trigger.analysis.trajectory import DisplacementFromStart, float32_floor, open_dump


def _run(tmp_path, datafile, kick, name):
    from remote_trigger.pywrap.config import RelaxConfig
    from remote_trigger.pywrap.engine import Engine
    from remote_trigger.pywrap.stage_common import _DECK_FIELDS, _deck_vars

    v = _deck_vars(RelaxConfig(datafile=datafile), datafile, 0.0)
    for var, _ in _DECK_FIELDS:
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
