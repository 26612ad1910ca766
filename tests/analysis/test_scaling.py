"""Power-law fits over sizes (analysis.scaling.power_law_fit)."""
import math

import numpy as np
import pytest

from remote_trigger.analysis.scaling import power_law_fit


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
