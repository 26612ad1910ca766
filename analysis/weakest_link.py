"""Is a size dependence that of a weakest link? An extreme-value test.

If a threshold y (e.g. F_x^c) is the smallest of M independent local
thresholds, with M = c N^a sites and a lower tail P(f < t) ~ (t / t0)^k,
then for large M (Weibull's weakest-link picture; the extreme-value limit
of minima bounded below by 0)

.. math::

    P(y < t) = 1 - \\exp\\left[-(t / \\lambda_N)^k\\right], \\qquad
    \\lambda_N = \\lambda_0 N^{-a/k},

so the picture predicts, all at once:

1. at each N, a Weibull distribution (ln y: a Gumbel law of minima,
   skewed towards small values), not a normal or lognormal one;
2. the same shape k at every N: the distribution's scale shrinks as its
   median, so the scatter of ln y does not change with N;
3. y ~ N^b with b = -a / k; with sites no more numerous than particles
   or contacts, a <= 1, and with local sites of fixed size a = 1: the
   exponent is fixed by the shape measured at fixed N, b = -1 / k.

:func:`weakest_link_test` fits the Weibull model with one shape and a
scale per size, and with one shape and lambda_N = lambda_0 N^(-a/k); it
gives a and its profile-likelihood interval, the likelihood-ratio test of
a = 1, the test of one shape at every size against one per size, and the
Weibull model against the lognormal one (the same number of parameters:
a location per size and one scatter), calibrated by a parametric bootstrap
under each. The mode's size is not tested here: a local weakest link has a
pair of a fixed number of particles (the caller fits N PR against N).

.. warning::

   A few values per size cannot tell a Weibull from a lognormal tail (the
   bootstrap p-values say how well they can); the test of a = 1 assumes the
   Weibull model it is made in.
"""
from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np

from remote_trigger.analysis.scaling import checked_sizes

__all__ = ["WeakestLinkTest", "weakest_link_test"]

#: chi-square(1) quantile of the 95 % profile-likelihood interval
_CHI2_95 = 3.841458820694124


@dataclass(frozen=True)
class WeakestLinkTest:
    """Result of :func:`weakest_link_test`.

    Attributes
    ----------
    sizes, counts : tuple of int
        The sizes and their usable values.
    shape : float
        k of the Weibull model with one shape and one scale per size.
    shape_ci : tuple of float
        Its 95 % profile-likelihood interval.
    shapes : tuple of float
        k fitted at each size alone (NaN with fewer than 3 values).
    same_shape_p : float
        Likelihood-ratio p-value of one shape at every size (with 3 values
        or more) against one shape per size (chi-square, sizes - 1 degrees
        of freedom; NaN with fewer than two such sizes).
    exponent : float
        b of lambda_N ~ N^b in the model with one shape (k_b, below).
    sites_exponent : float
        a = -b k_b: the number of independent sites M ~ N^a the picture
        needs for the exponent and shape measured.
    sites_ci : tuple of float
        Its 95 % profile-likelihood interval (inf where the profile does
        not reach the level within 50 of a).
    sites_p : float
        Likelihood-ratio p-value of a = 1 (sites in proportion to N: the
        exponent fixed by the shape, b = -1/k).
    predicted_exponent : float
        -1 / k (the exponent a = 1 predicts from the shape ``shape``).
    loglik : dict
        Maximum log-likelihood of y (units of y) under 'weibull' (one
        shape, a scale per size), 'lognormal' (a median per size, one sigma
        of ln y) and 'normal' (a mean per size, one coefficient of
        variation); each has sizes + 1 parameters, so the largest is also
        the best by AIC.
    weibull_p : float
        Parametric-bootstrap p-value of the Weibull model against the
        lognormal one: the fraction of data sets drawn from the fitted
        Weibull model whose loglik['weibull'] - loglik['lognormal'] is as
        small as observed (small: the data are not Weibull-like).
    lognormal_p : float
        The same under the fitted lognormal model, with the difference as
        large as observed (small: the data are not lognormal-like).
    n_resamples : int
        Data sets drawn per model.
    """

    sizes: tuple
    counts: tuple
    shape: float
    shape_ci: tuple
    shapes: tuple
    same_shape_p: float
    exponent: float
    sites_exponent: float
    sites_ci: tuple
    sites_p: float
    predicted_exponent: float
    loglik: dict
    weibull_p: float
    lognormal_p: float
    n_resamples: int

    def describe(self):
        """Three sentences: the shape, the sites exponent and the shape test."""
        lo, hi = self.sites_ci
        return (f"Weibull shape k = {self.shape:.3g} (95 % [{self.shape_ci[0]:.3g}, "
                f"{self.shape_ci[1]:.3g}]; one shape at every size: p = "
                f"{self.same_shape_p:.3g}). With the scale ~ N^b: b = {self.exponent:.3g}, "
                f"sites M ~ N^a with a = -b k = {self.sites_exponent:.3g} (95 % [{lo:.3g}, "
                f"{hi:.3g}]); sites in proportion to N (a = 1, b = -1/k = "
                f"{self.predicted_exponent:.3g}): p = {self.sites_p:.3g}. Weibull against "
                f"lognormal: log-likelihoods {self.loglik['weibull']:.4g} and "
                f"{self.loglik['lognormal']:.4g}, p = {self.weibull_p:.3g} under Weibull, "
                f"{self.lognormal_p:.3g} under lognormal ({self.n_resamples} bootstrap data "
                f"sets each; {sum(self.counts)} values at N = "
                f"{', '.join(str(s) for s in self.sizes)})")


# --------------------------------------------------------------------------- likelihoods
class _Sample:
    """Values in groups (one per size), kept as flat arrays for the likelihoods."""

    def __init__(self, values):
        self.x = np.concatenate(values)
        self.lx = np.log(self.x)
        self.cnt = np.array([v.size for v in values], float)
        self.gid = np.repeat(np.arange(len(values)), [v.size for v in values])
        self.m = self.x.size
        self.slx = float(self.lx.sum())

    def sums(self, w):
        """Sum of w over each group."""
        return np.bincount(self.gid, weights=w, minlength=self.cnt.size)

    def part(self, keep):
        """The sample of the groups ``keep`` (bool per group)."""
        return _Sample([self.x[self.gid == g] for g in np.flatnonzero(keep)])

    def weibull(self, logk):
        """Log-likelihood of Weibull(k = exp(logk)) with each group's own scale
        at its maximum (lambda_g^k = mean of x^k over the group)."""
        k = math.exp(logk)
        means = self.sums(np.exp(k * self.lx)) / self.cnt
        return self.m * logk - float(np.dot(self.cnt, np.log(means))) + (k - 1.0) * self.slx \
            - self.m

    def lognormal(self):
        """Log-likelihood of ln x ~ normal(mu_g, sigma) at its maximum (in x)."""
        mean = self.sums(self.lx) / self.cnt
        sse = float(np.sum((self.lx - mean[self.gid]) ** 2))
        m = self.m
        return -self.slx - 0.5 * m * math.log(sse / m) - 0.5 * m * math.log(2.0 * math.pi) \
            - 0.5 * m

    def normal_cv(self):
        """Log-likelihood of x ~ normal(mu_g, (c mu_g)^2) at its maximum (one c)."""
        s1, s2 = self.sums(self.x), self.sums(self.x * self.x)

        def at(logc):
            c2 = math.exp(2.0 * logc)
            u = (s1 + np.sqrt(s1 * s1 + 4.0 * s2 * self.cnt * c2)) / (2.0 * s2)   # 1 / mu_g
            r = self.x * u[self.gid] - 1.0
            return (float(np.dot(self.cnt, np.log(u))) - 0.5 * self.m *
                    (2.0 * logc + math.log(2.0 * math.pi)) - float(np.dot(r, r)) / (2.0 * c2))
        return _max_1d(at, -8.0, 3.0)[1]


def _max_1d(fun, lo=-4.0, hi=4.0):
    """(argmax, max) of a smooth concave function of one variable on [lo, hi]."""
    from scipy.optimize import minimize_scalar

    r = minimize_scalar(lambda t: -fun(t), bounds=(lo, hi), method="bounded",
                        options={"xatol": 1e-10})
    return float(r.x), float(-r.fun)


def _weibull_sites(lx, ln, a, logk):
    """Log-likelihood of Weibull(k, lambda_0 N^(-a/k)) at its best lambda_0:
    m ln k - m ln(S/m) + a sum ln N + (k - 1) sum ln x - m, S = sum x^k N^a."""
    k = math.exp(logk)
    m = lx.size
    t = k * lx + a * ln
    tmax = t.max()
    s = math.log(np.mean(np.exp(t - tmax))) + tmax
    return m * logk - m * s + a * ln.sum() + (k - 1.0) * lx.sum() - m


def _sites_profile(lx, ln, a):
    return _max_1d(lambda t: _weibull_sites(lx, ln, a, t))[1]


def _interval(fun, best, at_best, step=0.25, limit=50.0):
    """Where fun (a profile log-likelihood) falls _CHI2_95 / 2 below its maximum
    at_best, on each side of ``best``; +-inf if not within ``limit``."""
    from scipy.optimize import brentq

    level = at_best - 0.5 * _CHI2_95
    out = []
    for sign in (-1.0, 1.0):
        a, b, found = best, best, False
        while abs(b - best) < limit:
            b = b + sign * step
            if fun(b) < level:
                found = True
                break
            a = b
        out.append(brentq(lambda t: fun(t) - level, a, b, xtol=1e-8) if found
                   else sign * math.inf)
    return tuple(out)


def _fit(sample, sizes):
    """Every statistic of the test but the bootstrap (dict)."""
    from scipy import stats

    lx = sample.lx
    ln = np.log(np.asarray(sizes, float))[sample.gid]
    logk, l0 = _max_1d(sample.weibull)
    lo, hi = _interval(sample.weibull, logk, l0, step=0.1, limit=8.0)
    # one shape per size (3 values or more) against one for those sizes
    big = sample.cnt >= 3
    each = [_max_1d(sample.part(np.arange(sample.cnt.size) == g).weibull) if big[g] else
            (math.nan, math.nan) for g in range(sample.cnt.size)]
    same_p = math.nan
    if big.sum() >= 2:
        l_one = _max_1d(sample.part(big).weibull)[1]
        l_each = sum(e[1] for e, b in zip(each, big) if b)
        same_p = float(stats.chi2.sf(max(0.0, 2.0 * (l_each - l_one)), int(big.sum()) - 1))
    a_best, l_sites = _max_1d(lambda a: _sites_profile(lx, ln, a), -20.0, 20.0)
    logk_b = _max_1d(lambda t: _weibull_sites(lx, ln, a_best, t))[0]
    a_ci = _interval(lambda a: _sites_profile(lx, ln, a), a_best, l_sites)
    l_a1 = _sites_profile(lx, ln, 1.0)
    return {"shape": math.exp(logk), "shape_ci": (math.exp(lo), math.exp(hi)),
            "shapes": tuple(math.exp(e[0]) if b else math.nan for e, b in zip(each, big)),
            "same_shape_p": same_p,
            "exponent": -a_best / math.exp(logk_b), "sites_exponent": a_best,
            "sites_ci": a_ci,
            "sites_p": float(stats.chi2.sf(max(0.0, 2.0 * (l_sites - l_a1)), 1)),
            "weibull": l0, "lognormal": sample.lognormal(), "normal": sample.normal_cv()}


def weakest_link_test(n, y, n_resamples=500, seed=0):
    """Test the weakest-link (extreme-value) picture of y(N) on values at several N.

    Parameters
    ----------
    n : array_like of int, shape (m,)
        System size of each value.
    y : array_like of float, shape (m,)
        The values (e.g. F_x^c per packing); non-finite and non-positive
        values are dropped.
    n_resamples : int
        Data sets drawn from each fitted model for the Weibull-against-
        lognormal p-values (>= 100).
    seed : int
        Seed of those draws.

    Returns
    -------
    WeakestLinkTest

    Raises
    ------
    ValueError
        If ``n`` and ``y`` differ in length, a size is not positive, fewer
        than two sizes have two distinct usable values each, or
        ``n_resamples`` < 100 (the message names the value).
    """
    n, y, ok = checked_sizes(n, y, n_resamples=n_resamples)
    sizes = [s for s in np.unique(n[ok]) if np.unique(y[ok & (n == s)]).size >= 2]
    if len(sizes) < 2:
        raise ValueError(f"a weakest-link test needs two distinct values at two sizes or "
                         f"more, got {len(sizes)} such size(s)")
    # values scaled by their geometric mean (the likelihoods' maxima move by
    # -m ln(scale), the same for every model: added back below)
    scale = math.exp(np.mean(np.log(y[ok & np.isin(n, sizes)])))
    values = [y[ok & (n == s)] / scale for s in sizes]
    base = _fit(_Sample(values), sizes)
    shift = -sum(v.size for v in values) * math.log(scale)
    d_obs = base["weibull"] - base["lognormal"]
    # parametric bootstrap of that difference under each fitted model
    rng = np.random.default_rng(seed)
    k = base["shape"]
    lam = [np.mean(v ** k) ** (1.0 / k) for v in values]
    mu = [np.mean(np.log(v)) for v in values]
    sig = math.sqrt(sum(float(np.sum((np.log(v) - np.mean(np.log(v))) ** 2)) for v in values)
                    / sum(v.size for v in values))
    d_w, d_l = [], []
    for _ in range(int(n_resamples)):
        sw = _Sample([lm * rng.weibull(k, v.size) for lm, v in zip(lam, values)])
        sl = _Sample([np.exp(m_ + sig * rng.standard_normal(v.size))
                      for m_, v in zip(mu, values)])
        for smp, out in ((sw, d_w), (sl, d_l)):
            out.append(_max_1d(smp.weibull)[1] - smp.lognormal())
    B = int(n_resamples)
    return WeakestLinkTest(
        sizes=tuple(int(s) for s in sizes), counts=tuple(int(v.size) for v in values),
        shape=base["shape"], shape_ci=base["shape_ci"], shapes=base["shapes"],
        same_shape_p=base["same_shape_p"], exponent=base["exponent"],
        sites_exponent=base["sites_exponent"], sites_ci=base["sites_ci"],
        sites_p=base["sites_p"], predicted_exponent=-1.0 / base["shape"],
        loglik={m: base[m] + shift for m in ("weibull", "lognormal", "normal")},
        weibull_p=float((1 + np.sum(np.array(d_w) <= d_obs)) / (B + 1)),
        lognormal_p=float((1 + np.sum(np.array(d_l) >= d_obs)) / (B + 1)),
        n_resamples=B)
