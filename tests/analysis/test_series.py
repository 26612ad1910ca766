"""Time-series criteria of Fig. 5 and the trigger map (analysis.series), on series
whose answer is known in closed form."""
import math

import numpy as np
import pytest

from remote_trigger.analysis.dynamics import series as ser


def triggered_series(g=0.013, jump=1e-12, t_switch=5.0, t_grow=500.0, sat=1e-7, n=2401,
                     t_end=1200.0, mu0=1.0, mu_ss=0.8):
    """A run of Fig. 5 (c) in closed form: mu switches at t_switch, D jumps to
    `jump`, an unstable mode hidden below it grows at rate g (D ~ e^{2gt})
    from t_grow on and saturates at `sat`; D oscillates (factor 1 + 0.5 sin)."""
    t = np.linspace(0.0, t_end, n)
    osc = 1.0 + 0.5 * np.sin(37.0 * t)
    D = np.where(t < t_switch, 1e-25, jump + jump * np.exp(2 * g * np.maximum(t - t_grow, 0)))
    D = np.minimum(D, sat) * osc
    mu = np.where(t < t_switch, mu0, mu_ss)
    mu[(np.arange(n) % 17 == 0) & (t > t_switch)] = mu0      # zero crossings of v_top
    return t, D, mu


def test_growth_window_recovers_the_rate_after_the_jump():
    g = 0.013
    t, D, mu = triggered_series(g=g)
    i = ser.settle_index(t, mu, 0.8)
    level = ser.post_switch_level(t, D, mu, 1.0)
    assert level == pytest.approx(2e-12, rel=0.6)      # jump + the hidden mode
    win, gm = ser.growth_window(t, D, level, lo=10.0, hi=1e-2, start=i)
    assert win is not None and abs(gm / g - 1) < 0.05
    # the window starts above 10 x the jump: the offset does not bias the rate low
    assert D[win[0]] > 10 * level


def test_growth_window_fails_on_a_bounded_series():
    t = np.linspace(0, 1000, 2001)
    D = 1e-12 * (1 + 0.5 * np.sin(3 * t))
    assert ser.growth_window(t, D, 1e-12, lo=10.0)[0] is None


def test_settle_index_scattered_records_and_never():
    t, _, mu = triggered_series()
    i = ser.settle_index(t, mu, 0.8, tol=0.01)
    assert i is not None and t[i] <= 10.0
    assert ser.settle_index(t, np.ones_like(t), 0.8) is None


def test_saturated_only_after_growth_stops():
    t, D, mu = triggered_series(g=0.013, sat=1e-7)
    # D reaches 1e-7 at t = 500 + ln(1e5)/0.026 ~ 943
    t_sat = 500 + math.log(1e5) / 0.026
    first = next(k for k in range(10, t.size) if ser.saturated(t[:k], D[:k], mu[:k], 1.0))
    # fires after D stops growing, within one span (100) of the saturation
    assert t_sat < t[first - 1] <= t_sat + 101
    # still growing: never saturated
    t2, D2, mu2 = triggered_series(g=0.013, sat=1e3)
    assert not any(ser.saturated(t2[:k], D2[:k], mu2[:k], 1.0) for k in range(10, t2.size, 50))
    # no friction switch: never
    assert not ser.saturated(t, D, np.ones_like(t), 1.0)


def test_saturation_span_follows_a_slow_growth():
    """Below g = 0.0035 (e^{2 g 100} < 2; the 3D Fig. 5 (c) run grew at 0.0041
    to 0.0047 and, oscillating, was stopped so) the fixed 100 tau span calls
    a still-growing D saturated; the span scaled with g does not, and still
    fires within one span of the real saturation."""
    # unchanged at the 2D jobs' rates (default 2D ~0.012-0.013, 3D quick 0.0113)
    assert ser.saturation_span(0.0105) == ser.saturation_span(0.05) == 100.0
    assert ser.saturation_span(0.0053) == pytest.approx(196.2, abs=0.1)
    assert ser.saturation_span(0.0) == ser.saturation_span(float("nan")) == 100.0
    assert ser.saturation_span(0.002, span=50.0) == pytest.approx(math.log(8) / 0.004)
    assert math.exp(2 * 0.0053 * ser.saturation_span(0.0053)) == pytest.approx(ser.SPAN_GROWTH)
    g = 0.0033
    t, D, mu = triggered_series(g=g, t_grow=300.0, sat=1e3, t_end=3000.0, n=6001)
    ks = range(10, t.size, 25)
    assert any(ser.saturated(t[:k], D[:k], mu[:k], 1.0, span=100.0) for k in ks)
    span = ser.saturation_span(g)
    assert not any(ser.saturated(t[:k], D[:k], mu[:k], 1.0, span=span) for k in ks)
    t, D, mu = triggered_series(g=g, t_grow=300.0, sat=1e-8, t_end=3000.0, n=6001)
    t_sat = 300 + math.log(1e4) / (2 * g)
    first = next(k for k in range(10, t.size) if ser.saturated(t[:k], D[:k], mu[:k], 1.0,
                                                                 span=span))
    assert t_sat < t[first - 1] <= t_sat + span + 1


def test_growth_over_bounded_and_exponential():
    t = np.linspace(0, 1000, 4001)
    bounded = 1e-12 * (1 + 0.9 * np.sin(5 * t) ** 2)
    assert abs(ser.growth_over(t, bounded, 0.0, 1000.0)) < 0.05
    g = 0.005
    expo = 1e-12 * np.exp(2 * g * t) * (1 + 0.9 * np.sin(5 * t) ** 2)
    expected = 2 * g * 750 / math.log(10)
    assert ser.growth_over(t, expo, 0.0, 1000.0) == pytest.approx(expected, rel=0.02)


def test_friction_switch_and_decades():
    t = np.arange(5.0)
    assert ser.friction_switch_time(t, [1, 1, 0.99, 0.8, 0.8], 1.0) == 2.0
    assert math.isnan(ser.friction_switch_time(t, np.ones(5), 1.0))
    assert ser.decades_above([1e-3, -1e-2], 1e-12) == pytest.approx(10.0)


def test_quasi_static_velocity_step_and_smooth():
    C, a, w = 0.5, 2e-6, 0.01
    t = np.linspace(0, 2000, 4001)
    v = ser.quasi_static_velocity(t, a, w, C)
    assert np.max(np.abs(v)) == pytest.approx(C * a * w, rel=1e-4)
    t_on = 0.5 * math.pi / w
    vs = ser.quasi_static_velocity(t, a, w, C, t_on=t_on)
    # continuous at t = 0 (no jump of the velocity) and equal to the step's after t_on
    assert vs[0] == 0.0 and np.allclose(vs[t > t_on], v[t > t_on])
    # against a finite difference of C f(t)
    f = C * a * np.where(t < t_on, 0.5 * (1 - np.cos(np.pi * t / t_on)), 1.0) * np.cos(w * t)
    fd = np.gradient(f, t)
    assert np.max(np.abs(fd[1:-1] - vs[1:-1])) < 1e-3 * np.max(np.abs(vs))


def test_settled_growth_composes_the_window():
    t, D, mu = triggered_series(g=0.013)
    res = ser.settled_growth(t, D, mu, 1.0, 0.8, 0.01)
    assert res["mu_fit"] == pytest.approx(0.8) and abs(res["growth_rate"] / 0.013 - 1) < 0.05
    assert ser.settled_growth(t, D, np.ones_like(t), 1.0, 0.8, 0.01) is None


def _beating_series(g=0.0053, jump=1e-14, t_grow=1000.0, sat=4e-11, dt=0.85,
                    t_end=1950.0, beat=650.0, seed=0):
    """Fig. 5 (c) of the default 3D job in closed form: after the switch the
    spheres oscillate about the shifted equilibrium (amplitude sqrt(jump),
    beating slowly with period `beat`), a pair grows from below that
    oscillation at rate g and saturates at `sat`; records at random phases
    of both fast oscillations (as with records 0.85 time units apart)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, t_end, dt)
    env = 1.0 + 0.7 * np.cos(2 * np.pi * t / beat + rng.uniform(0, 2 * np.pi))
    a = np.sqrt(jump) * env * np.cos(rng.uniform(0, 2 * np.pi, t.size))
    amp = np.minimum(np.sqrt(jump) * np.exp(g * (t - t_grow)), np.sqrt(sat))
    D = (a + amp * np.cos(rng.uniform(0, 2 * np.pi, t.size))) ** 2
    D = np.where(t < 5.0, 1e-25, D)
    return t, D, np.where(t < 5.0, 1.0, 0.8)


def test_settled_growth_starts_above_the_beating_oscillation():
    # the window starts above 3 x the largest D before it, not above a multiple of
    # the median after the switch: measured over 20 seeds, at most 15 % off g
    # (median +1 %); the former window (10 x the median, 1e-2 x max D) was off by
    # up to 91 % on the same series
    g, errs, former = 0.0053, [], []
    for seed in range(10):
        t, D, mu = _beating_series(g=g, seed=seed)
        res = ser.settled_growth(t, D, mu, 1.0, 0.8, 0.01)
        errs.append(res["growth_rate"] / g - 1)
        assert D[res["window"][0]] > 3 * res["peak"] and res["peak"] > res["level"]
        level = ser.post_switch_level(t, D, mu, 1.0)
        former.append(ser.growth_window(t, D, level, lo=10.0, hi=1e-2,
                                        start=res["settle_index"])[1] / g - 1)
    assert max(abs(e) for e in errs) < 0.2 and np.median(np.abs(errs)) < 0.08
    assert max(abs(e) for e in former) > 0.5


def _pair_series(g, t_end=1200.0, dt=1.0, freq=115.7, seed=3):
    """D of a complex pair growing at rate g: e^{2gt} times an oscillation (a factor
    4.3 deep) at a frequency far above the record rate (records at random phases, as
    in the trigger map's runs: D sums every disk's motion, so its oscillation is
    shallower than a decade)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, t_end, dt)
    phase = rng.uniform(0, 2 * np.pi)
    return t, 1e-13 * np.exp(2 * g * t) * (0.3 + np.cos(freq * t + phase) ** 2)


def test_runaway_rate_least_squares_on_the_last_decade():
    g = 0.0123
    t, D = _pair_series(g)
    d_run = 1e-13 * math.exp(2 * g * 900)
    rate, n = ser.runaway_rate(t, D, d_run)
    # one decade at rate g spans ln(10) / (2 g) ~ 94 records of dt = 1; the dips of
    # the oscillation end it earlier (38 records here), the fit is unbiased
    assert n > 25 and abs(rate / g - 1) < 0.1
    # a rise that does not start before the last record below D_run / 10 is not fitted
    assert ser.runaway_rate(t, D, 1e3)[1] == 0 and math.isnan(ser.runaway_rate(t, D, 1e3)[0])


def test_runaway_consistent_needs_the_predicted_growth():
    g = 0.0123
    t, D = _pair_series(g)
    d_run = 1e-13 * math.exp(2 * g * 900)
    rate, n = ser.runaway_rate(t, D, d_run)
    assert ser.runaway_consistent(rate, n, g)
    # the same rise where no growth is predicted (below the window, damped): not it
    assert not ser.runaway_consistent(rate, n, 0.0)
    assert not ser.runaway_consistent(rate, n, -0.002)
    # three times faster than predicted (a resonance building up): not it
    assert not ser.runaway_consistent(rate, n, g / 3)
    # a forced jump: D passes D_run within one record of being 10x below it
    jump = np.where(t < 500, 1e-13, 1e-9)
    r1, n1 = ser.runaway_rate(t, jump, 1e-10)
    assert n1 == 1 and not ser.runaway_consistent(r1, n1, g)


def test_below_exponential_sees_saturation_despite_a_late_jump():
    """Fig. 4's saturation row: growth at g from noise, a plateau at 1e-8 from
    t ~ 1600, a slip to 2e-5 at t = 2050 inside the last 10 % (the default
    job's shape); the tail's own rate reads ~g there, the extrapolation does
    not. Still growing at the end: ~0 decades."""
    g = 0.0162
    t = np.linspace(0.0, 2164.0, 4329)
    grow = 1e-26 * np.exp(2 * g * t) * (1.0 + 0.5 * np.sin(0.3 * t))
    D = np.minimum(grow, 1e-8)
    D = np.where(t > 2050.0, 2e-5, D)
    win, gm = ser.growth_window(t, D, ser.noise_level(t, D))
    assert win is not None and abs(gm / g - 1) < 0.02
    below = ser.below_exponential(t, D, win, gm)
    assert below > 3 and below == pytest.approx(
        math.log10(D[win[1]]) + 2 * gm * (t[-1] - t[win[1]]) / math.log(10) - math.log10(2e-5))
    tail = slice(int(0.9 * t.size), t.size)
    assert ser.exp_rate(t[tail], D[tail], min_records=1) > 0.5 * g       # the old criterion
    # a run that ends while D still grows at g
    D2 = grow
    win2, g2 = ser.growth_window(t, D2, ser.noise_level(t, D2))
    assert abs(ser.below_exponential(t, D2, win2, g2)) < 0.5
    assert math.isnan(ser.below_exponential(t, D2, None, g2))
