"""The weakest-link (extreme-value) test (analysis.weakest_link).

Each check can fail: values made as the minimum over N sites of a power-law
lower tail must pass the test (sites in proportion to N, a Weibull shape);
lognormal values with an exponent steeper than the shape allows must fail
it; the likelihoods are those scipy's own densities give at the fitted
parameters, and the shape at one size is scipy's maximum-likelihood fit.
"""
import math

import numpy as np
import pytest
from scipy import stats

from remote_trigger.analysis.weakest_link import weakest_link_test

SIZES = (100, 400, 1600, 6400)


def _weakest_links(k, per=30, seed=0):
    """Minimum over M = N sites of f = u^(1/k), u uniform: P(f < t) = t^k
    exactly, so the minimum tends to Weibull(k, N^(-1/k)) (a = 1)."""
    rng = np.random.default_rng(seed)
    n, y = [], []
    for s in SIZES:
        u = rng.random((per, s))
        n += [s] * per
        y += list((u ** (1.0 / k)).min(axis=1))
    return np.array(n, float), np.array(y)


def _lognormal(b=-0.9, sigma=0.55, per=30, seed=0):
    rng = np.random.default_rng(seed)
    n = np.repeat(np.array(SIZES, float), per)
    return n, 1.2 * n ** b * np.exp(sigma * rng.standard_normal(n.size))


def test_minima_over_n_sites_pass():
    n, y = _weakest_links(2.0, seed=1)
    t = weakest_link_test(n, y, n_resamples=200)
    assert t.shape_ci[0] < 2.0 < t.shape_ci[1], t.describe()
    assert t.sites_ci[0] < 1.0 < t.sites_ci[1] and t.sites_p > 0.05, t.describe()
    assert t.exponent == pytest.approx(-0.5, abs=0.1)
    assert t.predicted_exponent == pytest.approx(-1.0 / t.shape)
    assert t.same_shape_p > 0.05 and t.weibull_p > 0.05, t.describe()
    assert t.counts == (30,) * 4 and t.sizes == SIZES


def test_lognormal_values_steeper_than_their_shape_fail():
    """sigma = 0.55 of ln y is the scatter of a Weibull of k ~ 2.3, which with
    sites in proportion to N gives N^-0.43; the values fall as N^-0.9."""
    n, y = _lognormal(seed=2)
    t = weakest_link_test(n, y, n_resamples=200)
    assert t.sites_ci[0] > 1.0 and t.sites_p < 0.01, t.describe()
    assert t.exponent == pytest.approx(-0.9, abs=0.15)
    assert t.weibull_p < 0.05 and t.lognormal_p > 0.05, t.describe()
    assert t.loglik["lognormal"] > t.loglik["weibull"]


def test_likelihoods_are_scipys_densities_at_the_fit():
    n, y = _lognormal(per=12, seed=3)
    t = weakest_link_test(n, y, n_resamples=100)
    k = t.shape
    lw = sum(stats.weibull_min.logpdf(y[n == s], k, scale=np.mean(y[n == s] ** k) ** (1 / k)).sum()
             for s in SIZES)
    assert t.loglik["weibull"] == pytest.approx(lw, rel=1e-9)
    sig = math.sqrt(sum(np.sum((np.log(y[n == s]) - np.log(y[n == s]).mean()) ** 2)
                        for s in SIZES) / n.size)
    ll = sum(stats.lognorm.logpdf(y[n == s], sig, scale=math.exp(np.log(y[n == s]).mean())).sum()
             for s in SIZES)
    assert t.loglik["lognormal"] == pytest.approx(ll, rel=1e-9)
    # the normal model with one coefficient of variation: scipy's optimizer
    # from its maximum finds no higher likelihood
    from scipy.optimize import minimize

    def neg(p):
        c = math.exp(p[-1])
        return -sum(stats.norm.logpdf(y[n == s], p[j], c * p[j]).sum()
                    for j, s in enumerate(SIZES))
    start = [np.mean(y[n == s]) for s in SIZES] + [math.log(0.5)]
    best = minimize(neg, start, method="Nelder-Mead",
                    options={"maxiter": 20000, "xatol": 1e-12, "fatol": 1e-12})
    assert t.loglik["normal"] >= -best.fun - 1e-6
    assert t.loglik["normal"] == pytest.approx(-best.fun, abs=1e-3)


def test_shape_at_one_size_is_scipys_fit():
    n, y = _weakest_links(1.5, per=25, seed=4)
    t = weakest_link_test(n, y, n_resamples=100)
    for s, k in zip(SIZES, t.shapes):
        want = stats.weibull_min.fit(y[n == s], floc=0)[0]
        assert k == pytest.approx(want, rel=1e-4), s


def test_a_size_with_two_values_has_no_shape_of_its_own():
    n, y = _weakest_links(2.0, per=8, seed=5)
    keep = (n != 6400) | (np.cumsum(n == 6400) <= 2)
    t = weakest_link_test(n[keep], y[keep], n_resamples=100)
    assert math.isnan(t.shapes[-1]) and t.counts[-1] == 2


@pytest.mark.parametrize("n, y, match", [
    ([100, 100, 400], [1.0, 2.0, 3.0], "two distinct values at two sizes"),
    ([100, 400], [1.0], "differ in length"),
    ([0, 400], [1.0, 2.0], "positive"),
])
def test_bad_input_named(n, y, match):
    with pytest.raises(ValueError, match=match):
        weakest_link_test(n, y)


def test_too_few_resamples_named():
    with pytest.raises(ValueError, match="n_resamples must be >= 100, got 5"):
        weakest_link_test([100, 100, 400, 400], [1.0, 2.0, 0.5, 0.3], n_resamples=5)
