"""Conformance of the causal diagnoser's accelerators (ftc_mj.fast.analysis_diagnosis: the whole-array pass of
the post-run diagnosis and the compiled period of a step) to their definition, the NumPy component stepped
sample by sample (ftc_mj.analysis.causal, the fast paths off): equal bits (tolerance 0) on random and edge-case
inputs (NaN, inf, runs shorter than the baseline, an empty baseline window, one joint, a filter, a bound, both
rules, persistence 1 and more, several rows)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from ftc_mj import fast
from ftc_mj.analysis.causal import CausalDiagnoser, run_causal
from ftc_mj.analysis.diagnosis import Diagnoser
from ftc_mj.config.expressions import StateFunction, parse, state_variables

DT = 1e-3


def _diagnoser(n: int, **kwargs) -> Diagnoser:
    values = {"space": "acceleration", "dt": DT, "start": 0.0, "fixed": np.full(n, 0.5), "k": 0.0,
              "persistence": 1}
    return Diagnoser(**{**values, **kwargs})


def _bound(n: int) -> StateFunction:
    variables = state_variables(n)
    return StateFunction([parse(f"0.1 + 0.05*abs(qd{j + 1}) + 0.01*t", variables) for j in range(n)], n)


CASES = {
    "plain": {},
    "baseline": {"baseline": (0.02, 0.05), "start": 0.05, "k": 3.0},
    "baseline never learned": {"baseline": (0.02, 5.0), "start": 5.0, "k": 3.0},
    "empty baseline window": {"baseline": (0.0205, 0.0206), "start": 0.03, "k": 1.0},
    "filter": {"filter_time_constant": 0.01, "baseline": (0.0, 0.03), "start": 0.04, "k": 2.0},
    "persistence": {"persistence": 4, "start": 0.01},
    "cusum": {"rule": "cusum", "drift": 0.5, "h": 3.0, "start": 0.01, "persistence": 2},
    "bound": {"bound": "bound", "start": 0.005},
    "everything": {"bound": "bound", "rule": "cusum", "drift": 0.2, "h": 2.0, "filter_time_constant": 0.005,
                   "baseline": (0.0, 0.02), "start": 0.025, "k": 1.0, "persistence": 3},
}


def _inputs(rng: np.random.Generator, steps: int, rows: int, n: int, edges: bool) -> tuple[np.ndarray, ...]:
    estimate = rng.normal(size=(steps, rows, n)) * 10.0 ** rng.uniform(-2, 1, n)
    estimate[steps // 2:] += rng.uniform(0, 3, n)  # a fault
    if edges and steps > 10:
        estimate[3, 0, 0] = np.nan
        estimate[steps - 4, rows - 1, n - 1] = np.inf
        estimate[steps // 3, 0, n - 1] = -np.inf
        estimate[steps // 4:steps // 4 + 3, rows - 1, 0] = np.nan
    q, qd = rng.normal(size=(steps, rows, n)), rng.normal(size=(steps, rows, n))
    return np.arange(steps) * DT, estimate, q, qd


@pytest.mark.parametrize("case", sorted(CASES))
def test_the_accelerator_gives_the_components_bits(case):
    rng = np.random.default_rng(sorted(CASES).index(case))
    for (steps, rows, n), edges in itertools.product([(80, 3, 2), (80, 1, 1), (7, 2, 1), (1, 1, 3), (0, 2, 2)],
                                                     (False, True)):
        kwargs = dict(CASES[case])
        if kwargs.get("bound") == "bound":
            kwargs["bound"] = _bound(n)
        diagnoser = _diagnoser(n, **kwargs)
        t, estimate, q, qd = _inputs(rng, steps, rows, n, edges)
        fast.set_enabled(False)
        try:
            definition = run_causal(diagnoser, t, estimate, q, qd)
        finally:
            fast.set_enabled(True)
        for accelerated in (diagnoser.diagnose_rows(t, estimate, q, qd), run_causal(diagnoser, t, estimate, q, qd)):
            for name in ("signal", "fault_estimate", "residual", "threshold", "alarm", "armed", "mean", "std"):
                expected, actual = getattr(definition, name), getattr(accelerated, name)
                assert actual.shape == expected.shape, name
                assert np.array_equal(actual, expected, equal_nan=True), (case, steps, rows, n, edges, name)


def _final_isolation(diagnoser: Diagnoser, t, estimate, q, qd, accelerated: bool) -> tuple[np.ndarray, ...]:
    fast.set_enabled(accelerated)
    try:
        component = CausalDiagnoser(diagnoser, estimate.shape[1])
    finally:
        fast.set_enabled(True)
    with np.errstate(all="ignore"):
        for i in range(len(t)):
            component.step(float(t[i]), estimate[i], q[i], qd[i])
    return component.isolated.copy(), component.alarm_time.copy()


@pytest.mark.parametrize("case", ["persistence", "cusum", "everything"])
def test_the_compiled_period_isolates_as_the_definition(case):
    """The latched isolation and the first alarm's time, stepped with the compiled period and without."""
    n = 2
    kwargs = dict(CASES[case])
    if kwargs.get("bound") == "bound":
        kwargs["bound"] = _bound(n)
    diagnoser = _diagnoser(n, **kwargs)
    t, estimate, q, qd = _inputs(np.random.default_rng(3), 80, 3, n, edges=True)
    definition = _final_isolation(diagnoser, t, estimate, q, qd, accelerated=False)
    compiled = _final_isolation(diagnoser, t, estimate, q, qd, accelerated=True)
    assert definition[0].any()
    assert np.array_equal(definition[0], compiled[0])
    assert np.array_equal(definition[1], compiled[1], equal_nan=True)


def test_every_row_is_a_diagnoser_of_its_own():
    """Rows stepped together give each row's outputs alone (3 rows, 2 joints; a NaN in one row stays there)."""
    rng = np.random.default_rng(7)
    n = 2
    diagnoser = _diagnoser(n, **{**CASES["everything"], "bound": _bound(n)})
    t, estimate, q, qd = _inputs(rng, 60, 3, n, edges=True)
    together = run_causal(diagnoser, t, estimate, q, qd)
    for row in range(3):
        alone = run_causal(diagnoser, t, estimate[:, row:row + 1], q[:, row:row + 1], qd[:, row:row + 1])
        for name in ("signal", "fault_estimate", "residual", "threshold", "alarm"):
            assert np.array_equal(getattr(alone, name)[:, 0], getattr(together, name)[:, row], equal_nan=True)


def test_the_component_reports_isolation_and_first_alarm_time_and_resets():
    """``isolated`` latches a joint whose alarm has been on; ``alarm_time`` is its first alarm's time; reset
    forgets both."""
    diagnoser = CausalDiagnoser(_diagnoser(2, fixed=np.ones(2), persistence=2), rows=1)
    zeros = np.zeros((1, 2))
    for k, value in enumerate([0.0, 2.0, 2.0, 2.0, 0.0, 0.0, 0.0]):
        diagnoser.step(k * DT, np.array([[value, 0.0]]), zeros, zeros)
        assert diagnoser.alarm[0, 0] == (2 <= k <= 4)
    assert diagnoser.isolated.tolist() == [[True, False]]
    assert diagnoser.alarm_time[0, 0] == 2 * DT and np.isnan(diagnoser.alarm_time[0, 1])
    diagnoser.reset()
    assert not diagnoser.isolated.any() and np.isnan(diagnoser.alarm_time).all()
