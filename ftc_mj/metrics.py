"""Metrics of a variant, per joint, in SI units. Definitions (also in README.md):

* ``rms_error``, ``max_error``: RMS and maximum of |e|, e = q - q_d (true position), over the whole run.
* ``rms_error_converged``, ``max_error_converged``: the same over the evaluation window: from
  ``metrics.window_start`` to the end, without the ``fault_settle`` seconds after each fault onset.
* ``convergence_time``: the first time after which |e| stays within ``tracking_tolerance`` until the first
  fault onset (or the end); NaN if it is never within.
* ``rms_velocity_error``, ``rms_luaf_error``: RMS of the estimate against ground truth over the estimation
  window (from ``estimation_window_start``, without the settle intervals after fault onsets).
* ``observer_convergence_time``: as ``convergence_time`` for the velocity estimation error with
  ``velocity_tolerance``.
* ``rms_torque``: RMS of the commanded torque over the whole run [N m].
* ``chattering``: total variation of the commanded torque per second over the evaluation window,
  sum |tau[k+1] - tau[k]| / window length [N m / s]. A smooth torque that follows the reference scores low;
  switching at the sampling rate scores high.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ftc_mj.results import VariantResult
from ftc_mj.scenario import MetricsSpec

METRICS: tuple[str, ...] = (
    "rms_error",
    "max_error",
    "rms_error_converged",
    "max_error_converged",
    "convergence_time",
    "rms_velocity_error",
    "rms_luaf_error",
    "observer_convergence_time",
    "rms_torque",
    "chattering",
)

#: Units for display.
UNITS: dict[str, str] = {
    "rms_error": "rad",
    "max_error": "rad",
    "rms_error_converged": "rad",
    "max_error_converged": "rad",
    "convergence_time": "s",
    "rms_velocity_error": "rad/s",
    "rms_luaf_error": "rad/s^2",
    "observer_convergence_time": "s",
    "rms_torque": "N m",
    "chattering": "N m/s",
}


def evaluation_mask(t: np.ndarray, start: float, fault_onsets: Sequence[float], settle: float) -> np.ndarray:
    """Samples from ``start`` on, minus ``[onset, onset + settle)`` for every fault onset."""
    mask = t >= start
    for onset in fault_onsets:
        mask &= ~((t >= onset) & (t < onset + settle))
    return mask


def settling_time(t: np.ndarray, error: np.ndarray, tolerance: float, until: float) -> np.ndarray:
    """Per joint: the first time from which |error| <= tolerance holds up to ``until``; NaN if never."""
    window = t < until
    outside = ~(np.abs(error[window]) <= tolerance)  # NaN counts as outside
    times = t[window]
    result = np.full(error.shape[1], np.nan)
    for joint in range(error.shape[1]):
        bad = np.flatnonzero(outside[:, joint])
        if bad.size == 0:
            result[joint] = times[0] if times.size else np.nan
        elif bad[-1] + 1 < times.size:
            result[joint] = times[bad[-1] + 1]
    return result


def _rms(x: np.ndarray, mask: np.ndarray) -> np.ndarray:
    if not mask.any():
        return np.full(x.shape[1], np.nan)
    return np.sqrt(np.mean(x[mask] ** 2, axis=0))


def _max_abs(x: np.ndarray, mask: np.ndarray) -> np.ndarray:
    if not mask.any():
        return np.full(x.shape[1], np.nan)
    return np.max(np.abs(x[mask]), axis=0)


def compute_metrics(result: VariantResult, spec: MetricsSpec, fault_onsets: Sequence[float]) -> dict[str, np.ndarray]:
    """All metrics of one variant, each an array with one value per joint."""
    t = result.t
    everything = np.ones(t.shape, dtype=bool)
    window = evaluation_mask(t, spec.window_start, fault_onsets, spec.fault_settle)
    estimation = evaluation_mask(t, spec.estimation_window_start, fault_onsets, spec.fault_settle)
    first_fault = min(fault_onsets, default=np.inf)
    error = result.tracking_error

    # Total variation inside the window: only differences between two consecutive samples that are both in it.
    pairs = window[1:] & window[:-1]
    window_seconds = pairs.sum() * (t[1] - t[0]) if t.size > 1 else 0.0
    variation = np.abs(np.diff(result.tau, axis=0))[pairs].sum(axis=0)
    chattering = variation / window_seconds if window_seconds > 0 else np.full(result.tau.shape[1], np.nan)

    return {
        "rms_error": _rms(error, everything),
        "max_error": _max_abs(error, everything),
        "rms_error_converged": _rms(error, window),
        "max_error_converged": _max_abs(error, window),
        "convergence_time": settling_time(t, error, spec.tracking_tolerance, first_fault),
        "rms_velocity_error": _rms(result.velocity_error, estimation),
        "rms_luaf_error": _rms(result.luaf_error, estimation),
        "observer_convergence_time": settling_time(t, result.velocity_error, spec.velocity_tolerance, first_fault),
        "rms_torque": _rms(result.tau, everything),
        "chattering": chattering,
    }
