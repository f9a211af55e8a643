"""Statistics over runs on examples: Wilson's formula, undefined values, paired verdicts, ROC (coverage by
simulation: test_statistics_coverage.py; every verdict branch: test_verdicts.py)."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.campaign import statistics as st


def test_wilson_interval_matches_the_formula():
    k, n, z = 7, 20, 1.959963984540054
    p = k / n
    centre = (p + z**2 / (2 * n)) / (1 + z**2 / n)
    half = z / (1 + z**2 / n) * np.sqrt(p * (1 - p) / n + z**2 / (4 * n**2))
    estimate = st.proportion(k, n)
    assert estimate.value == p
    assert estimate.low == pytest.approx(centre - half, rel=1e-9) and estimate.high == pytest.approx(centre + half, rel=1e-9)
    assert st.proportion(0, 10).low == 0.0 and st.proportion(0, 10).high > 0.2


def test_summaries_ignore_undefined_values():
    s = st.summarise(np.array([1.0, np.nan, 3.0, np.inf, 2.0]))
    assert s.count == 3 and s.mean.value == 2.0 and s.median.value == 2.0


def test_paired_verdicts():
    rng = np.random.default_rng(1)
    base = rng.lognormal(0, 1, 200)  # large spread between runs, small consistent difference
    assert st.paired(base * 0.9, base).verdict == "holds"
    assert st.paired(base * 1.1, base).verdict == "reversed"
    noisy = base + rng.normal(0, 1, 200)
    assert st.paired(noisy, base).verdict == "inconclusive"
    p = st.paired(np.array([1.0, 2.0, np.nan]), np.array([2.0, 2.0, 1.0]))
    assert p.count == 2 and p.win_rate.value == 0.75  # one win, one tie


def test_roc_and_auc():
    healthy = np.array([0.2, 0.4, 0.6, 0.8])
    fault = np.array([1.5, 3.0, 0.5, 10.0])
    p_fa, p_d = st.roc(healthy, fault, np.array([0.1, 0.5, 1.0, 5.0]))
    np.testing.assert_allclose(p_fa, [1.0, 0.5, 0.0, 0.0])
    np.testing.assert_allclose(p_d, [1.0, 0.75, 0.75, 0.25])
    assert st.auc(np.array([0.0]), np.array([1.0])) == 1.0  # a perfect detector
    assert st.auc(np.linspace(0, 1, 11), np.linspace(0, 1, 11)) == pytest.approx(0.5)


def test_dependence_finds_a_trend():
    x = np.linspace(0, 1, 90)
    difference = x - 0.5  # a wins for small x, loses for large x
    rho, p, low, high = st.dependence(difference, x)
    assert rho == pytest.approx(1.0) and p < 1e-6
    assert low.value == 1.0 and high.value == 0.0
