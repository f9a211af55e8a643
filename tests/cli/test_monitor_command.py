"""``ftc-mj monitor``: the scenario's log streamed row by row prints each alarm as the replay has it; a scenario
the monitor cannot run is one line and exit status 2."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ftc_mj import load_scenario, run_scenario
from ftc_mj.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
FREE = ROOT / "scenarios/real/ur10e_free_motion.yaml"


@pytest.mark.slow  # a replay and a stream of the log
def test_streaming_the_log_prints_the_replays_alarms_as_they_come(capsys):
    assert main(["monitor", str(FREE), "--variant", "tosmo"]) == 0
    lines = capsys.readouterr().out.splitlines()
    printed = [line.split(" (")[0].split() for line in lines if "alarm" in line and " s  " in line]
    replay = run_scenario(load_scenario(FREE, variants=["tosmo"]), record_poses=False)[0].diagnosis
    joints = [load_scenario(FREE, variants=["tosmo"]).model.joint(j).name for j in range(6)]
    steps = np.diff(np.vstack([np.zeros((1, 6), bool), replay.alarm]).astype(int), axis=0)
    expected = [[f"{replay.t[k]:.3f}", "s", f"{joints[j]}:", "alarm", "raised" if steps[k, j] > 0 else "cleared"]
                for k, j in np.argwhere(steps)]
    assert len(expected) >= 4 and printed == expected
    assert lines[-1].startswith("567 periods of 0.01 s; isolated: shoulder_pan_joint, shoulder_lift_joint, elbow_joint")


@pytest.mark.parametrize("options, message", [
    (["--set", "diagnosis=null"], "diagnosis: a monitor needs a diagnosis section"),
    (["--variant", "pid"], "variants: no variant 'pid'"),
    (["--lost-after", "0"], "--lost-after: must be positive"),
    (["--set", "diagnosis.baseline={start: 0.5, end: 1.0}", "--set", "diagnosis.start=0.6"], "diagnosis"),
])
def test_what_the_monitor_cannot_run_is_one_line_and_exit_2(capsys, options, message):
    assert main(["monitor", str(FREE), *options]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1 and captured.err.startswith("error: ")
    assert message in captured.err


@pytest.mark.slow  # a ROS 2 node for its duration
def test_ros_node_runs_for_its_duration_and_stops(capsys):
    pytest.importorskip("rclpy", reason="ROS 2's Python client is not installed (pip install ftc_mj[ros])")
    assert main(["monitor", str(FREE), "--ros", "--variant", "do", "--joint-states", "/cli_test/joint_states",
                 "--duration", "0.3", "--latency"]) == 0
    assert "variant do on /cli_test/joint_states" in capsys.readouterr().err


@pytest.mark.slow  # a ROS 2 node and a publisher
def test_ros_node_stops_on_a_bad_message_with_one_line_and_exit_2(capsys):
    rclpy = pytest.importorskip("rclpy", reason="ROS 2's Python client is not installed (pip install ftc_mj[ros])")
    import threading
    import time
    import uuid

    from sensor_msgs.msg import JointState

    topic = f"/cli_{uuid.uuid4().hex[:8]}/joint_states"
    outcome = {}
    thread = threading.Thread(target=lambda: outcome.setdefault("status", main(
        ["monitor", str(FREE), "--ros", "--variant", "do", "--joint-states", topic, "--duration", "20"])))
    thread.start()
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        node = rclpy.create_node(f"bad_{uuid.uuid4().hex[:6]}", context=context)
        publisher = node.create_publisher(JointState, topic, 10)
        message = JointState(name=["elbow", "b", "c", "d", "e", "f"], position=[0.0] * 6, velocity=[0.0] * 6,
                             effort=[0.0] * 6)
        deadline = time.monotonic() + 20
        while thread.is_alive() and time.monotonic() < deadline:
            publisher.publish(message)
            time.sleep(0.05)
    finally:
        rclpy.shutdown(context=context)
    thread.join()
    assert outcome["status"] == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("error")]
    assert errors == [f"error: {topic}: message 0 name: 'elbow' is not a joint of the robot (shoulder_pan_joint, "
                      "shoulder_lift_joint, elbow_joint, wrist_1_joint, wrist_2_joint, wrist_3_joint)"]
