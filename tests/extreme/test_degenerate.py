"""Degenerate systems: N = 2, one disk on the wall, all rattlers, no contacts.

Each gives a clear error or the correct trivial result, through the analyzer
(``analyze``, ``stiffness_matrix``, ``timestep``) and, for the geometry,
through LAMMPS.
"""
import math
import warnings

import numpy as np
import pytest

from remote_trigger.analysis.stability import timestep as ts
from remote_trigger.analysis.stability.analyze import analyze
from remote_trigger.analysis.stability.jacobian import generalized_forces, stiffness_matrix
from remote_trigger.analysis.state.state import ContactParams, build_state

from . import lmp_helpers as H

KN, KT, MU = 2e5, 2e5 * 2 / 7, 1.0
P = ContactParams(KN, KT, MU)


def state(pos, radii, wall_y=0.0, require_contacts=False):
    n = len(radii)
    return build_state(ids=np.arange(1, n + 1), positions=pos, radii=radii, masses=np.ones(n),
                       box_lo=[-10, -1], box_hi=[10, 20], params=P, wall_y=wall_y,
                       require_contacts=require_contacts)


def test_two_disks_one_contact():
    """N = 2 touching disks, no wall: both are rattlers (one contact each); K has
    the rigid-body zero modes; the analysis returns no eigenvalues, not an error."""
    st = state([[0.0, 5.0], [0.999, 5.0]], [0.5, 0.5], wall_y=None)
    K = stiffness_matrix(st).toarray()
    assert np.all(np.isfinite(K)) and K.shape == (6, 6)
    # translations are zero modes: K annihilates (1,0,0,1,0,0) and (0,1,0,0,1,0)
    np.testing.assert_allclose(K @ np.array([1, 0, 0, 1, 0, 0.0]), 0.0, atol=1e-9)
    np.testing.assert_allclose(K @ np.array([0, 1, 0, 0, 1, 0.0]), 0.0, atol=1e-9)
    res = analyze(st)
    assert sorted(res.rattlers.ids.tolist()) == [1, 2]
    assert res.eigen is None and res.decision is None
    # the stable step of such a pair is the two-body Hertz oscillator's:
    # omega^2 = k_eff / m_red = 1.5 k_n delta^(1/2) / (1/2)
    w2 = 1.5 * KN * math.sqrt(1e-3) / 0.5
    lim = ts.stability_limit(state([[0.0, 5.0], [0.999, 5.0]], [0.5, 0.5], wall_y=None)
                             .with_xi(contact_xi=[0.0]))
    assert lim <= 2.0 / math.sqrt(w2) * (1 + 1e-9)


def test_single_disk_on_the_wall():
    st = state([[0.0, 0.499]], [0.5])
    assert st.wall_index.tolist() == [0] and st.n_contacts == 0
    G = generalized_forces(st).reshape(-1, 3)
    assert G[0, 1] == pytest.approx(KN * 1e-3 ** 1.5, rel=1e-9)
    res = analyze(st)
    assert res.rattlers.ids.tolist() == [1]           # one contact: a rattler
    assert res.eigen is None
    lim = ts.stability_limit(st)
    assert math.isfinite(lim) and lim > 0
    # with the rattler criterion off the 3 x 3 block is analysed
    res1 = analyze(st, min_contacts=1)
    assert res1.eigenvalues.size == 3 and np.all(np.isfinite(res1.eigenvalues))


def test_single_disk_on_the_wall_in_lammps():
    lmp = H.scene([[0.0, 0.499]], [0.5], KN, KT, MU, 1e-4, wall_y=0.0)
    f, tq = H.arrays(lmp)["f"], H.arrays(lmp)["torque"]
    assert f[0, 1] == pytest.approx(KN * (0.5 - 0.499) ** 1.5, rel=1e-9)
    lmp.command("run 2000 pre no post no")            # bounces, stays finite
    a = H.arrays(lmp)
    assert np.all(np.isfinite(a["x"])) and np.all(np.isfinite(a["v"]))
    lmp.close()


def test_all_rattlers():
    """A chain of disks each touching only its neighbours (ends have one contact):
    the iterative peeling removes everything."""
    pos = [[k * 0.999, 5.0] for k in range(6)]
    st = state(pos, [0.5] * 6, wall_y=None)
    res = analyze(st)
    assert res.rattlers.ids.size == 6 and res.rattlers.keep_dofs.size == 0
    assert res.eigen is None and res.growth_rate is None


def test_no_contacts():
    pos = [[0.0, 3.0], [3.0, 3.0], [6.0, 3.0]]
    with pytest.raises(ValueError, match="no contacts"):
        state(pos, [0.5, 0.7, 0.5], require_contacts=True)
    st = state(pos, [0.5, 0.7, 0.5])
    assert stiffness_matrix(st).nnz == 0
    res = analyze(st)
    assert res.rattlers.ids.size == 3 and res.eigen is None
    assert ts.stability_limit(st) == math.inf
    with pytest.raises(ValueError, match="no contacts: the contact stiffness sets no time"):
        ts.stable_timestep(st)
    assert ts.check_timestep(1.0, ts.stability_limit(st)) == 0.0


def test_no_contacts_in_lammps_and_state_from_it():
    lmp = H.scene([[0.0, 3.0], [3.0, 3.0]], [0.5, 0.5], KN, KT, MU, 1e-3, wall_y=0.0)
    a = H.arrays(lmp)
    np.testing.assert_array_equal(a["f"], 0.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        st = H.to_state(lmp, KN, KT, MU)
    assert st.n_contacts == 0 and st.wall_index.size == 0
    lmp.close()
