"""Metrics of a variant, per joint, in SI units: each a NumPy function registered by name, unit and window
(:mod:`ftc_mj.analysis.registry`; adding one is one function). Definitions (also on the docs' metrics page):

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
``isolation_correct``, ``fault_estimate_rms``): defined and registered in :mod:`ftc_mj.analysis.diagnosis`.

Where the fast paths are on, the built-in series metrics are computed by their accelerator
(:func:`ftc_mj.fast.analysis_metrics.series_pass`, checked against these definitions to 1e-12 relative); a metric
registered beyond them always by its definition.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cached_property
from typing import NamedTuple

import numpy as np
from pydantic import Field

from ftc_mj import fast
from ftc_mj.analysis.diagnosis import DIAGNOSIS_METRICS, diagnosis_metrics
from ftc_mj.analysis.registry import METRICS, UNITS, metric, of_kind
from ftc_mj.config.types import NonNegativeFloat, PositiveFloat, Strict
from ftc_mj.results import VariantResult

__all__ = ["METRICS", "UNITS", "MetricsSpec", "RecordedSeries", "Samples", "compute_metrics", "series_metrics",
           "unit", "evaluation_mask", "onsets_per_joint", "windows_after_the_end", "DIAGNOSIS_METRICS"]


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


def unit(metric_name: str, diagnosis_space: str | None = None) -> str:
    """The unit of ``metric_name``; the fault-estimate error takes the diagnosis space's."""
    if metric_name == "fault_estimate_rms" and diagnosis_space is not None:
        return "N m" if diagnosis_space == "torque" else "rad/s^2"
    return UNITS[metric_name]


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


class Samples:
    """What a series metric reads: the recorded series ``(T, W, n)`` (as attributes: ``q_true``, ``tau``, ...),
    the times ``t``, the ``metrics`` section ``spec``, the fault onsets, per joint its first onset
    (``joint_onsets``, NaN: healthy) and torque limit, and the windows and errors the built-in metrics share
    (each computed once, on first use)."""

    def __init__(self, t: np.ndarray, series: RecordedSeries, spec: MetricsSpec, fault_onsets: Sequence[float],
                 joint_onsets: np.ndarray, torque_limits: np.ndarray | None):
        self.t = np.asarray(t, dtype=float)
        for name, values in zip(RecordedSeries._fields, series):
            setattr(self, name, np.asarray(values, dtype=float))
        self.spec = spec
        self.fault_onsets = list(fault_onsets)
        self.first_fault = min(self.fault_onsets, default=np.inf)
        self.joint_onsets = np.asarray(joint_onsets, dtype=float)
        n = self.q_true.shape[2]
        self.torque_limits = np.full(n, np.inf) if torque_limits is None else np.asarray(torque_limits, dtype=float)

    @property
    def steps(self) -> int:
        return len(self.t)

    @cached_property
    def error(self) -> np.ndarray:
        """e = q - q_d on the true position."""
        return self.q_true - self.q_ref

    @cached_property
    def error_size(self) -> np.ndarray:
        return np.abs(self.error)

    @cached_property
    def velocity_error(self) -> np.ndarray:
        return self.qd_true - self.qd_hat

    @cached_property
    def luaf_error(self) -> np.ndarray:
        return self.luaf_true - self.luaf_hat

    @cached_property
    def estimation(self) -> np.ndarray:
        """The estimation window ``(T,)``: from ``estimation_window_start``, outside the settle intervals."""
        return evaluation_mask(self.t, self.spec.estimation_window_start, self.fault_onsets, self.spec.fault_settle)

    @cached_property
    def before_fault(self) -> np.ndarray:
        """``(T,)``: before the first fault onset, where convergence and reaching are sought."""
        return self.t < self.first_fault

    @cached_property
    def transient(self) -> np.ndarray:
        """``(T,)``: before ``estimation_window_start``, the estimates' transient."""
        return self.t < self.spec.estimation_window_start

    @cached_property
    def converged(self) -> np.ndarray:
        """``(T, W, n)``: each column's evaluation window (the module docstring)."""
        spec = self.spec
        entry = first_time(self.error_size <= spec.tracking_tolerance, self.t, self.before_fault)
        begin = np.where(np.isfinite(entry), np.maximum(spec.window_start, entry + spec.fault_settle),
                         spec.window_start)
        free = evaluation_mask(self.t, 0.0, self.fault_onsets, spec.fault_settle)
        return free[:, None, None] & (self.t[:, None, None] >= begin[None])

    @cached_property
    def fault_windows(self) -> np.ndarray:
        """``(T, 1, n)``: per joint, from its first onset to the next onset of any fault (none: healthy)."""
        onsets = self.joint_onsets
        until = np.array([min((o for o in self.fault_onsets if o > onset), default=np.inf) for onset in onsets])
        return ((self.t[:, None] >= onsets) & (self.t[:, None] < until))[:, None, :]


def root_mean_square(values: np.ndarray, where: np.ndarray | None = None) -> np.ndarray:
    """sqrt(mean(values^2)) along time (axis 0) over the samples ``where`` (``(T,)`` or like ``values``; None: all),
    the squares summed in time order; NaN without samples."""
    squares = values * values
    if where is None:
        count = np.full(values.shape[1:], len(values))
    else:
        where = np.broadcast_to(where.reshape(where.shape + (1,) * (values.ndim - where.ndim)), values.shape)
        squares = np.where(where, squares, 0.0)
        count = where.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sqrt(_time_sum(squares) / np.where(count > 0, count, np.nan))


def _time_sum(values: np.ndarray) -> np.ndarray:
    """The sum along axis 0 in time order: NumPy's along the slow axis, a column at a time for one column (which
    NumPy would sum pairwise)."""
    if len(values) > 1 and values[0].size == 1:
        total = np.zeros(values.shape[1:])
        for sample in values:
            total += sample
        return total
    return values.sum(axis=0) if len(values) else np.zeros(values.shape[1:])


def peak(values: np.ndarray, where: np.ndarray | None = None) -> np.ndarray:
    """The largest of ``values`` along time over the samples ``where`` (as for :func:`root_mean_square`), NaN if
    one of them is NaN or there are none."""
    if where is not None:
        where = np.broadcast_to(where.reshape(where.shape + (1,) * (values.ndim - where.ndim)), values.shape)
        values = np.where(where, values, -np.inf)
        count = where.sum(axis=0)
    else:
        count = np.full(values.shape[1:], len(values))
    if not len(values):
        return np.full(values.shape[1:], np.nan)
    return np.where(count > 0, values.max(axis=0), np.nan)


def first_time(within: np.ndarray, t: np.ndarray, where: np.ndarray | None = None) -> np.ndarray:
    """The first time within (``within`` ``(T, W, n)``) among the samples ``where`` (as for
    :func:`root_mean_square`); NaN if never."""
    if where is not None:
        within = within & np.broadcast_to(where.reshape(where.shape + (1,) * (within.ndim - where.ndim)),
                                          within.shape)
    if not len(t):
        return np.full(within.shape[1:], np.nan)
    return np.where(within.any(axis=0), t[within.argmax(axis=0)], np.nan)


def settling_time(within: np.ndarray, t: np.ndarray, where: np.ndarray | None = None) -> np.ndarray:
    """The first time after which ``within`` holds until the last of the samples ``where`` (a run of consecutive
    samples, ``(T,)`` or ``(T, 1, n)``; None: all): the first sample of the last run within; NaN if the last
    sample is not within or there are none. NaN values count as not within."""
    steps = len(t)
    if where is None:
        where = np.ones(steps, dtype=bool)
    where = np.broadcast_to(where.reshape(where.shape + (1,) * (within.ndim - where.ndim)), within.shape)
    if not steps:
        return np.full(within.shape[1:], np.nan)
    outside = where & ~within
    last_outside = np.where(outside.any(axis=0), steps - 1 - outside[::-1].argmax(axis=0), -1)
    last_sample = np.where(where.any(axis=0), steps - 1 - where[::-1].argmax(axis=0), -1)
    first_sample = where.argmax(axis=0)
    start = np.where(last_outside >= 0, last_outside + 1, first_sample)
    settled = (last_sample >= 0) & (last_outside < last_sample)
    return np.where(settled, t[np.minimum(start, steps - 1)], np.nan)


# The built-in series metrics, in the order of the tables.

@metric("rms_error", "rad", "the whole run")
def rms_error(run: Samples) -> np.ndarray:
    """RMS of |e| over the whole run."""
    return root_mean_square(run.error)


@metric("max_error", "rad", "the whole run")
def max_error(run: Samples) -> np.ndarray:
    """Maximum of |e| over the whole run."""
    return peak(run.error_size)


@metric("rms_error_converged", "rad", "the evaluation window")
def rms_error_converged(run: Samples) -> np.ndarray:
    """RMS of |e| over the evaluation window, per variant and joint from its own convergence: from
    max(`metrics.window_start`, t_in + `fault_settle`) to the end, t_in the first time |e| <=
    `tracking_tolerance` (`window_start` if never; entering the tolerance ends the reaching phase, so the settle
    interval that follows a fault onset follows it too; the first entry, so that a later excursion that is no
    fault, e.g. a sensor effect, stays in the window), without `[onset, onset + fault_settle)` after each fault
    onset; a steady-state comparison never includes a variant's convergence."""
    return root_mean_square(run.error, run.converged)


@metric("max_error_converged", "rad", "the evaluation window")
def max_error_converged(run: Samples) -> np.ndarray:
    """The maximum of |e| over the evaluation window of `rms_error_converged`."""
    return peak(run.error_size, run.converged)


@metric("convergence_time", "s", "before the first fault")
def convergence_time(run: Samples) -> np.ndarray:
    """The time after which |e| stays within `tracking_tolerance` until the first fault onset (when |e| last leaves the
    tolerance); NaN if never within."""
    return settling_time(run.error_size <= run.spec.tracking_tolerance, run.t, run.before_fault)


@metric("rms_velocity_error", "rad/s", "the estimation window")
def rms_velocity_error(run: Samples) -> np.ndarray:
    """RMS of true minus estimated velocity over the estimation window (from `estimation_window_start`, without the
    settle intervals)."""
    return root_mean_square(run.velocity_error, run.estimation)


@metric("rms_luaf_error", "rad/s^2", "the estimation window")
def rms_luaf_error(run: Samples) -> np.ndarray:
    """RMS of true minus estimated lumped uncertainty over the estimation window."""
    return root_mean_square(run.luaf_error, run.estimation)


@metric("observer_convergence_time", "s", "before the first fault")
def observer_convergence_time(run: Samples) -> np.ndarray:
    """As `convergence_time`, for the velocity estimation error with `velocity_tolerance`."""
    return settling_time(np.abs(run.velocity_error) <= run.spec.velocity_tolerance, run.t, run.before_fault)


@metric("luaf_convergence_time", "s", "before the first fault")
def luaf_convergence_time(run: Samples) -> np.ndarray:
    """As `convergence_time`, for the LUaF estimation error with `luaf_tolerance` (default 0.5 rad/s^2)."""
    return settling_time(np.abs(run.luaf_error) <= run.spec.luaf_tolerance, run.t, run.before_fault)


@metric("peak_luaf_error_transient", "rad/s^2", "before estimation_window_start")
def peak_luaf_error_transient(run: Samples) -> np.ndarray:
    """Largest |LUaF error| before `estimation_window_start`: the initial error, or more if the estimate runs away
    first."""
    return peak(np.abs(run.luaf_error), run.transient)


@metric("luaf_overshoot", "rad/s^2", "before estimation_window_start")
def luaf_overshoot(run: Samples) -> np.ndarray:
    """The one definition of overshoot, for every observer: how far the LUaF estimate goes past the true LUaF before
    `estimation_window_start`, i.e. the largest estimation error of the sign opposite to the initial error (0 if
    it never crosses; the largest |error| if the initial error is 0). An estimate that only converges scores its
    steady-state error; in the reproduction an observer overshoots if it exceeds `luaf_tolerance`."""
    transient = np.flatnonzero(run.transient)
    if not transient.size:
        return np.full(run.luaf_error.shape[1:], np.nan)
    errors = run.luaf_error[transient]
    initial = np.sign(errors[0])
    beyond = np.maximum(np.max(-initial * errors, axis=0), 0.0)
    return np.where(initial == 0, np.max(np.abs(errors), axis=0), beyond)


@metric("rms_luaf_error_fault", "rad/s^2", "the estimation window after the first fault")
def rms_luaf_error_fault(run: Samples) -> np.ndarray:
    """`rms_luaf_error` over the samples after the first fault onset only; NaN without faults."""
    return root_mean_square(run.luaf_error, run.estimation & (run.t >= run.first_fault))


@metric("first_reaching_time", "s", "before the first fault")
def first_reaching_time(run: Samples) -> np.ndarray:
    """The first time |s| <= `sliding_tolerance` before the first fault onset: when the surface is first reached; NaN
    if never."""
    return first_time(np.abs(run.sliding) <= run.spec.sliding_tolerance, run.t, run.before_fault)


@metric("reaching_time", "s", "before the first fault")
def reaching_time(run: Samples) -> np.ndarray:
    """As `convergence_time`, for the controller's sliding variable with `sliding_tolerance` (default 0.01): when the
    sliding motion is reached for good (until the first fault onset); later than `first_reaching_time` when s is
    kicked off the surface after reaching it."""
    return settling_time(np.abs(run.sliding) <= run.spec.sliding_tolerance, run.t, run.before_fault)


@metric("fault_peak_error", "rad", "a faulty joint's fault window")
def fault_peak_error(run: Samples) -> np.ndarray:
    """Per faulty joint (a joint whose fault value is not identically 0): the largest |e| in the fault window `[onset,
    onset + metrics.fault_window)` after its first fault onset (default 2 s), cut at the next onset; NaN on
    healthy joints."""
    window = run.fault_windows & (run.t[:, None, None] < run.joint_onsets + run.spec.fault_window)
    return peak(run.error_size, window)


@metric("recovery_time", "s", "a faulty joint's onset to the next")
def recovery_time(run: Samples) -> np.ndarray:
    """Per faulty joint: how long after its first fault onset |e| is back within `tracking_tolerance` for good (up to
    the next onset); NaN if never or healthy."""
    within = run.error_size <= run.spec.tracking_tolerance
    return settling_time(within, run.t, run.fault_windows) - run.joint_onsets


@metric("rms_torque", "N m", "the whole run")
def rms_torque(run: Samples) -> np.ndarray:
    """RMS of the commanded torque over the whole run."""
    return root_mean_square(run.tau)


@metric("chattering", "N m/s", "the evaluation window")
def chattering(run: Samples) -> np.ndarray:
    """Total variation of the commanded torque per second over the (per-joint) evaluation window, sum |tau[k+1] -
    tau[k]| / window length."""
    window = run.converged
    if run.steps < 2:
        return np.full(run.tau.shape[1:], np.nan)
    pairs = window[1:] & window[:-1]
    variation = _time_sum(np.where(pairs, np.abs(run.tau[1:] - run.tau[:-1]), 0.0))
    seconds = pairs.sum(axis=0) * (run.t[1] - run.t[0])
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(seconds > 0, variation / np.where(seconds > 0, seconds, 1.0), np.nan)


@metric("saturation_time", "share", "the whole run")
def saturation_time(run: Samples) -> np.ndarray:
    """Share of the run's samples where |tau| was beyond the joint's torque limit, so that MuJoCo clipped the command
    (0 without limits; a warning after a run above 5% on any joint)."""
    if not run.steps:
        return np.full(run.tau.shape[1:], np.nan)
    return (np.abs(run.tau) > run.torque_limits).sum(axis=0) / run.steps


def series_metrics(
    t: np.ndarray, series: RecordedSeries, spec: MetricsSpec, fault_onsets: Sequence[float],
    joint_onsets: np.ndarray, torque_limits: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """Every registered series metric (the diagnosis' aside), from the recorded series themselves: each ``(n,)``
    for ``(T, n)`` series, ``(W, n)`` for ``W`` results side by side (``(T, W, n)``; ``joint_onsets`` and
    ``torque_limits`` ``(n,)``, the same for all). A column's value does not depend on the columns beside it.

    Each metric's NumPy definition, or for the built-in ones their accelerator where the fast paths are on
    (:func:`ftc_mj.fast.analysis_metrics.series_pass`)."""
    single = series.q_true.ndim == 2
    columns = RecordedSeries(*(values[:, None, :] if single else values for values in series))
    run = Samples(t, columns, spec, fault_onsets, joint_onsets, torque_limits)
    out: dict[str, np.ndarray] = {}
    if fast.enabled():
        out.update(_accelerated(run, columns))
    with np.errstate(invalid="ignore", divide="ignore"):
        for entry in of_kind("series"):
            if entry.name not in out:
                out[entry.name] = np.asarray(entry.definition(run), dtype=float)
    names = [entry.name for entry in of_kind("series")]
    return {name: out[name][0] if single else out[name] for name in names}


def _accelerated(run: Samples, columns: RecordedSeries) -> dict[str, np.ndarray]:
    """The built-in series metrics by their accelerator."""
    from ftc_mj.fast.analysis_metrics import ACCELERATED, series_pass

    spec, t = run.spec, run.t
    flags = np.stack([run.estimation, evaluation_mask(t, 0.0, run.fault_onsets, spec.fault_settle), run.transient,
                      run.before_fault, run.estimation & (t >= run.first_fault)])
    onsets = run.joint_onsets
    until = np.array([min((o for o in run.fault_onsets if o > onset), default=np.inf) for onset in onsets])
    tolerances = np.array([spec.tracking_tolerance, spec.velocity_tolerance, spec.luaf_tolerance,
                           spec.sliding_tolerance])
    values = series_pass(t, tuple(columns), flags, spec.window_start, spec.fault_settle, spec.fault_window,
                         tolerances, onsets, until, run.torque_limits)
    return dict(zip(ACCELERATED, values))


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
