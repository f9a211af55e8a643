"""The ``diagnosis`` section compiled (ftc_mj.analysis.diagnosis.compile_diagnoser): where the diagnoser is
armed from, the baseline it learns on (one that ends exactly at the first onset is fault-free), and the
adaptive bound, evaluated on the robot's joints."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.analysis.diagnosis import DiagnosisSpec, compile_diagnoser
from ftc_mj.config.errors import InputError


def _compile(section: dict, onsets=(5.0,), n: int = 2):
    return compile_diagnoser(DiagnosisSpec.model_validate(section), 0.001, 0.7, "s.yaml", n, list(onsets))


def test_armed_from_start_else_the_baseline_end_else_the_estimation_window():
    assert _compile({"threshold": {"fixed": 1.0}, "start": 2.5}).start == 2.5
    with_baseline = _compile({"threshold": {"k": 3.0}, "baseline": {"start": 1.0, "end": 4.0}})
    assert with_baseline.start == 4.0 and with_baseline.baseline == (1.0, 4.0)
    plain = _compile({"threshold": {"fixed": 1.0}})
    assert plain.start == 0.7 and plain.baseline is None and plain.bound is None


def test_a_baseline_may_end_at_the_first_onset_not_after_it():
    assert _compile({"threshold": {"k": 3.0}, "baseline": {"start": 1.0, "end": 5.0}}).baseline == (1.0, 5.0)
    with pytest.raises(InputError, match="fault-free"):
        _compile({"threshold": {"k": 3.0}, "baseline": {"start": 1.0, "end": 5.001}})


def test_the_bound_is_a_function_of_the_robots_state():
    diagnoser = _compile({"threshold": {"bound": ["1 + q1", "2*qd2 + t"]}})
    out = np.zeros((1, 2))
    diagnoser.bound.evaluate(0.5, np.array([[0.25, 0.0]]), np.array([[0.0, 3.0]]), np.zeros((1, 0)), out)
    np.testing.assert_array_equal(out, [[1.25, 6.5]])


def test_the_diagnoser_carries_the_sections_values():
    """Every field of the section reaches the compiled diagnoser: the space, the period, k, the filter and a
    persistence of one sample (the bare rule, not raised to two)."""
    diagnoser = _compile({"space": "torque", "threshold": {"k": 3.0, "fixed": [0.5, 0.25]},
                          "baseline": {"start": 1.0, "end": 4.0}, "filter_time_constant": 0.02,
                          "persistence": {"samples": 1}})
    assert (diagnoser.space, diagnoser.dt, diagnoser.k) == ("torque", 0.001, 3.0)
    assert diagnoser.filter_time_constant == 0.02 and diagnoser.persistence == 1
    np.testing.assert_array_equal(diagnoser.fixed, [0.5, 0.25])
    plain = _compile({"threshold": {"fixed": 1.0}, "persistence": {"samples": 7}})
    assert (plain.space, plain.filter_time_constant, plain.persistence, plain.rule) == ("acceleration", 0.0, 7,
                                                                                          "threshold")
