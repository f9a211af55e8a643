"""Suite v2's window statistics on synthetic envelopes: what a calibrated threshold, a window's peak, a delay,
an alarm on at the onset, a latched alarm, isolation and the draw-clustered bootstrap mean, each against a case
whose answer is known, and the v1 statistic that the one-statistic rule replaces."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.ranking import calibrated as cal
from ftc_mj.ranking.score import mann_whitney

BLOCK = 0.01  # s
BLOCKS = 200  # 2 s
LAYERS = [cal.Stratum(joint=1, onset=1.0, length=0.5)]


def population(envelope: np.ndarray, *, draw=None, joint=1, onset=1.0, kind="bias", size=1.0,
               effect=1.0) -> cal.Population:
    runs = envelope.shape[0]
    return cal.Population({"e": envelope}, np.arange(runs) if draw is None else np.asarray(draw),
                          np.full(runs, kind), np.full(runs, size), np.full(runs, joint), np.full(runs, onset),
                          np.full((runs, envelope.shape[2]), effect), 0, BLOCK)


def noise(rng: np.random.Generator, runs: int, joints: int = 3) -> np.ndarray:
    return np.abs(rng.standard_normal((runs, BLOCKS, joints)))


def test_the_threshold_is_the_population_quantile_and_its_false_alarm_rate_is_near_nominal():
    rng = np.random.default_rng(1)
    calibrate, healthy = population(noise(rng, 400)), population(noise(rng, 400))
    faults = population(noise(rng, 50))
    w, thresholds = cal.windows("e", calibrate, healthy, faults, LAYERS, 0.05, 0.0)
    peaks = cal.peaks(calibrate.envelopes["e"], LAYERS[0], BLOCK)
    assert thresholds[0, 0] == np.quantile(peaks[:, 0], 0.95, method="higher")
    realised = np.mean(w.healthy_z > 1)
    assert abs(realised - 0.05) < 2 * np.sqrt(0.05 * 0.95 / 400)


def test_noise_scores_one_half_with_one_statistic_and_below_it_with_v1s():
    """The same windows for healthy and faulty runs: a detector whose residual ignores the fault scores 1/2.
    v1's healthy statistic (the largest over every joint and the whole run) pushes it far below."""
    rng = np.random.default_rng(2)
    calibrate, healthy, faults = (population(noise(rng, 300)) for _ in range(3))
    w, _ = cal.windows("e", calibrate, healthy, faults, LAYERS, 0.05, 0.0)
    scores = cal.scores(w, resamples=200)
    assert scores["auc"].low <= 0.5 <= scores["auc"].high
    v1_healthy = np.nanmax(healthy.envelopes["e"], axis=(1, 2))
    v1_fault = cal.peaks(faults.envelopes["e"], LAYERS[0], BLOCK)[:, 0]
    assert mann_whitney(v1_healthy, v1_fault) < 0.1


def test_delay_alarm_on_at_onset_latched_and_isolation():
    rng = np.random.default_rng(3)
    calibrate, healthy = population(0.1 * noise(rng, 100)), population(0.1 * noise(rng, 100))
    latched = np.array(healthy.envelopes["e"])
    latched[:5, :, 0] = 10.0  # five healthy runs alarmed on joint 1 from start to end
    healthy = population(latched)
    fault = 0.1 * noise(rng, 3)
    fault[0, 120:, 0] = 5.0  # alarm from 1.2 s: delay 0.2 s (to the end of the first block over)
    fault[1, 95:, 0] = 5.0  # already on before the 1.0 s onset
    fault[2, 110:, 0] = 5.0  # detected at 1.1 s, but joint 2 alarms too: isolated wrong
    fault[2, 110:, 1] = 5.0
    w, _ = cal.windows("e", calibrate, healthy, population(fault), LAYERS, 0.05, 0.0)
    assert w.delay[0] == pytest.approx(0.21)
    assert np.isnan(w.delay[1]) and w.on_at_onset.tolist() == [False, True, False]
    assert w.isolated.tolist() == [True, True, False]
    assert w.healthy_latched.sum() == 5
    s = cal.scores(w, resamples=50)
    assert s["latched"].value == pytest.approx(0.05) and s["isolation"].value == pytest.approx(2 / 3)


def test_the_bootstrap_is_clustered_by_draw():
    """Fault cases sharing a draw are one cluster: with two draws whose cases all agree within each draw, the
    interval of P_d spans what resampling two draws gives, not the narrow one of independent windows."""
    rng = np.random.default_rng(4)
    calibrate, healthy = population(noise(rng, 200)), population(noise(rng, 200))
    fault = noise(rng, 40)
    fault[:20, 100:150, 0] = 50.0  # draw 0's twenty cases detected, draw 1's not
    draws = np.repeat([0, 1], 20)
    w, _ = cal.windows("e", calibrate, healthy, population(fault, draw=draws), LAYERS, 0.05, 0.0)
    clustered = cal.scores(w, resamples=200)["pd"]
    assert clustered.value == pytest.approx(0.5, abs=0.1)
    assert clustered.low <= 0.15 and clustered.high >= 0.95
    independent = population(fault, draw=np.arange(40))
    w, _ = cal.windows("e", calibrate, healthy, independent, LAYERS, 0.05, 0.0)
    narrow = cal.scores(w, resamples=200)["pd"]
    assert narrow.high - narrow.low < 0.5


def test_the_gate_fails_a_broken_pipeline():
    """A perfect fault detector scored against a null that leans (healthy windows larger than faulty ones) and
    an entry above the LUaF oracle: each condition of the gate is a condition that can fail."""
    rng = np.random.default_rng(5)
    calibrate, healthy = population(noise(rng, 100)), population(noise(rng, 100))
    strong = noise(rng, 40)
    strong[:, 100:, 0] += 100.0
    good, _ = cal.windows("e", calibrate, healthy, population(strong), LAYERS, 0.05, 0.0)
    leaning = population(0.5 * noise(rng, 40))
    bad, _ = cal.windows("e", calibrate, healthy, leaning, LAYERS, 0.05, 0.0)
    scores = {"oracle_fault": cal.scores(good, 100), "oracle_luaf": cal.scores(bad, 100),
              "null": cal.scores(bad, 100), "entry": cal.scores(good, 100)}
    gate = cal.gate(scores, {"oracle_fault": good, "null": bad})
    assert gate.oracle_fault_auc == 1.0 and gate.oracle_fault_pd == 1.0
    assert not gate.passed and gate.beating_oracle_luaf == ("entry",)
    assert [ok for _, ok in gate.conditions()] == [True, True, False, False]


def test_chance_interval_covers_a_useless_detector_95_percent_of_the_time():
    rng = np.random.default_rng(7)
    inside = [cal.consistent_with_chance(mann_whitney(rng.random(64), rng.random(12)), 64, 12) for _ in range(2000)]
    assert 0.93 <= np.mean(inside) <= 0.97
    assert not cal.consistent_with_chance(0.75, 64, 12)


def test_detectability_counts_windows_per_size():
    rng = np.random.default_rng(6)
    calibrate, healthy = population(noise(rng, 100)), population(noise(rng, 100))
    small, large = noise(rng, 10), noise(rng, 10)
    large[:, 100:, 0] += 100.0
    envelope = np.concatenate([small, large])
    faults = cal.Population({"e": envelope}, np.tile(np.arange(10), 2), np.full(20, "bias"),
                            np.repeat([0.3, 10.0], 10), np.ones(20, int), np.ones(20), np.ones((20, 3)), 0, BLOCK)
    w, _ = cal.windows("e", calibrate, healthy, faults, LAYERS, 0.05, 0.0)
    curve = cal.detectability(w)
    assert [point[0] for point in curve] == [0.3, 10.0] and curve[1][1] == 1.0 and curve[0][1] < 0.5
    assert all(point[4] == 10 for point in curve)


@pytest.mark.parametrize("n, rank, expected", [(32, 31, 2 / 33), (256, 244, 13 / 257)])
def test_a_threshold_from_n_peaks_gives_n_plus_1_minus_k_over_n_plus_1(n, rank, expected):
    """NumPy's ``higher`` quantile at 0.95 is the k-th smallest peak (k = 31 of 32, 244 of 256); fresh peaks
    exceed it at (n + 1 - k) / (n + 1) on average over 20,000 calibrations (standard error about 3e-4 at n = 32,
    1e-4 at 256), whatever the peaks' law; the ranks next to it give 1/(n + 1) more or less, 0.03 and 0.004 away.
    The conformal rank ceil((n + 1) 0.95), distribution-free and never above 0.05, lies further from 0.05 at
    both sizes, so the rule stays."""
    assert cal.threshold_rank(n, 0.05) == rank and cal.expected_false_alarm(n, 0.05) == pytest.approx(expected)
    rng = np.random.default_rng(n)
    draws, fresh = 20_000, 16
    peaks = rng.gamma(2.0, size=(draws, n))  # a skewed law, as a window's largest residual
    threshold = cal.quantile_threshold(peaks.T, 0.05)
    realised = np.mean(rng.gamma(2.0, size=(draws, fresh)) > threshold[:, None])
    tolerance = 0.3 / (n + 1)  # a rank one off moves the rate by 1 / (n + 1)
    assert abs(realised - expected) < tolerance
    conformal = int(np.ceil((n + 1) * 0.95))
    assert abs((n + 1 - conformal) / (n + 1) - 0.05) > abs(expected - 0.05)


def test_the_false_alarm_check_counts_off_rows_against_chance_and_holm_finds_a_broken_row():
    """Sixty rows whose healthy windows are exchangeable with their calibration (thresholds from 32 peaks, 64
    windows on two strata): the off rows are about as many as the calibrated law predicts, more than the binomial
    alone does, and Holm rejects none; a row whose threshold ignores its calibration (half its windows alarm) is
    found by Holm and makes the count's p-value small."""
    rng = np.random.default_rng(7)
    rows = {}
    for r in range(60):
        count = 0
        for _ in range(2):
            calibration, scored = rng.standard_normal(32), rng.standard_normal(32)
            count += int((scored > cal.quantile_threshold(calibration[:, None], 0.05)[0]).sum())
        rows[f"row{r}"] = (count, [32, 32], 32)
    check = cal.false_alarm_check(rows, 0.05)
    assert check.rows == 60 and check.expected_calibrated > 1.5 * check.expected_exact
    assert abs(check.off - check.expected_calibrated) < 3 * np.sqrt(check.expected_calibrated) + 1
    assert check.holm_rejected == () and check.p_value > 0.01
    broken = cal.false_alarm_check({**rows, "broken": (32, [32, 32], 32)}, 0.05)
    assert broken.holm_rejected == ("broken",)
    law = cal.false_alarm_law([32, 32], 32, 0.05)
    assert law.sum() == pytest.approx(1.0) and np.dot(np.arange(65), law) == pytest.approx(64 * 2 / 33)


def test_chance_interval_at_a_family_wise_level_covers_as_often_as_it_says():
    """Four robots' claim at a family-wise 5%: each robot's range covers a useless detector in 1 - 0.05/4 of
    samples (98.75%), wider than the 95% range."""
    rng = np.random.default_rng(5)
    level = 1.0 - 0.05 / 4
    inside = [cal.consistent_with_chance(mann_whitney(rng.random(64), rng.random(12)), 64, 12, level)
              for _ in range(4000)]
    assert 0.98 <= np.mean(inside) <= 0.995
    assert cal.chance_interval(64, 12, level)[1] > cal.chance_interval(64, 12)[1]
