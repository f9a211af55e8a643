"""The JointState reader (ftc_mj.logs.readers.read_joint_states) on small rosbag2 bags and MCAP files written
here: the two clocks, a one-joint robot, the topic picked among others, the log-time order, a file without a
summary, a bag's storage file for its folder, and each bad input as its exact one line (the file, the field,
the message, the sample counted from 0)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from log_files import JOINT_STATE, joint_state, write_bag, write_mcap

from ftc_mj.config.errors import InputError
from ftc_mj.logs import readers
from ftc_mj.logs.readers import read_joint_states
from ftc_mj.logs.schema import LogSpec
from ftc_mj.logs.trajectory import compile_log

pytest.importorskip("rosbags")
pytest.importorskip("mcap")

JOINTS = ["joint1", "joint2"]
TOPIC = "/joint_states"
FORMS = ["rosbag2", "mcap"]


def _messages(count: int = 4, topic: str = TOPIC, names=JOINTS, stamp=None, offset: float = 0.0, **signals):
    """``count`` JointState messages on ``topic``, received every 0.5 s from 7 s, stamped every 0.25 s from 1.5 s
    (or ``stamp(k)`` [ns]); each signal ``signals[name](k)`` (default: position 0.1 k + offset per joint, velocity
    and effort 10 times and 100 times that)."""
    def default(scale):
        return lambda k: [scale * (0.1 * k + offset)] * len(names)

    make = {"position": default(1.0), "velocity": default(10.0), "effort": default(100.0), **signals}
    out = []
    for k in range(count):
        ns = int(1.5e9 + 0.25e9 * k) if stamp is None else stamp(k)
        out.append((topic, int(7e9 + 0.5e9 * k), joint_state(names, make["position"](k), make["velocity"](k),
                                                          make["effort"](k), ns)))
    return out


def _write(folder: Path, form: str, messages, **options) -> Path:
    """A bag (``folder/bag``) or an MCAP file (``folder/log.mcap``) of ``messages``."""
    folder.mkdir(exist_ok=True)
    if form == "rosbag2":
        return write_bag(folder / "bag", messages, **options)
    return write_mcap(folder / "log.mcap", messages, **options)


def _read(path: Path, form: str, joints=JOINTS, clock: str = "header", topic: str = TOPIC):
    return read_joint_states(path, form, topic, joints, clock)


def _error(call, *args, **kwargs) -> str:
    with pytest.raises(InputError) as raised:
        call(*args, **kwargs)
    return str(raised.value)


@pytest.mark.parametrize("form", FORMS)
def test_header_stamps_or_received_times(tmp_path, form):
    path = _write(tmp_path, form, _messages())
    header = _read(path, form).times
    np.testing.assert_allclose(header, [1.5, 1.75, 2.0, 2.25], rtol=1e-15)
    np.testing.assert_allclose(_read(path, form, clock="received").times, [7.0, 7.5, 8.0, 8.5], rtol=1e-15)


@pytest.mark.parametrize("form", FORMS)
def test_the_topic_among_others_and_a_one_joint_robot(tmp_path, form):
    """Messages of another topic (other values) interleaved: only the topic's are read; a robot of one joint
    takes each message's single value."""
    ours, other = _messages(names=["joint1"]), _messages(topic="/other", names=["joint1"], offset=5.0)
    path = _write(tmp_path, form, [m for pair in zip(ours, other) for m in pair])
    recording = _read(path, form, joints=["joint1"])
    np.testing.assert_allclose(recording.position[:, 0], [0.0, 0.1, 0.2, 0.3], rtol=1e-15)
    np.testing.assert_allclose(recording.torque[:, 0], [0.0, 10.0, 20.0, 30.0], rtol=1e-15)
    assert recording.position.shape == (4, 1) and recording.sample == "message" and recording.first == 0


def test_a_bags_storage_file_stands_for_its_folder(tmp_path):
    """The storage file in its bag folder reads as the folder; moved out of it, it is no bag (the folder's
    metadata is what makes a bag)."""
    folder = _write(tmp_path, "rosbag2", _messages())
    (storage,) = folder.glob("*.db3")
    np.testing.assert_array_equal(_read(storage, "rosbag2").position, _read(folder, "rosbag2").position)
    alone = tmp_path / "alone"
    alone.mkdir()
    moved = storage.rename(alone / storage.name)
    assert _error(_read, moved, "rosbag2").startswith(f"{moved}: log.file: is not a readable rosbag2 bag: ")


def test_mcap_messages_in_log_time_order_and_a_file_without_summary(tmp_path):
    """Written out of order (log times 7, 8, 7.5, 8.5 s): read in log-time order. A file written without a
    summary section (no index: read from the start) reads the same."""
    messages = _messages(stamp=lambda k: int(7e9 + 0.5e9 * k))
    shuffled = [messages[i] for i in (0, 2, 1, 3)]
    from mcap.writer import IndexType

    plain = write_mcap(tmp_path / "plain.mcap", shuffled)
    bare = write_mcap(tmp_path / "bare.mcap", shuffled, use_chunking=False, use_statistics=False,
                      repeat_channels=False, repeat_schemas=False, index_types=IndexType.NONE,
                      use_summary_offsets=False)
    for path in (plain, bare):
        recording = _read(path, "mcap", clock="received")
        np.testing.assert_allclose(recording.times, [7.0, 7.5, 8.0, 8.5], rtol=1e-15)
        np.testing.assert_allclose(recording.position[:, 0], [0.0, 0.1, 0.2, 0.3], rtol=1e-15)


@pytest.mark.parametrize("form", FORMS)
def test_signals_the_messages_lack_are_none(tmp_path, form):
    path = _write(tmp_path, form, _messages(velocity=lambda k: []))
    recording = _read(path, form)
    assert recording.velocity is None and recording.torque.shape == (4, 2)


@pytest.mark.parametrize("form", FORMS)
def test_bad_messages_are_one_line(tmp_path, form):
    def lacking_from(first, signal="velocity"):
        return {signal: lambda k: [] if k >= first else [1.0, 2.0]}

    def having_from(first, signal="velocity"):
        return {signal: lambda k: [1.0, 2.0] if k >= first else []}

    cases = [
        (_messages(**lacking_from(2)), f"message 2 on '{TOPIC}' lacks velocity values, message 0 has them"),
        (_messages(**having_from(1, "effort")), f"message 1 on '{TOPIC}' has effort values, message 0 has none"),
        (_messages(velocity=lambda k: [1.0, 2.0, 3.0] if k == 1 else [1.0, 2.0]),
         f"message 1 on '{TOPIC}' has 3 velocity values for 2 names"),
        (_messages(position=lambda k: []), f"the messages on '{TOPIC}' hold no positions"),
    ]
    for k, (messages, problem) in enumerate(cases):
        path = _write(tmp_path / str(k), form, messages)
        assert _error(_read, path, form) == f"{path}: log.topic: {problem}"
    named = _write(tmp_path / "named", form, _messages(names=["joint1", "gripper", "wrist"]))
    assert _error(_read, named, form) == (f"{named}: log.joints: message 0 on '{TOPIC}' has no joint 'joint2' "
                                          "(it names joint1, gripper, wrist)")
    nameless = _write(tmp_path / "nameless", form, _messages(names=[]))
    assert _error(_read, nameless, form) == (f"{nameless}: log.joints: message 0 on '{TOPIC}' has no joint "
                                             "'joint1' (it names none)")


@pytest.mark.parametrize("form", FORMS)
def test_a_topic_missing_among_others_or_in_a_file_of_none(tmp_path, form):
    where = "bag" if form == "rosbag2" else "file"
    path = _write(tmp_path / "two", form, _messages() + _messages(topic="/other"))
    assert _error(_read, path, form, topic="/states") == (f"{path}: log.topic: no topic '/states' in the {where} "
                                                          f"(topics: {TOPIC}, /other)")
    path = _write(tmp_path / "none", form, [])
    assert _error(_read, path, form) == f"{path}: log.topic: no topic '{TOPIC}' in the {where} (topics: none)"
    path = _write(tmp_path / "silent", form, [], topics=[TOPIC])
    assert _error(_read, path, form) == f"{path}: log.topic: no {JOINT_STATE} messages on '{TOPIC}'"


@pytest.mark.parametrize("form", FORMS)
def test_more_messages_than_a_log_may_have(tmp_path, form, monkeypatch):
    """At most MAX_SAMPLES messages: as many read, one more refused."""
    monkeypatch.setattr(readers, "MAX_SAMPLES", 4)
    assert len(_read(_write(tmp_path / "four", form, _messages(4)), form).times) == 4
    path = _write(tmp_path / "five", form, _messages(5))
    assert _error(_read, path, form) == f"{path}: log.topic: '{TOPIC}' has more than the 4 messages a log may have"


@pytest.mark.parametrize("form", FORMS)
def test_a_log_larger_than_a_log_may_be(tmp_path, form, monkeypatch):
    monkeypatch.setattr(readers, "MAX_LOG_BYTES", 2**20)
    path = _write(tmp_path, form, _messages())
    (path if path.is_dir() else path.parent).joinpath("padding").write_bytes(b"\0" * 2**21)
    if form == "mcap":  # a file's own size, not its folder's
        assert len(_read(path, form).times) == 4
        path.write_bytes(path.read_bytes() + b"\0" * 2**21)
    assert _error(_read, path, form) == f"{path}: log.file: is 2 MiB, more than the 1 MiB a log may have"


def test_bag_topics_of_another_type_and_folders_that_are_no_bag(tmp_path):
    strings = write_bag(tmp_path / "strings", [], msgtype="std_msgs/msg/String", topics=[TOPIC])
    assert _error(_read, strings, "rosbag2") == (f"{strings}: log.topic: '{TOPIC}' holds std_msgs/msg/String "
                                                 f"messages, not {JOINT_STATE}")
    empty = tmp_path / "empty"
    empty.mkdir()
    version = _write(tmp_path / "version", "rosbag2", _messages())
    (version / "metadata.yaml").write_text("rosbag2_bagfile_information: {version: 999}\n")
    for folder in (empty, version):
        assert _error(_read, folder, "rosbag2").startswith(f"{folder}: log.file: is not a readable rosbag2 bag: ")


def test_mcap_channels_that_are_not_cdr_joint_states_and_files_that_are_no_mcap(tmp_path):
    data = joint_state(JOINTS, [0.0, 0.0])
    cases = [({"schema": "std_msgs/msg/String"}, "std_msgs/msg/String (cdr)"),
             ({"encoding": "json"}, f"{JOINT_STATE} (json)"),
             ({"schema": None}, "schema-less (cdr)")]
    for k, (options, held) in enumerate(cases):
        path = write_mcap(tmp_path / f"{k}.mcap", [(TOPIC, 0, data)], **options)
        assert _error(_read, path, "mcap") == (f"{path}: log.topic: '{TOPIC}' holds {held} messages, not "
                                               f"CDR-encoded {JOINT_STATE}")
    garbage = tmp_path / "garbage.mcap"
    garbage.write_bytes(b"not an mcap file at all")
    assert _error(_read, garbage, "mcap").startswith(f"{garbage}: log.file: is not a readable MCAP file: ")


def _compile(path: Path, form: str):
    spec = LogSpec.model_validate({"file": str(path), "format": form, "steps": {"resample": 0.25}})
    return compile_log(spec, path.parent / "replay.yaml", JOINTS, None, "replay.yaml")


@pytest.mark.parametrize("form", FORMS)
def test_bad_values_name_the_joint_the_signal_and_the_message(tmp_path, form):
    """Checked after reading (ftc_mj.logs.trajectory): the field names the topic's signal and joint, the sample
    is the message counted from 0, and the time is the clock's."""
    def nan_at(signal: str, k0: int, j0: int) -> dict:
        return {signal: lambda k: [np.nan if (k, j) == (k0, j0) else 1.0 for j in range(2)]}

    cases = [
        (nan_at("position", 2, 1), "log.topic position of 'joint2': message 2: nan is not a finite number"),
        (nan_at("velocity", 1, 0), "log.topic velocity of 'joint1': message 1: nan is not a finite number"),
        (nan_at("effort", 3, 0), "log.topic effort of 'joint1': message 3: nan is not a finite number"),
        ({"stamp": lambda k: int(0.5e9 * min(k, 2))},
         "log.clock (header): message 3: the time does not increase (1 after 1)"),
    ]
    for k, (options, problem) in enumerate(cases):
        path = _write(tmp_path / str(k), form, _messages(**options))
        assert _error(_compile, path, form) == f"{path}: {problem}"
    log = _compile(_write(tmp_path / "good", form, _messages()), form)
    np.testing.assert_allclose(log.position[:, 1], [0.0, 0.1, 0.2, 0.3], rtol=1e-12)


@pytest.mark.parametrize("form", FORMS)
def test_a_damaged_message_is_one_line_naming_it(tmp_path, form):
    """A message whose bytes end early (rosbags' SerdeError, or a field read past the end) is named, not a
    traceback."""
    messages = _messages()
    topic, ns, data = messages[2]
    messages[2] = (topic, ns, data[:len(data) // 2])
    path = _write(tmp_path, form, messages)
    problem = _error(_read, path, form)
    assert problem.startswith(f"{path}: log.topic: message 2 on '{TOPIC}' cannot be decoded (damaged): "), problem
    assert "\n" not in problem


def test_a_bag_whose_metadata_is_not_utf8_is_one_line(tmp_path):
    path = _write(tmp_path, "rosbag2", _messages())
    metadata = path / "metadata.yaml"
    metadata.write_bytes(metadata.read_bytes().replace(b"joint_states", b"joint_\xff\xfestates", 1))
    problem = _error(_read, path, "rosbag2")
    assert problem.startswith(f"{path}: log.file: is not a readable rosbag2 bag: UnicodeDecodeError"), problem


@pytest.mark.parametrize("form", FORMS)
def test_a_joint_named_twice_in_a_message_is_refused(tmp_path, form):
    """Which of the two values is the joint's? Replaying the first one (a constant) would be wrong data."""
    messages = _messages(names=["joint1", "joint2", "joint1"], position=lambda k: [9.0, 0.1 * k, 0.1 * k])
    path = _write(tmp_path, form, messages)
    assert _error(_read, path, form) == f"{path}: log.joints: message 0 on '{TOPIC}' names the joint 'joint1' twice"
