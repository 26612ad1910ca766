"""Contacts at the edges of the law, through LAMMPS and through the analyzer.

Two disks (R = 0.5, centres along x) or one disk on the wall, with the
tangential displacement written into the history arrays by hand and the
forces evaluated by ``run 0`` (which never changes the history):
u -> 1 from below, u = 1, u > 1 (the force is capped), mu -> 0 and mu = 0,
mu very large, delta -> 0+ and disks exactly touching. Everywhere: forces
finite and continuous (|F_t| -> mu F_n with zero slope at u = 1; F -> 0 as
delta^(3/2)), the analytic Jacobian finite, finite differences through
LAMMPS finite, no NaN.
"""
import warnings

import numpy as np
import pytest

from remote_trigger.pywrap.jobs.accuracy.jacobian_check import _LammpsFD
from remote_trigger.analysis.stability.jacobian import stiffness_matrix

from . import lmp_helpers as H

KN = 2e5
KT = 2 * KN / 7
DT = 1e-3


def pair(delta, u=0.0, mu=1.0, k_t=KT, sign=1.0):
    """Two disks overlapping by delta with xi = sign u t* stored on both sides."""
    pos = np.array([[0.0, 2.0], [1.0 - delta, 2.0]])
    lmp = H.scene(pos, [0.5, 0.5], KN, k_t, mu, DT, wall_y=None, integrate=False)
    if delta > 0:
        d_act = 1.0 - abs(pos[1, 0] - pos[0, 0])
        ts = mu * KN * d_act / k_t if k_t > 0 else 0.0
        ex = lmp.numpy.extract_atom
        ex("i2_mindlin_partner")[0, 0] = 2
        ex("i2_mindlin_partner")[1, 0] = 1
        ex("d2_mindlin_t")[0, 0] = sign * u * ts
        ex("d2_mindlin_t")[1, 0] = sign * u * ts
        lmp.command("run 0")
    return lmp


def wall_disk(delta, u=0.0, mu=1.0):
    pos = np.array([[0.0, 0.5 - delta]])
    lmp = H.scene(pos, [0.5], KN, KT, mu, DT, wall_y=0.0, integrate=False)
    d_act = 0.5 - pos[0, 1]
    lmp.numpy.extract_atom("d_mindlin_wall_t")[0] = u * mu * KN * d_act / KT
    lmp.command("run 0")
    return lmp


def forces(lmp):
    a = H.arrays(lmp)
    return a["f"], a["torque"]


def jacobians(lmp, mu=1.0, k_t=KT, wall_y=None, h=1e-9):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = H.to_state(lmp, KN, k_t, mu, wall_y=wall_y)
    K = stiffness_matrix(st).toarray()
    Kfd = _LammpsFD(lmp, DT).stiffness(h)
    return K, Kfd


U_BELOW = (0.5, 1 - 1e-3, 1 - 1e-6, 1 - 1e-9, 1 - 1e-12)


def test_u_to_one_from_below_is_continuous_with_zero_slope():
    delta = 1e-3
    fn = KN * delta ** 1.5
    gaps = []
    for u in U_BELOW + (1.0,):
        lmp = pair(delta, u)
        f, tq = forces(lmp)
        assert np.all(np.isfinite(f)) and np.all(np.isfinite(tq))
        ft = f[0, 1]                                  # s = (0, 1) for disk 1
        assert abs(ft) <= fn * (1 + 1e-12)
        gaps.append((1 - u, fn - abs(ft)))
        K, Kfd = jacobians(lmp)
        assert np.all(np.isfinite(K)) and np.all(np.isfinite(Kfd))
        lmp.close()
    for eps, gap in gaps:
        # |F_t| = mu F_n g(u) u = mu F_n (1 - (1-u)^2 (1 + u)) -> zero slope at u = 1
        assert gap <= 2.5 * eps ** 2 * fn + 1e-12 * fn, (eps, gap)
    assert gaps[-1][1] == pytest.approx(0.0, abs=1e-12 * fn)


def test_stiffness_continuous_at_the_cap():
    delta = 1e-3
    Ks = []
    for u in (1 - 1e-4, 1 - 1e-6, 1.0, 1.0 + 1e-9, 1.5, 10.0):
        lmp = pair(delta, u)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            st = H.to_state(lmp, KN, KT, 1.0, wall_y=None)
        Ks.append(stiffness_matrix(st).toarray())
        f, _ = forces(lmp)
        if u >= 1:                                    # capped: |F_t| = mu F_n exactly
            assert abs(f[0, 1]) == pytest.approx(KN * delta ** 1.5, rel=1e-12)
        lmp.close()
    scale = np.abs(Ks[2]).max()
    d4, d6 = np.abs(Ks[0] - Ks[2]).max(), np.abs(Ks[1] - Ks[2]).max()
    assert d6 < 2e-2 * d4 + 1e-12 * scale            # K(u) -> K(1) linearly in 1 - u
    for Kc in Ks[3:]:
        np.testing.assert_allclose(Kc, Ks[2], rtol=0, atol=1e-12 * scale)


def test_sliding_beyond_cap_after_a_step():
    """u > 1 stored: one step with no tangential motion caps the history at t*."""
    delta = 1e-3
    lmp = pair(delta, 1.5)
    lmp.command("run 1")
    a = H.arrays(lmp)
    ts = KN * (1.0 - abs(a["x"][1, 0] - a["x"][0, 0])) / KT
    assert abs(a["xi"][0, 0]) == pytest.approx(ts, rel=1e-12)
    assert np.all(np.isfinite(a["f"]))
    lmp.close()


@pytest.mark.parametrize("mu", [1e-3, 1e-8, 1e-15, 1e-300, 0.0])
def test_mu_to_zero(mu):
    delta = 1e-3
    lmp = pair(delta, 0.7, mu=mu)
    f, tq = forces(lmp)
    assert np.all(np.isfinite(f)) and np.all(np.isfinite(tq))
    assert abs(f[0, 1]) <= mu * KN * delta ** 1.5 * (1 + 1e-12)
    # tangential motion for one step: the history stays within t* (0 for mu = 0)
    lmp.numpy.extract_atom("v")[1, 1] = 1e-3
    lmp.command("run 1")
    a = H.arrays(lmp)
    assert np.all(np.isfinite(a["f"])) and np.all(np.isfinite(a["xi"]))
    assert np.all(np.abs(a["xi"]) <= mu * KN * delta / KT * (1 + 1e-12))
    K, Kfd = jacobians(lmp, mu=mu)
    assert np.all(np.isfinite(K)) and np.all(np.isfinite(Kfd))
    lmp.close()


def test_subnormal_mu_gives_finite_forces():
    # t* = mu k_n delta / k_t underflows to 0: treated as no friction, no 0/0
    lmp = pair(1e-3, 0.0, mu=5e-324)
    lmp.numpy.extract_atom("v")[1, 1] = 1e-3
    lmp.command("run 1")
    f, _ = forces(lmp)
    lmp.close()
    assert np.all(np.isfinite(f))


@pytest.mark.parametrize("mu", [1e3, 1e8, 1e300])
def test_mu_very_large(mu):
    delta = 1e-3
    xi = 1e-6
    lmp = pair(delta, 0.0, mu=mu)
    for k in (0, 1):
        lmp.numpy.extract_atom("d2_mindlin_t")[k, 0] = xi
    lmp.command("run 0")
    f, tq = forces(lmp)
    assert np.all(np.isfinite(f)) and np.all(np.isfinite(tq))
    # never slides: f_t = -k_t delta^(1/2) g(u) xi with u ~ 0
    assert f[0, 1] == pytest.approx(-KT * np.sqrt(delta) * xi, rel=1e-6)
    K, Kfd = jacobians(lmp, mu=mu)
    assert np.all(np.isfinite(K)) and np.all(np.isfinite(Kfd))
    lmp.close()


@pytest.mark.parametrize("delta", [1e-4, 1e-8, 1e-12, 1e-15])
@pytest.mark.parametrize("u", [0.0, 0.5, 1.0])
def test_delta_to_zero(delta, u):
    lmp = pair(delta, u)
    a = H.arrays(lmp)
    d_act = 1.0 - abs(a["x"][1, 0] - a["x"][0, 0])
    assert d_act > 0
    f, tq = forces(lmp)
    assert np.all(np.isfinite(f)) and np.all(np.isfinite(tq))
    assert -f[0, 0] == pytest.approx(KN * d_act ** 1.5, rel=1e-12)
    K, Kfd = jacobians(lmp, h=min(1e-9, d_act / 4))
    assert np.all(np.isfinite(K)) and np.all(np.isfinite(Kfd))
    # normal stiffness 3/2 k_n delta^(1/2) -> 0 continuously
    assert K[0, 0] == pytest.approx(1.5 * KN * np.sqrt(d_act), rel=1e-9)
    lmp.close()


@pytest.mark.parametrize("delta", [1e-4, 1e-10, 1e-15])
def test_wall_delta_to_zero_and_cap(delta):
    for u in (0.0, 1 - 1e-9, 1.0, 2.0):
        lmp = wall_disk(delta, u)
        f, tq = forces(lmp)
        assert np.all(np.isfinite(f)) and np.all(np.isfinite(tq))
        K, Kfd = jacobians(lmp, wall_y=0.0, h=1e-10 if delta > 1e-9 else 1e-16)
        assert np.all(np.isfinite(K)) and np.all(np.isfinite(Kfd))
        lmp.close()


def test_new_contact_forms_with_finite_force():
    """Disks approaching: the step in which the contact forms (delta -> 0+) gives
    a history equal to that step's increment (capped) and finite forces."""
    pos = np.array([[0.0, 2.0], [1.0 + 1e-6, 2.0]])
    lmp = H.scene(pos, [0.5, 0.5], KN, KT, 1.0, DT, wall_y=None,
                  velocities=[[0.0, 0.0], [-1e-3, 5e-3]])
    seen = False
    for _ in range(40):
        lmp.command("run 1 pre no post no")
        a = H.arrays(lmp)
        assert np.all(np.isfinite(a["f"])) and np.all(np.isfinite(a["xi"]))
        if a["partner"][0, 0] == 2:
            seen = True
            d = 1.0 - abs(a["x"][1, 0] - a["x"][0, 0])
            assert abs(a["xi"][0, 0]) <= KN * d / KT * (1 + 1e-12)
    assert seen
    lmp.close()


def test_exactly_touching_is_no_contact():
    """delta = 0 exactly: zero force, no contact in the analyzer; a history entry
    there is inside the touching band (docs/model.md section 2): LAMMPS keeps it
    on both sides with xi = 0, the analyzer counts it as touching, no NaN."""
    lmp = pair(0.0)
    a = H.arrays(lmp)
    assert abs(a["x"][1, 0] - a["x"][0, 0]) == 1.0
    ex = lmp.numpy.extract_atom
    ex("i2_mindlin_partner")[0, 0] = 2
    ex("i2_mindlin_partner")[1, 0] = 1
    ex("d2_mindlin_t")[0, 0] = ex("d2_mindlin_t")[1, 0] = 1e-5
    lmp.command("run 1")
    a = H.arrays(lmp)
    np.testing.assert_array_equal(a["f"], 0.0)
    assert np.all(np.isfinite(a["xi"]))
    assert a["partner"][0, 0] == 2 and a["partner"][1, 0] == 1
    np.testing.assert_array_equal(a["xi"], 0.0)
    st = H.to_state(lmp, KN, KT, 1.0, wall_y=None)
    assert st.n_contacts == 0 and st.notes["touching_pairs"] == 1
    assert st.notes["stale_history"] == 0
    assert np.all(stiffness_matrix(st).toarray() == 0.0)
    lmp.close()


def test_coincident_centres_in_lammps_are_not_silently_nan():
    """Two centres at the same point: the contact normal is undefined. The analyzer
    refuses such a state; LAMMPS should too (plugin: NaN forces, see report)."""
    from remote_trigger.analysis.state.state import ContactParams, build_state

    with pytest.raises(ValueError, match="overlapping centres"):
        build_state(ids=[1, 2], positions=[[0.0, 2.0], [0.0, 2.0]], radii=[0.5, 0.5],
                    masses=[1, 1], box_lo=[-5, -2], box_hi=[5, 10],
                    params=ContactParams(KN, KT, 1.0), wall_y=None)
