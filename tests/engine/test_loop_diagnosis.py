"""The diagnosis inside the loop (ftc_mj.engine.loop, ftc_mj.analysis.causal): on every shipped scenario with a
``diagnosis`` section, the causal diagnoser stepped each period on each variant's estimate gives the post-run
diagnosis of the recorded estimate (the same alarms, delays and isolation: the same bits of every series); a
controller that declares ``reads_diagnosis`` reads the component before it commands, and one without a
diagnosis section is refused in one line."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from ftc_mj.analysis.diagnosis import diagnose_result, diagnosis_metrics
from ftc_mj.analysis.metrics import onsets_per_joint
from ftc_mj.config.errors import InputError
from ftc_mj.engine.loop import simulate
from ftc_mj.engine.members import single
from ftc_mj.engine.runner import variant_result
from ftc_mj.scenario.definition import Scenario
from ftc_mj.scenario.loading import load_scenario

ROOT = Path(__file__).resolve().parents[2]


def _shipped() -> list[Path]:
    """The shipped scenarios (not their bases); those without a diagnosis are skipped when loaded."""
    return [path for path in sorted((ROOT / "scenarios").rglob("*.yaml")) if "bases" not in path.parts]


def _short(path: Path) -> Scenario:
    """The scenario cut to half a second after its first fault onset (or 1.5 s after the diagnoser is armed
    without faults): the baseline, the arming, the onset and the detections all happen. A replayed log runs
    whole (some thousands of periods; its events, scored against, may lie anywhere in it)."""
    scenario = load_scenario(path)
    diagnoser = scenario.diagnoser
    if diagnoser is None or scenario.log is not None:
        return scenario
    end = min(scenario.fault_onsets, default=diagnoser.start + 1.0) + 0.5
    return load_scenario(path, duration=min(scenario.spec.duration, end))


@pytest.mark.slow
@pytest.mark.parametrize("path", _shipped(), ids=lambda path: str(path.relative_to(ROOT / "scenarios")))
def test_the_diagnosis_in_the_loop_is_the_post_run_diagnosis(path):
    scenario = _short(path)
    if scenario.diagnoser is None:
        pytest.skip("no diagnosis section")
    run = simulate(scenario, single(scenario), diagnose_in_loop=True)
    n = scenario.n_joints
    joint_onsets = onsets_per_joint(scenario.joint_fault_onsets, scenario.fault_onsets, n)
    first_fault = min(scenario.fault_onsets, default=np.inf)
    armed_samples = 0
    for v, variant in enumerate(scenario.variants):
        result = variant_result(scenario, run, v, 0)
        in_loop = result.diagnosis
        after = dataclasses.replace(result, diagnosis=None)
        diagnose_result(scenario.diagnoser, after, None if run.luaf_torque is None else run.luaf_torque[:, v])
        post_run = after.diagnosis
        for name in ("signal", "fault_estimate", "residual", "threshold", "alarm", "armed", "mean", "std"):
            assert np.array_equal(getattr(in_loop, name), getattr(post_run, name), equal_nan=True), (variant.name, name)
        assert in_loop.alarm_times() == post_run.alarm_times()
        metrics = [diagnosis_metrics(d, joint_onsets, first_fault, n) for d in (in_loop, post_run)]
        for name in ("detection_delay", "missed_detection", "false_alarms", "isolation_correct"):
            assert np.array_equal(metrics[0][name], metrics[1][name], equal_nan=True), (variant.name, name)
        armed_samples += int(in_loop.armed.sum())
    assert armed_samples > 0  # the shortened run still diagnoses


@pytest.mark.slow
def test_a_controller_that_reads_the_diagnosis_sees_this_periods_alarms(monkeypatch):
    """A controller with ``reads_diagnosis`` gets the variant's component as ``controller.diagnosis``, stepped
    on this period's estimate before ``compute``: what it saw at each period is the recorded alarm there."""
    from ftc_mj.methods.controllers.base import Controller

    scenario = load_scenario(ROOT / "scenarios" / "faults" / "puma_bias.yaml", duration=8.5)
    controller_type = scenario.variants[0].controller_type
    seen: list[np.ndarray] = []

    class Reading(controller_type):
        reads_diagnosis = True

        def compute(self, t, q_ref, qd_ref, qdd_ref, q_meas, observer, model):
            seen.append(self.diagnosis.alarm.copy())
            return super().compute(t, q_ref, qd_ref, qdd_ref, q_meas, observer, model)

    variant = dataclasses.replace(scenario.variants[0], controller_type=Reading)
    scenario = dataclasses.replace(scenario, variants=[variant])
    run = simulate(scenario, single(scenario))
    assert "diagnosis" not in vars(Controller) and variant.name in run.diagnosis
    recorded = run.diagnosis[variant.name].alarm[:, 0]
    assert len(seen) == len(recorded) and recorded.any()
    np.testing.assert_array_equal(np.array(seen)[:, 0], recorded)

    bare = dataclasses.replace(scenario, diagnoser=None)
    with pytest.raises(InputError, match="reads the diagnosis: the scenario needs a diagnosis section"):
        simulate(bare, single(bare))
