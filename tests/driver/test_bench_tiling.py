"""benchmarks/bench_scale.tiled_packing: copies of a relaxed packing side by side
are an equilibrium of the wider box, force for force (the N ~ 1e4 point of
make bench rests on it)."""
import os
import sys

import numpy as np

from remote_trigger.pywrap.bindings.engine import Engine

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "benchmarks"))


def _forces(datafile):
    with Engine() as eng:
        eng.load_deck("in.ramp_step", {"datafile": datafile, "Fx": 0.0}, ("scene",))
        eng.command("run 0")
        st = eng.gather_state()
    return st, np.column_stack([st.forces, st.torques / st.radii])


def test_copies_are_an_equilibrium_force_for_force(relaxed, tmp_path):
    from bench_scale import tiled_packing

    from remote_trigger.pywrap.stages.newton_solve import analysis_state

    copies = 3
    path = str(tmp_path / "tiled.data")
    n3 = tiled_packing(relaxed.datafile, copies, path, jitter=0.0)
    st1, G1 = _forces(relaxed.datafile)
    st3, G3 = _forces(path)
    assert n3 == copies * st1.n == st3.n
    L1 = st1.box_hi[0] - st1.box_lo[0]
    np.testing.assert_allclose(st3.box_hi[0] - st3.box_lo[0], copies * L1, rtol=1e-15)
    # every copy feels the source's forces (history followed its partners
    # across the periodic boundary); rounding of the shifted coordinates only
    for m in range(copies):
        np.testing.assert_allclose(G3[m * st1.n:(m + 1) * st1.n], G1, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(st3.partner[m * st1.n:(m + 1) * st1.n] > 0,
                                      st1.partner > 0)
    assert np.max(np.abs(G3)) < 1e-9
    # the two sides of every contact's history mirror each other (the analyzer's check)
    analysis_state(st3, 2e5, 2e5 * 2 / 7, 1.0, 0.0, 3.0)
    # with the jitter: a different, nearby state
    tiled_packing(relaxed.datafile, copies, path, jitter=1e-6)
    _, Gj = _forces(path)
    assert 1e-6 < np.max(np.abs(Gj)) < 1e-1
