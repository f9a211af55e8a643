"""Conformance of the series metrics' accelerator (ftc_mj.fast.analysis_metrics) to their NumPy definitions (the
registry of ftc_mj.analysis.metrics): every built-in metric to 1e-12 relative (NaN where the definition is NaN)
on random and edge-case inputs: NaN and inf samples, runs shorter than their windows, one joint, several
results side by side, faults with and without settle intervals, torque limits."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from ftc_mj import fast
from ftc_mj.analysis.metrics import MetricsSpec, RecordedSeries, series_metrics
from ftc_mj.fast.analysis_metrics import ACCELERATED

DT = 1e-2


def _series(rng: np.random.Generator, steps: int, width: int, n: int, edges: bool) -> RecordedSeries:
    decay = np.exp(-np.arange(steps) * DT)[:, None, None]
    shape = (steps, width, n)
    q_ref = np.sin(np.arange(steps) * DT)[:, None, None] * np.ones(shape)
    q_true = q_ref + 0.05 * decay * rng.normal(size=shape) + 0.002 * rng.normal(size=shape)
    qd_true = rng.normal(size=shape)
    qd_hat = qd_true + 0.1 * decay * rng.normal(size=shape)
    luaf_true = rng.normal(size=shape)
    luaf_hat = luaf_true + decay * rng.normal(size=shape) + 0.1 * rng.normal(size=shape)
    tau = 10 * rng.normal(size=shape)
    sliding = 0.05 * decay * rng.normal(size=shape)
    if edges and steps > 20:
        q_true[steps // 2, 0, 0] = np.nan
        luaf_hat[2, width - 1, n - 1] = np.nan
        tau[steps - 3, 0, n - 1] = np.inf
        sliding[5:8, width - 1, 0] = np.nan
        qd_hat[steps // 3, 0, 0] = -np.inf
    return RecordedSeries(q_true, q_ref, qd_true, qd_hat, luaf_true, luaf_hat, tau, sliding)


SPECS = [
    MetricsSpec(),
    MetricsSpec(window_start=0.3, estimation_window_start=0.2, fault_settle=0.1, fault_window=0.2,
                tracking_tolerance=0.02, velocity_tolerance=0.2, luaf_tolerance=0.5, sliding_tolerance=0.02),
    MetricsSpec(window_start=50.0, estimation_window_start=50.0),  # windows after the end
]


@pytest.mark.parametrize("spec_index", range(len(SPECS)))
def test_the_accelerator_gives_the_definitions_values(spec_index):
    spec = SPECS[spec_index]
    rng = np.random.default_rng(spec_index)
    shapes = [(120, 3, 2), (120, 1, 1), (9, 2, 1), (1, 1, 3), (2, 2, 2), (0, 1, 2)]
    faults = [([], None), ([0.5], "first"), ([0.5, 0.8], "split")]
    for (steps, width, n), (onsets, kind), edges in itertools.product(shapes, faults, (False, True)):
        series = _series(rng, steps, width, n, edges)
        t = np.arange(steps) * DT
        joint_onsets = np.full(n, np.nan)
        if kind == "first":
            joint_onsets[:] = 0.5
        elif kind == "split":
            joint_onsets[0] = 0.8
        limits = np.full(n, 12.0)
        assert fast.enabled()
        accelerated = series_metrics(t, series, spec, onsets, joint_onsets, limits)
        fast.set_enabled(False)
        try:
            definition = series_metrics(t, series, spec, onsets, joint_onsets, limits)
        finally:
            fast.set_enabled(True)
        for name in ACCELERATED:
            expected, actual = definition[name], accelerated[name]
            assert actual.shape == expected.shape == (width, n)
            np.testing.assert_allclose(actual, expected, rtol=1e-12, atol=0,
                                       err_msg=f"{name} {steps, width, n} {kind} edges={edges}")
