"""growth_fit (instability.h5 measured_growth_rate) fits only the exponential stretch."""
import numpy as np

from remote_trigger.analysis.series import growth_fit


def _series(g=0.016, noise=1e-27, sat=1e-8, t_max=3000.0, n=3001, seed=3):
    """Noise plateau, then D = noise e^{2 g (t - t0)} until it saturates at ``sat``."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, t_max, n)
    t0 = 300.0
    D = noise * np.exp(2 * g * np.clip(t - t0, 0, None))
    D = sat * D / (sat + D)                      # smooth saturation at sat
    D *= np.exp(0.05 * rng.standard_normal(n))   # multiplicative scatter
    D[0] = 0.0
    return t, D


def test_saturated_plateau_is_not_fitted():
    t, D = _series()
    # the saturated plateau (1e-8) lies below the stop level 1e-2 / 1e2
    assert np.count_nonzero(D > 0.5e-8) > 500
    g = growth_fit(t, D, hi=1e-2 / 1e2)
    assert abs(g / 0.016 - 1) < 5e-3, g
    # the former selection (all records between 1e3 noise and hi) is biased low
    noise = np.median(D[1:151])
    sel = (D > 1e3 * noise) & (D < 1e-4)
    old = np.polyfit(t[sel], np.log(D[sel]), 1)[0] / 2
    assert old < 0.9 * 0.016


def test_no_growth_gives_nan():
    t = np.linspace(0, 10, 101)
    assert np.isnan(growth_fit(t, np.zeros_like(t)))
    D = np.full_like(t, 1e-25)
    D[0] = 0
    assert np.isnan(growth_fit(t, D))
