"""The monitor as a ROS 2 node beside a real robot (``ftc-mj monitor SCENARIO --ros``; the extra ``ftc_mj[ros]``).

The node subscribes to ``sensor_msgs/JointState`` (default ``/joint_states``): each message's joints are
matched by name to the robot's and its values scaled as the scenario's ``log`` section scales a log's
(:class:`~ftc_mj.online.inputs.InputMap`; ``effort`` e.g. motor currents times their constants), its time the
header stamp or its arrival (``log.clock``), and it is pushed into the streaming monitor
(:class:`~ftc_mj.online.monitor.Monitor`). For every control period that completes it publishes:

* ``PREFIX/residual``, ``sensor_msgs/JointState`` stamped with the period's time, the robot's joint names,
  ``position`` the residual, ``velocity`` the threshold (NaN while the diagnoser is not armed) and ``effort``
  the fault estimate, in the diagnosis space (N m in torque space): a JointState so that a recorded bag of it
  carries the joint names and times and replays with the log readers (:func:`ftc_mj.logs.readers.read_joint_states`);
* ``PREFIX/alarm/JOINT``, ``std_msgs/Bool`` per joint, when its alarm changes and every ``heartbeat`` seconds
  (durability transient-local: a late subscriber gets the last value at once);
* ``/diagnostics``, ``diagnostic_msgs/DiagnosticArray``, one status per joint (OK; WARN: isolated earlier, its
  alarm off now; ERROR: alarm on) with the residual, threshold and fault estimate, when an alarm changes and
  every ``heartbeat`` seconds: what ``rqt_robot_monitor`` and the diagnostic aggregator read.

Bad input stops the node before it publishes anything of that message: a joint name the robot does not have
(or a robot joint missing), a message without effort (or without velocity where the scenario's observer
reads it), time that does not increase, a value that is not a finite number. The node keeps the error
(:attr:`MonitorNode.error`, ``TOPIC: message K FIELD: PROBLEM``); the command prints it as one line and exits
with status 2. A topic that falls silent for ``lost_after`` seconds after its first message is said once
(on stderr), and the node goes on; when messages come back, the grid is interpolated across the gap
(:mod:`ftc_mj.online.grid`).

Latency: for each message the node keeps the time from its arrival (the middleware's receive stamp) to its
last residual published (:attr:`MonitorNode.latencies`, seconds), and the time its callback took.
"""

from __future__ import annotations

import array
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool

from ftc_mj.config.errors import InputError
from ftc_mj.online.grid import SampleError
from ftc_mj.online.inputs import InputMap
from ftc_mj.online.monitor import Monitor, Period

#: Messages whose latencies a node keeps (the latest, in a ring).
LATENCY_SAMPLES = 1 << 16
_OK, _WARN, _ERROR = DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR


@dataclass
class Topics:
    """The node's topic names."""

    #: The JointState messages monitored.
    joint_states: str = "/joint_states"
    #: The residual topic is PREFIX/residual, each joint's alarm PREFIX/alarm/JOINT.
    prefix: str = "/ftc_mj"
    diagnostics: str = "/diagnostics"


class MonitorNode:
    """A :class:`Monitor` on a JointState topic (the module docstring). ``context``: an rclpy context
    (default: the global one); ``say``: where the lost-topic notice goes (default: stderr)."""

    def __init__(self, monitor: Monitor, inputs: InputMap, topics: Topics = Topics(), *, clock: str = "header",
                 lost_after: float = 1.0, heartbeat: float = 1.0, name: str = "ftc_mj_monitor", context=None,
                 say: Callable[[str], None] | None = None):
        self.monitor, self.inputs, self.topics, self.clock = monitor, inputs, topics, clock
        self.node = node = Node(name, context=context)
        self.say = say or (lambda line: print(line, file=sys.stderr, flush=True))
        prefix = topics.prefix.rstrip("/")
        joints = inputs.robot_joints
        self._residual = node.create_publisher(JointState, f"{prefix}/residual", 100)
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self._alarms = [node.create_publisher(Bool, f"{prefix}/alarm/{joint}", latched) for joint in joints]
        self._diagnostics = node.create_publisher(DiagnosticArray, topics.diagnostics, 10)
        node.create_subscription(JointState, topics.joint_states, self._on_message, 100)
        self._lost_after = lost_after
        node.create_timer(min(lost_after, heartbeat) / 2, self._check)
        self._heartbeat, self._last_heartbeat = heartbeat, time.monotonic()
        #: The bad input that stopped the node, or None.
        self.error: InputError | None = None
        #: Messages taken; periods published.
        self.messages = self.periods = 0
        #: Per message (a ring of the latest :data:`LATENCY_SAMPLES`): arrival to its last residual published,
        #: and the callback's own time [s]; NaN for a message that completed no period.
        self.latencies = np.full(LATENCY_SAMPLES, np.nan)
        self.callback_times = np.full(LATENCY_SAMPLES, np.nan)
        #: Each alarm raised or cleared: (time from the first sample [s], joint name, raised).
        self.events: list[tuple[float, str, bool]] = []
        self._names: tuple[str, ...] | None = None
        self._order = np.arange(len(joints))
        self._state = np.zeros(len(joints), dtype=bool)  # the alarms last published
        self._isolated = np.zeros(len(joints), dtype=bool)
        self._last: Period | None = None
        self._last_message = 0.0  # monotonic time of the last message
        self._lost = False
        message = JointState()
        message.name = list(joints)
        self._message = message

    def _on_message(self, message: JointState, info) -> None:
        entered = time.perf_counter()
        if self.error is not None:
            return
        self._last_message, self._lost = time.monotonic(), False
        try:
            periods = self._push(message, info)
        except SampleError as error:
            self.error = InputError(self.topics.joint_states, f"message {self.messages} {error.field}", error.problem)
            return
        finally:
            self.messages += 1
        slot = (self.messages - 1) % LATENCY_SAMPLES
        if not periods:
            self.latencies[slot] = np.nan
            self.callback_times[slot] = time.perf_counter() - entered
            return
        for period in periods:
            self._publish_residual(period)
        self.latencies[slot] = (time.time_ns() - info["received_timestamp"]) * 1e-9
        self.periods += len(periods)
        for period in periods:
            self._publish_alarms(period)
        self.callback_times[slot] = time.perf_counter() - entered

    def _push(self, message: JointState, info) -> list[Period]:
        names = tuple(message.name)
        if names != self._names:  # a publisher names its joints in one order throughout: mapped once
            self._order = self.inputs.order(names)
            self._names = names
        count = len(names)
        for field in ("position", "velocity", "effort"):
            given = len(getattr(message, field))
            if given and given != count:
                raise SampleError(field, f"{given} values for {count} names")
        if not len(message.effort):
            raise SampleError("effort", "the message holds no effort: the monitor needs the applied torque")
        if not len(message.position):
            raise SampleError("position", "the message holds no positions")
        velocity = None
        if self.monitor.needs_velocity:
            if not len(message.velocity):
                raise SampleError("velocity", "the message holds no velocity: the scenario's observer reads it")
            velocity = self.inputs.to_robot("velocity", message.velocity, self._order)
        if self.clock == "header":
            stamp = message.header.stamp
            t = stamp.sec + 1e-9 * stamp.nanosec  # as the log readers read a bag
        else:
            t = 1e-9 * info["received_timestamp"]
        return self.monitor.push(t * self.inputs.time_scale, self.inputs.to_robot("position", message.position, self._order),
                                 velocity, self.inputs.to_robot("torque", message.effort, self._order))

    def _publish_residual(self, period: Period) -> None:
        message = self._message
        stamp = self.monitor.origin + period.time  # seconds, the first sample's time the grid's origin
        message.header.stamp.sec = int(stamp // 1)
        message.header.stamp.nanosec = min(int(round((stamp % 1) * 1e9)), 999_999_999)
        # array.array('d') fields are taken as they are; a list would be checked element by element in Python.
        message.position = _doubles(period.residual)
        message.velocity = _doubles(period.threshold)
        message.effort = _doubles(period.fault_estimate)
        self._residual.publish(message)

    def _publish_alarms(self, period: Period) -> None:
        self._last = period
        changed = period.alarm != self._state
        if changed.any() or (period.isolated != self._isolated).any():
            for j in np.flatnonzero(changed):
                raised = bool(period.alarm[j])
                self._alarms[j].publish(Bool(data=raised))
                self.events.append((period.time, self.inputs.robot_joints[j], raised))
            self._state[:] = period.alarm
            self._isolated[:] = period.isolated
            self._publish_diagnostics(period)

    def _publish_diagnostics(self, period: Period) -> None:
        array = DiagnosticArray()
        array.header.stamp = self.node.get_clock().now().to_msg()
        hardware = self.monitor.scenario.name
        for j, joint in enumerate(self.inputs.robot_joints):
            alarm, isolated = bool(period.alarm[j]), bool(period.isolated[j])
            level = _ERROR if alarm else _WARN if isolated else _OK
            text = "alarm" if alarm else "alarm earlier" if isolated else "ok"
            values = [KeyValue(key=key, value=f"{value:.6g}") for key, value in
                      (("residual", period.residual[j]), ("threshold", period.threshold[j]),
                       ("fault estimate", period.fault_estimate[j]))]
            array.status.append(DiagnosticStatus(level=level, name=f"ftc_mj/{self.monitor.variant}/{joint}",
                                                 message=text, hardware_id=hardware, values=values))
        self._diagnostics.publish(array)

    def _check(self) -> None:
        """The lost-topic notice, once per silence; the heartbeat of the alarms and the diagnostics."""
        now = time.monotonic()
        if self.messages and not self._lost and now - self._last_message > self._lost_after:
            self._lost = True
            self.say(f"{self.topics.joint_states}: no message for {self._lost_after:g} s (the monitor waits for "
                     "more)")
        if now - self._last_heartbeat >= self._heartbeat and self._last is not None:
            self._last_heartbeat = now
            for j, publisher in enumerate(self._alarms):
                publisher.publish(Bool(data=bool(self._state[j])))
            self._publish_diagnostics(self._last)

    def latency_summary(self) -> dict[str, float]:
        """Median and 99th percentile [s] of the arrival-to-residual latency and of the callback's time, over
        the messages that completed a period (and how many)."""
        kept = min(self.messages, LATENCY_SAMPLES)
        latencies, callbacks = self.latencies[:kept], self.callback_times[:kept]
        published = np.isfinite(latencies)
        if not published.any():
            return {"messages": 0}
        latencies, callbacks = latencies[published], callbacks[published]
        return {"messages": int(published.sum()),
                "latency_median": float(np.median(latencies)), "latency_p99": float(np.percentile(latencies, 99)),
                "callback_median": float(np.median(callbacks)), "callback_p99": float(np.percentile(callbacks, 99))}


def _doubles(values: np.ndarray) -> array.array:
    """``values`` as the ``array.array('d')`` a message's float64 sequence holds."""
    out = array.array("d")
    out.frombytes(np.ascontiguousarray(values, dtype=np.float64).tobytes())
    return out


def spin(node: MonitorNode, executor=None, duration: float | None = None) -> None:
    """Run ``node`` until its first bad input, ``duration`` seconds (None: until shut down), or Ctrl-C."""
    own = executor is None
    executor = executor or SingleThreadedExecutor(context=node.node.context)
    executor.add_node(node.node)
    end = None if duration is None else time.monotonic() + duration
    try:
        while node.error is None and rclpy.ok(context=node.node.context):
            if end is not None and time.monotonic() >= end:
                break
            executor.spin_once(timeout_sec=0.1)
    except ExternalShutdownException:
        pass
    finally:
        executor.remove_node(node.node)
        if own:
            executor.shutdown()
