"""Statistics over a population of runs: summaries with bootstrap confidence intervals, paired differences
between variants on the same runs, proportions with Wilson intervals, and the detection statistics (ROC,
detection probability against fault size, false alarms per hour) recomputed from the per-run threshold-free
columns that :func:`ftc_mj.analysis.diagnosis.detection_statistics` keeps.

Every interval is a 95% interval, and each is tested on that promise by simulation (it covers the true value
in 93-97% of samples drawn from a known distribution; tests/campaign/test_statistics_coverage.py):

* a mean, and a paired mean difference: the percentile bootstrap, over a fixed number of resamples drawn from a
  fixed seed, so that a report is the same each time it is made;
* a median or another percentile: the distribution-free interval between two order statistics (the inverted
  binomial test of the quantile, ``scipy.stats.quantile_test``), whose coverage is at least 95% for any
  continuous distribution. The percentile bootstrap of a tail percentile covers far less on the samples a
  campaign has (84% for the 5th percentile of 60 normal values); where the sample is too small to bound a side
  at 95% (the 5th percentile below 73 values), that side is infinite;
* a proportion (a rate, a win rate): Wilson's score interval.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import binomtest, quantile_test, spearmanr

CONFIDENCE = 0.95
_SEED = 20221130


@dataclass
class Estimate:
    value: float
    low: float
    high: float

    def text(self, fmt: str = ".3g") -> str:
        if not np.isfinite(self.value):
            return "-"
        return f"{self.value:{fmt}} [{self.low:{fmt}}, {self.high:{fmt}}]"


@dataclass
class Summary:
    """One metric of one variant (and joint) over the runs where it is defined."""

    count: int
    mean: Estimate
    median: Estimate
    p5: Estimate
    p95: Estimate


def _resample_index(n: int, resamples: int) -> np.ndarray:
    return np.random.default_rng(_SEED).integers(0, n, size=(resamples, n))


def _interval(samples: np.ndarray) -> tuple[float, float]:
    tail = (1 - CONFIDENCE) / 2 * 100
    low, high = np.percentile(samples, [tail, 100 - tail])
    return float(low), float(high)


def percentile(x: np.ndarray, q: float) -> Estimate:
    """The ``q``-th percentile of the finite sample ``x`` (linear interpolation) with its distribution-free 95%
    interval between two order statistics (``scipy.stats.quantile_test``); a side the sample is too small to
    bound is infinite."""
    value = float(np.percentile(x, q))
    ci = quantile_test(x, q=value, p=q / 100).confidence_interval(CONFIDENCE)
    low, high = float(ci.low), float(ci.high)
    return Estimate(value, -np.inf if np.isnan(low) else low, np.inf if np.isnan(high) else high)


def summarise(values: np.ndarray, resamples: int = 2000) -> Summary:
    """Mean (bootstrap interval), median, 5th and 95th percentiles (order-statistic intervals) of the finite
    values."""
    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    if x.size == 0:
        nan = Estimate(np.nan, np.nan, np.nan)
        return Summary(0, nan, nan, nan, nan)
    mean = Estimate(float(np.mean(x)), *_interval(x[_resample_index(x.size, resamples)].mean(axis=1)))
    return Summary(int(x.size), mean, percentile(x, 50), percentile(x, 5), percentile(x, 95))


@dataclass
class Paired:
    """``a - b`` on the runs where both are defined: lower is better, so a negative difference favours a."""

    count: int
    mean_difference: Estimate
    #: Share of runs with a < b (ties count half), with a Wilson interval.
    win_rate: Estimate

    @property
    def verdict(self) -> str:
        """``holds`` (a better: the mean difference's interval below 0 and the win rate's above 1/2), ``reversed``
        (both the other way), ``inconclusive`` otherwise."""
        d, w = self.mean_difference, self.win_rate
        if self.count == 0:
            return "no data"
        if d.high < 0 and w.low > 0.5:
            return "holds"
        if d.low > 0 and w.high < 0.5:
            return "reversed"
        return "inconclusive"


def paired(a: np.ndarray, b: np.ndarray, resamples: int = 2000) -> Paired:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    both = np.isfinite(a) & np.isfinite(b)
    d = a[both] - b[both]
    if d.size == 0:
        nan = Estimate(np.nan, np.nan, np.nan)
        return Paired(0, nan, nan)
    boot = d[_resample_index(d.size, resamples)].mean(axis=1)
    wins = float(np.sum(d < 0) + 0.5 * np.sum(d == 0))
    return Paired(int(d.size), Estimate(float(d.mean()), *_interval(boot)), proportion(wins, d.size))


def proportion(successes: float, trials: int) -> Estimate:
    """A proportion with its Wilson score interval (scipy's)."""
    if trials == 0:
        return Estimate(np.nan, np.nan, np.nan)
    k = int(round(successes))
    ci = binomtest(k, trials).proportion_ci(confidence_level=CONFIDENCE, method="wilson")
    return Estimate(successes / trials, float(ci.low), float(ci.high))


def dependence(difference: np.ndarray, field: np.ndarray) -> tuple[float, float, Estimate, Estimate]:
    """How a paired difference depends on a varied field: Spearman's rho and its p-value, and the win rate in
    the lowest and in the highest third of the field's values."""
    ok = np.isfinite(difference) & np.isfinite(field)
    d, x = difference[ok], field[ok]
    if d.size < 6 or np.ptp(x) == 0:
        nan = Estimate(np.nan, np.nan, np.nan)
        return np.nan, np.nan, nan, nan
    rho, p = spearmanr(x, d)
    low, high = np.percentile(x, [100 / 3, 200 / 3])
    thirds = []
    for mask in (x <= low, x >= high):
        part = d[mask]
        thirds.append(proportion(float(np.sum(part < 0) + 0.5 * np.sum(part == 0)), int(part.size)))
    return float(rho), float(p), thirds[0], thirds[1]


def roc(peaks_healthy: np.ndarray, peaks_fault: np.ndarray, scales: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """False-alarm and detection probability at each threshold multiple: a healthy run (or joint) alarms at c
    iff its held residual peak exceeds c, a faulty one is detected iff its peak after the onset does."""
    healthy = peaks_healthy[np.isfinite(peaks_healthy)]
    fault = peaks_fault[np.isfinite(peaks_fault)] if peaks_fault.size else peaks_fault
    p_fa = np.array([(healthy > c).mean() if healthy.size else np.nan for c in scales])
    p_d = np.array([(fault > c).mean() if fault.size else np.nan for c in scales])
    return p_fa, p_d


def auc(p_fa: np.ndarray, p_d: np.ndarray) -> float:
    """Area under the ROC curve through its points and the corners (0, 0) and (1, 1)."""
    ok = np.isfinite(p_fa) & np.isfinite(p_d)
    x = np.concatenate(([0.0], p_fa[ok], [1.0]))
    y = np.concatenate(([0.0], p_d[ok], [1.0]))
    order = np.lexsort((y, x))
    return float(np.trapezoid(y[order], x[order]))
