"""Accelerator of the detection statistics' held levels and scaled alarms
(:func:`ftc_mj.analysis.diagnosis.detection_statistics`, whose NumPy definition is ``_held_peaks`` and
``_scaled_alarms`` there).

:func:`detection_pass` returns what the definition returns: the same peaks (a minimum and a maximum are exact
in any order) and the same integer counts and first samples; its conformance test
(``tests/fast/test_analysis_detection.py``) asserts equality on random and edge-case inputs.
"""

from __future__ import annotations

import numpy as np

import ftc_mj.fast  # noqa: F401  (sets Numba's options before Numba is imported)
import numba  # noqa: E402


def detection_pass(t: np.ndarray, residual: np.ndarray, threshold: np.ndarray, armed: np.ndarray,
                   onsets: np.ndarray, p: int, scales: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(peaks (2, n), false_alarms (S, n), first (S, n))`` of the definition, from ``(T, n)`` residual and
    threshold, ``(T,)`` times and armed flags, ``(n,)`` onsets (inf: healthy) and ``(S,)`` scales in any order.
    Checks shapes and dtypes at its boundary (copies where they differ)."""
    t = np.ascontiguousarray(t, dtype=np.float64)
    residual = np.ascontiguousarray(residual, dtype=np.float64)
    threshold = np.ascontiguousarray(threshold, dtype=np.float64)
    armed = np.ascontiguousarray(armed, dtype=np.bool_)
    onsets = np.ascontiguousarray(onsets, dtype=np.float64)
    steps, n = residual.shape
    if threshold.shape != (steps, n) or t.shape != (steps,) or armed.shape != (steps,) or onsets.shape != (n,):
        raise ValueError(f"detection_pass: shapes {t.shape}, {residual.shape}, {threshold.shape}, {armed.shape}, "
                         f"{onsets.shape} do not match")
    scales = np.asarray(scales, dtype=np.float64)
    order = np.argsort(scales, kind="stable")
    ordered = np.ascontiguousarray(scales[order])  # the pass wants them sorted
    p = max(1, int(p))
    peaks = np.full((2, n), np.nan)
    false_alarms = np.empty((len(scales), n), dtype=np.int64)
    first = np.empty((len(scales), n), dtype=np.int64)
    scale_state = np.empty((3, len(scales)), dtype=np.int64)  # per scale: the alarm, the run, the last value
    window = np.empty((2, p + 1))  # the level's minimum over the last p samples: values and their samples
    _detection_pass(t, residual, threshold, armed, onsets, p, ordered, peaks, false_alarms, first, scale_state,
                    window)
    unsorted = np.empty_like(order)
    unsorted[order] = np.arange(len(order))
    return peaks, false_alarms[unsorted], first[unsorted]


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _detection_pass(t, residual, threshold, armed, onsets, p, scales, peaks, false_alarms, first, scale_state,
                    window):  # pragma: no cover - compiled
    """:func:`detection_pass`, one pass along each joint: into ``peaks`` (NaN where undefined, as the caller
    fills it) the two peaks; per scale, the false alarms and the first alarmed sample at or after the onset
    (-1: none) of :func:`_scaled_alarms`.

    The level z = residual / threshold (NaN unarmed) held over a window of ``p`` samples is its minimum there,
    NaN if one is NaN (NumPy's ``minimum``), kept by a monotone queue in ``window`` (``p + 1`` slots); a peak
    is the largest held level, NaN when none is finite (so a peak of inf alone is NaN)."""
    steps, n = residual.shape
    slots = window.shape[1]
    for j in range(n):
        onset = onsets[j]
        head, size, last_nan = 0, 0, -1
        peak_healthy, peak_fault, finite_healthy, finite_fault = -np.inf, -np.inf, False, False
        for i in range(steps):
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
        if finite_healthy:
            peaks[0, j] = peak_healthy
        if finite_fault:
            peaks[1, j] = peak_fault
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

@numba.njit(cache=True, nogil=True, inline="always")
def _debounce_step(value: bool, previous: bool, run: int, state: bool, samples: int) -> tuple[int, bool]:
    """One sample of the debounce: the run of equal samples ending here (``run`` 0 before the first sample) and
    the alarm, the value of the last run of ``samples`` equal samples that ends at or before it (off before
    any): the alarm switches at the ``samples``-th consecutive sample of a value."""
    run = run + 1 if run > 0 and value == previous else 1
    return run, value if run >= samples else state


