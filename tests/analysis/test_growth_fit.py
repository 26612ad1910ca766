"""growth_fit (instability.h5 measured_growth_rate) fits only the exponential stretch."""
import numpy as np

from remote_trigger.analysis.dynamics.series import growth_fit


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


def _bent(g=0.016, g2=0.008, t_bend=1300.0, t_max=2600.0, n=5201, wiggle=0.3):
    """Exponential growth (with the pair's oscillation), bent to a slower rate at
    t_bend by a weak nonlinearity, long before the final saturation."""
    t = np.linspace(0.0, t_max, n)
    lnD = np.log(1e-26) + 2 * g * np.minimum(t, t_bend) + 2 * g2 * np.clip(t - t_bend, 0, None)
    D = np.exp(lnD) * (1 + wiggle * np.cos(2 * 3.0 * t))
    return t, D


def test_window_ends_at_the_first_departure_from_a_constant_rate():
    from remote_trigger.analysis.dynamics.series import growth_window

    t, D = _bent()
    (i0, i1), g = growth_window(t, D, noise=1e-26)
    assert abs(g / 0.016 - 1) < 0.01, g
    assert t[i1] <= 1300.0 + 1e-9 and t[i1] > 1000.0       # cut at the bend, data only
    # without the cut (max D / 1e3 is far above the bend) the fit mixes both rates
    sel = (t >= t[i0]) & (D <= 1e-3 * D.max())
    mixed = np.polyfit(t[sel], np.log(D[sel]), 1)[0] / 2
    assert mixed < 0.9 * 0.016
    # a constant rate is measured whatever it is (the check can fail): no cut
    t, D = _bent(g=0.011, g2=0.011)
    (i0, i1), g = growth_window(t, D, noise=1e-26)
    assert abs(g / 0.011 - 1) < 0.01 and D[i1] > 1e-3 * D.max()


def test_short_windows_are_not_cut():
    """Fewer than one decade per piece (Fig. 5 (c) windows): the rates are not compared."""
    from remote_trigger.analysis.dynamics.series import growth_window

    t, D = _bent(g=0.016, g2=0.004, t_bend=100.0, t_max=200.0, n=201, wiggle=0.0)
    (i0, i1), g = growth_window(t, D, noise=1e-30, hi=0.999)    # 1.7 decades in all
    assert i0 == 0 and t[i1] > 190.0
