"""Power laws over system sizes: F_x^c(N) ~ A N^b fitted over every packing.

An exponent between two medians uses two numbers and says nothing of its
uncertainty. :func:`power_law_fit` fits

.. math::

    \\ln F_i = \\ln A + b \\ln N_i + e_i

by least squares over every packing i (all sizes at once), and gives the
exponent's uncertainty twice: the ordinary least-squares standard error
(which assumes independent, equal scatter of ln F at every N) and a
percentile interval from a bootstrap that resamples the packings of each
size independently (:func:`scipy.stats.bootstrap` with one sample per size),
which assumes neither.

.. warning::

   With two sizes the fit is a line through two clouds and the bootstrap
   interval reflects only the scatter within each; it cannot tell a power
   law from any other monotonic law. Read ``n_sizes`` before the exponent.

Whether one power law holds over the whole range is a question of its own.
:func:`local_slopes` gives the exponent between the medians of neighbouring
sizes (with a bootstrap interval), :func:`crossover_test` tests one law
against a broken one,

.. math::

    \\ln F_i = a + b \\ln N_i + c\\,(\\ln N_i - \\ln N_b)_+ + e_i ,

(slopes b below N_b and b + c above), and the lack of fit of the line
against one mean per size; :func:`fraction_by_size` gives a yes/no
property's fraction per size (exact intervals) and a permutation test of a
trend in ln N.
"""
from __future__ import annotations

from dataclasses import dataclass, field
import math

import numpy as np

__all__ = ["PowerLawFit", "power_law_fit", "LocalSlope", "local_slopes", "CrossoverTest",
           "crossover_test", "FractionBySize", "fraction_by_size"]


@dataclass(frozen=True)
class PowerLawFit:
    """Result of :func:`power_law_fit`.

    Attributes
    ----------
    exponent : float
        b of y = A N^b (least squares on ln y).
    prefactor : float
        A (units of y).
    stderr : float
        Standard error of b from least squares; nan with two values (no
        degree of freedom left: least squares gives 0).
    ci : tuple of float
        (low, high): the stratified bootstrap's percentile interval of b at
        ``confidence`` (the values of each size resampled independently; a
        size with a single value enters unchanged); (nan, nan) if every size
        has a single value.
    confidence : float
        Level of ``ci``.
    n_points : int
        Values used (finite and > 0).
    n_dropped : int
        Values not used (non-finite or <= 0: no onset, a failed packing, a
        reversed order for a window width).
    sizes : tuple of int
        The distinct N, ascending.
    counts : tuple of int
        Values used per size.
    medians : tuple of float
        Median of y per size.
    """

    exponent: float
    prefactor: float
    stderr: float
    ci: tuple
    confidence: float
    n_points: int
    n_dropped: int
    sizes: tuple
    counts: tuple
    medians: tuple = field(default=())

    @property
    def n_sizes(self):
        """Number of distinct sizes."""
        return len(self.sizes)

    def describe(self, name="y"):
        """One line, e.g. ``'y ~ N^-1.39 (95 % bootstrap interval [-1.6, -1.2],
        s.e. 0.1; 31 values at N = 100, 400)'``."""
        lo, hi = self.ci
        ci = (f"{self.confidence * 100:g} % bootstrap interval [{lo:.3g}, {hi:.3g}]"
              if math.isfinite(lo) else "no bootstrap interval: one value per size")
        se = (f"least-squares s.e. {self.stderr:.2g}" if math.isfinite(self.stderr) else
              "no least-squares s.e.: two values")
        return (f"{name} ~ {self.prefactor:.3g} N^{self.exponent:.3g} ({ci}, {se}; "
                f"{self.n_points} values at N = {', '.join(str(s) for s in self.sizes)})")


def checked_sizes(n, y, confidence=0.95, n_resamples=100):
    """(n, y, usable) as float arrays; usable: y finite and > 0.

    The checks of every fit over system sizes here and in
    :mod:`remote_trigger.analysis.weakest_link`.

    Raises
    ------
    ValueError
        ``n`` and ``y`` of different lengths, a size not finite and > 0,
        ``confidence`` outside (0, 1) or ``n_resamples`` < 100; the message
        names the value.
    """
    n = np.asarray(n, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    if n.shape != y.shape:
        raise ValueError(f"n and y differ in length: {n.size} and {y.size}")
    if np.any(~np.isfinite(n)) or np.any(n <= 0):
        raise ValueError(f"sizes must be positive, got {n[~(n > 0)][:3].tolist()}")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    if not int(n_resamples) >= 100:
        raise ValueError(f"n_resamples must be >= 100, got {n_resamples!r}")
    return n, y, np.isfinite(y) & (y > 0)


def _enough_sizes(n, least, what):
    """The distinct sizes of ``n``, ascending; ValueError with fewer than ``least``."""
    sizes = np.unique(n)
    if sizes.size < least:
        words = {2: "two", 3: "three"}.get(least, str(least))
        raise ValueError(f"{what} needs usable values at {words} sizes or more, got "
                         f"{sizes.size} ({sizes.astype(int).tolist()})")
    return sizes


def power_law_fit(n, y, confidence=0.95, n_resamples=2000, seed=0):
    """Fit y = A N^b over every value, with the exponent's uncertainty.

    Parameters
    ----------
    n : array_like of int, shape (m,)
        System size of each value (e.g. disks per packing).
    y : array_like of float, shape (m,)
        The values (e.g. F_x^c per packing, force units); non-finite and
        non-positive values are dropped and counted.
    confidence : float
        Level of the bootstrap interval, in (0, 1).
    n_resamples : int
        Bootstrap resamples (>= 100).
    seed : int
        Seed of the bootstrap's generator (the interval is reproducible).

    Returns
    -------
    PowerLawFit

    Raises
    ------
    ValueError
        If ``n`` and ``y`` differ in length, a size is not positive, fewer
        than two distinct sizes have a usable value, or ``confidence`` /
        ``n_resamples`` are out of range (the message names the value).
    """
    from scipy import stats

    n, y, ok = checked_sizes(n, y, confidence, n_resamples)
    sizes = _enough_sizes(n[ok], 2, "a power law")
    x, ly = np.log(n[ok]), np.log(y[ok])
    reg = stats.linregress(x, ly)
    groups = [ly[n[ok] == s] for s in sizes]
    logs = [np.log(s) for s in sizes]
    ci = (math.nan, math.nan)
    many = [k for k, g in enumerate(groups) if g.size > 1]
    if many:
        # a size with one value has nothing to resample: it enters as it is
        xs = np.concatenate([np.full(len(g), lx) for g, lx in zip(groups, logs)])
        dx = xs - xs.mean()

        def statistic(*samples, axis=-1):
            batch = np.shape(samples[0])[:-1]
            gs = [np.broadcast_to(g, batch + g.shape) for g in groups]
            for k, g in zip(many, samples):
                gs[k] = g
            return np.concatenate(gs, axis=-1) @ dx / np.dot(dx, dx)

        res = stats.bootstrap(tuple(groups[k] for k in many), statistic, vectorized=True,
                              n_resamples=int(n_resamples), confidence_level=confidence,
                              method="percentile", rng=np.random.default_rng(seed))
        ci = (float(res.confidence_interval.low), float(res.confidence_interval.high))
    return PowerLawFit(
        exponent=float(reg.slope), prefactor=float(np.exp(reg.intercept)),
        stderr=float(reg.stderr) if ok.sum() > 2 else math.nan, ci=ci,
        confidence=float(confidence),
        n_points=int(ok.sum()), n_dropped=int((~ok).sum()),
        sizes=tuple(int(s) for s in sizes), counts=tuple(int(g.size) for g in groups),
        medians=tuple(float(np.exp(np.median(g))) for g in groups))


# --------------------------------------------------------------------------- local slopes
@dataclass(frozen=True)
class LocalSlope:
    """The exponent between the medians of two neighbouring sizes (:func:`local_slopes`).

    Attributes
    ----------
    n_low, n_high : int
        The two sizes.
    slope : float
        ln(median y(n_high) / median y(n_low)) / ln(n_high / n_low).
    ci : tuple of float
        Percentile interval of the slope at ``confidence`` from a bootstrap
        that resamples the values of each size independently; a size with
        one value enters unchanged (its median has no scatter here).
    confidence : float
    counts : tuple of int
        Values at n_low and n_high.
    """

    n_low: int
    n_high: int
    slope: float
    ci: tuple
    confidence: float
    counts: tuple


def local_slopes(n, y, confidence=0.95, n_resamples=2000, seed=0):
    """Median-to-median exponents between neighbouring sizes, with intervals.

    A single power law has one slope everywhere; a crossover shows as
    slopes that change along N. Each slope uses two medians only, so its
    interval (bootstrap of the medians) is wide where a size has few values.

    Parameters
    ----------
    n : array_like of int, shape (m,)
        System size of each value.
    y : array_like of float, shape (m,)
        The values; non-finite and non-positive ones are dropped.
    confidence : float
        Level of the intervals, in (0, 1).
    n_resamples : int
        Bootstrap resamples (>= 100).
    seed : int
        Seed of the bootstrap's generator.

    Returns
    -------
    tuple of LocalSlope
        One per pair of neighbouring sizes, ascending in N.

    Raises
    ------
    ValueError
        As :func:`power_law_fit` (lengths, sizes, fewer than two usable
        sizes, ``confidence``, ``n_resamples``).
    """
    n, y, ok = checked_sizes(n, y, confidence, n_resamples)
    sizes = _enough_sizes(n[ok], 2, "a slope between sizes")
    rng = np.random.default_rng(seed)
    groups = [y[ok & (n == s)] for s in sizes]
    med = np.array([np.median(g) for g in groups])
    boot = np.array([np.median(rng.choice(g, size=(int(n_resamples), g.size)), axis=1)
                     for g in groups])                     # (sizes, resamples)
    q = 100.0 * np.array([(1.0 - confidence) / 2.0, (1.0 + confidence) / 2.0])
    out = []
    for k in range(sizes.size - 1):
        dl = math.log(sizes[k + 1] / sizes[k])
        b = np.log(boot[k + 1] / boot[k]) / dl
        lo, hi = np.percentile(b, q)
        out.append(LocalSlope(n_low=int(sizes[k]), n_high=int(sizes[k + 1]),
                              slope=float(math.log(med[k + 1] / med[k]) / dl),
                              ci=(float(lo), float(hi)), confidence=float(confidence),
                              counts=(int(groups[k].size), int(groups[k + 1].size))))
    return tuple(out)


# --------------------------------------------------------------------------- crossover
@dataclass(frozen=True)
class CrossoverTest:
    """One power law against a broken one (:func:`crossover_test`).

    Attributes
    ----------
    exponent : float
        b of the single law (least squares on ln y).
    break_n : float
        N_b of the best broken law (least squares over a grid of breaks).
    exponent_below, exponent_above : float
        Its slopes below and above N_b.
    break_value : float
        Its value at N_b (units of y): the broken law is
        ``break_value * (N / N_b) ** slope``, the slope below or above N_b.
    f_statistic : float
        (SSE_single - SSE_broken) / (SSE_broken / (m - 3)) at N_b: the
        largest over the breaks tried.
    p_value : float
        Probability under the single law of an F statistic as large,
        maximised over the same breaks: a bootstrap of the single law's
        fitted line plus residuals resampled within each size (centred and
        rescaled per size, so each size keeps its own scatter). It accounts
        for the break being chosen by the data, which a table of the F
        distribution does not.
    lack_of_fit_f : float
        Lack-of-fit F of the single law against one mean per size,
        ((SSE_single - SSE_means) / (k - 2)) / (SSE_means / (m - k)), k the
        number of sizes: a test of the line that assumes no shape for the
        alternative.
    lack_of_fit_df : tuple of int
        (k - 2, m - k).
    lack_of_fit_p : float
        Its p-value from the F distribution (assumes equal scatter of ln y
        at every size).
    lack_of_fit_p_bootstrap : float
        Its p-value from the bootstrap above (each size its own scatter).
    aic_single, aic_broken : float
        Gaussian AIC on ln y, m ln(SSE / m) + 2 p, p = 3 (A, b, sigma) and
        5 (A, b, c, N_b, sigma). Lower is better; a difference below ~2 does
        not prefer either.
    n_points : int
    sizes, counts : tuple of int
    n_resamples : int
    """

    exponent: float
    break_n: float
    exponent_below: float
    exponent_above: float
    break_value: float
    f_statistic: float
    p_value: float
    lack_of_fit_f: float
    lack_of_fit_df: tuple
    lack_of_fit_p: float
    lack_of_fit_p_bootstrap: float
    aic_single: float
    aic_broken: float
    n_points: int
    sizes: tuple
    counts: tuple
    n_resamples: int

    @property
    def delta_aic(self):
        """AIC of the broken law minus that of the single one (< 0 prefers the broken)."""
        return self.aic_broken - self.aic_single

    def describe(self):
        """Two sentences with the statistics and p-values."""
        df1, df2 = self.lack_of_fit_df
        return (f"broken law: slopes {self.exponent_below:.3g} below and "
                f"{self.exponent_above:.3g} above N_b = {self.break_n:.3g} against one law "
                f"N^{self.exponent:.3g}: F = {self.f_statistic:.3g}, p = {self.p_value:.3g} "
                f"(bootstrap under one law, {self.n_resamples} resamples, the break "
                f"chosen in each), AIC(broken) - AIC(one law) = {self.delta_aic:.3g}; "
                f"lack of fit of one law against one mean per size: F({df1}, {df2}) = "
                f"{self.lack_of_fit_f:.3g}, p = {self.lack_of_fit_p:.3g} (F distribution), "
                f"{self.lack_of_fit_p_bootstrap:.3g} (bootstrap); {self.n_points} values at "
                f"N = {', '.join(str(s) for s in self.sizes)}")


def _sse(q, Y, yy):
    """Residual sum of squares of each column of Y (centred; ``yy``: the
    columns' squared norms) after least squares on a design with an intercept
    whose orthonormal basis is q: |Y|^2 - |q^T Y|^2."""
    p = q.T @ Y
    return yy - np.einsum("ij,ij->j", p, p)


def crossover_test(n, y, n_resamples=10000, seed=0, n_breaks=61):
    """Test one power law y = A N^b against a broken (continuous) one.

    The broken law is ln y = a + b ln N + c (ln N - ln N_b)_+, its break
    N_b on a grid of ``n_breaks`` points, log-spaced from the second
    smallest to the second largest size (each segment holds two sizes or
    more), plus those sizes themselves.

    Parameters
    ----------
    n : array_like of int, shape (m,)
        System size of each value.
    y : array_like of float, shape (m,)
        The values; non-finite and non-positive ones are dropped.
    n_resamples : int
        Bootstrap resamples under the single law (>= 100).
    seed : int
        Seed of the bootstrap.
    n_breaks : int
        Breaks on the grid (>= 2).

    Returns
    -------
    CrossoverTest

    Raises
    ------
    ValueError
        As :func:`power_law_fit`; fewer than three usable sizes; no more
        usable values than sizes (no scatter within a size); ``n_breaks`` < 2.
    """
    from scipy import stats

    n, y, ok = checked_sizes(n, y, 0.95, n_resamples)
    if not int(n_breaks) >= 2:
        raise ValueError(f"n_breaks must be >= 2, got {n_breaks!r}")
    sizes = _enough_sizes(n[ok], 3, "a crossover test")
    x, ly = np.log(n[ok]), np.log(y[ok])
    m, k = x.size, sizes.size
    if m <= k:
        raise ValueError(f"a crossover test needs more usable values than sizes, got {m} "
                         f"values at {k} sizes")
    gid = np.searchsorted(sizes, n[ok])
    counts = np.bincount(gid, minlength=k)
    lx = np.log(sizes)
    breaks = np.unique(np.concatenate([np.linspace(lx[1], lx[-2], int(n_breaks)), lx[1:-1]]))
    one = np.ones(m)
    x0 = np.column_stack([one, x])
    q0 = np.linalg.qr(x0)[0]
    qb = [np.linalg.qr(np.column_stack([one, x, np.maximum(x - b, 0.0)]))[0] for b in breaks]
    member = np.zeros((m, k))
    member[np.arange(m), gid] = 1.0

    def statistics(Y):
        Y = Y - Y.mean(axis=0)          # every design has an intercept
        yy = np.einsum("ij,ij->j", Y, Y)
        sse0 = _sse(q0, Y, yy)
        sse1 = np.array([_sse(q, Y, yy) for q in qb])
        j = np.argmin(sse1, axis=0)
        s1 = sse1[j, np.arange(Y.shape[1])]
        means = (member.T @ Y) / counts[:, None]
        ssep = np.einsum("ij,ij->j", Y - member @ means, Y - member @ means)
        with np.errstate(divide="ignore", invalid="ignore"):
            f = (sse0 - s1) / (s1 / (m - 3))
            flof = ((sse0 - ssep) / (k - 2)) / (ssep / (m - k))
        return f, flof, j, sse0, s1

    f, flof, j, sse0, s1 = (v[0] for v in statistics(ly[:, None]))
    d = np.column_stack([one, x, np.maximum(x - breaks[j], 0.0)])
    coef = np.linalg.lstsq(d, ly, rcond=None)[0]
    beta = np.linalg.lstsq(x0, ly, rcond=None)[0]
    # the bootstrap under the single law: its line plus residuals drawn within
    # each size, centred and rescaled there (a size's own scatter; a size
    # with one value draws from every size's)
    fitted = x0 @ beta
    e = ly - fitted
    pools = []
    for g in range(k):
        eg = e[gid == g]
        if eg.size > 1:
            pools.append((eg - eg.mean()) * math.sqrt(eg.size / (eg.size - 1)))
        else:
            pools.append(None)
    allc = np.concatenate([p for p in pools if p is not None])
    rng = np.random.default_rng(seed)
    B = int(n_resamples)
    Y = np.repeat(fitted[:, None], B, axis=1)
    for g in range(k):
        rows = np.flatnonzero(gid == g)
        pool = pools[g] if pools[g] is not None else allc
        Y[rows] += rng.choice(pool, size=(rows.size, B))
    fb, flofb, *_ = statistics(Y)
    return CrossoverTest(
        exponent=float(beta[1]), break_n=float(math.exp(breaks[j])),
        exponent_below=float(coef[1]), exponent_above=float(coef[1] + coef[2]),
        break_value=float(math.exp(coef[0] + coef[1] * breaks[j])),
        f_statistic=float(f), p_value=float((1 + np.sum(fb >= f)) / (B + 1)),
        lack_of_fit_f=float(flof), lack_of_fit_df=(k - 2, m - k),
        lack_of_fit_p=float(stats.f.sf(flof, k - 2, m - k)),
        lack_of_fit_p_bootstrap=float((1 + np.sum(flofb >= flof)) / (B + 1)),
        aic_single=float(m * math.log(sse0 / m) + 6.0),
        aic_broken=float(m * math.log(s1 / m) + 10.0),
        n_points=int(m), sizes=tuple(int(s) for s in sizes),
        counts=tuple(int(c) for c in counts), n_resamples=B)


# --------------------------------------------------------------------------- fractions
@dataclass(frozen=True)
class FractionBySize:
    """A yes/no property's fraction per size (:func:`fraction_by_size`).

    Attributes
    ----------
    sizes, present, totals : tuple of int
        The sizes, the values with the property, all values, per size.
    ci : tuple of (float, float)
        Exact (Clopper-Pearson) interval of each size's fraction at
        ``confidence``.
    confidence : float
    trend_z : float
        Standardised Cochran-Armitage statistic with scores ln N (negative:
        the fraction falls with N); NaN when every value or none has the
        property.
    trend_p : float
        Two-sided p-value of no trend, from random permutations of the
        property over the values (margins fixed); 1 when the property is
        constant.
    n_permutations : int
    """

    sizes: tuple
    present: tuple
    totals: tuple
    ci: tuple
    confidence: float
    trend_z: float
    trend_p: float
    n_permutations: int

    @property
    def fractions(self):
        """present / totals per size."""
        return tuple(p / t for p, t in zip(self.present, self.totals))


def fraction_by_size(n, present, confidence=0.95, n_permutations=20000, seed=0):
    """Fraction of values with a property per size, and a test of a trend in ln N.

    Parameters
    ----------
    n : array_like of int, shape (m,)
        System size of each value.
    present : array_like of bool, shape (m,)
        Whether each value has the property (e.g. a packing has the window).
    confidence : float
        Level of the exact intervals, in (0, 1).
    n_permutations : int
        Random permutations for the trend's p-value (>= 100).
    seed : int

    Returns
    -------
    FractionBySize

    Raises
    ------
    ValueError
        Lengths differ, a size is not positive, fewer than two sizes,
        ``confidence`` or ``n_permutations`` out of range.
    """
    from scipy import stats

    n, _, _ = checked_sizes(n, np.ones(np.size(n)), confidence, n_permutations)
    present = np.asarray(present, dtype=bool).ravel()
    if present.shape != n.shape:
        raise ValueError(f"n and present differ in length: {n.size} and {present.size}")
    sizes = _enough_sizes(n, 2, "a fraction by size")
    hits = [int(present[n == s].sum()) for s in sizes]
    tot = [int((n == s).sum()) for s in sizes]
    ci = []
    for h, t in zip(hits, tot):
        c = stats.binomtest(h, t).proportion_ci(confidence_level=confidence, method="exact")
        ci.append((float(c.low), float(c.high)))
    t = np.log(n)
    K, m = int(present.sum()), n.size
    z, p = math.nan, 1.0
    if 0 < K < m:
        s = float(t[present].sum())
        mean = K * t.mean()
        var = K * (m - K) / (m * (m - 1)) * float(np.sum((t - t.mean()) ** 2))
        z = (s - mean) / math.sqrt(var)
        rng = np.random.default_rng(seed)
        perm = rng.permuted(np.tile(present.astype(float), (int(n_permutations), 1)), axis=1)
        sb = perm @ t
        p = float((1 + np.sum(np.abs(sb - mean) >= abs(s - mean) - 1e-12))
                  / (int(n_permutations) + 1))
    return FractionBySize(sizes=tuple(int(v) for v in sizes), present=tuple(hits),
                          totals=tuple(tot), ci=tuple(ci), confidence=float(confidence),
                          trend_z=float(z), trend_p=p, n_permutations=int(n_permutations))
