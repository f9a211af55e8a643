"""The ROS 2 node (ftc_mj.online.ros) over loopback: a shipped log's JointState messages published at their real
rate give the offline replay's residuals and alarm times; the latency from message to residual; bad messages
stop it before anything of them is published; a silent topic is said once."""

from __future__ import annotations

import os
import random
import threading
import time
import uuid
from pathlib import Path

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy", reason="ROS 2's Python client is not installed (pip install ftc_mj[ros])")

from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402

from ftc_mj import load_scenario, run_scenario  # noqa: E402
from ftc_mj.logs.readers import read_csv  # noqa: E402
from ftc_mj.online import InputMap, Monitor  # noqa: E402
from ftc_mj.online.ros import MonitorNode, Topics  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
FREE = ROOT / "scenarios/real/ur10e_free_motion.yaml"


@pytest.fixture
def ros():
    """An rclpy context of its own on a random domain, discovery on this host only, and an executor spinning
    in a thread; yields (context, executor, topics with unique names)."""
    os.environ["ROS_DOMAIN_ID"] = str(random.randrange(1, 100))
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    context = rclpy.Context()
    rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    running = threading.Event()
    running.set()

    def spin():
        while running.is_set():
            executor.spin_once(timeout_sec=0.05)

    thread = threading.Thread(target=spin, daemon=True)
    thread.start()
    tag = uuid.uuid4().hex[:8]
    try:
        yield context, executor, Topics(f"/test_{tag}/joint_states", f"/test_{tag}/ftc_mj", f"/test_{tag}/diagnostics")
    finally:
        running.clear()
        thread.join()
        executor.shutdown()
        rclpy.shutdown(context=context)


def _messages(scenario, shuffle: bool = False) -> tuple[np.ndarray, list[JointState]]:
    """The scenario's CSV log as JointState messages in its raw units (currents as effort), the joints named in
    reversed order when ``shuffle``."""
    spec = scenario.spec.log
    recording = read_csv(scenario.log.file, spec.columns, spec.delimiter)
    names = InputMap.of(scenario).source_joints
    order = list(range(len(names)))[::-1] if shuffle else list(range(len(names)))
    messages = []
    for i, t in enumerate(recording.times):
        message = JointState()
        message.header.stamp.sec, message.header.stamp.nanosec = int(t // 1), int(round((t % 1) * 1e9))
        message.name = [names[j] for j in order]
        message.position = recording.position[i, order].tolist()
        message.velocity = recording.velocity[i, order].tolist()
        message.effort = recording.torque[i, order].tolist()
        messages.append(message)
    return recording.times, messages


def _node(ros, scenario, variant: str, **options) -> tuple[MonitorNode, list, object]:
    """The monitor node and a test node with a publisher of JointState and a subscriber of the residuals."""
    context, executor, topics = ros
    node = MonitorNode(Monitor(scenario, variant), InputMap.of(scenario), topics, context=context,
                       name=f"monitor_{uuid.uuid4().hex[:6]}", **options)
    test = rclpy.create_node(f"test_{uuid.uuid4().hex[:6]}", context=context)
    received: list[JointState] = []
    test.create_subscription(JointState, f"{topics.prefix}/residual", received.append, 1000)
    publisher = test.create_publisher(JointState, topics.joint_states, 1000)
    executor.add_node(node.node)
    executor.add_node(test)
    deadline = time.monotonic() + 10
    while (publisher.get_subscription_count() < 1 or test.count_publishers(f"{topics.prefix}/residual") < 1) \
            and time.monotonic() < deadline:
        time.sleep(0.01)
    return node, received, publisher


def _wait(condition, seconds: float = 10.0) -> None:
    deadline = time.monotonic() + seconds
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.01)


@pytest.mark.slow  # 5.7 s of messages at their real rate
def test_a_log_published_at_its_real_rate_gives_the_replays_residuals_and_alarm_times(ros, tmp_path):
    scenario = load_scenario(FREE, variants=["tosmo"])  # its residuals cross the thresholds on this log
    replay = run_scenario(scenario, record_poses=False)[0].diagnosis
    node, received, publisher = _node(ros, scenario, "tosmo")
    times, messages = _messages(scenario, shuffle=True)
    start = time.monotonic()
    for t, message in zip(times, messages):  # at the log's own times (5.7 s)
        delay = start + (t - times[0]) - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        publisher.publish(message)
    _wait(lambda: node.messages == len(messages) and len(received) == node.periods)
    assert node.error is None
    count = node.periods
    assert len(replay.t) - 1 <= count <= len(replay.t) and len(received) == count
    residual = np.array([m.position for m in received])
    np.testing.assert_array_equal(residual, replay.residual[:count])  # the same bits, through the middleware
    np.testing.assert_array_equal(np.array([m.velocity for m in received]), replay.threshold[:count])
    stamps = np.array([m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in received])
    np.testing.assert_allclose(stamps - times[0], replay.t[:count], atol=1e-6)
    alarm = replay.alarm[:count]
    changes = np.argwhere(np.diff(np.vstack([np.zeros((1, alarm.shape[1]), bool), alarm]).astype(int), axis=0))
    joints = InputMap.of(scenario).robot_joints
    expected = [(replay.t[k], joints[j], bool(alarm[k, j])) for k, j in changes]
    assert len(expected) >= 4  # the TOSMO's false alarms on this log: raised and cleared
    assert node.events == expected
    _bag_reads_back(tmp_path, received, replay, count)
    summary = node.latency_summary()
    assert summary["messages"] >= len(messages) - 60  # a message between two grid instants completes none
    print(f"loopback latency, message to residual: {summary['latency_median'] * 1e3:.3f} ms median, "
          f"{summary['latency_p99'] * 1e3:.3f} ms p99")


def _bag_reads_back(folder: Path, received: list[JointState], replay, count: int) -> None:
    """The node's residual messages, serialised as ROS 2 serialises them, in a rosbag2 bag: the log readers read
    the residual back from ``position`` and the threshold from ``velocity``."""
    from rclpy.serialization import serialize_message
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    from ftc_mj.logs.readers import read_joint_states

    bag = folder / "residual_bag"
    with Writer(bag, version=8) as writer:
        connection = writer.add_connection("/ftc_mj/residual", "sensor_msgs/msg/JointState",
                                           typestore=get_typestore(Stores.ROS2_HUMBLE))
        for message in received:
            stamp = message.header.stamp
            writer.write(connection, stamp.sec * 10**9 + stamp.nanosec, serialize_message(message))
    read = read_joint_states(bag, "rosbag2", "/ftc_mj/residual", list(received[0].name), "header")
    np.testing.assert_array_equal(read.position, replay.residual[:count])
    np.testing.assert_array_equal(read.velocity, replay.threshold[:count])


@pytest.mark.parametrize("change, problem", [
    (lambda m: setattr(m, "name", ["elbow"] + list(m.name[1:])), "message 0 name: 'elbow' is not a joint"),
    (lambda m: setattr(m, "effort", []), "message 0 effort: the message holds no effort"),
    (lambda m: setattr(m, "velocity", []), "message 0 velocity: the message holds no velocity"),
])
def test_a_bad_first_message_stops_the_node_with_nothing_published(ros, change, problem):
    scenario = load_scenario(FREE, variants=["do"])
    node, received, publisher = _node(ros, scenario, "do")
    _, messages = _messages(scenario)
    change(messages[0])
    publisher.publish(messages[0])
    _wait(lambda: node.error is not None)
    assert str(node.error) == f"{ros[2].joint_states}: {problem}" + str(node.error).split(problem, 1)[1]
    time.sleep(0.2)
    assert received == [] and node.periods == 0


def test_time_going_backwards_stops_the_node_after_what_came_before(ros):
    scenario = load_scenario(FREE, variants=["do"])
    node, received, publisher = _node(ros, scenario, "do")
    _, messages = _messages(scenario)
    publisher.publish(messages[1])
    _wait(lambda: len(received) == 1)
    publisher.publish(messages[0])
    _wait(lambda: node.error is not None)
    assert "message 1 time: " in str(node.error) and "does not come after" in str(node.error)
    publisher.publish(messages[2])  # ignored once stopped
    time.sleep(0.2)
    assert len(received) == 1 and node.messages == 2


def test_a_silent_topic_is_said_once(ros):
    scenario = load_scenario(FREE, variants=["do"])
    said: list[str] = []
    node, received, publisher = _node(ros, scenario, "do", lost_after=0.2, say=said.append)
    _, messages = _messages(scenario)
    publisher.publish(messages[0])
    _wait(lambda: len(received) == 1)
    time.sleep(0.8)
    assert said == [f"{ros[2].joint_states}: no message for 0.2 s (the monitor waits for more)"]
    assert node.error is None
