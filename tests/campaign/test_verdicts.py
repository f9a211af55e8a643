"""Every verdict rule on every branch: each criterion alone, both, neither, and at the boundary.

The rules: a claim's or a paired difference's verdict (ftc_mj.campaign.statistics.Paired.verdict: ``holds``
needs the mean difference's interval below 0 AND the win rate's above 1/2), the claim's dependence on a field
(ftc_mj.campaign.summary._depends: the win rates of the lowest and highest thirds apart AND their verdicts
different), the thresholds (a detection or an alarm at c needs z > c, the operating threshold allows at most
the target false-alarm probability, the calibrated threshold is the Gumbel quantile raised to the empirical one
where the runs resolve the rate).
"""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.campaign import statistics as st
from ftc_mj.campaign.calibrate import gumbel_quantile, threshold_quantile
from ftc_mj.campaign.summary import _depends, _operating_scale
from ftc_mj.ranking import score as sc


def _e(low: float, high: float) -> st.Estimate:
    return st.Estimate((low + high) / 2, low, high)


BELOW_ZERO, ABOVE_ZERO, STRADDLES_ZERO = _e(-2.0, -0.5), _e(0.5, 2.0), _e(-1.0, 1.0)
ABOVE_HALF, BELOW_HALF, STRADDLES_HALF = _e(0.6, 0.8), _e(0.2, 0.4), _e(0.4, 0.6)


@pytest.mark.parametrize("difference, win_rate, verdict", [
    (BELOW_ZERO, ABOVE_HALF, "holds"),              # both criteria
    (BELOW_ZERO, STRADDLES_HALF, "inconclusive"),   # the mean difference alone
    (BELOW_ZERO, BELOW_HALF, "inconclusive"),       # the mean difference alone, the win rate against
    (STRADDLES_ZERO, ABOVE_HALF, "inconclusive"),   # the win rate alone
    (ABOVE_ZERO, ABOVE_HALF, "inconclusive"),       # the win rate alone, the mean difference against
    (STRADDLES_ZERO, STRADDLES_HALF, "inconclusive"),  # neither
    (ABOVE_ZERO, BELOW_HALF, "reversed"),           # both the other way
    (ABOVE_ZERO, STRADDLES_HALF, "inconclusive"),   # reversed by the mean difference alone
    (STRADDLES_ZERO, BELOW_HALF, "inconclusive"),   # reversed by the win rate alone
    # The boundaries are open: an interval that reaches 0 or 1/2 does not exclude it.
    (_e(-2.0, 0.0), ABOVE_HALF, "inconclusive"),
    (BELOW_ZERO, _e(0.5, 0.7), "inconclusive"),
    (_e(-2.0, -1e-12), _e(0.5 + 1e-12, 0.7), "holds"),
    (_e(0.0, 2.0), BELOW_HALF, "inconclusive"),
    (ABOVE_ZERO, _e(0.3, 0.5), "inconclusive"),
    (_e(1e-12, 2.0), _e(0.3, 0.5 - 1e-12), "reversed"),
])
def test_a_claims_verdict_needs_both_criteria(difference, win_rate, verdict):
    assert st.Paired(10, difference, win_rate).verdict == verdict


def test_a_verdict_on_no_runs_is_no_data():
    nan = st.Estimate(np.nan, np.nan, np.nan)
    assert st.Paired(0, nan, nan).verdict == "no data"


def test_the_verdict_of_data_where_one_criterion_holds():
    """From runs, not from intervals: a is lower on 90% of the runs by 1 but higher on 10% by 30, so the win
    rate favours a and the mean difference (+2.1) does not: inconclusive, never ``holds``."""
    d = np.where(np.arange(200) % 10 == 0, 30.0, -1.0)
    p = st.paired(d, np.zeros(200))
    assert p.win_rate.low > 0.5 and p.mean_difference.low > 0
    assert p.verdict == "inconclusive"
    assert st.paired(-np.abs(d) / 30 - 0.1, np.zeros(200)).verdict == "holds"


@pytest.mark.parametrize("low, high, depends", [
    (ABOVE_HALF, BELOW_HALF, True),            # apart and different verdicts (holds, reversed)
    (_e(0.7, 0.9), _e(0.4, 0.6), True),        # apart, holds against open
    (_e(0.55, 0.75), _e(0.7, 0.95), False),    # both hold, overlapping
    (_e(0.51, 0.6), _e(0.7, 0.95), False),     # apart, but both hold: the verdict does not turn
    (_e(0.4, 0.7), _e(0.6, 0.9), False),       # different verdicts (open, holds), overlapping
    (_e(0.3, 0.6), _e(0.6, 0.9), False),       # touching at 0.6 is not apart
    (_e(0.3, 0.6), _e(0.6 + 1e-12, 0.9), True),
    (STRADDLES_HALF, STRADDLES_HALF, False),   # neither
])
def test_a_claim_depends_on_a_field_when_its_thirds_are_apart_and_differ(low, high, depends):
    assert _depends(low, high) is depends
    assert _depends(high, low) is depends


def test_detection_and_alarms_need_z_above_the_threshold():
    """c = 1: a faulty run at z = 1 is missed and a healthy one at z = 1 raises no alarm; just above, both."""
    runs = sc.DiagnosisRuns(np.array([1.0, 1.0 + 1e-9, 0.0, 0.5]), np.zeros(4), np.ones(4),
                            np.array([1.0, 1.0 + 1e-9, 3.0]), np.full(3, 0.1), np.ones(3, bool))
    scores = sc.diagnosis_scores(runs, resamples=20)
    assert scores["detection_rate"].value == pytest.approx(2 / 3)
    assert scores["specificity"].value == pytest.approx(3 / 4)


@pytest.mark.parametrize("healthy, target, threshold", [
    (np.arange(1.0, 21.0), 0.05, 19.0),   # at 19 exactly one of 20 (5%) alarms: allowed at the boundary
    (np.arange(1.0, 21.0), 0.049, 20.0),  # just below the boundary, the next peak
    (np.arange(1.0, 21.0), 0.10, 18.0),
    (np.zeros(20), 0.05, 0.0),            # no run above 0
])
def test_the_operating_threshold_allows_at_most_the_target(healthy, target, threshold):
    c = sc.operating_threshold(healthy, target)
    assert c == threshold
    assert np.mean(healthy > c) <= target


def test_the_operating_scale_is_the_first_at_or_below_the_target():
    p_fa = np.array([1.0, 0.5, 0.05, 0.01, 0.0])
    assert _operating_scale(p_fa, 0.05) == 2
    assert _operating_scale(p_fa, 0.049) == 3
    assert _operating_scale(np.array([1.0, 0.5]), 0.05) is None


def test_the_calibrated_threshold_takes_the_larger_of_the_fit_and_the_empirical_quantile():
    """Column 1: Gumbel samples (the fit is right, above the empirical quantile at this seed or not); column 2:
    a heavy tail the moment fit misses (the empirical quantile is larger). Each criterion alone decides."""
    rng = np.random.default_rng(5)
    samples = np.column_stack([rng.gumbel(0.0, 1.0, 100), np.where(np.arange(100) < 90, 0.0, 50.0)])
    rate = 0.1
    fit = gumbel_quantile(samples, rate)
    empirical = np.quantile(samples, 1 - rate, axis=0, method="higher")
    np.testing.assert_array_equal(threshold_quantile(samples, rate), np.maximum(fit, empirical))
    assert empirical[1] > fit[1]  # the empirical quantile alone decides column 2


@pytest.mark.parametrize("runs, rate, resolved", [(10, 0.1, True), (9, 0.1, False), (20, 0.1, True)])
def test_the_empirical_quantile_counts_only_where_the_runs_resolve_the_rate(runs, rate, resolved):
    """runs * rate >= 1, the boundary included: with a tail the fit misses, the empirical quantile is used
    exactly where the runs resolve the rate."""
    samples = np.zeros((runs, 1))
    samples[-max(1, round(runs * rate)):] = 100.0  # the top share ``rate`` of the runs (one at least)
    fit = gumbel_quantile(samples, rate)
    result = threshold_quantile(samples, rate)
    if resolved:
        assert result[0] == 100.0 > fit[0]
    else:
        assert result[0] == fit[0] < 100.0
