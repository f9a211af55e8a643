"""Accelerator of the causal diagnoser (:class:`ftc_mj.analysis.causal.CausalDiagnoser`) over a recorded run.

:func:`causal_pass` gives what the component stepped sample by sample gives (:func:`ftc_mj.analysis.causal.
run_causal`), in one compiled pass per row and joint: the same operations in the same order, so the same bits
(its conformance test, ``tests/fast/test_analysis_diagnosis.py``, asserts equality on random and edge-case
inputs). The adaptive threshold's ``bound`` is evaluated by the caller on every sample at once.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

import ftc_mj.fast  # noqa: F401  (sets Numba's options before Numba is imported)
import numba  # noqa: E402

from ftc_mj.fast.kernels import WITHOUT_RUNTIME, bound  # noqa: E402


def causal_pass(t: np.ndarray, estimate: np.ndarray, bound: np.ndarray | None, fixed: np.ndarray, k: float,
                start: float, baseline: tuple[float, float] | None, dt: float, a: float, cusum_rule: bool,
                drift: float, h: float, samples: int) -> tuple[np.ndarray, ...]:
    """The component's outputs over ``(T, rows, n)`` ``estimate`` at increasing times ``t``: ``signal,
    fault_estimate, residual, threshold, alarm, armed, mean, std`` (the last two ``(rows, n)``). ``bound``
    ``(T, rows, n)`` or None; ``dt`` the period; ``a`` the filter's pole (0: no filter). Checks its arguments'
    shapes, dtypes and the times' order (a ValueError otherwise)."""
    t = np.ascontiguousarray(t, dtype=np.float64)
    estimate = np.ascontiguousarray(estimate, dtype=np.float64)
    if estimate.ndim != 3 or t.shape != (estimate.shape[0],):
        raise ValueError(f"causal_pass: estimate {estimate.shape} and t {t.shape} do not match")
    if t.size > 1 and not np.all(t[1:] > t[:-1]):
        raise ValueError("causal_pass: the times are not increasing")
    steps, rows, n = estimate.shape
    if bound is None:
        bound = np.zeros((0, rows, n))
    bound = np.ascontiguousarray(bound, dtype=np.float64)
    if bound.shape[0] not in (0, steps) or bound.shape[1:] != (rows, n):
        raise ValueError(f"causal_pass: bound {bound.shape} does not match estimate {estimate.shape}")
    fixed = np.ascontiguousarray(np.broadcast_to(np.asarray(fixed, dtype=np.float64), (n,)))
    if baseline is None:
        first, stop, learned_at, has_baseline = 0, 0, 0, False
    else:  # the window's samples [first, stop); learned at the first sample with t + dt >= its end
        first, stop = (int(i) for i in np.searchsorted(t, baseline, side="left"))
        learned_at = int(np.searchsorted(t + float(dt), baseline[1] - 1e-9, side="left"))
        stop = min(stop, learned_at + 1)
        has_baseline = True
    shape = (steps, rows, n)
    signal, fault_estimate, residual, threshold = (np.empty(shape) for _ in range(4))
    alarm, armed = np.empty(shape, dtype=np.bool_), t >= start
    mean, std = np.empty((rows, n)), np.empty((rows, n))
    _pass(t, estimate, bound, fixed, float(k), first, stop, learned_at, has_baseline, float(a), 1.0 - float(a),
          bool(cusum_rule), float(drift), float(h), max(1, int(samples)), armed, signal, fault_estimate, residual,
          threshold, alarm, mean, std)
    return signal, fault_estimate, residual, threshold, alarm, armed, mean, std


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _pass(t, estimate, bound, fixed, k, first, stop, learned_at, has_baseline, a, b0, cusum_rule, drift, h, samples,
          armed, signal, fault_estimate, residual, threshold, alarm, mean, std):  # pragma: no cover - compiled
    steps, rows, n = estimate.shape
    with_bound = bound.shape[0] > 0
    for r in range(rows):
        for j in range(n):
            z = 0.0
            for i in range(steps):  # the filter: y = b0 x + z, z = a y, z = a x_0 before the first sample
                x = estimate[i, r, j]
                if a > 0.0:
                    if i == 0:
                        z = a * x
                    y = z + b0 * x
                    z = a * y
                else:
                    y = x
                signal[i, r, j] = y
            m, sd = 0.0, 0.0
            if has_baseline:
                if learned_at < steps:  # learned at that sample from the window's samples, sums in time order
                    total = 0.0
                    for i in range(first, stop):
                        total += signal[i, r, j]
                    count = stop - first
                    m = total / count
                    squares = 0.0
                    for i in range(first, stop):
                        d = signal[i, r, j] - m
                        squares += d * d
                    sd = np.sqrt(squares / count)
                else:
                    m, sd = np.nan, np.nan
            mean[r, j], std[r, j] = m, sd
            level = fixed[j] + k * sd
            known = learned_at if has_baseline else 0  # the sample from which the baseline is known
            g, state, run, previous = 0.0, False, 0, False
            for i in range(steps):
                centre = m if i >= known else np.nan
                e = signal[i, r, j] - centre
                fault_estimate[i, r, j] = e
                value = abs(e)
                limit = np.nan
                if armed[i]:
                    limit = level + bound[i, r, j] if with_bound else level
                if cusum_rule:
                    g = g + value / limit - drift
                    g = g if g >= 0.0 or g != g else 0.0
                    value = g
                    if g != g:
                        g = 0.0
                    limit = h if armed[i] else np.nan
                residual[i, r, j], threshold[i, r, j] = value, limit
                exceeded = value > limit
                run = run + 1 if exceeded == previous else 1
                if run > samples:
                    run = samples
                if run >= samples:
                    state = exceeded
                previous = exceeded
                alarm[i, r, j] = state


def bind_period(estimate: np.ndarray, bound_values: np.ndarray, window: np.ndarray, fixed: np.ndarray,
                state: tuple[np.ndarray, ...], kept: tuple[np.ndarray, ...], a: float, k: float, cusum_rule: bool,
                drift: float, h: float, samples: int) -> Callable[..., None]:
    """:func:`_period`, the accelerator of one :meth:`~ftc_mj.analysis.causal.CausalDiagnoser.step` after its
    Python part (the baseline window's bookkeeping, the arming, the threshold's ``bound``), bound to the
    component's buffers (:func:`ftc_mj.fast.kernels.bound`, which checks them once): a call of the period's
    ``(t, first, keep, learn, count, armed, with_bound, sample)``. ``state``: signal, filter state, mean, std,
    level, fault estimate, residual, threshold, CUSUM sum, previous value, run, alarm, isolated, first alarm
    time, each ``(rows, n)``; ``kept``: the record's signal, fault estimate, residual, threshold and alarm
    ``(T, rows, n)``, into which the outputs also go at ``sample`` (-1: not kept; ``(0, rows, n)`` without one). The same operations in the same order as the NumPy step on every row and joint, so the same
    bits (its conformance test steps the component with and without it)."""
    return bound(_period, estimate, bound_values, window, fixed, *state, *kept, float(a), 1.0 - float(a),
                 float(k), bool(cusum_rule), float(drift), float(h), int(samples),
                 free=(0.0, False, 0, False, 0, False, False, 0))


@numba.njit(cache=True, nogil=True, error_model="numpy", **WITHOUT_RUNTIME)
def _period(estimate, bound, window, fixed, signal, filtered, mean, std, level, fault_estimate, residual, threshold,
            g, previous, run, alarm, isolated, alarm_time, kept_signal, kept_fault_estimate, kept_residual,
            kept_threshold, kept_alarm, a, b0, k, cusum_rule, drift, h, samples, t, first, keep, learn, count, armed,
            with_bound, sample):  # pragma: no cover - compiled
    rows, n = estimate.shape
    for r in range(rows):
        for j in range(n):
            x = estimate[r, j]
            if a > 0.0:
                if first:
                    filtered[r, j] = a * x
                y = filtered[r, j] + b0 * x
                filtered[r, j] = a * y
            else:
                y = x
            signal[r, j] = y
            if keep >= 0:
                window[keep, r, j] = y
            if learn:  # the baseline from the kept samples, sums in time order
                total = 0.0
                for i in range(count):
                    total += window[i, r, j]
                m = total / count
                squares = 0.0
                for i in range(count):
                    d = window[i, r, j] - m
                    squares += d * d
                sd = np.sqrt(squares / count)
                mean[r, j], std[r, j] = m, sd
                level[r, j] = fixed[j] + k * sd
            e = y - mean[r, j]
            fault_estimate[r, j] = e
            value = abs(e)
            limit = np.nan
            if armed:
                limit = level[r, j] + bound[r, j] if with_bound else level[r, j]
            if cusum_rule:
                s = g[r, j] + value / limit - drift
                s = s if s >= 0.0 or s != s else 0.0
                value = s
                g[r, j] = 0.0 if s != s else s
                limit = h if armed else np.nan
            residual[r, j], threshold[r, j] = value, limit
            exceeded = value > limit
            length = run[r, j] + 1 if exceeded == previous[r, j] else 1
            if length > samples:
                length = samples
            run[r, j] = length
            if length >= samples:
                alarm[r, j] = exceeded
            previous[r, j] = exceeded
            if alarm[r, j] and not isolated[r, j]:
                isolated[r, j] = True
                alarm_time[r, j] = t
            if sample >= 0:
                kept_signal[sample, r, j] = y
                kept_fault_estimate[sample, r, j] = e
                kept_residual[sample, r, j] = value
                kept_threshold[sample, r, j] = limit
                kept_alarm[sample, r, j] = alarm[r, j]
