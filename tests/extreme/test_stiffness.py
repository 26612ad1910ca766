"""Stiff contacts: the time step chosen from the contact stiffness keeps an
undamped Hertz run stable and energy-conserving at k_n = 2e5, 2e7, 2e9, and a
step above the stability limit is refused (and really is unstable).

Scene: 24 monodisperse disks (R = 0.5) on a triangular lattice, periodic in
x, every contact and the wall compressed by delta0 = (F0/k_n)^(2/3) (contact
force F0 = 3, the model's load), random velocities with kinetic energy
comparable to the elastic energy; frictionless (k_t = 0: the pair tallies
2/5 k_n delta^(5/2), the wall fix's elastic energy is added with
``fix_modify energy yes``). Hertz contacts are scale free: at fixed force the
dynamics at k_n is that at 2e5 with time scaled by (2e5/k_n)^(1/3), so with
dt chosen as a fixed fraction of the stability limit the relative energy
error must be the same for every k_n.
"""
import math
import warnings

import numpy as np
import pytest

from remote_trigger.analysis.stability import timestep as ts

from . import lmp_helpers as H

F0 = 3.0
STEPS, CHUNK = 4000, 200
KNS = (2e5, 2e7, 2e9)


def _setup(k_n, k_t=0.0, mu=0.0, dt=1e-3):
    d0 = (F0 / k_n) ** (2.0 / 3.0)
    pos, R, L = H.lattice(6, 4, d0)
    v = np.random.default_rng(1).normal(size=pos.shape) * math.sqrt(F0 * d0)
    lmp = H.scene(pos, R, k_n, k_t, mu, dt, width=L, velocities=v)
    return lmp, (pos, R, L, v)


def _energy_series(k_n, frac, limit, geom, k_t=0.0, mu=0.0):
    pos, R, L, v = geom
    lmp = H.scene(pos, R, k_n, k_t, mu, frac * limit, width=L, velocities=v)
    E0 = H.energy(lmp)[0]
    E = []
    try:
        for _ in range(STEPS // CHUNK):
            lmp.command(f"run {CHUNK} pre no post no")
            E.append(H.energy(lmp)[0])
    except Exception as exc:             # LAMMPS "Lost atoms": the run blew up
        return E0, None, str(exc)
    finally:
        lmp.close()
    return E0, np.array(E), ""


@pytest.fixture(scope="module")
def limits():
    out = {}
    for k_n in KNS:
        lmp, geom = _setup(k_n)
        st = H.to_state(lmp, k_n, 0.0, 0.0)
        lmp.close()
        out[k_n] = (ts.stability_limit(st), ts.stability_limit(st, "gershgorin"),
                    ts.stable_timestep(st), geom)
    return out


def test_limit_scales_as_kn_to_minus_one_third(limits):
    lim = np.array([limits[k][0] for k in KNS])
    ratio = lim[:-1] / lim[1:]
    np.testing.assert_allclose(ratio, 100.0 ** (1.0 / 3.0), rtol=0.02)
    for k in KNS:
        exact, gersh, dt, _ = limits[k]
        assert gersh <= exact                      # Gershgorin: never above the true limit
        assert dt == pytest.approx(ts.SAFETY_FACTOR * exact)
        assert ts.hertz_limit(k, F0, k_t=0.0) <= exact


@pytest.mark.parametrize("k_n", KNS)
def test_energy_bounded_at_chosen_dt(limits, k_n):
    exact, _, dt, geom = limits[k_n]
    E0, E, err = _energy_series(k_n, ts.SAFETY_FACTOR, exact, geom)
    assert E is not None, err
    dev = np.max(np.abs(E - E0)) / E0
    # measured 1.5e-3 for all three k_n (Verlet: proportional to dt^2)
    assert dev < 5e-3, dev
    E0h, Eh, _ = _energy_series(k_n, ts.SAFETY_FACTOR / 2, exact, geom)
    devh = np.max(np.abs(Eh - E0h)) / E0h
    assert 2.5 < dev / devh < 6.0, (dev, devh)     # second order in dt


def test_energy_error_is_independent_of_stiffness(limits):
    devs = []
    for k_n in KNS:
        exact, _, _, geom = limits[k_n]
        E0, E, err = _energy_series(k_n, ts.SAFETY_FACTOR, exact, geom)
        devs.append(np.max(np.abs(E - E0)) / E0)
    assert max(devs) / min(devs) < 1.5, devs


@pytest.mark.parametrize("k_n", KNS)
def test_step_above_limit_is_refused_and_unstable(limits, k_n):
    exact, _, _, geom = limits[k_n]
    with pytest.raises(ts.TimestepError, match=f"dt_max = 2/omega_max = {exact:.6g}"):
        ts.check_timestep(1.05 * exact, exact)
    assert ts.check_timestep(0.9 * exact, exact) == pytest.approx(0.9)
    with pytest.raises(ts.TimestepError, match="above 0.1 x"):
        ts.check_timestep(0.2 * exact, exact, safety=0.1)
    # the limit is the real one: 10 % above it the run blows up within 4000 steps
    E0, E, err = _energy_series(k_n, 1.1, exact, geom)
    assert E is None or np.max(E) > 1e3 * E0, (err, None if E is None else E[-5:])


def test_check_timestep_from_state_and_bad_values(limits):
    lmp, _ = _setup(2e5)
    st = H.to_state(lmp, 2e5, 0.0, 0.0)
    lmp.close()
    lim = ts.stability_limit(st)
    with pytest.raises(ts.TimestepError, match="stability limit"):
        ts.check_timestep(2 * lim, st)
    for bad in (0.0, -1e-3, float("nan"), float("inf"), "1e-3"):
        with pytest.raises(ts.TimestepError, match="finite number > 0"):
            ts.check_timestep(bad, lim)
    with pytest.raises(ValueError, match="safety"):
        ts.stable_timestep(st, safety=1.5)


def test_friction_limit_includes_rotation():
    """With friction the rotational coordinate (mass m/2) stiffens the top of the
    spectrum: the limit is lower than frictionless, and still sharp."""
    k_n = 2e5
    lmp, geom = _setup(k_n, 2 * k_n / 7, 1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = H.to_state(lmp, k_n, 2 * k_n / 7, 1.0)
    lmp.close()
    lim_f = ts.stability_limit(st)
    lmp, _ = _setup(k_n)
    lim_0 = ts.stability_limit(H.to_state(lmp, k_n, 0.0, 0.0))
    lmp.close()
    assert lim_f < lim_0
    assert ts.hertz_limit(k_n, F0) <= lim_f
    E0, E, err = _energy_series(k_n, 1.1, lim_f, geom, 2 * k_n / 7, 1.0)
    assert E is None or np.max(E) > 1e3 * E0
    E0, E, err = _energy_series(k_n, ts.SAFETY_FACTOR, lim_f, geom, 2 * k_n / 7, 1.0)
    assert E is not None and np.all(np.isfinite(E)) and np.max(E) <= E0 * 1.01
