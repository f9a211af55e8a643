"""The tracking task's actuators: every entry under the robot's torque limits, applied by the plant (MuJoCo's
``ctrlrange``), the actuator faults acting on what the limited motor gives; the diagnosis task's populations
do not see the tracking limits (their protocol digests stay), and their fault populations on an arm whose
motors limit the torque were redone with the faults acting after the limit."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from ftc_mj.engine.runner import run_scenario
from ftc_mj.ranking.entries import load_bench
from ftc_mj.ranking.execute import protocol_digest
from ftc_mj.ranking.suite import REFERENCE, load_suite
from ftc_mj.scenario.loading import load_scenario


def _scenario(folder, suite, robot: str, task: str, variants: dict):
    (folder / "stage.yaml").write_text(yaml.safe_dump(suite.stage(robot)))
    (folder / "scenario.yaml").write_text(yaml.safe_dump(suite.scenario(robot, task, "quick", variants)))
    return folder / "scenario.yaml"


@pytest.mark.parametrize("robot", ["two_link", "puma560", "ur5e", "panda"])
def test_tracking_plant_clips_at_the_suites_limit_and_diagnosis_keeps_its_own(tmp_path, robot):
    suite = load_suite("v2")
    limit = np.array(suite.spec.robots[robot].torque_limit)
    assert len(limit) == suite.joints(robot)
    tracking = load_scenario(_scenario(tmp_path, suite, robot, "tracking", {"x": suite.loop(robot)}))
    np.testing.assert_array_equal(tracking.torque_limits, limit)
    assert tracking.model.actuator_ctrllimited.all() and tracking.spec.faults_after_torque_limit
    diagnosis = load_scenario(_scenario(tmp_path, suite, robot, "diagnosis", {REFERENCE: suite.loop(robot)}))
    assert diagnosis.spec.faults_after_torque_limit  # the fix in the diagnosis task too
    if robot in ("two_link", "puma560"):  # their model files have no limits, and diagnosis keeps none
        assert np.isinf(diagnosis.torque_limits).all()


def test_tracking_limits_change_tracking_digests_only():
    bench = load_bench()
    changed = load_bench()
    for robot in changed.suite.spec.robots.values():
        robot.torque_limit = [2 * value for value in robot.torque_limit]
    for robot in bench.suite.spec.robots:
        for task in ("diagnosis", "tracking"):
            for population in bench.suite.populations(task):
                for tier in ("quick", "full"):
                    same = (protocol_digest(bench, robot, task, population, tier)
                            == protocol_digest(changed, robot, task, population, tier))
                    assert same == (task == "diagnosis"), (robot, task, population, tier)


def _float_case(suite, robot: str) -> dict:
    return next(c for c in suite.fault_cases(robot, "tracking") if c["values"]["kind"] == "float")


@pytest.mark.slow
@pytest.mark.parametrize("robot", ["two_link", "puma560"])
def test_every_tracking_entry_gets_at_most_the_limit_and_a_float_gets_nothing(tmp_path, robot):
    """Every built-in tracking entry, in a float of the first fault joint from 0.6 s (2 s runs) and with a bias of
    twice the limit: the torque the plant receives, clip(command) + what the actuator fault adds, stays within
    the limit at every sample; under the float it is zero on the faulty joint (acting on the command instead, it
    would be clip(command) - command, beyond the limit when the command is), and the commands do exceed the limit
    (the check is not vacuous)."""
    suite = load_suite("v2")
    bench = load_bench()
    limit = np.array(suite.spec.robots[robot].torque_limit)
    variants = {entry.name: entry.sections[robot] for entry in bench.of("tracking")}
    path = _scenario(tmp_path, suite, robot, "tracking", variants)
    fault = _float_case(suite, robot)["set"]["actuator_faults"][0]
    joint = fault["joints"][0] - 1
    exceeded = 0
    for kind, values in (("float", {}), ("bias", {"offset": 2 * float(limit[joint])})):
        faulty = {**fault, "kind": kind, **values, "profile": {"onset": 0.6, "end": 2.0}}
        scenario = load_scenario(path, duration=2.0, assignments={"actuator_faults": [faulty], "diagnosis": None})
        for result in run_scenario(scenario, record_poses=False):
            received = np.clip(result.tau, -limit, limit) + result.fault_torque
            finite = np.isfinite(received).all(axis=1)
            assert (np.abs(received[finite]) <= limit + 1e-9).all(), (kind, result.name)
            on = result.fault_active & finite & (result.t >= 0.6)
            if kind == "float":
                np.testing.assert_allclose(received[on, joint], 0.0, atol=1e-9, err_msg=result.name)
            exceeded += int((np.abs(result.tau[finite]) > limit).any())
    assert exceeded >= 1


def test_diagnosis_faults_on_a_torque_limited_arm_were_redone_with_the_fix():
    """The fault population's digest names the fix where the model clips the command (UR5e, Panda), so runs made
    with faults acting on the raw command are not reused; healthy populations (no fault) and unlimited arms keep
    theirs."""
    bench = load_bench()
    for robot in bench.suite.spec.robots:
        limited = np.isfinite(load_scenario(bench.suite.scenarios[robot]).torque_limits).any()
        assert limited == (robot in ("ur5e", "panda"))
    import ftc_mj.ranking.execute as execute
    from unittest import mock
    digests = {robot: protocol_digest(bench, robot, "diagnosis", "faults", "full") for robot in bench.suite.spec.robots}
    with mock.patch.object(execute, "torque_limits", lambda model: np.full(model.nu, np.inf)):
        unlimited = {robot: protocol_digest(bench, robot, "diagnosis", "faults", "full")
                     for robot in bench.suite.spec.robots}
    assert {robot for robot in digests if digests[robot] != unlimited[robot]} == {"ur5e", "panda"}
