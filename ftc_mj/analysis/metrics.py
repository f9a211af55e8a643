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
from typing import NamedTuple

import numba
import numpy as np
from pydantic import Field

from ftc_mj.analysis.diagnosis import DIAGNOSIS_METRICS, diagnosis_metrics
from ftc_mj.config.kernels import for_any_layout
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


def compute_metrics(
    result: VariantResult,
    spec: MetricsSpec,
    fault_onsets: Sequence[float],
    joint_onsets: np.ndarray | None = None,
    torque_limits: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """All metrics of one variant, each an array with one value per joint.

    ``fault_onsets`` are all onsets of the scenario (they shape the windows); ``joint_onsets`` the first
    onset per joint, NaN for healthy joints (:attr:`~ftc_mj.scenario.definition.Scenario.joint_fault_onsets`); without
    it every joint counts as faulty from the first onset. ``torque_limits``: per joint the |torque| at which
    the plant clips the command (inf: none; :attr:`~ftc_mj.scenario.definition.Scenario.torque_limits`).
    """
    n = result.q_true.shape[1]
    joint_onsets = onsets_per_joint(joint_onsets, fault_onsets, n)
    metrics = series_metrics(result.t, RecordedSeries.of(result), spec, fault_onsets, joint_onsets, torque_limits)
    return {**metrics, **diagnosis_metrics(result.diagnosis, joint_onsets, min(fault_onsets, default=np.inf), n)}


def onsets_per_joint(joint_onsets: np.ndarray | None, fault_onsets: Sequence[float], n: int) -> np.ndarray:
    """``joint_onsets``, or without it the first of ``fault_onsets`` for all ``n`` joints (NaN without faults)."""
    if joint_onsets is not None:
        return joint_onsets
    first_fault = min(fault_onsets, default=np.inf)
    return np.full(n, first_fault if np.isfinite(first_fault) else np.nan)


class RecordedSeries(NamedTuple):
    """The series the metrics read, as recorded: each ``(T, n)`` for one result, or ``(T, W, n)`` for ``W``
    results side by side (``q_ref`` may be a broadcast view, one reference for all)."""

    q_true: np.ndarray
    q_ref: np.ndarray
    qd_true: np.ndarray
    qd_hat: np.ndarray
    luaf_true: np.ndarray
    luaf_hat: np.ndarray
    tau: np.ndarray
    sliding: np.ndarray

    @classmethod
    def of(cls, result: VariantResult) -> "RecordedSeries":
        """One result's series."""
        return cls(*(getattr(result, name) for name in cls._fields))


def series_metrics(
    t: np.ndarray, series: RecordedSeries, spec: MetricsSpec, fault_onsets: Sequence[float],
    joint_onsets: np.ndarray, torque_limits: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """The metrics of :func:`compute_metrics` but the diagnosis', from the recorded series themselves: each
    ``(n,)`` for ``(T, n)`` series, ``(W, n)`` for ``W`` results side by side (``(T, W, n)``; ``joint_onsets``
    and ``torque_limits`` ``(n,)``, the same for all).

    One compiled pass over the samples computes every metric of every column, then a second one the windows
    that start at each column's own convergence (:func:`_series_pass`). Each column's sums run over its samples
    in time order, so a column's value has the same bits whatever results stand beside it: those of NumPy's sums
    over the time axis of a ``(T, n)`` array with n >= 2 (of a single column NumPy's sum would be pairwise)."""
    single = series.q_true.ndim == 2
    # Read-only float views: one compiled version for a result's views, a broadcast reference and arrays.
    columns = RecordedSeries(*(_read_only(values[:, None, :] if single else values) for values in series))
    t = _read_only(t)
    steps, width, n = columns.q_true.shape
    first_fault = min(fault_onsets, default=np.inf)
    # The windows that are the same for every column, one flag per sample.
    estimation = evaluation_mask(t, spec.estimation_window_start, fault_onsets, spec.fault_settle)
    flags = np.stack([
        estimation,
        evaluation_mask(t, 0.0, fault_onsets, spec.fault_settle),  # the converged window, before its start
        t < spec.estimation_window_start,  # the estimates' transient
        t < first_fault,  # where convergence and reaching are sought
        estimation & (t >= first_fault),  # the estimates after the fault
    ])
    # Per joint, its fault window: from its first onset to the next onset of any fault.
    until = np.array([min((o for o in fault_onsets if o > onset), default=np.inf) for onset in joint_onsets])
    limits = np.full(n, np.inf) if torque_limits is None else np.asarray(torque_limits, dtype=float)
    out = np.empty((len(_PASS_OUTPUTS), width, n))
    tolerances = np.array([spec.tracking_tolerance, spec.velocity_tolerance, spec.luaf_tolerance,
                           spec.sliding_tolerance])
    state = np.repeat(_STATE_START[:, None, None], width, axis=1).repeat(n, axis=2)
    searching = np.ones((6, width, n), dtype=bool)  # each settling time searching; no previous sample inside
    searching[5] = False
    arguments = (t, *columns, flags, float(spec.window_start), float(spec.fault_settle), float(spec.fault_window),
                 tolerances, np.asarray(joint_onsets, dtype=float), until, limits, out, state, searching,
                 np.zeros((4, width, n), dtype=np.int64))
    for_any_layout(_series_pass, *arguments)(*arguments)
    return {name: values[0] if single else values for name, values in zip(_PASS_OUTPUTS, out)}


def _read_only(values: np.ndarray) -> np.ndarray:
    """``values`` as a read-only float view (a float copy if they are of another dtype)."""
    view = np.asarray(values, dtype=float).view()
    view.flags.writeable = False
    return view


#: Where each row of :func:`_series_pass`'s float state starts, in its order: sums at 0, peaks at -inf (the
#: maximum of no sample yet), times at NaN (none yet). The caller makes the state: a kernel that allocates
#: its own (some thirty arrays) takes a third longer to compile.
_STATE_START = np.array([0.0, -np.inf, np.nan, np.nan, 0.0, np.nan, 0.0, 0.0, np.nan, -np.inf, 0.0, -np.inf,
                         np.nan, np.nan, 0.0, -np.inf, np.nan, 0.0, 0.0, -np.inf, 0.0])

#: The metrics of :func:`_series_pass`'s output, in its order.
_PASS_OUTPUTS: tuple[str, ...] = METRICS[:METRICS.index(DIAGNOSIS_METRICS[0])]


@numba.njit(cache=True, nogil=True)
def _nan_peak(peak: float, value: float) -> float:  # pragma: no cover - compiled
    """NumPy's ``maximum``: the larger of the two, NaN if either is."""
    if peak != peak:
        return peak
    if value != value or value > peak:
        return value
    return peak


@numba.njit(cache=True, nogil=True)
def _settle_step(result: float, searching: bool, outside: bool, time: float) -> tuple[float, bool]:  # pragma: no cover
    """One sample of a settling time: the first time of the last run of samples within the tolerance so far
    (NaN while outside), and whether the next sample within starts a new run."""
    if outside:
        return np.nan, True
    if searching:
        return time, False
    return result, False


@numba.njit(cache=True, nogil=True)
def _root_mean(squares: float, count: int) -> float:  # pragma: no cover - compiled
    """sqrt(squares / count); NaN without samples."""
    return np.sqrt(squares / count) if count > 0 else np.nan


@numba.njit(cache=True, nogil=True)
def _series_pass(t, q_true, q_ref, qd_true, qd_hat, luaf_true, luaf_hat, tau, sliding, flags, window_start,
                 settle, fault_window, tolerances, onsets, until, limits, out, state, searching,
                 counts):  # pragma: no cover - compiled
    """Every metric of :data:`_PASS_OUTPUTS` into ``out[metric, w, j]``, from ``(T, W, n)`` series (see
    :func:`series_metrics`) and the per-sample ``flags`` (estimation window, outside the settle intervals, the
    estimates' transient, before the first fault, estimation window after it).

    The definitions (module docstring) as state updated sample by sample, samples in time order: sums of
    squares from 0 (NumPy's time-ordered sums, whose first term is the first square), maxima that NaN
    poisons (NumPy's), settling times as the first sample after the last one outside the tolerance (NaN
    counts as outside), and after a first pass, a second one over each column's converged window. The state
    is the caller's (``state`` from :data:`_STATE_START`, ``searching``, ``counts`` at 0), one row each."""
    steps, width, n = q_true.shape
    tracking, velocity, luaf_tolerance, sliding_tolerance = tolerances[0], tolerances[1], tolerances[2], tolerances[3]
    error_squares = state[0]
    error_peak = state[1]
    convergence = state[2]
    entry = state[3]
    velocity_squares = state[4]
    observer = state[5]
    luaf_squares = state[6]
    luaf_fault_squares = state[7]
    luaf_settled = state[8]
    transient_peak = state[9]
    initial = state[10]
    beyond = state[11]
    reached = state[12]
    first_reached = state[13]
    torque_squares = state[14]
    fault_peak = state[15]
    recovery = state[16]
    begin = state[17]
    window_squares = state[18]
    window_peak = state[19]
    variation = state[20]
    converging = searching[0]
    observing = searching[1]
    luaf_settling = searching[2]
    reaching = searching[3]
    recovering = searching[4]
    was_inside = searching[5]
    saturated = counts[0]
    fault_samples = counts[1]
    window_count = counts[2]
    pairs = counts[3]
    estimation_count = fault_count = transient_count = 0
    for i in range(steps):
        time = t[i]
        estimated, transient, before, after = flags[0, i], flags[2, i], flags[3, i], flags[4, i]
        first_transient = transient and transient_count == 0
        if estimated:
            estimation_count += 1
        if after:
            fault_count += 1
        if transient:
            transient_count += 1
        for w in range(width):
            for j in range(n):
                error = q_true[i, w, j] - q_ref[i, w, j]
                size = abs(error)
                error_squares[w, j] += error * error
                error_peak[w, j] = _nan_peak(error_peak[w, j], size)
                velocity_error = qd_true[i, w, j] - qd_hat[i, w, j]
                luaf_error = luaf_true[i, w, j] - luaf_hat[i, w, j]
                if estimated:
                    velocity_squares[w, j] += velocity_error * velocity_error
                    luaf_squares[w, j] += luaf_error * luaf_error
                if after:
                    luaf_fault_squares[w, j] += luaf_error * luaf_error
                if transient:
                    if first_transient:
                        initial[w, j] = np.sign(luaf_error)
                    transient_peak[w, j] = _nan_peak(transient_peak[w, j], abs(luaf_error))
                    beyond[w, j] = _nan_peak(beyond[w, j], -initial[w, j] * luaf_error)
                s = sliding[i, w, j]
                if before:
                    convergence[w, j], converging[w, j] = _settle_step(
                        convergence[w, j], converging[w, j], not size <= tracking, time)
                    if entry[w, j] != entry[w, j] and size <= tracking:
                        entry[w, j] = time
                    observer[w, j], observing[w, j] = _settle_step(
                        observer[w, j], observing[w, j], not abs(velocity_error) <= velocity, time)
                    luaf_settled[w, j], luaf_settling[w, j] = _settle_step(
                        luaf_settled[w, j], luaf_settling[w, j], not abs(luaf_error) <= luaf_tolerance, time)
                    reached[w, j], reaching[w, j] = _settle_step(
                        reached[w, j], reaching[w, j], not abs(s) <= sliding_tolerance, time)
                    if first_reached[w, j] != first_reached[w, j] and abs(s) <= sliding_tolerance:
                        first_reached[w, j] = time
                onset = onsets[j]
                if time >= onset and time < until[j]:
                    recovery[w, j], recovering[w, j] = _settle_step(
                        recovery[w, j], recovering[w, j], not size <= tracking, time)
                    if time < onset + fault_window:
                        fault_peak[w, j] = _nan_peak(fault_peak[w, j], size)
                        fault_samples[w, j] += 1
                torque = tau[i, w, j]
                torque_squares[w, j] += torque * torque
                if abs(torque) > limits[j]:
                    saturated[w, j] += 1

    # The converged window: outside the settle intervals, from max(window_start, entry + settle) on.
    for w in range(width):
        for j in range(n):
            begin[w, j] = max(window_start, entry[w, j] + settle) if np.isfinite(entry[w, j]) else window_start
    for i in range(steps):
        time, free = t[i], flags[1, i]
        for w in range(width):
            for j in range(n):
                inside = free and time >= begin[w, j]
                if inside:
                    error = q_true[i, w, j] - q_ref[i, w, j]
                    window_squares[w, j] += error * error
                    window_peak[w, j] = _nan_peak(window_peak[w, j], abs(error))
                    window_count[w, j] += 1
                    if was_inside[w, j]:
                        pairs[w, j] += 1
                        variation[w, j] += abs(tau[i, w, j] - tau[i - 1, w, j])
                was_inside[w, j] = inside

    dt = t[1] - t[0] if steps > 1 else 0.0
    for w in range(width):
        for j in range(n):
            out[0, w, j] = _root_mean(error_squares[w, j], steps)
            out[1, w, j] = error_peak[w, j] if steps else np.nan
            out[2, w, j] = _root_mean(window_squares[w, j], window_count[w, j])
            out[3, w, j] = window_peak[w, j] if window_count[w, j] else np.nan
            out[4, w, j] = convergence[w, j]
            out[5, w, j] = _root_mean(velocity_squares[w, j], estimation_count)
            out[6, w, j] = _root_mean(luaf_squares[w, j], estimation_count)
            out[7, w, j] = observer[w, j]
            out[8, w, j] = luaf_settled[w, j]
            out[9, w, j] = transient_peak[w, j] if transient_count else np.nan
            if not transient_count:
                out[10, w, j] = np.nan
            elif initial[w, j] == 0:
                out[10, w, j] = transient_peak[w, j]
            else:
                out[10, w, j] = _nan_peak(beyond[w, j], 0.0)
            out[11, w, j] = _root_mean(luaf_fault_squares[w, j], fault_count)
            out[12, w, j] = first_reached[w, j]
            out[13, w, j] = reached[w, j]
            out[14, w, j] = fault_peak[w, j] if fault_samples[w, j] else np.nan
            out[15, w, j] = recovery[w, j] - onsets[j]
            out[16, w, j] = _root_mean(torque_squares[w, j], steps)
            seconds = pairs[w, j] * dt
            out[17, w, j] = variation[w, j] / seconds if seconds > 0 else np.nan
            out[18, w, j] = saturated[w, j] / steps if steps else np.nan


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
