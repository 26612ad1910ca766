"""Power laws over sizes (analysis.scaling): the fit, local slopes, the crossover
test and fractions by size."""
import math

import numpy as np
import pytest

from remote_trigger.analysis.scaling import (crossover_test, fraction_by_size, local_slopes,
                                              power_law_fit)


def _sample(b, sizes=(100, 400, 1600), per=(20, 11, 6), scatter=0.4, A=2.0, seed=0):
    rng = np.random.default_rng(seed)
    n = np.concatenate([np.full(k, s) for s, k in zip(sizes, per)])
    y = A * n ** b * np.exp(rng.normal(scale=scatter, size=n.size))
    return n, y


def test_exact_power_law_recovered():
    n = np.array([100, 100, 400, 1600, 1600])
    y = 3.0 * n ** -1.5
    fit = power_law_fit(n, y)
    assert fit.exponent == pytest.approx(-1.5, abs=1e-12)
    assert fit.prefactor == pytest.approx(3.0, rel=1e-10)
    assert fit.stderr < 1e-6           # the square root of a round-off residual
    assert fit.ci[0] == pytest.approx(-1.5, abs=1e-9) and fit.ci[1] == pytest.approx(-1.5, abs=1e-9)
    assert fit.sizes == (100, 400, 1600) and fit.counts == (2, 1, 2)


def test_interval_covers_the_true_exponent_most_of_the_time():
    """Coverage of the 90 % bootstrap interval on lognormal scatter: a check
    that fails if the interval is too narrow (or the slope biased)."""
    hits = 0
    trials = 30
    for seed in range(trials):
        n, y = _sample(-1.2, seed=seed)
        fit = power_law_fit(n, y, confidence=0.9, n_resamples=500, seed=seed)
        hits += fit.ci[0] <= -1.2 <= fit.ci[1]
        # the least-squares standard error and the bootstrap agree in size
        assert 0.3 < (fit.ci[1] - fit.ci[0]) / (2 * 1.645 * fit.stderr) < 3.0
    assert hits >= 22, hits           # ~27 expected; 22 of 30 has p < 0.01 under 0.9


def test_unusable_values_dropped_and_counted():
    n, y = _sample(-1.0, seed=3)
    y[:3] = [np.nan, 0.0, -1e-3]
    fit = power_law_fit(n, y)
    assert fit.n_dropped == 3 and fit.n_points == n.size - 3
    assert "N^" in fit.describe("F_x^c") and "100, 400, 1600" in fit.describe()


def test_one_value_per_size_has_no_bootstrap_interval():
    fit = power_law_fit([100, 400], [1e-2, 2e-3])
    assert fit.exponent == pytest.approx(math.log(0.2) / math.log(4))
    assert all(math.isnan(c) for c in fit.ci)
    assert "one value per size" in fit.describe()
    # two values leave least squares no degree of freedom: no standard error
    # (linregress gives 0, which read as an exact exponent)
    assert math.isnan(fit.stderr) and "no least-squares s.e.: two values" in fit.describe()


@pytest.mark.parametrize("n, y, match", [
    ([100, 100], [1.0, 2.0], "two sizes"),
    ([100, 400], [1.0, np.nan], "two sizes"),
    ([100, 400, 1600], [1.0, 2.0], "differ in length"),
    ([0, 400], [1.0, 2.0], "positive"),
])
def test_bad_input_named(n, y, match):
    with pytest.raises(ValueError, match=match):
        power_law_fit(n, y)


def test_bad_confidence_named():
    with pytest.raises(ValueError, match="1.5"):
        power_law_fit([100, 400], [1.0, 2.0], confidence=1.5)


# --------------------------------------------------------------------------- crossover
SIZES5 = (100, 400, 1600, 6400, 10000)
PER5 = (20, 11, 12, 7, 4)


def _broken(below, above, n_b, sizes=SIZES5, per=PER5, scatter=0.4, seed=0):
    """Values of a continuous broken power law (slopes ``below`` / ``above`` of
    N_b) with lognormal scatter."""
    rng = np.random.default_rng(seed)
    n = np.concatenate([np.full(k, s) for s, k in zip(sizes, per)]).astype(float)
    x = np.log(n / n_b)
    ly = np.where(x < 0, below * x, above * x) + rng.normal(scale=scatter, size=n.size)
    return n, np.exp(ly)


def test_a_known_break_is_detected_and_placed():
    """Slopes -1.4 and -0.4 about N_b = 1000, the ensemble's design with twice
    its packings: the single law is rejected and the slopes recovered."""
    n, y = _broken(-1.4, -0.4, 1000.0, per=tuple(2 * p for p in PER5), seed=1)
    t = crossover_test(n, y, n_resamples=500, seed=1)
    assert t.p_value < 0.01 and t.lack_of_fit_p < 0.01, t.describe()
    assert t.delta_aic < -4
    assert 400 <= t.break_n <= 2500, t.break_n
    assert t.exponent_below == pytest.approx(-1.4, abs=0.3)
    assert t.exponent_above == pytest.approx(-0.4, abs=0.3)
    # the broken law through its break: the data's level there (A = 1 at N_b = 1000)
    assert t.break_value * (1000.0 / t.break_n) ** (
        t.exponent_below if t.break_n > 1000 else t.exponent_above) == pytest.approx(1.0, rel=0.3)
    assert t.sizes == SIZES5 and t.counts == tuple(2 * p for p in PER5)


def _one_law(sizes, per, sd, seed):
    rng = np.random.default_rng(seed)
    n = np.concatenate([np.full(k, s) for s, k in zip(sizes, per)]).astype(float)
    sd = np.select([n == s for s in sizes], sd)
    return n, 1.2 * n ** -0.9 * np.exp(sd * rng.standard_normal(n.size))


def test_one_law_is_rejected_at_about_the_nominal_rate():
    """Under one power law the bootstrap p-value of the broken law (the break
    chosen by the data) is near uniform: at 10 % it rejects ~6 of 60 data
    sets of 12 sizes. The F distribution read at the best break rejects
    ~36 % of them (measured: 0.36 of 300; the bootstrap 0.10), so this
    fails if the search over breaks is not accounted for."""
    sizes = tuple(int(v) for v in np.geomspace(100, 10000, 12))
    rej = sum(crossover_test(*_one_law(sizes, (6,) * 12, [0.5] * 12, 1000 + seed),
                             n_resamples=100, seed=seed).p_value < 0.1 for seed in range(60))
    assert rej <= 12, rej                   # P(>= 13 of 60 | 0.1) = 0.005


def test_one_law_with_each_size_its_own_scatter():
    """The ensemble's design and scatter of ln F_x^c per size (0.35-0.8): both
    bootstrap p-values keep their level (at 10 %: ~4 of 40)."""
    rej = rej_lof = 0
    for seed in range(40):
        t = crossover_test(*_one_law(SIZES5, PER5, [0.8, 0.6, 0.5, 0.35, 0.7], 100 + seed),
                           n_resamples=200, seed=seed)
        rej += t.p_value < 0.1
        rej_lof += t.lack_of_fit_p_bootstrap < 0.1
    assert rej <= 9 and rej_lof <= 9, (rej, rej_lof)     # P(>= 10 of 40 | 0.1) < 0.01


def test_lack_of_fit_matches_its_definition():
    """F of the line against one mean per size, computed here from sums of squares."""
    from scipy import stats as st

    n, y = _broken(-1.0, -1.0, 1000.0, seed=3)
    t = crossover_test(n, y, n_resamples=100)
    x, ly = np.log(n), np.log(y)
    line = st.linregress(x, ly)
    sse0 = np.sum((ly - line.intercept - line.slope * x) ** 2)
    ssep = sum(np.sum((ly[n == s] - ly[n == s].mean()) ** 2) for s in SIZES5)
    k, m = len(SIZES5), n.size
    f = ((sse0 - ssep) / (k - 2)) / (ssep / (m - k))
    assert t.lack_of_fit_f == pytest.approx(f, rel=1e-10)
    assert t.lack_of_fit_p == pytest.approx(st.f.sf(f, k - 2, m - k), rel=1e-10)
    assert t.exponent == pytest.approx(line.slope, rel=1e-12)
    assert t.lack_of_fit_df == (3, m - 5)


def test_crossover_needs_three_sizes():
    with pytest.raises(ValueError, match="three sizes"):
        crossover_test([100, 100, 400, 400], [1.0, 2.0, 0.5, 0.4])
    with pytest.raises(ValueError, match="more usable values than sizes"):
        crossover_test([100, 400, 1600], [1.0, 0.5, 0.2])


# --------------------------------------------------------------------------- local slopes
def test_local_slopes_of_known_medians():
    n = np.array([100, 100, 100, 400, 400, 400, 1600])
    y = np.array([1.0, 2.0, 3.0, 0.1, 0.2, 0.3, 0.05])
    s = local_slopes(n, y, n_resamples=200)
    assert [(v.n_low, v.n_high) for v in s] == [(100, 400), (400, 1600)]
    assert s[0].slope == pytest.approx(math.log(0.1) / math.log(4))
    assert s[1].slope == pytest.approx(math.log(0.25) / math.log(4))
    assert s[0].ci[0] <= s[0].slope <= s[0].ci[1] and s[1].counts == (3, 1)


def test_local_slopes_see_a_break_the_single_fit_averages():
    n, y = _broken(-1.4, -0.4, 1000.0, per=(200,) * 5, scatter=0.2, seed=4)
    s = local_slopes(n, y, n_resamples=200)
    assert s[0].ci[1] < -1.0 and s[-1].ci[0] > -0.8, s


# --------------------------------------------------------------------------- fractions
def test_fraction_by_size_counts_intervals_and_trend():
    n = np.repeat([100, 400, 1600, 6400], 20)
    falling = np.concatenate([np.arange(20) < k for k in (18, 13, 8, 3)])
    f = fraction_by_size(n, falling, n_permutations=2000)
    assert f.present == (18, 13, 8, 3) and f.totals == (20,) * 4
    assert f.fractions[0] == 0.9 and f.ci[0][0] < 0.9 < f.ci[0][1]
    assert f.trend_z < -4 and f.trend_p < 0.001
    flat = np.concatenate([np.arange(20) < 12 for _ in range(4)])
    g = fraction_by_size(n, flat, n_permutations=2000)
    assert abs(g.trend_z) < 1e-12 and g.trend_p > 0.9
    # the exact interval of 1 of 2 (Clopper-Pearson): [0.0126, 0.987]
    h = fraction_by_size([100, 100, 400, 400], [True, False, True, True])
    assert h.ci[0] == pytest.approx((0.01257911709367899, 0.987420882906321), rel=1e-9)
    assert fraction_by_size([100, 400], [True, True]).trend_p == 1.0
