"""Metrics of a variant, per joint, in SI units. Definitions (also on the docs' metrics page):

* ``rms_error``, ``max_error``: RMS and maximum of |e|, e = q - q_d (true position), over the whole run.
* ``rms_error_converged``, ``max_error_converged``: the same over the evaluation window, per variant and
  joint from its own convergence: from max(``metrics.window_start``, t_in + ``fault_settle``) to the end,
  t_in the first time |e| <= ``tracking_tolerance`` (``window_start`` alone if it never is), without the
  ``fault_settle`` seconds after each fault onset. Entering the tracking tolerance ends the reaching phase, not
  the terminal one, so the same settle interval follows it as follows a fault onset; a steady-state comparison
  thus never includes a variant's own convergence. The first entry, not ``convergence_time`` (the last one
  before the first fault), so that a later excursion that is no fault (a sensor effect) stays in the window.
* ``convergence_time``: the first time after which |e| stays within ``tracking_tolerance`` until the first
  fault onset (or the end); NaN if it is never within.
* ``rms_velocity_error``, ``rms_luaf_error``: RMS of the estimate against ground truth over the estimation
  window (from ``estimation_window_start``, without the settle intervals after fault onsets).
* ``observer_convergence_time``: as ``convergence_time`` for the velocity estimation error with
  ``velocity_tolerance``.
* ``luaf_convergence_time``: as ``convergence_time`` for the LUaF estimation error with ``luaf_tolerance``.
* ``peak_luaf_error_transient``: the largest |LUaF estimation error| before ``estimation_window_start``: the
  initial error, or more if the estimate overshoots while it converges (Fig. 2.3's ESO).
* ``luaf_overshoot``: how far the LUaF estimate goes past the true LUaF before ``estimation_window_start``:
  the largest estimation error of the sign opposite to the initial error (0 if it never crosses; the
  largest |error| if the initial error is exactly 0). The same definition for every observer: an estimate
  that only converges from its initial error (the DO's peak is its error at t = 0) has an overshoot near 0
  (its steady-state error), one that shoots past the truth (the ESO) has a large one.
* ``rms_luaf_error_fault``: ``rms_luaf_error`` restricted to the samples after the first fault onset (outside
  the settle intervals); NaN without faults. With ``rms_luaf_error`` it separates accuracy before and after.
* ``first_reaching_time``: the first time |s| <= ``sliding_tolerance`` (before the first fault onset; NaN if
  never): when the sliding surface is first reached.
* ``reaching_time``: as ``convergence_time`` for the controller's sliding variable with ``sliding_tolerance``:
  when the sliding motion is reached for good (until the first fault onset; Fig. 3.12, 4.11). A law that
  reaches the surface and is kicked off it again has ``first_reaching_time`` < ``reaching_time``.
* ``fault_peak_error``: per faulty joint, the largest |e| in the fault window after the joint's first fault
  onset: ``[onset, onset + metrics.fault_window)``, cut at the next fault onset of the scenario; NaN on a
  healthy joint.
* ``recovery_time``: per faulty joint, how long after its first fault onset |e| comes back within
  ``tracking_tolerance`` for good (up to the next fault onset, or the end); NaN on a healthy joint or if it
  never does.
* ``rms_torque``: RMS of the commanded torque over the whole run [N m].
* ``chattering``: total variation of the commanded torque per second over the (per-joint) evaluation window,
  sum |tau[k+1] - tau[k]| / window length [N m / s]. A smooth torque that follows the reference scores low;
  switching at the sampling rate scores high.
* ``saturation_time``: the share of the run's samples (0-1) at which the command was beyond the joint's
  torque limit, |tau| > limit, so that the plant (MuJoCo's ``ctrlrange`` / ``forcerange``) delivered the limit
  instead; 0 on a joint without a limit, or when no limits are given (a replayed log).

Diagnosis metrics (``detection_delay``, ``missed_detection``, ``false_alarms``, ``false_alarm_rate``,
``isolation_correct``, ``fault_estimate_rms``): defined and computed in :mod:`ftc_mj.analysis.diagnosis`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydantic import Field

from ftc_mj.analysis.diagnosis import DIAGNOSIS_METRICS, diagnosis_metrics
from ftc_mj.results import VariantResult
from ftc_mj.config.types import NonNegativeFloat, PositiveFloat, Strict


class MetricsSpec(Strict):
    """The scenario's ``metrics`` section: evaluation windows and tolerances."""

    window_start: NonNegativeFloat = Field(0.0, description="Tracking metrics \"after convergence\" are taken "
                                           "from this time on [s]; default 0: the whole run (no zoom panel).")
    estimation_window_start: NonNegativeFloat = Field(0.0, description="Estimation metrics (velocity, LUaF) are "
                                                      "taken from this time on [s]; default 0: the whole run.")
    fault_settle: NonNegativeFloat = Field(1.0, description="Interval excluded after each fault onset [s].")
    fault_window: PositiveFloat = Field(2.0,
        description="fault_peak_error looks at [onset, onset + fault_window) after a joint's fault onset [s].")
    tracking_tolerance: PositiveFloat = Field(0.01, description="|e| tolerance of convergence_time [rad].")
    velocity_tolerance: PositiveFloat = Field(0.05,
        description="|velocity error| tolerance of observer_convergence_time [rad/s].")
    luaf_tolerance: PositiveFloat = Field(0.5,
        description="|LUaF estimation error| tolerance of luaf_convergence_time [rad/s^2].")
    sliding_tolerance: PositiveFloat = Field(0.01,
        description="|sliding variable| tolerance of reaching_time (units of the surface, rad/s for every built-in law).")


METRICS: tuple[str, ...] = (
    "rms_error",
    "max_error",
    "rms_error_converged",
    "max_error_converged",
    "convergence_time",
    "rms_velocity_error",
    "rms_luaf_error",
    "observer_convergence_time",
    "luaf_convergence_time",
    "peak_luaf_error_transient",
    "luaf_overshoot",
    "rms_luaf_error_fault",
    "first_reaching_time",
    "reaching_time",
    "fault_peak_error",
    "recovery_time",
    "rms_torque",
    "chattering",
    "saturation_time",
    *DIAGNOSIS_METRICS,
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
    "luaf_convergence_time": "s",
    "peak_luaf_error_transient": "rad/s^2",
    "luaf_overshoot": "rad/s^2",
    "rms_luaf_error_fault": "rad/s^2",
    "first_reaching_time": "s",
    "reaching_time": "s",
    "fault_peak_error": "rad",
    "recovery_time": "s",
    "rms_torque": "N m",
    "chattering": "N m/s",
    "saturation_time": "share",
    "detection_delay": "s",
    "missed_detection": "0/1",
    "false_alarms": "count",
    "false_alarm_rate": "1/s",
    "isolation_correct": "0/1",
    "fault_estimate_rms": "rad/s^2 or N m",
}

def unit(metric: str, diagnosis_space: str | None = None) -> str:
    """The unit of ``metric``; the fault-estimate error takes the diagnosis space's."""
    if metric == "fault_estimate_rms" and diagnosis_space is not None:
        return "N m" if diagnosis_space == "torque" else "rad/s^2"
    return UNITS[metric]


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


def first_entry_time(t: np.ndarray, error: np.ndarray, tolerance: float, until: float) -> np.ndarray:
    """Per joint: the first time before ``until`` with |error| <= tolerance; NaN if never."""
    window = t < until
    inside = np.abs(error[window]) <= tolerance  # NaN counts as outside
    times = t[window]
    first = np.argmax(inside, axis=0) if times.size else np.zeros(error.shape[1], dtype=int)
    found = inside.any(axis=0) if times.size else np.zeros(error.shape[1], dtype=bool)
    return np.where(found, times[first] if times.size else np.nan, np.nan)


def overshoot(error: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Per joint: the largest error of the sign opposite to the first masked sample's (the initial error),
    over the masked samples; 0 if it never crosses; the largest |error| if the initial error is 0."""
    if not mask.any():
        return np.full(error.shape[1], np.nan)
    window = error[mask]
    initial = np.sign(window[0])
    beyond = np.max(-initial * window, axis=0)
    return np.where(initial == 0, np.max(np.abs(window), axis=0), np.maximum(beyond, 0.0))


def _rms(x: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Per joint RMS over the samples of ``mask``: ``(T,)`` for all joints alike or ``(T, n)`` per joint.

    The squares are summed sample by sample in time order (NumPy's sum over the first axis), so leaving the
    samples outside a ``(T,)`` mask out gives the same bits as adding them as zeros, at less cost."""
    if mask.ndim == 1:
        selected = x if mask.all() else x[mask]
        count = np.full(x.shape[1], len(selected))
        total = np.square(selected).sum(axis=0)
    else:
        count = mask.sum(axis=0)
        total = np.square(np.where(mask, x, 0.0)).sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, np.sqrt(total / np.maximum(count, 1)), np.nan)


def _max_abs(x: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Per joint max |x| over the samples of ``mask`` (``(T,)`` or ``(T, n)``); NaN where none."""
    if mask.ndim == 1:
        if not mask.any():
            return np.full(x.shape[1], np.nan)
        return np.abs(x if mask.all() else x[mask]).max(axis=0)
    if x.shape[0] == 0:
        return np.full(x.shape[1], np.nan)
    peak = np.max(np.where(mask, np.abs(x), -np.inf), axis=0)
    return np.where(mask.any(axis=0), peak, np.nan)


def saturation_share(tau: np.ndarray, limits: np.ndarray | None) -> np.ndarray:
    """Per joint, the share of the samples of ``tau`` ``(T, n)`` beyond ``limits`` ``(n,)`` in magnitude (the
    samples the plant clipped); zeros without limits, NaN without samples."""
    n = tau.shape[1]
    if tau.shape[0] == 0:
        return np.full(n, np.nan)
    if limits is None:
        return np.zeros(n)
    return (np.abs(tau) > limits).mean(axis=0)


def converged_mask(t: np.ndarray, start: float, fault_onsets: Sequence[float], settle: float,
                   convergence: np.ndarray) -> np.ndarray:
    """``(T, n)``: the evaluation mask of :func:`evaluation_mask` starting per joint at max(``start``, that
    joint's ``convergence`` (its first entry into the tolerance) + ``settle``); NaN starts at ``start``."""
    begin = np.where(np.isfinite(convergence), np.maximum(start, convergence + settle), start)
    return evaluation_mask(t, 0.0, fault_onsets, settle)[:, None] & (t[:, None] >= begin[None, :])


def fault_response(
    t: np.ndarray, error: np.ndarray, joint_onsets: np.ndarray, fault_onsets: Sequence[float], tolerance: float,
    window: float = np.inf,
) -> tuple[np.ndarray, np.ndarray]:
    """Per joint: (peak |error| in ``[onset, onset + window)``, recovery time up to the next onset of any
    fault or the end) after the joint's first fault onset; both are cut at the next onset. NaN for joints
    without a fault."""
    n = error.shape[1]
    peak, recovery = np.full(n, np.nan), np.full(n, np.nan)
    for joint in range(n):
        onset = joint_onsets[joint]
        if not np.isfinite(onset):
            continue
        until = min((o for o in fault_onsets if o > onset), default=np.inf)
        inside = (t >= onset) & (t < until)
        if not inside.any():
            continue
        column = error[inside, joint : joint + 1]
        peak[joint] = np.max(np.abs(error[inside & (t < onset + window), joint]))
        recovery[joint] = settling_time(t[inside], column, tolerance, until)[0] - onset
    return peak, recovery


def compute_metrics(
    result: VariantResult,
    spec: MetricsSpec,
    fault_onsets: Sequence[float],
    joint_onsets: np.ndarray | None = None,
    torque_limits: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """All metrics of one variant, each an array with one value per joint.

    ``fault_onsets`` are all onsets of the scenario (they shape the windows); ``joint_onsets`` the first
    onset per joint, NaN for healthy joints (:attr:`~ftc_mj.spec.scenario.Scenario.joint_fault_onsets`); without
    it every joint counts as faulty from the first onset. ``torque_limits``: per joint the |torque| at which
    the plant clips the command (inf: none; :attr:`~ftc_mj.spec.scenario.Scenario.torque_limits`).
    """
    # Each error series once (the result's properties compute them anew at every access).
    error = result.tracking_error
    n = error.shape[1]
    joint_onsets = onsets_per_joint(joint_onsets, fault_onsets, n)
    metrics = series_metrics(result.t, error, result.velocity_error, result.luaf_error, result.tau,
                             result.sliding, spec, fault_onsets, joint_onsets, torque_limits)
    return {**metrics, **diagnosis_metrics(result.diagnosis, joint_onsets, min(fault_onsets, default=np.inf), n)}


def onsets_per_joint(joint_onsets: np.ndarray | None, fault_onsets: Sequence[float], n: int) -> np.ndarray:
    """``joint_onsets``, or without it the first of ``fault_onsets`` for all ``n`` joints (NaN without faults)."""
    if joint_onsets is not None:
        return joint_onsets
    first_fault = min(fault_onsets, default=np.inf)
    return np.full(n, first_fault if np.isfinite(first_fault) else np.nan)


def series_metrics(
    t: np.ndarray, error: np.ndarray, velocity_error: np.ndarray, luaf_error: np.ndarray, tau: np.ndarray,
    sliding: np.ndarray, spec: MetricsSpec, fault_onsets: Sequence[float], joint_onsets: np.ndarray,
    torque_limits: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """The metrics of :func:`compute_metrics` but the diagnosis', from the series themselves, ``(T, columns)``.

    Every metric is per column and every reduction runs over the samples alone (sums in time order), so the
    columns may be one result's joints or the joints of many results side by side (``joint_onsets`` and
    ``torque_limits`` then repeated per result): each column's value has the same bits either way. With a
    single column the sums over time become NumPy's pairwise ones, so one column is one result's (n = 1) only.
    """
    everything = np.ones(t.shape, dtype=bool)
    estimation = evaluation_mask(t, spec.estimation_window_start, fault_onsets, spec.fault_settle)
    first_fault = min(fault_onsets, default=np.inf)
    n = error.shape[1]
    convergence = settling_time(t, error, spec.tracking_tolerance, first_fault)
    # Per joint, from max(window_start, its first entry into the tolerance + fault_settle): steady states only.
    entry = first_entry_time(t, error, spec.tracking_tolerance, first_fault)
    window = converged_mask(t, spec.window_start, fault_onsets, spec.fault_settle, entry)
    fault_peak, recovery = fault_response(t, error, joint_onsets, fault_onsets, spec.tracking_tolerance,
                                          spec.fault_window)

    # Total variation inside the window: only differences between two consecutive samples that are both in it.
    pairs = window[1:] & window[:-1]
    window_seconds = pairs.sum(axis=0) * (t[1] - t[0]) if t.size > 1 else np.zeros(n)
    variation = np.where(pairs, np.abs(np.diff(tau, axis=0)), 0.0).sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        chattering = np.where(window_seconds > 0, variation / np.where(window_seconds > 0, window_seconds, 1.0),
                              np.nan)
    transient = t < spec.estimation_window_start

    return {
        "rms_error": _rms(error, everything),
        "max_error": _max_abs(error, everything),
        "rms_error_converged": _rms(error, window),
        "max_error_converged": _max_abs(error, window),
        "convergence_time": convergence,
        "rms_velocity_error": _rms(velocity_error, estimation),
        "rms_luaf_error": _rms(luaf_error, estimation),
        "observer_convergence_time": settling_time(t, velocity_error, spec.velocity_tolerance, first_fault),
        "luaf_convergence_time": settling_time(t, luaf_error, spec.luaf_tolerance, first_fault),
        "peak_luaf_error_transient": _max_abs(luaf_error, transient),
        "luaf_overshoot": overshoot(luaf_error, transient),
        "rms_luaf_error_fault": _rms(luaf_error, estimation & (t >= first_fault)),
        "first_reaching_time": first_entry_time(t, sliding, spec.sliding_tolerance, first_fault),
        "reaching_time": settling_time(t, sliding, spec.sliding_tolerance, first_fault),
        "fault_peak_error": fault_peak,
        "recovery_time": recovery,
        "rms_torque": _rms(tau, everything),
        "chattering": chattering,
        "saturation_time": saturation_share(tau, torque_limits),
    }



def windows_after_the_end(result: VariantResult, spec: MetricsSpec, fault_onsets: Sequence[float]) -> dict[str, str]:
    """The metrics of ``result`` left undefined (NaN) because their window starts after its last sample, each
    with that start (``{"rms_error_converged": "metrics.window_start = 5 s"}``): a run shortened below its
    windows says why they are empty instead of showing a number."""
    end = result.t[-1] if result.t.size else -np.inf
    first_fault = min(fault_onsets, default=np.inf)
    windows = [
        (spec.window_start, "metrics.window_start", ("rms_error_converged", "max_error_converged", "chattering")),
        (spec.estimation_window_start, "metrics.estimation_window_start",
         ("rms_velocity_error", "rms_luaf_error", "rms_luaf_error_fault")),
        (first_fault, "the first fault onset", ("rms_luaf_error_fault", "fault_peak_error", "recovery_time",
                                                "detection_delay", "missed_detection", "isolation_correct",
                                                "fault_estimate_rms")),
    ]
    undefined: dict[str, str] = {}
    for start, name, metrics in windows:
        if np.isfinite(start) and start > end:
            undefined.update({metric: f"{name} = {start:g} s" for metric in metrics if metric not in undefined})
    diagnosis = result.diagnosis
    if diagnosis is not None and diagnosis.t.size and not diagnosis.armed.any():
        undefined.update({metric: "the diagnoser's start" for metric in DIAGNOSIS_METRICS if metric not in undefined})
    return undefined
