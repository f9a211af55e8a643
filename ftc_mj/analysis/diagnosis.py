"""Fault diagnosis on any observer's lumped-uncertainty (LUaF) estimate: detection, isolation, estimation.

Per joint j and sample k (all causal: an output at t_k uses samples up to t_k only; the definition is the
component :class:`ftc_mj.analysis.causal.CausalDiagnoser`, which the loop steps where a controller reads it
and which runs over the recorded arrays after the run otherwise, the same numbers):

* signal s: the LUaF estimate in the diagnosis ``space``: ``acceleration`` (the estimate itself, rad/s^2)
  or ``torque`` (M(q_meas) times it, N m, with the controller's nominal model, formed in the loop where that
  M is at hand; an actuator fault of one joint then shows on that joint only, while in acceleration units
  M^-1 spreads it over coupled joints); optionally through a first-order low-pass filter
  (``filter_time_constant``);
* baseline: mean m_j and standard deviation sd_j of s over a fault-free ``baseline`` window [t0, t1),
  learned at the window's last sample (without one, m = 0 and sd = 0: the estimate is compared against the
  bound alone);
* fault estimate: s - m, its magnitude over time; residual r = |s - m| (both NaN until m is learned);
* threshold: ``fixed`` + ``k`` sd_j + ``bound``_j(t, q_meas, qd_hat) (the last an adaptive bound of the
  healthy uncertainty, an expression of the measured position and the estimated velocity);
* alarm: raised after ``persistence`` consecutive samples with r > threshold, cleared after as many below
  it (against chattering-induced alarms); nothing before the diagnoser is armed (``start``, default the
  baseline's end).

The decision ``rule``: ``{kind: threshold}`` (the default) is the above. ``{kind: cusum, drift: nu, h: h}`` is
Page's one-sided cumulative sum (Page, "Continuous inspection schemes", Biometrika 41, 1954) on the normalised
residual z = r / threshold, the residual over the threshold above (so the threshold section sets the
normalisation: with ``threshold: {k: 1}`` z is the residual in baseline standard deviations; with the
threshold rule's own threshold z > 1 is where that rule would alarm):

    g_k = max(0, g_(k-1) + z_k - nu),   g = 0 before the diagnoser is armed,

alarm where g_k > h, debounced by ``persistence`` as the threshold rule is (one sample: the bare CUSUM). Since
r = |s - m| is folded, the one-sided sum on it detects changes of either sign. ``drift`` nu is in units of the
threshold (the level below which z is forgotten), ``h`` in threshold-samples (z - nu summed over samples). The
diagnosis then holds the CUSUM's statistic g as its ``residual`` and h as its ``threshold``, so that every
metric and the campaign statistics (which scale the threshold) apply unchanged: a multiple c scales h.

The section ``diagnosis`` of a scenario (:class:`DiagnosisSpec`) is compiled by :func:`compile_diagnoser`;
the runner hands every result not diagnosed inside the loop to :func:`diagnose_result`.

Metrics (:func:`diagnosis_metrics`, part of :func:`ftc_mj.analysis.metrics.compute_metrics`; all NaN without a
``diagnosis`` section). A joint is faulty from the first onset of a fault acting on it (a fault term or an
actuator fault; sensor effects are not faults):

* ``detection_delay``: per faulty joint, the first time at or after its onset with its alarm on, minus the
  onset [s]; NaN on a healthy joint and on a missed one.
* ``missed_detection``: per faulty joint, 1 if its alarm is never on from the onset to the end, else 0.
* ``false_alarms``: alarms raised while the joint is fault-free and the diagnoser armed (before the joint's
  onset; the whole armed run on a healthy joint).
* ``false_alarm_rate``: that count per second of armed fault-free time [1/s].
* ``isolation_correct``: 1 if the diagnoser names the joint faulty (an alarm at or after the first fault
  onset; at any armed time in a run without faults) exactly when it is faulty, else 0.

A metric whose window holds no armed sample is undefined (NaN), never 0 or 1: the detection metrics of a
joint whose onset comes after the run's last armed sample (a run shortened below its fault's onset: the fault
never acted), ``isolation_correct`` of every joint when the first onset does, and the false alarms of a joint
with no armed fault-free sample.
* ``fault_estimate_rms``: per detected faulty joint, RMS of the fault estimate minus the injected fault
  (both in the diagnosis space: rad/s^2 for ``acceleration``, N m for ``torque``) from detection to the end.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated, Literal

import numpy as np
from pydantic import Field, StrictInt, model_validator

from ftc_mj import fast
from ftc_mj.analysis.causal import DiagnosisSeries, run_causal
from ftc_mj.analysis.registry import metric, of_kind
from ftc_mj.config.errors import InputError
from ftc_mj.config.expressions import StateFunction, state_variables
from ftc_mj.config.types import (
    ExpressionText, NonNegativeFloat, PositiveFloat, Strict, parse_expression, per_joint)
from ftc_mj.results import Diagnosis, VariantResult


#: The diagnosis metrics, in the order of :data:`ftc_mj.analysis.metrics.METRICS` (they close it).
DIAGNOSIS_METRICS: tuple[str, ...] = (
    "detection_delay",
    "missed_detection",
    "false_alarms",
    "false_alarm_rate",
    "isolation_correct",
    "fault_estimate_rms",
)


class WindowSpec(Strict):
    #: Start of the fault-free window [s].
    start: NonNegativeFloat
    #: End of the window [s]; before the first fault onset.
    end: PositiveFloat

    @model_validator(mode="after")
    def _ordered(self) -> "WindowSpec":
        if self.end <= self.start:
            raise ValueError(f"end {self.end} must be after start {self.start}")
        return self


class ThresholdSpec(Strict):
    """threshold_j(t) = fixed_j + k sd_j + bound_j(t, q, qd), or max(floor_j, fixed_j) with a floor; at least one
    part must be given."""

    #: A constant, one number or one per joint (units of the diagnosis space).
    fixed: NonNegativeFloat | list[NonNegativeFloat] = 0.0
    #: Multiple of the baseline's standard deviation (needs a baseline).
    k: NonNegativeFloat = 0.0
    #: Adaptive part: one expression of t, q1..qn, qd1..qn per joint, on the measured position and the
    #: observer's velocity estimate.
    bound: list[ExpressionText] | None = None
    #: The smallest threshold, one number or one per joint, of a fixed threshold: threshold_j =
    #: max(floor_j, fixed_j). Keeps a threshold set on a quiet joint (a wrist in free motion) above what
    #: another motion leaves there (``ftc-mj calibrate`` on a log writes ``fixed``; the floor stays).
    floor: NonNegativeFloat | list[NonNegativeFloat] = 0.0

    @model_validator(mode="after")
    def _floor_of_fixed(self) -> "ThresholdSpec":
        floor = self.floor if isinstance(self.floor, list) else [self.floor]
        if any(floor) and (self.k > 0 or self.bound is not None):
            raise ValueError("floor is for a fixed threshold (no k, no bound: write a bound's floor in its "
                             "expressions)")
        return self

    @model_validator(mode="after")
    def _not_zero(self) -> "ThresholdSpec":
        fixed = self.fixed if isinstance(self.fixed, list) else [self.fixed]
        if self.k == 0 and self.bound is None and not any(fixed):
            raise ValueError("the threshold is zero: give fixed, k or bound")
        return self


class PersistenceSpec(Strict):
    """How long the residual must stay above (below) the threshold to raise (clear) an alarm: a number of
    ``samples`` or a ``time`` [s] (rounded up to whole samples)."""

    #: Consecutive samples above (below) the threshold that raise (clear) an alarm.
    samples: Annotated[StrictInt, Field(gt=0)] | None = None
    #: The same as a time [s], rounded up to whole samples.
    time: PositiveFloat | None = None

    @model_validator(mode="after")
    def _exactly_one(self) -> "PersistenceSpec":
        if (self.samples is None) == (self.time is None):
            raise ValueError("give samples or time (exactly one)")
        return self


class ThresholdRuleSpec(Strict):
    """The residual against the threshold (the module docstring)."""

    #: The plain rule: an alarm where the residual stays above the threshold for the persistence.
    kind: Literal["threshold"] = "threshold"


class CusumRuleSpec(Strict):
    """Page's CUSUM on the residual over the threshold: g = max(0, g + z - drift), alarm where g > h."""

    #: Page's CUSUM on the residual in units of the threshold.
    kind: Literal["cusum"]
    #: nu, in units of the threshold: the part of z that is forgotten every sample.
    drift: NonNegativeFloat
    #: The decision threshold on g, in threshold-samples.
    h: PositiveFloat


RuleSpec = Annotated[ThresholdRuleSpec | CusumRuleSpec, Field(discriminator="kind")]


class DiagnosisSpec(Strict):
    #: ``acceleration``: the LUaF estimate itself [rad/s^2]; ``torque``: M(q_meas) times it [N m], a joint's
    #: actuator fault on that joint only.
    space: Literal["acceleration", "torque"] = "acceleration"
    #: A fault-free window over which the signal's mean and standard deviation are learned (without it the mean is
    #: 0).
    baseline: WindowSpec | None = None
    #: Time constant of a first-order low-pass filter on the LUaF estimate [s]; 0 = none.
    filter_time_constant: NonNegativeFloat = 0.0
    #: The per-joint threshold on the residual |signal - mean|.
    threshold: ThresholdSpec
    #: How long the residual must stay above (below) the threshold to raise (clear) an alarm.
    persistence: PersistenceSpec = PersistenceSpec(samples=1)
    #: The diagnoser is armed from this time [s]; default: the baseline's end, else
    #: ``metrics.estimation_window_start``.
    start: NonNegativeFloat | None = None
    #: The decision rule on the residual (the module docstring).
    rule: RuleSpec = ThresholdRuleSpec()

    @model_validator(mode="after")
    def _baseline_first(self) -> "DiagnosisSpec":
        if self.threshold.k > 0 and self.baseline is None:
            raise ValueError("threshold.k needs a baseline window")
        if self.baseline is not None and self.start is not None and self.start < self.baseline.end:
            # Causality: an alarm at t may only use a baseline learned before t.
            raise ValueError(f"start {self.start} is before the baseline's end {self.baseline.end}")
        return self


@dataclass
class Diagnoser:
    """A compiled ``diagnosis`` section (see the module docstring)."""

    space: str
    dt: float
    start: float
    fixed: np.ndarray
    k: float
    persistence: int
    baseline: tuple[float, float] | None = None
    filter_time_constant: float = 0.0
    bound: StateFunction | None = None
    #: ``threshold`` or ``cusum`` (then ``drift`` and ``h`` of Page's CUSUM).
    rule: str = "threshold"
    drift: float = 0.0
    h: float = 0.0

    def diagnose(
        self, t: np.ndarray, estimate: np.ndarray, q_meas: np.ndarray, qd_hat: np.ndarray, injected: np.ndarray
    ) -> Diagnosis:
        """Diagnose one run from its recorded ``(T, n)`` arrays: ``estimate`` is the LUaF estimate in this
        diagnoser's space (M(q_meas) luaf_hat in torque space), ``injected`` the true fault in the same space;
        ``t`` increasing. The causal component run over them (:meth:`diagnose_rows`)."""
        def rows(values: np.ndarray) -> np.ndarray:
            return np.asarray(values, dtype=float)[:, None, :]

        series = self.diagnose_rows(t, rows(estimate), rows(q_meas), rows(qd_hat))
        return series.of_row(0, self.space, t, np.asarray(injected, dtype=float))

    def diagnose_rows(self, t: np.ndarray, estimate: np.ndarray, q_meas: np.ndarray,
                      qd_hat: np.ndarray) -> DiagnosisSeries:
        """The causal component (:class:`~ftc_mj.analysis.causal.CausalDiagnoser`) over ``(T, rows, n)``
        recorded arrays, every row its own diagnoser: stepped sample by sample (the definition), or its
        accelerator (:func:`ftc_mj.fast.analysis_diagnosis.causal_pass`, the same bits) where the fast paths
        are on."""
        t = np.asarray(t, dtype=float)
        if not fast.enabled() or (t.size > 1 and not np.all(t[1:] > t[:-1])):
            return run_causal(self, t, estimate, q_meas, qd_hat)
        from ftc_mj.fast.analysis_diagnosis import causal_pass

        steps, rows, n = estimate.shape
        bound = None
        if self.bound is not None and steps:
            bound = np.empty((steps, rows, n))
            # Every sample at once: per joint a (rows, T) column, times broadcast along the rows.
            for j, column in enumerate(self.bound(t, q_meas.transpose(2, 1, 0), qd_hat.transpose(2, 1, 0))):
                bound[:, :, j] = np.broadcast_to(column, (rows, steps)).T
        a = math.exp(-self.dt / self.filter_time_constant) if self.filter_time_constant > 0 else 0.0
        return DiagnosisSeries(*causal_pass(t, estimate, bound, self.fixed, self.k, self.start, self.baseline,
                                            self.dt, a, self.rule == "cusum", self.drift, self.h, self.persistence))


def compile_diagnoser(spec: DiagnosisSpec, dt: float, estimation_window_start: float, file: str, n: int,
                      fault_onsets: list[float]) -> Diagnoser:
    """The scenario's ``diagnosis`` section for a robot of ``n`` joints, a control period ``dt`` and the
    scenario's ``metrics.estimation_window_start`` and ``fault_onsets``."""
    bound = None
    if spec.threshold.bound is not None:
        texts = spec.threshold.bound
        if len(texts) != n:
            raise InputError(file, "diagnosis.threshold.bound", f"has {len(texts)} values, the robot has {n} joints")
        variables = state_variables(n)
        bound = StateFunction(
            [parse_expression(text, variables, file, f"diagnosis.threshold.bound.{j}") for j, text in enumerate(texts)], n)
    baseline = None
    if spec.baseline is not None:
        baseline = (spec.baseline.start, spec.baseline.end)
        if fault_onsets and spec.baseline.end > fault_onsets[0]:
            raise InputError(file, "diagnosis.baseline.end",
                             f"the baseline must be fault-free: it ends after the first fault onset ({fault_onsets[0]:g} s)")
    # Persistence time in whole samples, rounded up (a float just above an integer is that integer).
    persistence = spec.persistence.samples or math.ceil(spec.persistence.time / dt - 1e-9)
    start = spec.start
    if start is None:
        start = spec.baseline.end if spec.baseline is not None else estimation_window_start
    rule = spec.rule
    cusum_parameters = {"drift": rule.drift, "h": rule.h} if rule.kind == "cusum" else {}
    fixed = per_joint(spec.threshold.fixed, n, file, "diagnosis.threshold.fixed")
    fixed = np.maximum(fixed, per_joint(spec.threshold.floor, n, file, "diagnosis.threshold.floor"))
    return Diagnoser(space=spec.space, dt=dt, start=start, k=spec.threshold.k, persistence=max(1, persistence),
                     fixed=fixed, baseline=baseline, filter_time_constant=spec.filter_time_constant, bound=bound,
                     rule=rule.kind, **cusum_parameters)


def diagnose_result(diagnoser: Diagnoser | None, result: VariantResult, luaf_torque: np.ndarray | None) -> None:
    """Run the scenario's diagnoser, if any, on the result's LUaF estimate (in its diagnosis space) and store
    the diagnosis in the result. ``luaf_torque``: M(q_meas) luaf_hat, formed in the loop, for torque space."""
    if diagnoser is None:
        return
    if diagnoser.space == "torque":
        estimate, injected = luaf_torque[:len(result.t)], result.fault_torque
    else:
        estimate, injected = result.luaf_hat, result.fault_acceleration
    result.diagnosis = diagnoser.diagnose(result.t, estimate, result.q_meas, result.qd_hat, injected)


def low_pass(x: np.ndarray, dt: float, time_constant: float) -> np.ndarray:
    """First-order low-pass filter along axis 0, exactly discretised, starting at the first sample."""
    from scipy.signal import lfilter  # imported here: scipy.signal costs more to import than a short run

    a = math.exp(-dt / time_constant)
    return lfilter([1.0 - a], [1.0, -a], x, axis=0, zi=a * x[:1])[0]

def cusum(z: np.ndarray, drift: float) -> np.ndarray:
    """Page's one-sided CUSUM along axis 0 of ``(N, ...)``, every other column at once: g_k = max(0, g_(k-1) +
    z_k - drift) from g_(-1) = 0; where z_k is NaN, g_k is NaN and the sum restarts from 0 after it. Causal:
    g_k uses z_0..z_k only (the recursion the causal diagnoser steps)."""
    z = np.asarray(z, dtype=float)
    out = np.empty_like(z)
    g = np.zeros(z.shape[1:])
    for k in range(len(z)):
        out[k] = np.maximum(g + z[k] - drift, 0.0)  # NaN stays NaN
        g = np.where(np.isnan(out[k]), 0.0, out[k])
    return out


def persistent(exceeded: np.ndarray, samples: int, axis: int = 0) -> np.ndarray:
    """Debounce along ``axis`` (time), every other column at once: on from the ``samples``-th consecutive True,
    off from the ``samples``-th consecutive False; starts off. The causal diagnoser's debounce over whole
    arrays: the alarm at sample i is the value of the last run of ``samples`` equal values ending at or before
    i (a window of ``samples`` all True or all False, counted exactly in integers)."""
    exceeded = np.moveaxis(np.asarray(exceeded, dtype=bool), axis, 0)
    if samples <= 1 or exceeded.size == 0:
        return np.moveaxis(exceeded.copy(), 0, axis)
    steps = len(exceeded)
    counts = np.cumsum(exceeded, axis=0, dtype=np.int64)
    if steps < samples:
        return np.moveaxis(np.zeros_like(exceeded), 0, axis)
    trues = counts[samples - 1:].copy()
    trues[1:] -= counts[:steps - samples]
    complete = (trues == samples) | (trues == 0)  # the window ending at sample samples - 1 + i is one value
    index = np.where(complete, np.arange(samples - 1, steps).reshape((-1,) + (1,) * (exceeded.ndim - 1)), -1)
    last = np.maximum.accumulate(index, axis=0)  # the last completed window's end
    alarm = np.zeros_like(exceeded)
    alarm[samples - 1:] = np.where(last >= 0, np.take_along_axis(exceeded, np.maximum(last, 0), axis=0), False)
    return np.moveaxis(alarm, 0, axis)


class DiagnosedRun:
    """What a diagnosis metric reads: the run's :class:`~ftc_mj.results.Diagnosis` (``diagnosis``, with at
    least one sample), per joint its first fault onset (``onsets``, inf: healthy; ``faulty``), the first onset
    of any fault (``first_fault``, inf: none) and the windows the built-in metrics share."""

    def __init__(self, diagnosis: Diagnosis, joint_onsets: np.ndarray, first_fault: float):
        self.diagnosis = diagnosis
        self.t = np.asarray(diagnosis.t, dtype=float)
        self.faulty = np.isfinite(joint_onsets)
        self.onsets = np.where(self.faulty, joint_onsets, np.inf)
        self.first_fault = first_fault
        armed = diagnosis.armed[:, None]
        #: ``(T, n)``: armed and fault-free; armed from the joint's onset on.
        self.fault_free = armed & (self.t[:, None] < self.onsets)
        self.observed = armed & (self.t[:, None] >= self.onsets)
        self.dt = self.t[1] - self.t[0] if self.t.size > 1 else 0.0
        window = diagnosis.armed & (self.t >= first_fault) if math.isfinite(first_fault) else diagnosis.armed
        #: Per joint, whether its detection and isolation are defined: an armed sample in the isolation window
        #: (at or after the first onset; anywhere without faults) and, on a faulty joint, from its onset on. A
        #: fault that never acted within the run is neither detected nor missed.
        self.decided = window.any() & (~self.faulty | self.observed.any(axis=0))
        detected = diagnosis.alarm & (self.t[:, None] >= self.onsets)
        #: Per joint, the first sample alarmed at or after its onset (-1: none).
        self.detected = np.where(detected.any(axis=0), detected.argmax(axis=0), -1)


@metric("detection_delay", "s", "a faulty joint's onset to the end", kind="diagnosis")
def detection_delay(run: DiagnosedRun) -> np.ndarray:
    """Per faulty joint, the first time at or after its onset with its alarm on, minus the onset; undefined on a
    healthy or missed joint."""
    found = run.faulty & run.decided & (run.detected >= 0)
    return np.where(found, run.t[np.maximum(run.detected, 0)] - run.onsets, np.nan)


@metric("missed_detection", "0/1", "a faulty joint's onset to the end", kind="diagnosis")
def missed_detection(run: DiagnosedRun) -> np.ndarray:
    """Per faulty joint, 1 if its alarm is never on from the onset to the end, else 0."""
    return np.where(run.faulty & run.decided, (run.detected < 0).astype(float), np.nan)


@metric("false_alarms", "count", "armed and fault-free", kind="diagnosis")
def false_alarms(run: DiagnosedRun) -> np.ndarray:
    """Alarms raised while the joint is fault-free and the diagnoser armed (before its onset; the whole armed run on a
    healthy joint)."""
    raised = (run.diagnosis.raised & run.fault_free).sum(axis=0)
    return np.where(run.fault_free.any(axis=0), raised, np.nan)


@metric("false_alarm_rate", "1/s", "armed and fault-free", kind="diagnosis")
def false_alarm_rate(run: DiagnosedRun) -> np.ndarray:
    """That count per second of armed fault-free time."""
    seconds = run.fault_free.sum(axis=0) * run.dt
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(seconds > 0, false_alarms(run) / seconds, np.nan)


@metric("isolation_correct", "0/1", "from the first fault onset", kind="diagnosis")
def isolation_correct(run: DiagnosedRun) -> np.ndarray:
    """1 if the diagnoser names the joint faulty (an alarm at or after the first fault onset; at any armed time without
    faults) exactly when it is faulty, else 0."""
    isolated = run.diagnosis.isolated(run.first_fault)
    return np.where(run.decided, (isolated == run.faulty).astype(float), np.nan)


@metric("fault_estimate_rms", "rad/s^2 or N m", "a detected joint's detection to the end", kind="diagnosis")
def fault_estimate_rms(run: DiagnosedRun) -> np.ndarray:
    """Per detected faulty joint, RMS of fault estimate minus injected fault from detection to the end, in the
    diagnosis space."""
    out = np.full(len(run.faulty), np.nan)
    d = run.diagnosis
    for j in np.flatnonzero(run.faulty & run.decided & (run.detected >= 0)):
        first = run.detected[j]
        error = d.fault_estimate[first:, j] - d.injected[first:, j]
        out[j] = np.sqrt(np.mean(error**2))
    return out


def diagnosis_metrics(
    diagnosis: Diagnosis | None, joint_onsets: np.ndarray, first_fault: float, n: int
) -> dict[str, np.ndarray]:
    """Every registered diagnosis metric per joint (see the module docstring); NaN everywhere without a
    diagnosis."""
    metrics = of_kind("diagnosis")
    if diagnosis is None or diagnosis.t.size == 0:
        return {m.name: np.full(n, np.nan) for m in metrics}
    run = DiagnosedRun(diagnosis, joint_onsets, first_fault)
    return {m.name: np.asarray(m.definition(run), dtype=float) for m in metrics}


def scale_tag(scale: float) -> str:
    """A threshold multiple as a column-name tag: 1.5 -> ``x1p5``, 2 -> ``x2``."""
    return "x" + f"{scale:g}".replace(".", "p")


def detection_statistics(
    diagnosis: Diagnosis | None, persistence: int, joint_onsets: np.ndarray, scales: list[float], n: int
) -> dict[str, np.ndarray]:
    """Threshold-free detection statistics of one run, per joint, from which ROC curves, detection probability
    against fault size, delay distributions and false alarms per hour are recomputed without simulating again:

    * ``residual_peak_healthy``: the largest level z the residual holds for ``persistence`` consecutive armed
      samples before the joint's onset (the whole armed run on a healthy joint), z = residual / threshold: an
      alarm would be raised at c times the threshold iff z > c;
    * ``residual_peak_fault``: the same from the onset on (NaN on a healthy joint);
    * ``healthy_time``: armed fault-free seconds (for false alarms per hour);
    * per scale c of ``scales`` (tag :func:`scale_tag`): ``false_alarms_<tag>`` (alarms raised while armed and
      fault-free at c times the threshold) and ``detection_delay_<tag>`` (first alarm at or after the onset
      minus the onset; NaN if missed or healthy): the scenario's own diagnoser with a scaled threshold
      (``residual > c * threshold``, debounced by :func:`persistent`), so at c = 1 they equal ``false_alarms``
      and ``detection_delay``;
    * ``isolated``: 1 where the diagnoser names the joint faulty (at the scenario's threshold), else 0; NaN
      when no armed sample lies at or after the first onset (the run ends first).

    All NaN without a diagnosis. Where the fast paths are on, the held levels and the scaled alarms are
    computed by their accelerator (:mod:`ftc_mj.fast.analysis_detection`, the same numbers)."""
    names = ["residual_peak_healthy", "residual_peak_fault", "healthy_time", "isolated"]
    names += [f"{kind}_{scale_tag(c)}" for c in scales for kind in ("false_alarms", "detection_delay")]
    out = {name: np.full(n, np.nan) for name in names}
    if diagnosis is None or diagnosis.t.size == 0:
        return out
    t = np.asarray(diagnosis.t, dtype=float)
    residual, threshold = np.asarray(diagnosis.residual, dtype=float), np.asarray(diagnosis.threshold, dtype=float)
    armed = np.asarray(diagnosis.armed, dtype=bool)
    dt = t[1] - t[0] if t.size > 1 else 0.0
    p = max(1, persistence)
    faulty = np.isfinite(joint_onsets)
    onsets = np.where(faulty, joint_onsets, np.inf)
    first_fault = float(np.nanmin(joint_onsets)) if faulty.any() else np.inf
    window = armed & (t >= first_fault) if math.isfinite(first_fault) else armed
    if window.any():  # else undefined: the run ends before the first onset or before the diagnoser is armed
        out["isolated"] = diagnosis.isolated(first_fault).astype(float)
    for j in range(n):
        out["healthy_time"][j] = (armed & (t < onsets[j])).sum() * dt
    ordered = np.asarray(scales, dtype=float)
    if fast.enabled():
        from ftc_mj.fast.analysis_detection import detection_pass

        peaks, false_alarms, first = detection_pass(t, residual, threshold, armed, onsets, p, ordered)
    else:
        peaks, false_alarms, first = _held_peaks(t, residual, threshold, armed, onsets, p), \
            *_scaled_alarms(t, residual, threshold, armed, onsets, p, ordered)
    out["residual_peak_healthy"] = peaks[0]
    out["residual_peak_fault"] = np.where(faulty, peaks[1], np.nan)
    delay = np.where((first >= 0) & faulty, t[np.maximum(first, 0)] - onsets, np.nan)
    for s, c in enumerate(ordered.tolist()):
        tag = scale_tag(c)
        out[f"false_alarms_{tag}"] = false_alarms[s].astype(float)
        out[f"detection_delay_{tag}"] = delay[s]
    return out


def _held_peaks(t: np.ndarray, residual: np.ndarray, threshold: np.ndarray, armed: np.ndarray, onsets: np.ndarray,
                p: int) -> np.ndarray:
    """``(2, n)``: per joint the largest level z = residual / threshold (NaN unarmed) held over ``p``
    consecutive samples (its minimum there, NaN if one is NaN), before the joint's onset and from it on; NaN
    where no held level is finite."""
    n = residual.shape[1]
    with np.errstate(invalid="ignore", divide="ignore"):
        level = np.where(armed[:, None], residual / threshold, np.nan)
    peaks = np.full((2, n), np.nan)
    if len(t) < p:
        return peaks
    held = _window(level, p, np.minimum)  # dated by the window's last sample
    held_t = t[p - 1:]
    for j in range(n):
        for side, values in enumerate((held[held_t < onsets[j], j], held[held_t >= onsets[j], j])):
            if np.isfinite(values).any():
                peaks[side, j] = np.nanmax(values)
    return peaks


def _scaled_alarms(t: np.ndarray, residual: np.ndarray, threshold: np.ndarray, armed: np.ndarray,
                   onsets: np.ndarray, p: int, scales: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per scale c and joint, the diagnoser at c times its threshold (``residual > c * threshold``, debounced
    by :func:`persistent`): the alarms raised while armed before the joint's onset ``(S, n)`` and the first
    sample alarmed at or after it ``(S, n)`` (-1: none)."""
    with np.errstate(invalid="ignore"):
        exceeded = residual[None] > scales[:, None, None] * threshold[None]
    alarm = persistent(exceeded, p, axis=1)
    before = np.zeros_like(alarm)
    before[:, 1:] = alarm[:, :-1]
    raised = alarm & ~before
    healthy = armed[:, None] & (t[:, None] < onsets[None, :])
    false_alarms = (raised & healthy[None]).sum(axis=1)
    after = alarm & (t[:, None] >= onsets[None, :])[None]
    first = np.where(after.any(axis=1), after.argmax(axis=1), -1)
    return false_alarms, first


def _window(x: np.ndarray, p: int, combine: np.ufunc) -> np.ndarray:
    """``combine`` (minimum: associative, commutative, idempotent) over every window of ``p`` consecutive
    samples along axis 0, dated by the window's last sample (``N - p + 1`` of them), by windows of doubling
    length: the result does not depend on the order in which a window is reduced (a minimum also propagates
    NaN in any order)."""
    count = len(x) - p + 1
    result, done = None, 0  # ``result`` combines the first ``done`` samples of each window
    power, span, remaining = x, 1, p  # ``power`` combines windows of ``span`` samples
    while remaining:
        if remaining & 1:
            piece = power[done:done + count]
            result = piece.copy() if result is None else combine(result, piece, out=result)
            done += span
        remaining >>= 1
        if remaining:
            length = len(power) - span
            power = combine(power[:length], power[span:span + length])
            span *= 2
    return result
