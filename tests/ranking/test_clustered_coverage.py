"""The benchmark's clustered intervals (ftc_mj.ranking.calibrated.clustered) tested on what they promise: windows
that share a run (healthy) or a draw (faulty) are correlated, and the 95% interval of a rate over them covers the
true rate in 93-97% of populations drawn from a known model, widened by three binomial standard deviations of
the share over ``draws`` populations. The same windows resampled one by one, as if independent, cover far less:
the clustering is what the interval's width comes from."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from ftc_mj.ranking.calibrated import Windows, _point, clustered

LEVEL = 0.95


def _band(draws: int) -> tuple[float, float]:
    tolerance = 3 * math.sqrt(LEVEL * (1 - LEVEL) / draws)
    return 0.93 - tolerance, 0.97 + tolerance


def _population(rng: np.random.Generator, runs: int, per_run: int, effect: float, shift: float
                ) -> tuple[np.ndarray, np.ndarray]:
    """``runs`` clusters of ``per_run`` windows: z = exp(shared run effect + own noise + shift), so a window's
    z > 1 with probability Phi((shift) / sqrt(effect^2 + 1)) and windows of one run are correlated."""
    shared = np.repeat(rng.normal(0.0, effect, runs), per_run)
    return np.exp(shared + rng.normal(0.0, 1.0, runs * per_run) + shift), np.repeat(np.arange(runs), per_run)


def _windows(healthy: tuple[np.ndarray, np.ndarray], faulty: tuple[np.ndarray, np.ndarray]) -> Windows:
    hz, hc = healthy
    fz, fc = faulty
    zeros_h, zeros_f = np.zeros(hz.size), np.zeros(fz.size)
    return Windows(healthy_z=hz, healthy_cluster=hc, healthy_stratum=zeros_h.astype(int),
                   healthy_alarms=(hz > 1).astype(float), healthy_latched=zeros_h.astype(bool), fault_z=fz,
                   fault_cluster=fc, fault_stratum=zeros_f.astype(int), fault_kind=np.full(fz.size, "bias"),
                   fault_size=np.ones(fz.size), isolated=np.ones(fz.size, bool), delay=np.full(fz.size, 0.1),
                   on_at_onset=zeros_f.astype(bool), acts=np.ones(fz.size, bool), window_seconds=np.ones(hz.size))


def _rates(sample: Windows) -> dict[str, float]:
    """The realised false-alarm rate and P_d as the leaderboard defines them (``_point``), without its other
    scores (the AUC's ranks would make the simulation slow)."""
    return {"false_alarm": float(np.mean(sample.healthy_z > 1.0)), "pd": float(np.mean(sample.fault_z > 1.0))}


def test_the_rates_are_the_leaderboards():
    rng = np.random.default_rng(3)
    w = _windows(_population(rng, 10, 4, EFFECT, HEALTHY_SHIFT), _population(rng, 10, 4, EFFECT, FAULTY_SHIFT))
    point = _point(w, w.window_seconds / 3600.0)
    assert _rates(w) == {"false_alarm": point["false_alarm"], "pd": point["pd"]}


EFFECT = 1.5  # the run's share of the spread: windows of one run far from independent
HEALTHY_SHIFT, FAULTY_SHIFT = -2.0, 1.0
TRUE_FA = float(stats.norm.cdf(HEALTHY_SHIFT / math.hypot(EFFECT, 1.0)))
TRUE_PD = float(stats.norm.cdf(FAULTY_SHIFT / math.hypot(EFFECT, 1.0)))


@pytest.mark.slow  # 200 populations x 2 bootstraps of 250 resamples: about 20 s
def test_the_clustered_interval_covers_the_rates_and_the_unclustered_one_does_not():
    rng, draws = np.random.default_rng(21), 200
    covered = {"false_alarm": 0, "pd": 0}
    naive_covered = 0
    for _ in range(draws):
        healthy = _population(rng, 40, 8, EFFECT, HEALTHY_SHIFT)
        faulty = _population(rng, 40, 8, EFFECT, FAULTY_SHIFT)
        w = _windows(healthy, faulty)
        intervals = clustered(w, _rates, resamples=250)
        for name, truth in (("false_alarm", TRUE_FA), ("pd", TRUE_PD)):
            low, high = intervals[name]
            covered[name] += low <= truth <= high
        # Every window its own cluster: the bootstrap that treats correlated windows as independent.
        alone = _windows((healthy[0], np.arange(healthy[0].size)), (faulty[0], np.arange(faulty[0].size)))
        low, high = clustered(alone, _rates, resamples=250)["false_alarm"]
        naive_covered += low <= TRUE_FA <= high
    low, high = _band(draws)
    print({name: count / draws for name, count in covered.items()}, "unclustered:", naive_covered / draws)
    for name, count in covered.items():
        assert low <= count / draws <= high, (name, count / draws)
    assert naive_covered / draws < 0.85, naive_covered / draws


def test_each_cluster_can_be_drawn():
    """An interval over clusters of which one holds every window over the threshold reaches it: a resampling
    that never drew the last cluster would give the interval (0, 0)."""
    z = np.concatenate([np.full(9 * 5, 0.5), np.full(5, 2.0)])
    clusters = np.repeat(np.arange(10), 5)
    w = _windows((z, clusters), (z, clusters))
    low, high = clustered(w, _rates, resamples=400)["false_alarm"]
    assert low == 0.0 and high > 0.0
