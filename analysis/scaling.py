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
"""
from __future__ import annotations

from dataclasses import dataclass, field
import math

import numpy as np

__all__ = ["PowerLawFit", "power_law_fit"]


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


def _slope(x, y):
    xm = x.mean()
    dx = x - xm
    return float(np.dot(dx, y - y.mean()) / np.dot(dx, dx))


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
    ok = np.isfinite(y) & (y > 0)
    sizes = np.unique(n[ok])
    if sizes.size < 2:
        raise ValueError(f"a power law needs usable values at two sizes or more, got "
                         f"{sizes.size} ({sizes.astype(int).tolist()})")
    x, ly = np.log(n[ok]), np.log(y[ok])
    reg = stats.linregress(x, ly)
    groups = [ly[n[ok] == s] for s in sizes]
    logs = [np.log(s) for s in sizes]
    ci = (math.nan, math.nan)
    many = [k for k, g in enumerate(groups) if g.size > 1]
    if many:
        # a size with one value has nothing to resample: it enters as it is
        def statistic(*samples):
            gs = list(groups)
            for k, g in zip(many, samples):
                gs[k] = g
            xs = np.concatenate([np.full(len(g), lx) for g, lx in zip(gs, logs)])
            return _slope(xs, np.concatenate(gs))

        res = stats.bootstrap(tuple(groups[k] for k in many), statistic, vectorized=False,
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
