"""Small logs of the two-link arm, written by the tests (no committed binaries), and a scenario that replays one."""

from __future__ import annotations

from collections.abc import Sequence
from functools import cache
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[2]
TWO_LINK = ROOT / "models" / "two_link.xml"
JOINTS = ["joint1", "joint2"]


def trajectory(steps: int = 200, dt: float = 0.01) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Time, positions, velocities and torques of a smooth motion of both joints."""
    t = np.arange(steps) * dt
    q = np.column_stack([0.3 * np.sin(t), -0.2 * np.cos(2 * t)])
    qd = np.column_stack([0.3 * np.cos(t), 0.4 * np.sin(2 * t)])
    tau = np.column_stack([2.0 + np.sin(t), 1.0 - 0.5 * np.cos(t)])
    return t, q, qd, tau


def write_csv(path: Path, t, q, qd, tau, header: bool = True) -> Path:
    table = np.column_stack([t, q, qd, tau])
    names = "t,q1,q2,qd1,qd2,i1,i2"
    np.savetxt(path, table, fmt="%.17g", delimiter=",", header=names if header else "", comments="")
    return path


def log_scenario(tmp_path: Path, log: dict, variants: dict | None = None, **extra) -> Path:
    """A scenario on the two-link arm that replays ``log``."""
    raw = {
        "name": "replay",
        "robot": {"model": str(TWO_LINK)},
        "log": log,
        "variants": variants or {"eso": {"observer": {"type": "eso", "gains": {"bandwidth": 20.0}}}},
        "metrics": {"window_start": 0.5, "estimation_window_start": 0.5},
        **extra,
    }
    path = tmp_path / "replay.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path


CSV_LOG = {"format": "csv", "columns": {"time": "t", "position": ["q1", "q2"], "velocity": ["qd1", "qd2"],
                                        "torque": ["i1", "i2"]},
           "steps": {"resample": 0.01}}




JOINT_STATE = "sensor_msgs/msg/JointState"


@cache
def typestore():
    """The ROS 2 message types (rosbags), made once."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


def joint_state(names: Sequence[str], position, velocity=(), effort=(), stamp_ns: int = 0) -> bytes:
    """One CDR-serialised JointState message stamped ``stamp_ns``; an empty signal is one the message lacks."""
    store = typestore()
    JointState, Header = store.types[JOINT_STATE], store.types["std_msgs/msg/Header"]
    Time = store.types["builtin_interfaces/msg/Time"]
    message = JointState(header=Header(stamp=Time(sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9), frame_id=""),
                         name=list(names), position=np.asarray(position, dtype=float),
                         velocity=np.asarray(velocity, dtype=float), effort=np.asarray(effort, dtype=float))
    return bytes(store.serialize_cdr(message, JOINT_STATE))


def write_mcap(path: Path, messages: Sequence[tuple[str, int, bytes]], schema: str | None = JOINT_STATE,
               encoding: str = "cdr", topics: Sequence[str] = (), **options) -> Path:
    """An MCAP file of ``(topic, log time [ns], data)`` messages in the given order, one channel per topic (the
    messages' and ``topics``, which may have none) with the ``schema`` (None: schema-less) and ``encoding``;
    ``options`` go to mcap's ``Writer`` (its summary, chunks, indexes)."""
    from mcap.writer import Writer

    with path.open("wb") as stream:
        writer = Writer(stream, **options)
        writer.start(profile="ros2")
        schema_id = 0
        if schema is not None:
            definition = typestore().generate_msgdef(schema)[0]
            schema_id = writer.register_schema(schema, "ros2msg", definition.encode())
        channels = {topic: writer.register_channel(topic, encoding, schema_id)
                    for topic in dict.fromkeys([*topics, *(topic for topic, _, _ in messages)])}
        for topic, ns, data in messages:
            writer.add_message(channels[topic], log_time=ns, data=data, publish_time=ns)
        writer.finish()
    return path


def write_bag(folder: Path, messages: Sequence[tuple[str, int, bytes]], msgtype: str = JOINT_STATE,
              topics: Sequence[str] = ()) -> Path:
    """A rosbag2 bag (SQLite storage) of ``(topic, received time [ns], data)`` messages, one connection of
    ``msgtype`` per topic (the messages' and ``topics``, which may have none)."""
    from rosbags.rosbag2 import Writer

    with Writer(folder, version=9) as writer:
        connections = {topic: writer.add_connection(topic, msgtype, typestore=typestore())
                       for topic in dict.fromkeys([*topics, *(topic for topic, _, _ in messages)])}
        for topic, ns, data in messages:
            writer.write(connections[topic], ns, data)
    return folder
