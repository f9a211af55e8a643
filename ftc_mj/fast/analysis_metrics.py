"""Accelerator of the built-in series metrics (their NumPy definitions: the registry of
:mod:`ftc_mj.analysis.metrics`).

:func:`series_pass` computes every metric of :data:`ACCELERATED` for ``(T, W, n)`` series in one compiled pass
(two over each column's converged window): sums of squares in time order from 0, maxima that NaN poisons,
settling times as state updated sample by sample. Its conformance test (``tests/fast/test_analysis_metrics.py``)
checks it against the definitions on random and edge-case inputs (NaN, short windows, one joint) to 1e-12
relative: the sums are in time order as NumPy's along the time axis of a ``(T, m)`` array with m >= 2 (a single
column NumPy sums pairwise, which differs in the last bits).
"""

from __future__ import annotations

import numpy as np

import ftc_mj.fast  # noqa: F401  (sets Numba's options before Numba is imported)
import numba  # noqa: E402

from ftc_mj.fast.kernels import for_any_layout  # noqa: E402


def series_pass(t: np.ndarray, columns: tuple[np.ndarray, ...], flags: np.ndarray, window_start: float,
                settle: float, fault_window: float, tolerances: np.ndarray, onsets: np.ndarray, until: np.ndarray,
                limits: np.ndarray) -> np.ndarray:
    """``(len(ACCELERATED), W, n)``: the metrics of :data:`ACCELERATED` of the ``(T, W, n)`` ``columns``
    (q_true, q_ref, qd_true, qd_hat, luaf_true, luaf_hat, tau, sliding) at times ``t``, from the per-sample
    ``flags`` ``(5, T)`` (estimation window, outside the settle intervals, the estimates' transient, before
    the first fault, estimation window after it), the tolerances (tracking, velocity, LUaF, sliding) and per
    joint its first onset, the next onset after it and its torque limit. Checks the shapes at its boundary;
    any float layout (strided views, a broadcast reference) is read in place."""
    columns = tuple(_read_only(values) for values in columns)
    t = _read_only(t)
    steps, width, n = columns[0].shape
    if len(columns) != 8 or any(values.shape != (steps, width, n) for values in columns) or t.shape != (steps,) \
            or flags.shape != (5, steps) or any(np.shape(v) != (n,) for v in (onsets, until, limits)):
        raise ValueError("series_pass: the series, times, flags and per-joint values do not match")
    out = np.empty((len(ACCELERATED), width, n))
    state = np.repeat(_STATE_START[:, None, None], width, axis=1).repeat(n, axis=2)
    searching = np.ones((6, width, n), dtype=bool)  # each settling time searching; no previous sample inside
    searching[5] = False
    arguments = (t, *columns, np.ascontiguousarray(flags, dtype=bool), float(window_start), float(settle),
                 float(fault_window), np.asarray(tolerances, dtype=float), np.asarray(onsets, dtype=float),
                 np.asarray(until, dtype=float), np.asarray(limits, dtype=float), out, state, searching,
                 np.zeros((4, width, n), dtype=np.int64))
    for_any_layout(_series_pass, *arguments)(*arguments)
    return out


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

#: The metrics of :func:`_series_pass`'s output, in its order: the built-in series metrics.
ACCELERATED: tuple[str, ...] = (
    "rms_error", "max_error", "rms_error_converged", "max_error_converged", "convergence_time",
    "rms_velocity_error", "rms_luaf_error", "observer_convergence_time", "luaf_convergence_time",
    "peak_luaf_error_transient", "luaf_overshoot", "rms_luaf_error_fault", "first_reaching_time",
    "reaching_time", "fault_peak_error", "recovery_time", "rms_torque", "chattering", "saturation_time",
)


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
    """Every metric of :data:`ACCELERATED` into ``out[metric, w, j]``, from ``(T, W, n)`` series (see
    :func:`series_pass`) and the per-sample ``flags`` (estimation window, outside the settle intervals, the
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
