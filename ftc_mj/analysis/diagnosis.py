"""Fault diagnosis on any observer's lumped-uncertainty (LUaF) estimate: detection, isolation, estimation.

Per joint j and sample k (all causal: an output at t_k uses samples up to t_k only, so running it on the
recorded arrays after the run gives what an online diagnoser would have given):

* signal s: the LUaF estimate in the diagnosis ``space``: ``acceleration`` (the estimate itself, rad/s^2)
  or ``torque`` (M(q_meas) times it, N m, with the controller's nominal model, formed in the loop where that
  M is at hand; an actuator fault of one joint then shows on that joint only, while in acceleration units
  M^-1 spreads it over coupled joints); optionally through a first-order low-pass filter
  (``filter_time_constant``);
* baseline: mean m_j and standard deviation sd_j of s over a fault-free ``baseline`` window [t0, t1)
  (without one, m = 0 and sd = 0: the estimate is compared against the bound alone);
* fault estimate: s - m, its magnitude over time; residual r = |s - m|;
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
the loop hands every result to :func:`diagnose_result`.

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
import os
from dataclasses import dataclass
from typing import Annotated, Literal

# As in ftc_mj.robot.rigid (whichever imports Numba first): no SVML, so a compiled loop rounds as the scalar code.
os.environ.setdefault("NUMBA_DISABLE_INTEL_SVML", "1")

import numba  # noqa: E402
import numpy as np  # noqa: E402
from pydantic import Field, StrictInt, model_validator  # noqa: E402

from ftc_mj.config.errors import InputError  # noqa: E402
from ftc_mj.config.kernels import WITHOUT_RUNTIME, for_any_layout  # noqa: E402
from ftc_mj.config.expressions import StateFunction, state_variables  # noqa: E402
from ftc_mj.results import Diagnosis, VariantResult  # noqa: E402
from ftc_mj.config.types import (  # noqa: E402
    ExpressionText, NonNegativeFloat, PositiveFloat, Strict, parse_expression, per_joint)


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
    """threshold_j(t) = fixed_j + k sd_j + bound_j(t, q, qd); at least one part must be given."""

    #: A constant, one number or one per joint (units of the diagnosis space).
    fixed: NonNegativeFloat | list[NonNegativeFloat] = 0.0
    #: Multiple of the baseline's standard deviation (needs a baseline).
    k: NonNegativeFloat = 0.0
    #: Adaptive part: one expression of t, q1..qn, qd1..qn per joint, on the measured position and the
    #: observer's velocity estimate.
    bound: list[ExpressionText] | None = None

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
        """Diagnose one run from its recorded arrays: ``estimate`` is the LUaF estimate in this diagnoser's
        space (M(q_meas) luaf_hat in torque space), ``injected`` the true fault in the same space; ``t``
        increasing.

        The bound's expressions (on every sample at once) and the low-pass filter in NumPy and SciPy, the rest
        in one compiled pass (:func:`_diagnose_pass`) with NumPy's bits: the baseline's mean and standard
        deviation summed as NumPy sums ``(K, n)`` along time (in time order, pairwise for one joint), the
        CUSUM and the debounce as :func:`cusum` and :func:`persistent`."""
        steps, n = estimate.shape
        signal = np.empty((steps, n))
        source = estimate
        if self.filter_time_constant > 0 and steps:
            source = low_pass(np.array(estimate, dtype=float), self.dt, self.filter_time_constant)
        bound = np.zeros((0, n))
        if self.bound is not None:
            bound = np.empty((steps, n))
            for j, column in enumerate(self.bound(t, q_meas.T, qd_hat.T)):  # every sample at once
                bound[:, j] = column
        # The baseline: 0 none (mean and deviation 0), 1 learned over samples [first, first + count), 2 not
        # learned (a run that ended or diverged before the window's end: NaN, so no alarm).
        baseline, first, count = 0, 0, 0
        if self.baseline is not None:
            baseline = 1 if steps and t[-1] + self.dt >= self.baseline[1] - 1e-9 else 2
            first, stop = np.searchsorted(t, self.baseline, side="left").tolist()  # t >= start, t < end
            count = stop - first
        fault_estimate, residual, threshold = np.empty((steps, n)), np.empty((steps, n)), np.empty((steps, n))
        alarm, armed = np.empty((steps, n), dtype=bool), np.empty(steps, dtype=bool)
        mean, std = np.empty(n), np.empty(n)
        arguments = (np.asarray(t, dtype=float), np.asarray(source, dtype=float), bound,
                     np.asarray(self.fixed, dtype=float), float(self.k), float(self.start), first, count, baseline,
                     self.rule == "cusum", float(self.drift), float(self.h), max(1, self.persistence), signal,
                     fault_estimate, residual, threshold, alarm, armed, mean, std)
        for_any_layout(_diagnose_pass, *arguments)(*arguments)
        return Diagnosis(space=self.space, t=t, signal=signal, fault_estimate=fault_estimate, residual=residual,
                         threshold=threshold, alarm=alarm, armed=armed, mean=mean, std=std,
                         injected=np.asarray(injected, dtype=float))


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _diagnose_pass(t, estimate, bound, fixed, k, start, first, count, baseline, cusum_rule, drift, h, samples,
                   signal, fault_estimate, residual, threshold, alarm, armed, mean,
                   std):  # pragma: no cover - compiled
    """:meth:`Diagnoser.diagnose` from the (filtered) estimate on: every output array filled in place, column
    by column in time order. ``bound`` ``(T, n)`` is added to the threshold, or ``(0, n)``: none."""
    steps, n = estimate.shape
    for i in range(steps):
        armed[i] = t[i] >= start
        for j in range(n):
            signal[i, j] = estimate[i, j]
    for j in range(n):
        if baseline == 0:
            mean[j], std[j] = 0.0, 0.0
        elif baseline == 2:
            mean[j], std[j] = np.nan, np.nan
        else:  # NumPy's mean and std over the window: its sum along time, then the squares about the mean
            centre = _time_sum(signal, signal, 0.0, _PLAIN, first, count, j) / count
            mean[j] = centre
            std[j] = np.sqrt(_time_sum(signal, signal, centre, _SQUARED_FROM, first, count, j) / count)
    with_bound = bound.shape[0] > 0
    for j in range(n):
        level = fixed[j] + k * std[j]
        g, state, run, previous = 0.0, False, 0, False
        for i in range(steps):
            estimate_ij = signal[i, j] - mean[j]
            fault_estimate[i, j] = estimate_ij
            r = abs(estimate_ij)
            limit = np.nan  # no threshold before the diagnoser is armed (also in the plots)
            if armed[i]:
                limit = level + bound[i, j] if with_bound else level
            if cusum_rule:  # the residual becomes Page's statistic on r / threshold, the threshold h
                g, r = _cusum_step(g, r / limit, drift)
                limit = h if armed[i] else np.nan
            residual[i, j], threshold[i, j] = r, limit
            value = r > limit  # NaN compares False: no alarm
            run, state = _debounce_step(value, previous, run, state, samples)
            previous = value
            alarm[i, j] = state


#: What :func:`_time_sum` sums: the values, their squares about a centre, the squares of their differences.
_PLAIN, _SQUARED_FROM, _SQUARED_DIFFERENCE = 0, 1, 2


@numba.njit(cache=True, nogil=True, inline="always")
def _term(a, b, centre, kind, i, j):  # pragma: no cover - compiled
    """Sample ``i`` of column ``j`` as :func:`_time_sum` sums it."""
    if kind == _PLAIN:
        return a[i, j]
    d = a[i, j] - (centre if kind == _SQUARED_FROM else b[i, j])
    return d * d


@numba.njit(cache=True, nogil=True)
def _time_sum(a, b, centre, kind, first, count, j):  # pragma: no cover - compiled
    """NumPy's sum along time of samples [first, first + count) of column ``j`` of ``(T, n)`` ``a`` (``kind``:
    the values, or (a - centre)^2, or (a - b)^2): in time order from 0 for n >= 2 (a reduction over the slow
    axis), pairwise for one column (:func:`_pairwise_sum`, a contiguous reduction)."""
    if a.shape[1] == 1:
        return 0.0 + _pairwise_sum(a, b, centre, kind, first, count, j)
    total = 0.0
    for i in range(first, first + count):
        total += _term(a, b, centre, kind, i, j)
    return total


@numba.njit(cache=True, nogil=True)
def _pairwise_sum(a, b, centre, kind, first, count, j):  # pragma: no cover - compiled
    """NumPy's pairwise summation of a contiguous run of ``count`` terms (its ``pairwise_sum``): blocks of at most
    128 terms summed in eight interleaved partial sums, halves of a larger run (at a multiple of 8) summed
    apart. The terms those of :func:`_term`."""
    if count < 8:
        total = -0.0
        for i in range(first, first + count):
            total += _term(a, b, centre, kind, i, j)
        return total
    if count <= 128:
        r0, r1 = _term(a, b, centre, kind, first, j), _term(a, b, centre, kind, first + 1, j)
        r2, r3 = _term(a, b, centre, kind, first + 2, j), _term(a, b, centre, kind, first + 3, j)
        r4, r5 = _term(a, b, centre, kind, first + 4, j), _term(a, b, centre, kind, first + 5, j)
        r6, r7 = _term(a, b, centre, kind, first + 6, j), _term(a, b, centre, kind, first + 7, j)
        i = 8
        while i < count - count % 8:
            r0 += _term(a, b, centre, kind, first + i, j)
            r1 += _term(a, b, centre, kind, first + i + 1, j)
            r2 += _term(a, b, centre, kind, first + i + 2, j)
            r3 += _term(a, b, centre, kind, first + i + 3, j)
            r4 += _term(a, b, centre, kind, first + i + 4, j)
            r5 += _term(a, b, centre, kind, first + i + 5, j)
            r6 += _term(a, b, centre, kind, first + i + 6, j)
            r7 += _term(a, b, centre, kind, first + i + 7, j)
            i += 8
        total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
        while i < count:
            total += _term(a, b, centre, kind, first + i, j)
            i += 1
        return total
    half = count // 2
    half -= half % 8
    return (_pairwise_sum(a, b, centre, kind, first, half, j)
            + _pairwise_sum(a, b, centre, kind, first + half, count - half, j))


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
    return Diagnoser(space=spec.space, dt=dt, start=start, k=spec.threshold.k, persistence=max(1, persistence),
                     fixed=per_joint(spec.threshold.fixed, n, file, "diagnosis.threshold.fixed"), baseline=baseline,
                     filter_time_constant=spec.filter_time_constant, bound=bound, rule=rule.kind,
                     **cusum_parameters)


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
    g_k uses z_0..z_k only. The recursion itself (compiled), so g is what an online CUSUM computes, bit for bit."""
    z = np.asarray(z, dtype=float)
    columns = np.ascontiguousarray(z.reshape(len(z), -1))
    out = np.empty_like(columns)
    _cusum(columns, float(drift), out)
    return out.reshape(z.shape)


@numba.njit(cache=True, nogil=True)
def _cusum(z: np.ndarray, drift: float, out: np.ndarray) -> None:  # pragma: no cover - compiled
    g = np.zeros(z.shape[1])
    for k in range(z.shape[0]):
        for j in range(z.shape[1]):
            g[j], out[k, j] = _cusum_step(g[j], z[k, j], drift)


@numba.njit(cache=True, nogil=True, inline="always")
def _cusum_step(g: float, z: float, drift: float) -> tuple[float, float]:
    """One sample of Page's CUSUM: the sum carried on and the output, max(0, g + z - drift) for both, or (0,
    NaN) where z is NaN (the sum restarts)."""
    if np.isnan(z):
        return 0.0, np.nan
    g = max(0.0, g + z - drift)
    return g, g


def persistent(exceeded: np.ndarray, samples: int, axis: int = 0) -> np.ndarray:
    """Debounce along ``axis`` (time), every other column at once: on from the ``samples``-th consecutive True,
    off from the ``samples``-th consecutive False; starts off."""
    exceeded = np.asarray(exceeded, dtype=bool)
    if samples <= 1 or exceeded.size == 0:
        return exceeded.copy()
    # Time last and contiguous: the compiled state machine runs along rows.
    series = np.ascontiguousarray(np.moveaxis(exceeded, axis, -1))
    alarm = np.zeros_like(series)
    _debounce_rows(series.reshape(-1, series.shape[-1]), samples, alarm.reshape(-1, series.shape[-1]))
    return np.ascontiguousarray(np.moveaxis(alarm, -1, axis))


@numba.njit(cache=True, nogil=True, inline="always")
def _debounce_step(value: bool, previous: bool, run: int, state: bool, samples: int) -> tuple[int, bool]:
    """One sample of the debounce: the run of equal samples ending here (``run`` 0 before the first sample) and
    the alarm, the value of the last run of ``samples`` equal samples that ends at or before it (off before
    any): the alarm switches at the ``samples``-th consecutive sample of a value."""
    run = run + 1 if run > 0 and value == previous else 1
    return run, value if run >= samples else state


@numba.njit(cache=True, nogil=True, **WITHOUT_RUNTIME)
def _debounce_rows(series: np.ndarray, samples: int, alarm: np.ndarray) -> None:  # pragma: no cover - compiled
    """Each row's alarm in one pass (:func:`_debounce_step`)."""
    for r in range(series.shape[0]):
        state, run, previous = False, 0, False
        for i in range(series.shape[1]):
            value = series[r, i]
            run, state = _debounce_step(value, previous, run, state, samples)
            previous = value
            alarm[r, i] = state


def diagnosis_metrics(
    diagnosis: Diagnosis | None, joint_onsets: np.ndarray, first_fault: float, n: int
) -> dict[str, np.ndarray]:
    """The diagnosis metrics per joint (see the module docstring); NaN everywhere without a diagnosis. One
    compiled pass over the alarms (:func:`_diagnosis_metrics_pass`)."""
    out = np.full((len(DIAGNOSIS_METRICS), n), np.nan)
    if diagnosis is not None and diagnosis.t.size:
        faulty = np.isfinite(joint_onsets)
        arguments = (np.asarray(diagnosis.t, dtype=float), np.asarray(diagnosis.alarm, dtype=bool),
                     np.asarray(diagnosis.armed, dtype=bool), np.asarray(diagnosis.fault_estimate, dtype=float),
                     np.asarray(diagnosis.injected, dtype=float), np.where(faulty, joint_onsets, np.inf), faulty,
                     float(first_fault), out)
        for_any_layout(_diagnosis_metrics_pass, *arguments)(*arguments)
    return dict(zip(DIAGNOSIS_METRICS, out))


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _diagnosis_metrics_pass(t, alarm, armed, fault_estimate, injected, onsets, faulty, first_fault,
                            out):  # pragma: no cover - compiled
    """:data:`DIAGNOSIS_METRICS` into ``out[metric, j]`` (NaN where undefined, as the caller fills it), one
    pass along each joint's alarms. A window with no armed sample (the run ends before the onset or before
    the diagnoser is armed) leaves its metrics undefined: a fault that never acted within the run is neither
    detected nor missed. The estimate's RMS from detection on is NumPy's mean of the squared errors (pairwise)."""
    steps, n = alarm.shape
    dt = t[1] - t[0] if steps > 1 else 0.0
    isolation_window = _any_armed_since(t, armed, first_fault)
    for j in range(n):
        onset = onsets[j]
        fault_free, raised, observed, detected = 0, 0, False, -1
        for i in range(steps):
            on = alarm[i, j]
            if armed[i] and t[i] < onset:
                fault_free += 1
                if on and not (i > 0 and alarm[i - 1, j]):
                    raised += 1
            elif armed[i]:
                observed = True
            if on and detected < 0 and t[i] >= onset:
                detected = i
        if fault_free:
            out[2, j] = raised
            out[3, j] = raised / (fault_free * dt) if dt > 0 else np.nan
        if not isolation_window or (faulty[j] and not observed):
            continue
        out[4, j] = 1.0 if _isolated(t, alarm, armed, first_fault, j) == faulty[j] else 0.0
        if not faulty[j]:
            continue
        out[1, j] = 1.0 if detected < 0 else 0.0
        if detected >= 0:
            out[0, j] = t[detected] - onset
            after = steps - detected
            squares = 0.0 + _pairwise_sum(fault_estimate, injected, 0.0, _SQUARED_DIFFERENCE, detected, after, j)
            out[5, j] = np.sqrt(squares / after)


@numba.njit(cache=True, nogil=True, inline="always")
def _any_armed_since(t, armed, first_fault):  # pragma: no cover - compiled
    """Whether the isolation window holds an armed sample: at or after the first fault onset, or anywhere in
    a run without faults (``first_fault`` inf)."""
    since_fault = np.isfinite(first_fault)
    for i in range(t.shape[0]):
        if armed[i] and (t[i] >= first_fault or not since_fault):
            return True
    return False


@numba.njit(cache=True, nogil=True, inline="always")
def _isolated(t, alarm, armed, first_fault, j):  # pragma: no cover - compiled
    """:meth:`~ftc_mj.results.Diagnosis.isolated` of joint ``j``: an alarm at or after the first onset (at
    any armed sample without faults)."""
    since_fault = np.isfinite(first_fault)
    for i in range(t.shape[0]):
        if alarm[i, j] and (t[i] >= first_fault if since_fault else armed[i]):
            return True
    return False


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
      minus the onset; NaN if missed or healthy): the scenario's own diagnoser with a scaled threshold, so at
      c = 1 they equal ``false_alarms`` and ``detection_delay``;
    * ``isolated``: 1 where the diagnoser names the joint faulty (at the scenario's threshold), else 0; NaN
      when no armed sample lies at or after the first onset (the run ends first).

    All NaN without a diagnosis. One compiled pass along each joint (:func:`_detection_pass`)."""
    names = ["residual_peak_healthy", "residual_peak_fault", "healthy_time", "isolated"]
    names += [f"{kind}_{scale_tag(c)}" for c in scales for kind in ("false_alarms", "detection_delay")]
    out = {name: np.full(n, np.nan) for name in names}
    if diagnosis is None or diagnosis.t.size == 0:
        return out
    t = np.asarray(diagnosis.t, dtype=float)
    faulty = np.isfinite(joint_onsets)
    onsets = np.where(faulty, joint_onsets, np.inf)
    first_fault = float(np.nanmin(joint_onsets)) if faulty.any() else np.inf
    p = max(1, persistence)
    ordered = np.sort(np.asarray(scales, dtype=float))  # the pass wants them sorted (the columns are named)
    levels = np.full((4, n), np.nan)
    # Filled by the pass, which starts each joint's counts and scale states itself.
    false_alarms = np.empty((len(scales), n), dtype=np.int64)
    first = np.empty((len(scales), n), dtype=np.int64)
    scale_state = np.empty((3, len(scales)), dtype=np.int64)  # per scale: the alarm, the run, the last value
    window = np.empty((2, p + 1))  # the level's minimum over the last p samples: values and their samples
    arguments = (t, np.asarray(diagnosis.residual, dtype=float), np.asarray(diagnosis.threshold, dtype=float),
                 np.asarray(diagnosis.alarm, dtype=bool), np.asarray(diagnosis.armed, dtype=bool), onsets, faulty,
                 first_fault, p, ordered, levels, false_alarms, first, scale_state, window)
    for_any_layout(_detection_pass, *arguments)(*arguments)
    for name, values in zip(names[:4], levels):
        out[name] = values
    delay = np.where((first >= 0) & faulty, t[np.maximum(first, 0)] - onsets, np.nan)
    for s, c in enumerate(ordered.tolist()):
        tag = scale_tag(c)
        out[f"false_alarms_{tag}"] = false_alarms[s].astype(float)
        out[f"detection_delay_{tag}"] = delay[s]
    return out


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _detection_pass(t, residual, threshold, alarm, armed, onsets, faulty, first_fault, p, scales, levels,
                    false_alarms, first, scale_state, window):  # pragma: no cover - compiled
    """:func:`detection_statistics`, one pass along each joint: into ``levels`` (NaN where undefined, as the
    caller fills it) the two peaks, the healthy time and the isolation; per scale, the false alarms and the
    first alarmed sample at or after the onset (-1: none) of :func:`_scaled_alarms`.

    The level z = residual / threshold (NaN unarmed) held over a window of ``p`` samples is its minimum there,
    NaN if one is NaN (NumPy's ``minimum``), kept by a monotone queue in ``window`` (``p + 1`` slots); a peak
    is the largest held level, NaN when none is finite (so a peak of inf alone is NaN)."""
    steps, n = residual.shape
    dt = t[1] - t[0] if steps > 1 else 0.0
    isolation_window = _any_armed_since(t, armed, first_fault)
    slots = window.shape[1]
    for j in range(n):
        onset = onsets[j]
        healthy, head, size, last_nan = 0, 0, 0, -1
        peak_healthy, peak_fault, finite_healthy, finite_fault = -np.inf, -np.inf, False, False
        for i in range(steps):
            if armed[i] and t[i] < onset:
                healthy += 1
            level = residual[i, j] / threshold[i, j] if armed[i] else np.nan
            if level != level:
                last_nan, size = i, 0  # no window holding this sample has a minimum; older samples leave with it
            else:
                while size > 0 and window[0, _slot(head + size - 1, slots)] >= level:
                    size -= 1
                back = _slot(head + size, slots)
                window[0, back], window[1, back] = level, i
                size += 1
            oldest = i - p + 1
            if oldest < 0:
                continue
            while size > 0 and window[1, head] < oldest:
                head, size = _slot(head + 1, slots), size - 1
            if last_nan >= oldest:
                continue  # the held level is NaN: no peak
            held = window[0, head]
            if t[i] < onset:
                peak_healthy = max(peak_healthy, held)
                finite_healthy = finite_healthy or np.isfinite(held)
            else:
                peak_fault = max(peak_fault, held)
                finite_fault = finite_fault or np.isfinite(held)
        levels[0, j] = peak_healthy if finite_healthy else np.nan
        if faulty[j]:
            levels[1, j] = peak_fault if finite_fault else np.nan
        levels[2, j] = healthy * dt
        if isolation_window:
            levels[3, j] = 1.0 if _isolated(t, alarm, armed, first_fault, j) else 0.0
        _scaled_alarms(residual, threshold, scales, p, armed, t, onset, j, false_alarms, first, scale_state)


@numba.njit(cache=True, nogil=True, inline="always")
def _slot(position, slots):  # pragma: no cover - compiled
    """A position of a ring of ``slots``, ``position`` at most one turn past its end."""
    return position - slots if position >= slots else position


@numba.njit(cache=True, nogil=True)
def _scaled_alarms(residual, threshold, scales, samples, armed, t, onset, j, false_alarms, first,
                   state):  # pragma: no cover - compiled
    """Joint ``j``'s diagnoser at c times its threshold for every scale c (sorted; ``residual > c * threshold``,
    NaN never above), debounced by :func:`_debounce_step`: the alarms raised while armed before the onset
    into ``false_alarms[s, j]``, the first sample alarmed at or after the onset into ``first[s, j]`` (-1: none).

    Every scale's state machine is the plain one, but a sample steps only the scales it can change. With a
    threshold >= 0 the scales exceeded are the first few (rounding is monotone: c * threshold grows with c).
    A scale settled off (off for ``samples`` samples in a row: its alarm off, and a step off changes nothing)
    has every scale above it settled off too, and a scale settled on every scale below it: so from the first
    scale not exceeded upwards, the steps stop at the first scale settled off, and from the last exceeded
    downwards at the first settled on. Where a threshold is negative (the order reverses) every scale is
    stepped, and for ``samples`` samples after it (until the order holds over a whole run of them again), as
    for the first ``samples`` samples and at the first sample at or after the onset (where a scale that is
    on takes its first alarm)."""
    count = scales.shape[0]
    for s in range(count):
        state[0, s], state[1, s], state[2, s] = 0, 0, 0
        false_alarms[s, j], first[s, j] = 0, -1
    step_all_until, crossed = samples, False
    for i in range(residual.shape[0]):
        r, limit = residual[i, j], threshold[i, j]
        if limit < 0:
            step_all_until = i + samples + 1
        if not crossed and t[i] >= onset:
            crossed = True
            step_all_until = max(step_all_until, i + 1)
        if i < step_all_until:
            for s in range(count):
                _scaled_step(r > scales[s] * limit, s, i, samples, armed, t, onset, j, false_alarms, first, state)
            continue
        exceeded = 0  # the scales exceeded are the first ``exceeded``
        while exceeded < count and r > scales[exceeded] * limit:
            exceeded += 1
        for s in range(exceeded, count):
            if state[1, s] >= samples and state[2, s] == 0:
                break
            _scaled_step(False, s, i, samples, armed, t, onset, j, false_alarms, first, state)
        for s in range(exceeded - 1, -1, -1):
            if state[1, s] >= samples and state[2, s] == 1:
                break
            _scaled_step(True, s, i, samples, armed, t, onset, j, false_alarms, first, state)


@numba.njit(cache=True, nogil=True, inline="always")
def _scaled_step(value, s, i, samples, armed, t, onset, j, false_alarms, first, state):  # pragma: no cover
    """Sample ``i`` of scale ``s``'s diagnoser (``state[:, s]``: its alarm, its run of equal values capped at
    ``samples``, its last value)."""
    alarm_before = state[0, s] != 0
    run, alarm = _debounce_step(value, state[2, s] != 0, state[1, s], alarm_before, samples)
    if alarm and not alarm_before and armed[i] and t[i] < onset:  # raised here
        false_alarms[s, j] += 1
    if alarm and first[s, j] < 0 and t[i] >= onset:
        first[s, j] = i
    state[0, s], state[1, s], state[2, s] = alarm, min(run, samples), value
