"""A simulated run as the log a real controller would have written: per variant, the time, the measured
positions, the measured velocities where the robot has tachometers, the commanded and the delivered torques.

Two forms, by the file's extension (:func:`log_bytes`):

* ``.csv``: a header row (``t``, ``q_<joint>``, ``qd_<joint>``, ``tau_<joint>``, ``tau_delivered_<joint>``)
  and one row per control period, every number with 17 significant digits, so that reading it back gives
  the same doubles: a ``log`` section on it (:func:`csv_log_section`) replays the run's readings and commands
  bit for bit;
* ``.mcap``: one ``sensor_msgs/msg/JointState`` per period on ``/joint_states`` (position, velocity, effort =
  the commanded torque; CDR through ``rosbags``), stamped with the run's time (nanoseconds).

A monitor shares its host's readings and commands: only the variants' own results are exported.
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ftc_mj.logs.readers import JOINT_STATE
from ftc_mj.results import VariantResult

#: The topic of the exported JointState messages.
TOPIC = "/joint_states"
FORMATS = (".csv", ".mcap")


def variant_path(path: Path, variant: str) -> Path:
    """Where variant ``variant``'s log goes: ``PATH``'s name with ``.<variant>`` before the extension."""
    return path.with_name(f"{path.stem}.{variant}{path.suffix}")


def columns(result: VariantResult, joints: Sequence[str]) -> tuple[list[str], np.ndarray]:
    """The header and the ``(steps, columns)`` table of one variant's log."""
    names, blocks = ["t"], [result.t[:, None]]
    signals = [("q", result.q_meas), ("qd", result.qd_meas), ("tau", result.tau),
               ("tau_delivered", result.tau_delivered)]
    for prefix, values in signals:
        if values is not None:
            names += [f"{prefix}_{joint}" for joint in joints]
            blocks.append(values)
    return names, np.hstack(blocks)


def csv_bytes(result: VariantResult, joints: Sequence[str]) -> bytes:
    """The CSV log of one variant (the module docstring)."""
    names, table = columns(result, joints)
    buffer = io.StringIO()
    np.savetxt(buffer, table, fmt="%.17g", delimiter=",", header=",".join(names), comments="")
    return buffer.getvalue().encode("ascii")


def mcap_bytes(result: VariantResult, joints: Sequence[str]) -> bytes:
    """The MCAP log of one variant: JointState messages (the module docstring)."""
    from mcap.writer import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    JointState, Header = store.types[JOINT_STATE], store.types["std_msgs/msg/Header"]
    Time = store.types["builtin_interfaces/msg/Time"]
    definition = store.generate_msgdef(JOINT_STATE)[0]
    buffer = io.BytesIO()
    writer = Writer(buffer)
    writer.start(profile="ros2", library="ftc_mj")
    schema = writer.register_schema(JOINT_STATE, "ros2msg", definition.encode("utf-8"))
    channel = writer.register_channel(TOPIC, "cdr", schema)
    nanoseconds = np.round(result.t * 1e9).astype(np.int64)
    empty = np.zeros(0)
    for k, stamp in enumerate(nanoseconds.tolist()):
        message = JointState(
            header=Header(stamp=Time(sec=stamp // 10**9, nanosec=stamp % 10**9), frame_id=""),
            name=list(joints), position=np.ascontiguousarray(result.q_meas[k]),
            velocity=empty if result.qd_meas is None else np.ascontiguousarray(result.qd_meas[k]),
            effort=np.ascontiguousarray(result.tau[k]))
        data = bytes(store.serialize_cdr(message, JOINT_STATE))
        writer.add_message(channel, log_time=stamp, data=data, publish_time=stamp, sequence=k)
    writer.finish()
    return buffer.getvalue()


def log_bytes(path: Path, result: VariantResult, joints: Sequence[str]) -> bytes:
    """One variant's log in the form ``path``'s extension names (``.csv`` or ``.mcap``)."""
    if path.suffix == ".mcap":
        return mcap_bytes(result, joints)
    return csv_bytes(result, joints)


def csv_log_section(file: str | Path, joints: Sequence[str], control_dt: float, velocity: bool) -> dict:
    """The ``log`` section (as YAML values) that replays a CSV written by :func:`csv_bytes`."""
    return {
        "file": str(file), "format": "csv",
        "columns": {"time": "t", "position": [f"q_{j}" for j in joints],
                    "velocity": [f"qd_{j}" for j in joints] if velocity else None,
                    "torque": [f"tau_{j}" for j in joints]},
        "steps": {"resample": control_dt},
    }
