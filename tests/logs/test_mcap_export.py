"""The MCAP form of an exported run (ftc_mj.logs.export.mcap_bytes) read back record by record: the ROS 2
profile and the writer's name, the JointState schema as ``ros2msg`` text, and per period one message stamped
with the run's time in whole seconds and nanoseconds, numbered, with the readings and the command (no velocity
values without tachometers)."""

from __future__ import annotations

import io
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from log_files import JOINT_STATE, typestore

from ftc_mj.logs.export import TOPIC, log_bytes, mcap_bytes

pytest.importorskip("rosbags")
pytest.importorskip("mcap")

JOINTS = ["joint1", "joint2"]
T = np.array([0.0, 1.5, 12.25])  # exact in binary: whole nanoseconds


def _run(velocity: bool) -> SimpleNamespace:
    q = np.array([[0.1, -0.2], [0.3, 0.4], [0.5, -0.6]])
    return SimpleNamespace(t=T, q_meas=q, qd_meas=10 * q if velocity else None, tau=100 * q, tau_delivered=90 * q)


def _records(data: bytes):
    from mcap.reader import make_reader

    reader = make_reader(io.BytesIO(data))
    header, summary = reader.get_header(), reader.get_summary()
    messages = [(schema, channel, message, typestore().deserialize_cdr(message.data, JOINT_STATE))
                for schema, channel, message in reader.iter_messages()]
    return header, summary, messages


@pytest.mark.parametrize("velocity", [True, False])
def test_mcap_records_of_a_run(velocity):
    run = _run(velocity)
    header, summary, messages = _records(mcap_bytes(run, JOINTS))
    assert (header.profile, header.library) == ("ros2", "ftc_mj")
    (schema,) = summary.schemas.values()
    assert (schema.name, schema.encoding) == (JOINT_STATE, "ros2msg")
    assert schema.data == typestore().generate_msgdef(JOINT_STATE)[0].encode("utf-8")
    assert len(messages) == len(T)
    stamps = [(0, 0), (1, 500_000_000), (12, 250_000_000)]
    for k, (_, channel, message, state) in enumerate(messages):
        assert (channel.topic, channel.message_encoding) == (TOPIC, "cdr")
        assert message.sequence == k and message.log_time == message.publish_time == round(T[k] * 1e9)
        assert (state.header.stamp.sec, state.header.stamp.nanosec) == stamps[k] and state.header.frame_id == ""
        assert list(state.name) == JOINTS
        np.testing.assert_array_equal(state.position, run.q_meas[k])
        np.testing.assert_array_equal(state.effort, run.tau[k])
        np.testing.assert_array_equal(state.velocity, run.qd_meas[k] if velocity else np.zeros(0))


def test_the_extension_chooses_the_form():
    run = _run(True)
    assert log_bytes(Path("x.mcap"), run, JOINTS) == mcap_bytes(run, JOINTS)
    assert log_bytes(Path("x.csv"), run, JOINTS).startswith(b"t,q_joint1,q_joint2,qd_joint1")
