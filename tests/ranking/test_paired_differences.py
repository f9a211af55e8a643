"""Paired comparisons of two entries scored on the same windows (ftc_mj.ranking.calibrated.paired_differences,
holm): an entry against itself differs by exactly 0 and is not apart; a perfect detector against a useless one,
through the calibrated windows, is apart by nearly 1/2 of AUC; two useless entries on the same clustered windows
are called apart no more often than the nominal 5% (each score, and both at once with Holm) over many
populations drawn from a known model; and a known true difference is found and covered."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ftc_mj.ranking import calibrated as cal
from ftc_mj.ranking.score import mann_whitney
from test_calibrated import BLOCK, LAYERS, noise, population
from test_clustered_coverage import _windows

RUNS, PER_RUN = 30, 3


def _pair(rng: np.random.Generator, faulty_gain: float = 0.0, effect: float = 1.0, own: float = 1.0
          ) -> tuple[cal.Windows, cal.Windows]:
    """Two entries' windows over the same RUNS runs of PER_RUN windows each, healthy and faulty: log z = the run's
    effect (sd ``effect``, shared by its windows) + the window's own (sd 1, shared by both entries: the same
    trajectory) + each entry's own noise (sd ``own``); the second entry's faulty windows ``faulty_gain`` higher
    (0: both useless)."""
    def clusters() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        cluster = np.repeat(np.arange(RUNS), PER_RUN)
        shared = np.repeat(rng.normal(0.0, effect, RUNS), PER_RUN) + rng.normal(0.0, 1.0, cluster.size)
        return cluster, shared, rng.normal(0.0, own, (2, cluster.size))

    h_cluster, h_shared, h_own = clusters()
    f_cluster, f_shared, f_own = clusters()
    first = _windows((np.exp(h_shared + h_own[0]), h_cluster), (np.exp(f_shared + f_own[0]), f_cluster))
    second = _windows((np.exp(h_shared + h_own[1]), h_cluster),
                      (np.exp(f_shared + f_own[1] + faulty_gain), f_cluster))
    return first, second


def test_an_entry_against_itself_differs_by_exactly_zero_and_is_not_apart():
    first, _ = _pair(np.random.default_rng(1))
    differences = cal.paired_differences(first, first, ("auc", "pd", "false_alarm"), resamples=200)
    for difference in differences.values():
        assert (difference.value, difference.low, difference.high, difference.p_value) == (0.0, 0.0, 0.0, 1.0)
        assert cal.paired_verdict(difference, cal.holm([difference.p_value])[0]) == "not apart"


def test_the_paired_draws_are_each_entrys_interval_draws():
    """The difference's resamples are those of each entry's own interval (the same clusters, the same seed): the
    difference of the two intervals' draws, not a second bootstrap."""
    first, second = _pair(np.random.default_rng(2), faulty_gain=1.0)

    def pd(sample: cal.Windows) -> dict[str, float]:
        return {"pd": float(np.mean(sample.fault_z > 1.0))}

    draws = [(pd(cal._take(first, h, f))["pd"], pd(cal._take(second, h, f))["pd"])
             for h, f in cal._cluster_draws(first, 300)]
    assert cal.clustered(first, pd, 300)["pd"] == cal._percentiles([a for a, _ in draws])
    difference = cal.paired_differences(first, second, ("pd",), resamples=300)["pd"]
    assert (difference.low, difference.high) == cal._percentiles([a - b for a, b in draws])


def test_windows_of_other_runs_are_not_paired():
    first, second = _pair(np.random.default_rng(3))
    other = cal._take(second, np.arange(second.healthy_z.size)[::-1], np.arange(second.fault_z.size))
    assert cal.same_windows(first, second) and not cal.same_windows(first, other)
    with pytest.raises(ValueError, match="not paired"):
        cal.paired_differences(first, other)


def test_a_perfect_detector_against_a_useless_one_is_apart_by_nearly_one_half():
    """Through the calibrated windows (thresholds from calibration runs): a residual that jumps at the fault
    against noise alone, on the same runs."""
    rng = np.random.default_rng(4)
    calibrate, healthy, faulty = noise(rng, 64), noise(rng, 64), noise(rng, 40)
    perfect = faulty.copy()
    perfect[:, int(LAYERS[0].onset / BLOCK):, 0] += 20.0

    def windows(faults: np.ndarray) -> cal.Windows:
        return cal.windows("e", population(calibrate), population(healthy), population(faults), LAYERS, 0.05,
                           0.0)[0]

    differences = cal.paired_differences(windows(perfect), windows(faulty), resamples=400)
    assert differences["auc"].value > 0.4 and differences["auc"].low > 0.3
    assert differences["pd"].value > 0.85 and differences["pd"].low > 0.75
    adjusted = cal.holm([differences["auc"].p_value, differences["pd"].p_value])
    assert adjusted.max() == pytest.approx(2 * 2 / 401)  # no resample crosses 0: the p-value's floor, twice
    assert [cal.paired_verdict(differences[s], p) for s, p in zip(("auc", "pd"), adjusted)] == ["better"] * 2
    swapped = cal.paired_differences(windows(faulty), windows(perfect), ("auc",), resamples=400)["auc"]
    assert swapped.value == -differences["auc"].value and cal.paired_verdict(swapped, 0.01) == "worse"


def test_holm_adjusts_step_down():
    """Holm (1979): the i-th smallest of m p-values times m + 1 - i, non-decreasing, capped at 1, in the order
    given; Bonferroni's m p at the smallest, less beyond it."""
    adjusted = cal.holm([0.04, 0.001, 0.03, 0.5])
    assert adjusted.tolist() == pytest.approx([0.09, 0.004, 0.09, 0.5])
    assert cal.holm([0.2, 0.6]).tolist() == pytest.approx([0.4, 0.6])
    assert cal.holm([0.4, 0.4, 0.4]).tolist() == pytest.approx([1.0, 1.0, 1.0])


def test_the_resamples_resolve_the_familys_strictest_level():
    for tests in (1, 8, 32, 200):
        resamples = cal.paired_resamples(tests)
        assert resamples >= cal.RESAMPLES and 2 / (resamples + 1) <= 0.05 / tests / 5 * 1.0001


def test_a_known_difference_is_found_and_its_interval_covers_it():
    """The second entry's faulty windows a known gain higher: the true differences are the model's (from a
    million windows), and 20 populations of the benchmark's size find them (power) with intervals around them."""
    gain = 0.8
    big = np.random.default_rng(5)
    healthy, faulty = big.normal(0, math.sqrt(2), 10**6), big.normal(0, math.sqrt(2), 10**6)
    own = big.normal(0, 1.0, 10**6)
    # log z = run + window + own: N(0, 1 + 1 + 1) for one entry; the two entries share run and window.
    true_auc = mann_whitney(healthy + own, faulty + big.normal(0, 1, 10**6) + gain) - 0.5
    true_pd = float(np.mean(faulty + own + gain > 0) - np.mean(faulty + own > 0))
    rng = np.random.default_rng(6)
    found = {"auc": 0, "pd": 0}
    covered = {"auc": 0, "pd": 0}
    populations = 20
    for _ in range(populations):
        first, second = _pair(rng, faulty_gain=gain)
        differences = cal.paired_differences(second, first, resamples=200)
        adjusted = cal.holm([differences["auc"].p_value, differences["pd"].p_value])
        for (name, truth), p in zip((("auc", true_auc), ("pd", true_pd)), adjusted):
            found[name] += cal.paired_verdict(differences[name], p) == "better"
            covered[name] += differences[name].low <= truth <= differences[name].high
    assert found["auc"] >= 0.8 * populations and found["pd"] >= 0.8 * populations, found
    assert covered["auc"] >= 0.8 * populations and covered["pd"] >= 0.8 * populations, covered


@pytest.mark.slow  # 300 populations x 300 paired resamples: about 20 s
def test_two_useless_entries_are_apart_no_more_often_than_the_nominal_level():
    """Two useless entries on the same clustered windows (their windows correlated through the run and the
    trajectory): each score's difference called apart at 5%, and either of the two at 5% family-wise (Holm), in
    at most 5% of populations, widened by three binomial standard deviations of the share."""
    rng, populations = np.random.default_rng(7), 300
    apart = {"auc": 0, "pd": 0, "family": 0}
    for _ in range(populations):
        first, second = _pair(rng)
        differences = cal.paired_differences(first, second, resamples=300)
        for name in ("auc", "pd"):
            apart[name] += differences[name].p_value <= 0.05
        apart["family"] += bool((cal.holm([differences[n].p_value for n in ("auc", "pd")]) <= 0.05).any())
    ceiling = 0.05 + 3 * math.sqrt(0.05 * 0.95 / populations)
    print({name: count / populations for name, count in apart.items()})
    for name, count in apart.items():
        assert count / populations <= ceiling, (name, count / populations)
