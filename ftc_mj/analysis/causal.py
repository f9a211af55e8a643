"""The diagnosis as a causal component: one sample at a time, its state kept, many rows at once.

This is the definition of the scenario's ``diagnosis`` section (:mod:`ftc_mj.analysis.diagnosis` has the
section, its compiled form :class:`~ftc_mj.analysis.diagnosis.Diagnoser` and the metrics). The engine steps it
inside the loop where a controller reads it; the post-run diagnosis is this component run over the recorded
estimate (:meth:`~ftc_mj.analysis.diagnosis.Diagnoser.diagnose_rows`), so both give the same alarms, delays
and isolation.

**Interface** (stable; ``ftc_mj.online`` and the controllers that reconfigure read it)::

    from ftc_mj.analysis.causal import CausalDiagnoser

    diagnoser = CausalDiagnoser(scenario.diagnoser, rows)       # rows: members of a batch (1 for one run)
    for t, estimate, q_meas, qd_hat in samples:                 # each (rows, n), in the diagnosis space
        diagnoser.step(t, estimate, q_meas, qd_hat)
        diagnoser.alarm            # (rows, n) bool: the debounced alarm at this sample
        diagnoser.isolated         # (rows, n) bool: joints whose alarm has been on since the diagnoser was armed
        diagnoser.fault_estimate   # (rows, n): signal - baseline mean (NaN until the baseline is learned)
        diagnoser.alarm_time       # (rows, n): time of each joint's first alarm, NaN before it
        diagnoser.residual, diagnoser.threshold, diagnoser.signal, diagnoser.armed

``step`` takes the time of the sample and ``(rows, n)`` arrays: the LUaF estimate in the diagnoser's space
(``acceleration``: the observer's ``luaf_hat``; ``torque``: M(q_meas) times it), the measured position and
the observer's velocity estimate (for an adaptive threshold ``bound``). The attributes are the component's
own arrays, updated in place at every step: read them, copy them to keep them. :meth:`CausalDiagnoser.reset`
goes back to before the first sample. Every row is a diagnoser of its own: a row's outputs depend on its own
inputs only (the batch-equals-single guarantee).

**In the loop.** A controller class that sets ``reads_diagnosis = True`` gets its variant's component (one row
per member) as ``self.diagnosis`` before the run; each control period the engine steps it on the observer's
estimate of that period, after the observer's ``update`` and before the controller's ``compute``, so
``self.diagnosis.alarm`` in ``compute`` is this period's. A scenario without a ``diagnosis`` section is then
refused in one line. Where the fast paths are on, a step's arithmetic runs compiled
(:mod:`ftc_mj.fast.analysis_diagnosis`, the same bits).

Per sample k at time t_k, per row and joint (the module docstring of :mod:`ftc_mj.analysis.diagnosis` gives the
section's fields):

1. signal s_k: the estimate, or through the first-order low-pass filter exactly discretised, y_k = (1 - a) x_k
   + a y_(k-1), a = exp(-dt / tau), started at the first sample as if it had always been there (y_0 = x_0 up to
   rounding: SciPy's ``lfilter`` with ``zi = a x_0``);
2. baseline: without one, mean 0 and deviation 0 from the first sample. With a window [t0, t1), the samples
   with t0 <= t_k < t1 are kept; at the first sample with t_k + dt >= t1 (up to 1e-9 s: the window's last
   sample on the control grid) the mean m and the standard deviation sd (NumPy's definition, population) are
   computed from them, each sum in time order. Before that the baseline is unknown: the fault estimate and the
   residual are NaN. A run that stops earlier never learns it;
3. fault estimate e_k = s_k - m, residual r_k = |e_k|;
4. armed from ``start`` (t_k >= start, never before the baseline's end: :func:`require_causal`); threshold
   fixed + k sd (+ bound(t_k, q_meas, qd_hat)) while armed, NaN before;
5. the CUSUM rule: g_k = max(0, g_(k-1) + r_k / threshold_k - nu), restarted at 0 where that is NaN (before
   arming); the residual is then g_k and the threshold h (Page, 1954);
6. exceeded: residual > threshold (NaN never exceeds); alarm: the debounce, which switches to a value at its
   ``persistence``-th consecutive sample and starts off;
7. isolated: the alarm has been on at some sample so far (latched until :meth:`~CausalDiagnoser.reset`), and
   the first alarm's time. The post-run metric ``isolation_correct`` knows the fault onsets and looks from
   the first onset on; the component does not, so a false alarm before the onset isolates a joint here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ftc_mj import fast
from ftc_mj.config.errors import InputError
from ftc_mj.results import Diagnosis

if TYPE_CHECKING:  # the section's module imports this one
    from ftc_mj.analysis.diagnosis import Diagnoser


def require_causal(diagnoser: Diagnoser, monitoring_start: float, file: str) -> None:
    """Refuse (one line, :class:`InputError`) a diagnosis that an online diagnoser starting at
    ``monitoring_start`` [s] cannot compute: its baseline window starts before the first sample it sees (it
    would learn from samples it never had), or it is armed before the baseline's end."""
    baseline = diagnoser.baseline
    if baseline is None:
        return
    if diagnoser.start < baseline[1]:
        raise InputError(file, "diagnosis.start", f"the diagnoser is armed at {diagnoser.start:g} s, before its "
                         f"baseline window ends ({baseline[1]:g} s): not causal")
    if baseline[0] < monitoring_start - 1e-9:
        raise InputError(file, "diagnosis.baseline.start",
                         f"the baseline window [{baseline[0]:g}, {baseline[1]:g}) s starts before monitoring does "
                         f"({monitoring_start:g} s): an online diagnoser cannot learn from samples it never saw")


class CausalDiagnoser:
    """The ``diagnosis`` section of a scenario stepped one sample at a time over ``rows`` rows (the module
    docstring); ``diagnoser`` is its compiled form (:class:`~ftc_mj.analysis.diagnosis.Diagnoser`). ``record``:
    where :class:`RecordedDiagnoser` keeps every sample's outputs (use that class rather than this argument)."""

    def __init__(self, diagnoser: Diagnoser, rows: int = 1, *, record: DiagnosisSeries | None = None):
        require_causal(diagnoser, -math.inf, "the scenario")
        #: Where :class:`RecordedDiagnoser` keeps each sample's outputs, or None.
        self._record = record
        n = len(diagnoser.fixed)
        self.diagnoser = diagnoser
        self.rows, self.n = rows, n
        shape = (rows, n)
        self._a = math.exp(-diagnoser.dt / diagnoser.filter_time_constant) if diagnoser.filter_time_constant > 0 \
            else 0.0
        self._b0 = 1.0 - self._a
        self._fixed = np.asarray(diagnoser.fixed, dtype=float)
        self._cusum = diagnoser.rule == "cusum"
        self._samples = max(1, int(diagnoser.persistence))
        window = diagnoser.baseline
        # At most this many samples fall in the baseline window [t0, t1) of a period dt.
        capacity = 1 if window is None else int(math.floor((window[1] - window[0]) / diagnoser.dt + 1e-9)) + 2
        self._window = np.empty((capacity, rows, n))
        #: (rows, n): the (filtered) estimate at the last sample.
        self.signal = np.zeros(shape)
        #: (rows, n): signal - the baseline mean (NaN until the baseline is learned).
        self.fault_estimate = np.zeros(shape)
        #: (rows, n): the decision statistic (|fault estimate|, or the CUSUM's g).
        self.residual = np.zeros(shape)
        #: (rows, n): the threshold (h for the CUSUM rule), NaN while not armed.
        self.threshold = np.zeros(shape)
        #: (rows, n): the debounced alarm.
        self.alarm = np.zeros(shape, dtype=bool)
        #: (rows, n): the alarm has been on at some sample since the last reset.
        self.isolated = np.zeros(shape, dtype=bool)
        #: (rows, n): the time of each joint's first alarm, NaN before it.
        self.alarm_time = np.zeros(shape)
        #: (rows, n): the baseline's mean and standard deviation (0 without one, NaN until learned).
        self.mean = np.zeros(shape)
        self.std = np.zeros(shape)
        self._filtered = np.zeros(shape)  # the filter's state a y_(k-1)
        self._g = np.zeros(shape)  # the CUSUM's sum
        self._exceeded = np.zeros(shape, dtype=bool)
        self._previous = np.zeros(shape, dtype=bool)
        self._same = np.zeros(shape, dtype=bool)
        self._run = np.zeros(shape, dtype=np.int64)
        self._level = np.zeros(shape)  # fixed + k sd
        self._scratch = np.zeros(shape)
        self._bound = np.zeros(shape)  # the threshold's bound at this sample
        self._input = np.zeros(shape)  # the sample's estimate, for the compiled period
        #: The compiled period bound to this component's buffers (:mod:`ftc_mj.fast.analysis_diagnosis`) where
        #: the fast paths are on, else None.
        self._period = None
        if fast.enabled():
            self._bind()
        self.reset()

    def _bind(self) -> None:
        """The compiled period on this component's buffers (again after the window's buffer grows)."""
        from ftc_mj.fast.analysis_diagnosis import bind_period

        d = self.diagnoser
        state = (self.signal, self._filtered, self.mean, self.std, self._level, self.fault_estimate, self.residual,
                 self.threshold, self._g, self._previous, self._run, self.alarm, self.isolated, self.alarm_time)
        record = self._record
        kept = (np.zeros((0, self.rows, self.n)),) * 4 + (np.zeros((0, self.rows, self.n), dtype=bool),)
        if record is not None:
            kept = (record.signal, record.fault_estimate, record.residual, record.threshold, record.alarm)
        self._period = bind_period(self._input, self._bound, self._window, self._fixed, state, kept, self._a,
                                   float(d.k), self._cusum, float(d.drift), float(d.h), self._samples)

    def reset(self) -> None:
        """Back to before the first sample."""
        known = self.diagnoser.baseline is None
        for values in (self.signal, self.fault_estimate, self.residual, self.threshold, self._g, self._filtered):
            values.fill(0.0)
        self.mean.fill(0.0 if known else np.nan)
        self.std.fill(0.0 if known else np.nan)
        self.alarm_time.fill(np.nan)
        for flags in (self.alarm, self.isolated, self._exceeded, self._previous):
            flags.fill(False)
        self._run.fill(0)
        self._kept = 0  # samples of the baseline window kept so far
        self._learned = known
        self._first = True
        self.armed = False
        self._update_level()

    def _update_level(self) -> None:
        np.multiply(self.diagnoser.k, self.std, out=self._level)
        np.add(self._fixed, self._level, out=self._level)

    def step(self, t: float, estimate: np.ndarray, q_meas: np.ndarray | None = None,
             qd_hat: np.ndarray | None = None) -> None:
        """Sample ``t``: ``estimate``, ``q_meas``, ``qd_hat`` ``(rows, n)`` (the last two read only by a threshold
        ``bound``). The outputs are this component's arrays, updated in place. Where the fast paths are on, the
        arithmetic after the baseline's bookkeeping runs in its accelerator
        (:func:`ftc_mj.fast.analysis_diagnosis.bind_period`, the same bits)."""
        self._step(t, estimate, q_meas, qd_hat, -1)

    def _step(self, t: float, estimate: np.ndarray, q_meas: np.ndarray | None, qd_hat: np.ndarray | None,
              k: int) -> None:
        """:meth:`step`, its outputs also kept at sample ``k`` of the record (-1: not kept)."""
        d = self.diagnoser
        keep, learn = -1, False
        if not self._learned:
            window = d.baseline
            if window[0] <= t < window[1]:
                if self._kept == len(self._window):  # irregular samples: more than the period allows
                    self._window = np.concatenate([self._window, np.empty_like(self._window)])
                    if self._period is not None:
                        self._bind()
                keep = self._kept
                self._kept += 1
            # The window's last sample (or one after it): no more to come.
            learn = self._learned = bool(t + d.dt >= window[1] - 1e-9)
        self.armed = armed = bool(t >= d.start)
        record = self._record if k >= 0 else None
        if record is not None:
            record.armed[k] = armed
        bound = None
        if armed and d.bound is not None:
            bound = self._bound
            for j, column in enumerate(d.bound(t, q_meas.T, qd_hat.T)):
                bound[:, j] = column
        if self._period is not None:
            if np.shape(estimate) != (self.rows, self.n):
                raise ValueError(f"the estimate is {np.shape(estimate)}, the diagnoser {(self.rows, self.n)}")
            np.copyto(self._input, estimate)
            self._period(float(t), self._first, keep, learn, self._kept, armed, bound is not None, k)
            self._first = False
            return
        signal = self.signal
        if self._a > 0.0:  # y = b0 x + a y_(k-1), as SciPy's lfilter forms it: the state z = a y
            if self._first:
                np.multiply(self._a, estimate, out=self._filtered)
            np.multiply(self._b0, estimate, out=signal)
            np.add(self._filtered, signal, out=signal)
            np.multiply(self._a, signal, out=self._filtered)
        else:
            signal[...] = estimate
        self._first = False
        if keep >= 0:
            self._window[keep] = signal
        if learn:
            self._learn()
        np.subtract(signal, self.mean, out=self.fault_estimate)
        residual, threshold = self.residual, self.threshold
        np.abs(self.fault_estimate, out=residual)
        if armed:
            threshold[...] = self._level
            if bound is not None:
                threshold += bound
        else:
            threshold.fill(np.nan)
        if self._cusum:  # z = r / threshold; g = max(0, g + z - nu), or 0 (and NaN out) where z is NaN
            g, z = self._g, self._scratch
            np.divide(residual, threshold, out=z)
            np.add(g, z, out=g)
            np.subtract(g, d.drift, out=g)
            np.maximum(g, 0.0, out=g)  # NaN stays NaN
            np.copyto(residual, g)
            np.isnan(g, out=self._exceeded)
            g[self._exceeded] = 0.0
            threshold.fill(d.h if armed else np.nan)
        exceeded = self._exceeded
        np.greater(residual, threshold, out=exceeded)
        run, previous, same = self._run, self._previous, self._same
        # The run of equal values ending here (capped at the persistence): one more where the value repeats
        # (the first sample's run, from 0, is 1 either way), else 1; the alarm takes the value of a full run.
        np.equal(exceeded, previous, out=same)
        np.multiply(run, same, out=run)
        np.add(run, 1, out=run)
        np.minimum(run, self._samples, out=run)
        np.greater_equal(run, self._samples, out=same)
        np.copyto(self.alarm, exceeded, where=same)
        np.copyto(previous, exceeded)
        first = self.alarm & ~self.isolated
        if first.any():
            self.alarm_time[first] = t
            self.isolated |= first
        if record is not None:
            record.signal[k] = self.signal
            record.fault_estimate[k] = self.fault_estimate
            record.residual[k] = residual
            record.threshold[k] = threshold
            record.alarm[k] = self.alarm

    def _learn(self) -> None:
        """The baseline's mean and deviation from the kept samples, sums in time order (NaN without one)."""
        kept = self._window[:self._kept]
        count = self._kept
        with np.errstate(invalid="ignore", divide="ignore"):
            total = np.zeros((self.rows, self.n))
            for sample in kept:
                total += sample
            mean = total / count
            squares = np.zeros((self.rows, self.n))
            for sample in kept:
                deviation = sample - mean
                squares += deviation * deviation
            std = np.sqrt(squares / count)
        self.mean[...] = mean
        self.std[...] = std
        self._update_level()


@dataclass
class DiagnosisSeries:
    """Every output of a :class:`CausalDiagnoser` over a run, ``(T, rows, n)`` (``armed`` ``(T,)``), and the
    baseline it learned ``(rows, n)``."""

    signal: np.ndarray
    fault_estimate: np.ndarray
    residual: np.ndarray
    threshold: np.ndarray
    alarm: np.ndarray
    armed: np.ndarray
    mean: np.ndarray
    std: np.ndarray

    def of_row(self, row: int, space: str, t: np.ndarray, injected: np.ndarray, kept: slice = slice(None)
               ) -> Diagnosis:
        """Row ``row``'s :class:`~ftc_mj.results.Diagnosis` over the samples ``kept`` (its times ``t``, the true
        fault ``injected`` in the diagnosis space)."""
        return Diagnosis(space=space, t=t, signal=self.signal[kept, row], fault_estimate=self.fault_estimate[kept, row],
                         residual=self.residual[kept, row], threshold=self.threshold[kept, row],
                         alarm=self.alarm[kept, row], armed=self.armed[kept], mean=self.mean[row], std=self.std[row],
                         injected=injected)


def run_causal(diagnoser: Diagnoser, t: np.ndarray, estimate: np.ndarray, q_meas: np.ndarray,
               qd_hat: np.ndarray) -> DiagnosisSeries:
    """The component stepped over recorded ``(T, rows, n)`` arrays, sample by sample: the definition of the
    post-run diagnosis (:meth:`~ftc_mj.analysis.diagnosis.Diagnoser.diagnose_rows` runs its accelerator where
    the fast paths are on)."""
    steps, rows, n = estimate.shape
    recorded = RecordedDiagnoser(diagnoser, rows, steps)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):  # NaN and inf are inputs like others
        for i in range(steps):
            recorded.step(i, float(t[i]), estimate[i], q_meas[i], qd_hat[i])
    return recorded.series


class RecordedDiagnoser:
    """A :class:`CausalDiagnoser` over ``rows`` rows whose outputs are kept for ``steps`` samples
    (:attr:`series`, ``(steps, rows, n)``): stepped by the engine inside the loop, where a controller reads
    it (:attr:`component`) before it commands, and the post-run diagnosis made during the run."""

    def __init__(self, diagnoser: Diagnoser, rows: int, steps: int):
        n = len(diagnoser.fixed)
        series = DiagnosisSeries(*(np.full((steps, rows, n), np.nan) for _ in range(4)),
                                 np.zeros((steps, rows, n), dtype=bool), np.zeros(steps, dtype=bool),
                                 np.zeros((rows, n)), np.zeros((rows, n)))
        self.component = CausalDiagnoser(diagnoser, rows, record=series)
        series.mean, series.std = self.component.mean, self.component.std
        self.series = series

    def step(self, k: int, t: float, estimate: np.ndarray, q_meas: np.ndarray, qd_hat: np.ndarray) -> None:
        """Sample ``k`` at time ``t`` (the arguments of :meth:`CausalDiagnoser.step`), kept at ``k``."""
        self.component._step(t, estimate, q_meas, qd_hat, k)
