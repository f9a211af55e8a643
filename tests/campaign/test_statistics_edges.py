"""The statistics over runs at their edges (ftc_mj.campaign.statistics): one run, no defined run, undefined
values (NaN, and None as JSON's null reads back), the interval's level, a report the same each time it is
made, each percentile of the summary, and the dependence on a varied field: its minimum of six runs, a field
not varied, the thirds of the field's values (a third each; a value held by many runs in one third whole),
ties counted half. Written from the survivors of the statistics mutation run (tools/mutation.py statistics).
"""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.campaign import statistics as st
from ftc_mj.campaign.schema import ReportSpec
from ftc_mj.ranking import score as sc


def _undefined(estimate: st.Estimate) -> bool:
    return bool(np.isnan([estimate.value, estimate.low, estimate.high]).all()) and estimate.text() == "-"


# ------------------------------------------------------------------------------------------- the intervals


def test_the_bootstrap_interval_is_the_central_95_percent_of_the_resampled_statistic():
    """The percentile bootstrap's interval runs from the 2.5th to the 97.5th percentile of the resampled
    means. Coverage by simulation (test_statistics_coverage.py) cannot tell a 95% level from 96.7% or 94.95%
    within its draws; on the distribution 0, 1, ..., 1000 the two percentiles are 25 and 975 (to the rounding
    of 1 - 0.95)."""
    assert st._interval(np.arange(1001.0)) == pytest.approx((25.0, 975.0), abs=1e-9)


def test_a_report_is_the_same_each_time_it_is_made():
    """The resamples come from a fixed seed: the same runs give the same intervals, call after call."""
    x = np.random.default_rng(21).lognormal(0.0, 1.0, 30)
    assert st.summarise(x, resamples=500) == st.summarise(x, resamples=500)
    assert st.paired(x, x[::-1], resamples=500) == st.paired(x, x[::-1], resamples=500)


def test_the_default_resamples_are_the_campaigns_and_the_benchmarks():
    """A direct call (the tuning's outcome compares its costs with ``paired``) gives the intervals a campaign
    report or the benchmark gives of the same runs with their default ``bootstrap``."""
    x = np.random.default_rng(22).normal(0.0, 1.0, 25)
    assert ReportSpec().bootstrap == sc.BOOTSTRAP
    assert st.summarise(x) == st.summarise(x, resamples=ReportSpec().bootstrap)
    assert st.paired(x, x**2) == st.paired(x, x**2, resamples=ReportSpec().bootstrap)


def test_the_summary_reports_the_5th_and_95th_percentiles():
    x = np.arange(101.0)  # the q-th percentile of 0, 1, ..., 100 is q
    s = st.summarise(x[::-1])
    assert (s.median.value, s.p5.value, s.p95.value) == (50.0, 5.0, 95.0)
    assert s.p5 == st.percentile(x, 5) and s.p95 == st.percentile(x, 95)
    assert s.p5.low < 5.0 < s.p5.high and s.p95.low < 95.0 < s.p95.high


def test_an_estimates_text():
    assert st.Estimate(1.234, 1.0, 2.0).text() == "1.23 [1, 2]"
    assert st.Estimate(0.5, 0.25, 0.75).text(".2f") == "0.50 [0.25, 0.75]"
    assert st.Estimate(np.nan, 0.0, 1.0).text() == "-"


# ------------------------------------------------------------------------------------------- one run, none


def test_one_run():
    """One run is a sample: its mean is its value with a zero-width bootstrap interval; no order statistic
    bounds a percentile of one value at 95%; one win of one has Wilson's interval [0.21, 1]."""
    s = st.summarise(np.array([3.0]))
    assert s.count == 1 and s.mean == st.Estimate(3.0, 3.0, 3.0)
    assert s.median == st.Estimate(3.0, -np.inf, np.inf)
    one_win = st.proportion(1, 1)
    assert one_win.value == 1.0 and one_win.low == pytest.approx(0.2065, abs=1e-4) and one_win.high == 1.0
    p = st.paired(np.array([1.0]), np.array([3.0]))
    assert p.count == 1 and p.mean_difference == st.Estimate(-2.0, -2.0, -2.0) and p.win_rate == one_win
    assert p.verdict == "inconclusive"  # one win cannot put the win rate's interval above 1/2


def test_no_defined_run():
    s = st.summarise(np.array([np.nan, np.inf, -np.inf]))
    assert s.count == 0 and all(_undefined(e) for e in (s.mean, s.median, s.p5, s.p95))
    assert s == st.summarise(np.array([]))
    p = st.paired(np.array([1.0, np.nan]), np.array([np.nan, 2.0]))
    assert p.count == 0 and _undefined(p.mean_difference) and _undefined(p.win_rate)
    assert p.verdict == "no data"
    assert _undefined(st.proportion(0, 0))


def test_undefined_values_read_back_from_json_are_left_out():
    """JSON has no NaN: an undefined metric is written as null and reads back as None, left out like NaN."""
    values = [1.0, None, 3.0, 2.0]
    assert st.summarise(values, resamples=300) == st.summarise(np.array([1.0, 3.0, 2.0]), resamples=300)
    p = st.paired([1.0, None, 2.0, 5.0], [2.0, 1.0, None, 1.0], resamples=300)
    assert p == st.paired(np.array([1.0, 5.0]), np.array([2.0, 1.0]), resamples=300)
    assert p.count == 2 and p.mean_difference.value == 1.5 and p.win_rate.value == 0.5


def test_the_mean_difference_is_the_mean_of_a_minus_b():
    a, b = np.array([1.0, 4.0, 2.0, 8.0]), np.array([2.0, 1.0, 2.0, 3.0])
    p = st.paired(a, b, resamples=300)
    assert p.mean_difference.value == np.mean(a - b) == 1.75
    assert p.mean_difference.low <= 1.75 <= p.mean_difference.high


# ------------------------------------------------------------------------------------------- ROC


def test_undefined_faulty_peaks_are_left_out_of_the_detection_probability():
    """A faulty run whose peak is undefined is not a missed detection: 1 of the 2 defined peaks exceeds 1."""
    p_fa, p_d = st.roc(np.array([0.5, np.nan]), np.array([np.nan, 2.0, 0.5]), np.array([1.0]))
    assert p_fa.tolist() == [0.0] and p_d.tolist() == [0.5]


def test_a_roc_point_with_an_undefined_coordinate_is_left_out_of_the_area():
    """The area through the defined points and the corners: (0, 1) makes a perfect detector, the point whose
    false-alarm probability is undefined adds nothing."""
    assert st.auc(np.array([np.nan, 0.0, 0.5]), np.array([0.3, 1.0, 1.0])) == 1.0
    assert st.auc(np.array([0.0, 0.5, 0.2]), np.array([1.0, 1.0, np.nan])) == 1.0


# ------------------------------------------------------------------------------------------- dependence


def _no_dependence(result) -> bool:
    rho, p, low, high = result
    return bool(np.isnan(rho) and np.isnan(p)) and _undefined(low) and _undefined(high)


def test_a_dependence_needs_six_runs():
    """Six runs (the tutorial's campaign) give Spearman's rho and the thirds' win rates; five give none."""
    field = np.arange(6.0)
    rho, p, low, high = st.dependence(field - 2.5, field)
    assert rho == pytest.approx(1.0) and low.value == 1.0 and high.value == 0.0
    assert _no_dependence(st.dependence(field[:5] - 2.5, field[:5]))


def test_a_field_not_varied_has_no_dependence():
    assert _no_dependence(st.dependence(np.linspace(-1.0, 1.0, 12), np.full(12, 0.3)))


def test_a_dependence_leaves_out_the_runs_where_either_is_undefined():
    field = np.linspace(0.0, 1.0, 12)
    difference = np.sin(7 * field)
    expected = st.dependence(difference, field)
    with_undefined = st.dependence(np.append(difference, [np.nan, 0.2]), np.append(field, [0.5, np.nan]))
    assert with_undefined == expected and np.isfinite(expected[0])


def test_the_thirds_hold_a_third_of_the_runs_each():
    """300 distinct field values: 100 runs in each third. a wins on the 50 lowest and the 50 highest values,
    so each third's win rate is 50 / 100; a third of 99 or 101 runs (or a quarter) would not give 1/2."""
    field = np.random.default_rng(23).permutation(300).astype(float)
    difference = np.where((field < 50) | (field >= 250), -1.0, 1.0)
    _, _, low, high = st.dependence(difference, field)
    assert low.value == 0.5 and high.value == 0.5


def test_a_field_value_held_by_many_runs_stays_whole_in_its_third():
    """A field varied over two values, each on half the runs: the lowest third is every run at the lower value
    and the highest third every run at the higher one (a field's tertile falls on a value it holds)."""
    field = np.repeat([0.0, 1.0], 10)
    difference = np.where(field == 0.0, -1.0, 1.0)  # a wins at 0, loses at 1
    rho, _, low, high = st.dependence(difference, field)
    assert rho == pytest.approx(1.0)
    assert low.value == 1.0 and high.value == 0.0
    assert low.low > 0.5 > high.high  # ten runs each: the verdict turns with the field


def test_ties_count_half_in_each_third():
    """Each third: 2 wins, 3 ties, 5 losses of 10 runs: a win rate of (2 + 3 / 2) / 10 = 0.35."""
    third = np.array([-1.0, -1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 1.0])
    difference = np.concatenate([third, np.full(10, -1.0), third])
    _, _, low, high = st.dependence(difference, np.arange(30.0))
    assert low.value == pytest.approx(0.35) and high.value == pytest.approx(0.35)
