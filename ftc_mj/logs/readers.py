"""Readers of robot logs: a CSV table of numbers (NumPy), and ``sensor_msgs/msg/JointState`` messages in a
rosbag2 bag or an MCAP file (through the pure-Python ``rosbags`` and ``mcap`` packages: no ROS install).

A log is untrusted input: its size is bounded (:data:`MAX_LOG_BYTES`, :data:`MAX_SAMPLES`), numbers are parsed
by NumPy (never evaluated), and every problem is an :class:`~ftc_mj.config.errors.InputError` naming the log
file, the scenario field that points into it and what is wrong. A reader returns the signals as logged, in
the order of ``log.joints`` (:class:`Recording`); :mod:`ftc_mj.logs.trajectory` checks, scales, reorders and
resamples them.
"""

from __future__ import annotations

import io
import struct
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ftc_mj.config.errors import InputError
from ftc_mj.logs.schema import ColumnRef, ColumnsSpec

#: The largest log read [bytes] (a bag folder: all its files).
MAX_LOG_BYTES = 512 * 2**20
#: The most samples (rows, messages) read from a log.
MAX_SAMPLES = 2_000_000
#: The message type the bag and MCAP readers take.
JOINT_STATE = "sensor_msgs/msg/JointState"
SIGNALS = ("position", "velocity", "torque")
#: What a damaged bag, MCAP file or metadata raises while it is read (besides each library's own errors): a
#: missing or unreadable file, text that is not UTF-8 or not YAML, a record read past its end.
DECODING_ERRORS: tuple[type[BaseException], ...] = (OSError, ValueError, KeyError, IndexError, TypeError,
                                                    AttributeError, EOFError, struct.error)


@dataclass
class Recording:
    """A log's signals as read, one column per joint of ``log.joints``; None where the log holds none.

    ``fields`` names, per signal, where its columns come from (for the one-line errors) and ``sample`` what a
    sample is called there (``row`` of a CSV, counted from the file's first line; ``message`` of a topic)."""

    file: str
    times: np.ndarray
    position: np.ndarray
    velocity: np.ndarray | None
    torque: np.ndarray | None
    fields: dict[str, list[str]]
    sample: str
    #: The 1-based number of the first sample in the file (a CSV's header row comes before it).
    first: int = 1


def check_size(path: Path, file: str) -> None:
    """Refuse a log larger than :data:`MAX_LOG_BYTES` before reading it."""
    size = sum(p.stat().st_size for p in path.rglob("*") if p.is_file()) if path.is_dir() else path.stat().st_size
    if size > MAX_LOG_BYTES:
        raise InputError(file, "log.file", f"is {size / 2**20:.0f} MiB, more than the {MAX_LOG_BYTES / 2**20:.0f} MiB "
                         "a log may have")


def read_csv(path: Path, columns: ColumnsSpec, delimiter: str) -> Recording:
    """A table of numbers, one sample per row; a first row that is not all numbers is its header (the names
    ``columns`` may use). Fields may be quoted by nothing; NaN and inf parse (and are refused later)."""
    file = str(path)
    check_size(path, file)
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as error:
        raise InputError(file, "log.file", f"is not UTF-8 text (byte {error.start})") from None
    lines = text.splitlines()
    while lines and not lines[0].strip():  # leading blank lines are nothing
        lines.pop(0)
    if not lines:
        raise InputError(file, "log.file", "is empty")
    first = [field.strip() for field in lines[0].split(delimiter)]
    header = None if all(_is_number(field) for field in first) else first
    body = lines[1:] if header is not None else lines
    if len(body) > MAX_SAMPLES:
        raise InputError(file, "log.file", f"has {len(body)} rows, more than the {MAX_SAMPLES} a log may have")
    width = len(first)
    refs = {"time": [columns.time], **{name: getattr(columns, name) for name in SIGNALS}}
    indices: dict[str, list[int] | None] = {}
    for name, listed in refs.items():
        if listed is None:
            indices[name] = None
            continue
        indices[name] = [_column(ref, header, width, file, _field(name, j, name == "time"))
                         for j, ref in enumerate(listed)]
    used = sorted({i for found in indices.values() if found is not None for i in found})
    try:
        table = np.loadtxt(io.StringIO("\n".join(body)), delimiter=delimiter, ndmin=2, usecols=used, dtype=float,
                           comments=None)
    except ValueError as error:
        raise InputError(file, "log.file", f"is not a {delimiter!r}-separated table of numbers: {error}") from None
    if table.shape[0] == 0:
        raise InputError(file, "log.file", "has no rows of numbers")
    position_of = {column: k for k, column in enumerate(used)}

    def signal(name: str) -> np.ndarray | None:
        found = indices[name]
        return None if found is None else table[:, [position_of[i] for i in found]]

    fields = {name: [_field(name, j, False) for j in range(len(found))]
              for name, found in indices.items() if found is not None and name != "time"}
    fields["time"] = ["log.columns.time"]
    return Recording(file, signal("time")[:, 0], signal("position"), signal("velocity"), signal("torque"), fields,
                     "row", first=2 if header is not None else 1)


def _field(signal: str, j: int, single: bool) -> str:
    return f"log.columns.{signal}" if single else f"log.columns.{signal}.{j}"


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _column(ref: ColumnRef, header: list[str] | None, width: int, file: str, field: str) -> int:
    """The 0-based index of a column named by index or by header name."""
    if isinstance(ref, int):
        if ref >= width:
            raise InputError(file, field, f"column {ref} is not in the file (it has {width} columns, 0 to {width - 1})")
        return ref
    if header is None:
        raise InputError(file, field, f"names the column {ref!r}, but the file has no header row")
    if ref not in header:
        shown = ", ".join(header[:12]) + (", ..." if len(header) > 12 else "")
        raise InputError(file, field, f"no column {ref!r} in the header ({shown})")
    found = [k for k, name in enumerate(header) if name == ref]
    if len(found) > 1:  # which one was meant? (the first would be replayed silently)
        raise InputError(file, field, f"the header names {len(found)} columns {ref!r} (columns "
                         f"{', '.join(map(str, found))}): name each column once, or give the column by its index")
    return found[0]


def read_joint_states(path: Path, format: str, topic: str, joints: Sequence[str], clock: str) -> Recording:
    """The JointState messages on ``topic`` of a rosbag2 bag (``format`` ``rosbag2``: its folder, or a storage
    file inside it) or of an MCAP file (``mcap``), each joint's position, velocity and effort picked by name.

    A message's time is its header stamp (``clock`` ``header``) or when it was recorded (``received``).
    Velocity and effort may be absent (empty in every message); a message that holds them for some joints
    and not for others, or lacks one of ``joints``, is an error."""
    file = str(path)
    check_size(path, file)
    messages = _bag_messages(path, topic, file) if format == "rosbag2" else _mcap_messages(path, topic, file)
    times, rows = [], {name: [] for name in ("position", "velocity", "effort")}
    order: tuple[str, ...] | None = None
    picks: list[int] = []
    for count, (received, message) in enumerate(messages):
        if count >= MAX_SAMPLES:
            raise InputError(file, "log.topic", f"{topic!r} has more than the {MAX_SAMPLES} messages a log may have")
        names = tuple(message.name)
        if names != order:  # most logs name the joints in one order throughout
            twice = next((name for k, name in enumerate(names) if name in names[:k]), None)
            if twice is not None:  # which value is the joint's? (the first would be replayed silently)
                raise InputError(file, "log.joints", f"message {count} on {topic!r} names the joint {twice!r} twice")
            try:
                picks = [names.index(joint) for joint in joints]
            except ValueError:
                missing = next(joint for joint in joints if joint not in names)
                raise InputError(file, "log.joints", f"message {count} on {topic!r} has no joint {missing!r} "
                                 f"(it names {', '.join(names) or 'none'})") from None
            order = names
        stamp = message.header.stamp
        times.append(stamp.sec + 1e-9 * stamp.nanosec if clock == "header" else 1e-9 * received)
        for name in rows:
            values = np.asarray(getattr(message, name), dtype=float)
            if len(values) == 0:
                rows[name].append(None)
            elif len(values) != len(names):
                raise InputError(file, "log.topic", f"message {count} on {topic!r} has {len(values)} {name} values "
                                 f"for {len(names)} names")
            else:
                rows[name].append(values[picks])
    if not times:
        raise InputError(file, "log.topic", f"no {JOINT_STATE} messages on {topic!r}")
    signals = {}
    for name, values in rows.items():
        empty = [value is None for value in values]
        if all(empty):
            signals[name] = None
        elif any(empty):
            k = empty.index(not empty[0])
            raise InputError(file, "log.topic", f"message {k} on {topic!r} {'lacks' if empty[k] else 'has'} {name} "
                             f"values, message 0 {'has them' if not empty[0] else 'has none'}")
        else:
            signals[name] = np.array(values)
    fields = {signal: [f"log.topic {name} of {joint!r}" for joint in joints]
              for signal, name in zip(SIGNALS, ("position", "velocity", "effort"))}
    fields["time"] = [f"log.clock ({clock})"]
    if signals["position"] is None:
        raise InputError(file, "log.topic", f"the messages on {topic!r} hold no positions")
    return Recording(file, np.array(times), signals["position"], signals["velocity"], signals["effort"], fields,
                     "message", first=0)


def _typestore():
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


def _bag_messages(path: Path, topic: str, file: str) -> Iterator[tuple[int, object]]:
    """(received time [ns], message) of a rosbag2 bag's topic, in recording order."""
    from rosbags.rosbag2 import Reader
    import yaml
    from rosbags.rosbag2.errors import ReaderError

    folder = path if path.is_dir() else path.parent
    store = _typestore()
    try:
        with Reader(folder) as reader:
            connections = [c for c in reader.connections if c.topic == topic]
            if not connections:
                topics = sorted({c.topic for c in reader.connections})
                raise InputError(file, "log.topic", f"no topic {topic!r} in the bag (topics: {', '.join(topics) or 'none'})")
            wrong = [c.msgtype for c in connections if c.msgtype != JOINT_STATE]
            if wrong:
                raise InputError(file, "log.topic", f"{topic!r} holds {wrong[0]} messages, not {JOINT_STATE}")
            for count, (connection, received, data) in enumerate(reader.messages(connections=connections)):
                yield received, _decode(store, data, connection.msgtype, file, topic, count)
    except (ReaderError, yaml.YAMLError, *DECODING_ERRORS) as error:  # no metadata.yaml: FileNotFoundError
        raise InputError(file, "log.file", f"is not a readable rosbag2 bag: {_reason(error)}") from None


def _mcap_messages(path: Path, topic: str, file: str) -> Iterator[tuple[int, object]]:
    """(log time [ns], message) of an MCAP file's topic (CDR-encoded ROS 2 messages), in log-time order."""
    from mcap.exceptions import McapError
    from mcap.reader import make_reader

    store = _typestore()
    try:
        with path.open("rb") as stream:
            reader = make_reader(stream)
            summary = reader.get_summary()
            channels = summary.channels.values() if summary is not None else []
            found = [c for c in channels if c.topic == topic]
            if summary is not None and not found:
                topics = sorted({c.topic for c in channels})
                raise InputError(file, "log.topic", f"no topic {topic!r} in the file (topics: {', '.join(topics) or 'none'})")
            count = 0
            for schema, channel, message in reader.iter_messages(topics=[topic], log_time_order=True):
                if schema is None or schema.name != JOINT_STATE or channel.message_encoding != "cdr":
                    name = schema.name if schema is not None else "schema-less"
                    raise InputError(file, "log.topic", f"{topic!r} holds {name} ({channel.message_encoding}) "
                                     f"messages, not CDR-encoded {JOINT_STATE}")
                yield message.log_time, _decode(store, message.data, JOINT_STATE, file, topic, count)
                count += 1
    except (McapError, EOFError, *DECODING_ERRORS) as error:
        raise InputError(file, "log.file", f"is not a readable MCAP file: {_reason(error)}") from None


def _decode(store, data: bytes, message_type: str, file: str, topic: str, count: int) -> object:
    """One CDR message, or the one-line error naming it (a damaged message: rosbags' ``SerdeError``, or a
    field read past the message's end)."""
    try:
        return store.deserialize_cdr(data, message_type)
    except Exception as error:  # noqa: BLE001 - the deserializer raises anything on damaged bytes
        raise InputError(file, "log.topic", f"message {count} on {topic!r} cannot be decoded (damaged): "
                         f"{_reason(error)}") from None


def _reason(error: BaseException) -> str:
    text = str(error).strip().splitlines()
    return f"{type(error).__name__}: {text[0]}" if text else type(error).__name__
