"""Conformance of the detection statistics' accelerator (ftc_mj.fast.analysis_detection) to its NumPy definition
(ftc_mj.analysis.diagnosis.detection_statistics with the fast paths off): every statistic equal (tolerance 0:
peaks are a minimum and a maximum, the rest integer counts and sample times) on random and edge-case inputs:
NaN and inf residuals, negative and zero thresholds, unarmed starts, runs shorter than the persistence, one
joint, unsorted and repeated scales, healthy joints and a fault past the run's end."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from ftc_mj import fast
from ftc_mj.analysis.diagnosis import detection_statistics
from ftc_mj.results import Diagnosis

DT = 0.01


def _diagnosis(rng: np.random.Generator, steps: int, n: int, edges: bool) -> Diagnosis:
    t = np.arange(steps) * DT
    residual = np.abs(rng.normal(size=(steps, n))) * rng.uniform(0.5, 2.0, n)
    residual[steps // 2:] *= 3.0  # a fault
    threshold = np.full((steps, n), 1.0) + 0.2 * rng.normal(size=(steps, n))
    armed = t >= 0.05
    threshold[~armed] = np.nan
    if edges and steps > 12:
        residual[7, 0] = np.nan
        residual[steps - 3, n - 1] = np.inf
        threshold[9, 0] = -0.5
        threshold[10, n - 1] = 0.0
    alarm = residual > threshold
    zeros = np.zeros((steps, n))
    return Diagnosis(space="acceleration", t=t, signal=zeros, fault_estimate=zeros, residual=residual,
                     threshold=threshold, alarm=alarm, armed=armed, mean=np.zeros(n), std=np.zeros(n),
                     injected=zeros)


@pytest.mark.parametrize("persistence", [1, 3, 40])
def test_the_accelerator_gives_the_definitions_statistics(persistence):
    rng = np.random.default_rng(persistence)
    scales = [2.0, 0.5, 1.0, 1.0, 1.5]
    seen = {"false alarms": persistence > 3, "detections": False, "peaks": False}  # 40 in a row: no false alarm
    for (steps, n), edges in itertools.product([(120, 3), (120, 1), (5, 2), (1, 2)], (False, True)):
        diagnosis = _diagnosis(rng, steps, n, edges)
        onsets = np.full(n, np.nan)
        onsets[0] = steps * DT / 2
        if n > 2:
            onsets[2] = steps * DT * 2  # past the run's end
        assert fast.enabled()
        accelerated = detection_statistics(diagnosis, persistence, onsets, scales, n)
        fast.set_enabled(False)
        try:
            definition = detection_statistics(diagnosis, persistence, onsets, scales, n)
        finally:
            fast.set_enabled(True)
        assert accelerated.keys() == definition.keys()
        for name in definition:
            assert np.array_equal(accelerated[name], definition[name], equal_nan=True), (name, steps, n, edges)
        seen["false alarms"] |= bool(np.nansum(definition["false_alarms_x0p5"]) > 0)
        seen["detections"] |= bool(np.isfinite(definition["detection_delay_x0p5"]).any())
        seen["peaks"] |= bool(np.isfinite(definition["residual_peak_fault"]).any())
    assert all(seen.values()), seen  # the comparisons were of something
