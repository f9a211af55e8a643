"""The readers on small files written here: a CSV (header names and indices), a rosbag2 bag and an MCAP file of
JointState messages (written with rosbags and mcap), each compiled into the same trajectory; and every bad input
as its one line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from log_files import (
    CSV_LOG,
    joint_state,
    log_scenario,
    trajectory,
    write_bag,
    write_csv,
    write_mcap,
)

from ftc_mj import load_scenario
from ftc_mj.config.errors import InputError

rosbags = pytest.importorskip("rosbags")
pytest.importorskip("mcap")


def test_csv_by_name_and_by_index_scaled_and_reordered(tmp_path):
    t, q, qd, tau = trajectory()
    write_csv(tmp_path / "log.csv", t, q, qd, tau)
    log = load_scenario(log_scenario(tmp_path, {**CSV_LOG, "file": "log.csv", "scale": {"torque": [2.0, 3.0]}})).log
    np.testing.assert_array_equal(log.position, q)  # on the grid: the samples themselves
    np.testing.assert_array_equal(log.velocity, qd)
    np.testing.assert_allclose(log.torque, tau * [2.0, 3.0], rtol=1e-15)
    # Columns by index, the joints in the other order: the robot's order comes back.
    write_csv(tmp_path / "plain.csv", t, q[:, ::-1], qd[:, ::-1], tau[:, ::-1], header=False)
    section = {"file": "plain.csv", "format": "csv", "joints": ["joint2", "joint1"], "steps": {"resample": 0.01},
               "columns": {"time": 0, "position": [1, 2], "velocity": [3, 4], "torque": [5, 6]}}
    log = load_scenario(log_scenario(tmp_path, section)).log
    np.testing.assert_array_equal(log.position, q)
    np.testing.assert_array_equal(log.torque, tau)


def test_resampling_interpolates_between_irregular_samples(tmp_path):
    t = np.array([0.0, 0.01, 0.022, 0.03, 0.041])
    q = np.column_stack([t, 2 * t])
    write_csv(tmp_path / "log.csv", t, q, q, q)
    log = load_scenario(log_scenario(tmp_path, {**CSV_LOG, "file": "log.csv"})).log
    np.testing.assert_allclose(log.times, [0.0, 0.01, 0.02, 0.03, 0.04])
    np.testing.assert_allclose(log.position[:, 1], 2 * log.times, atol=1e-15)  # linear in time: exact


@pytest.mark.parametrize("form", ["rosbag2", "mcap"])
def test_joint_states_by_name(tmp_path, form):
    t, q, qd, tau = trajectory(50)
    names = ["joint2", "gripper", "joint1"]  # another order and a joint the robot lacks: picked by name
    path = _write_named(tmp_path, form, t, q, qd, tau, names)
    log = load_scenario(log_scenario(tmp_path, {"file": path.name, "format": form, "steps": {"resample": 0.01}})).log
    np.testing.assert_allclose(log.position, q, atol=1e-12)
    np.testing.assert_allclose(log.velocity, qd, atol=1e-12)
    np.testing.assert_allclose(log.torque, tau, atol=1e-12)


def _write_named(tmp_path, form, t, q, qd, tau, names):
    """JointState messages naming ``names`` (the robot's joints among them, the others zeros), in a rosbag2 bag
    or an MCAP file."""
    columns = {"joint1": 0, "joint2": 1}

    def pick(x):
        return np.column_stack([x[:, columns[name]] if name in columns else np.zeros(len(t)) for name in names])

    qn, qdn, taun = pick(q), pick(qd), pick(tau)
    messages = []
    for k in range(len(t)):
        ns = int(round(t[k] * 1e9))
        messages.append(("/joint_states", ns, joint_state(names, qn[k], qdn[k], taun[k], ns)))
    if form == "rosbag2":
        return write_bag(tmp_path / "bag", messages)
    return write_mcap(tmp_path / "log.mcap", messages)


def _bad_csv(tmp_path: Path, edit) -> Path:
    t, q, qd, tau = trajectory(20)
    table = np.column_stack([t, q, qd, tau])
    edit(table)
    np.savetxt(tmp_path / "log.csv", table, fmt="%.17g", delimiter=",", header="t,q1,q2,qd1,qd2,i1,i2", comments="")
    return tmp_path / "log.csv"


def _set(row: int, column: int, value: float):
    def edit(table):
        table[row, column] = value
    return edit


BAD = [
    ("non-monotonic time", _set(7, 0, 0.01), {}, "log.csv: log.columns.time: row 9: the time does not increase"),
    ("NaN row", _set(4, 2, np.nan), {}, "log.csv: log.columns.position.1: row 6: nan is not a finite number"),
    ("missing column", None, {"columns": {"time": "t", "position": ["q1", "q9"], "torque": ["i1", "i2"]}},
     "log.csv: log.columns.position.1: no column 'q9' in the header"),
    ("column index", None, {"columns": {"time": 0, "position": [1, 31], "torque": [5, 6]}},
     "log.csv: log.columns.position.1: column 31 is not in the file (it has 7 columns"),
    ("unknown joint", None, {"joints": ["joint1", "elbow"]},
     "replay.yaml: log.joints.1: 'elbow' is not a joint of the robot (joint1, joint2)"),
    ("scale length", None, {"scale": {"torque": [10.0, 10.7, 8.5]}}, "replay.yaml: log.scale.torque: "),
    ("no torque", None, {"columns": {"time": "t", "position": ["q1", "q2"]}},
     "replay.yaml: log.columns.torque: the log holds no torque"),
    ("a controller", None, {"__variants": {"eso": {"observer": {"type": "eso", "gains": {"bandwidth": 20.0}},
                                                   "controller": {"type": "smc"}}}},
     "replay.yaml: variants.eso.controller: a log has no controller"),
    ("velocity needed", None, {"columns": {"time": "t", "position": ["q1", "q2"], "torque": ["i1", "i2"]},
                               "__variants": {"do": {"observer": {"type": "do", "gains": {
                                   "k1": 8.0, "k2": 18.0, "p1": 10.0, "p2": 10.0}}}}},
     "replay.yaml: variants.do.observer.type: do needs velocity, which the log does not hold"),
    ("a simulation section", None, {"__initial": {"q": [0.0, 0.0]}},
     "replay.yaml: initial: a log replaces the simulated robot"),
    ("too long", None, {"__duration": 5.0}, "replay.yaml: duration: 5 s is longer than the log"),
]


@pytest.mark.parametrize("case, edit, section, expected", BAD, ids=[case[0] for case in BAD])
def test_bad_input_is_one_line(tmp_path, monkeypatch, case, edit, section, expected):
    _bad_csv(tmp_path, edit or (lambda table: None))
    # Copies, not pops: the parameters are module-level dicts, shared by every run of this test in the process
    # (mutmut runs the subset twice in one interpreter).
    extra = {key[2:]: value for key, value in section.items() if key.startswith("__")}
    section = {key: value for key, value in section.items() if not key.startswith("__")}
    variants = extra.pop("variants", None)
    path = log_scenario(tmp_path, {**CSV_LOG, "file": "log.csv", **section}, variants, **extra)
    monkeypatch.chdir(tmp_path)
    with pytest.raises(InputError) as raised:
        load_scenario("replay.yaml")
    message = str(raised.value)
    assert "\n" not in message
    assert message.replace(str(tmp_path) + "/", "").startswith(expected), message
    del path


def test_command_line_exits_2_and_writes_nothing(tmp_path, monkeypatch):
    from ftc_mj.cli.run import main

    _bad_csv(tmp_path, _set(3, 0, np.nan))
    log_scenario(tmp_path, {**CSV_LOG, "file": "log.csv"})
    monkeypatch.chdir(tmp_path)
    before = sorted(p.name for p in tmp_path.iterdir())
    assert main(["replay.yaml", "--json", "out.json", "--out", "out.rrd", "--export-log", "x.csv"]) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == before


@pytest.mark.parametrize("form", ["rosbag2", "mcap"])
def test_joint_states_lacking_a_joint(tmp_path, form):
    t, q, qd, tau = trajectory(5)
    path = _write_named(tmp_path, form, t, q, qd, tau, ["joint1", "gripper"])
    with pytest.raises(InputError, match=r"log\.joints: message 0 on '/joint_states' has no joint 'joint2'"):
        load_scenario(log_scenario(tmp_path, {"file": path.name, "format": form, "steps": {"resample": 0.01}}))


def test_a_topic_that_is_not_there(tmp_path):
    t, q, qd, tau = trajectory(5)
    path = _write_named(tmp_path, "mcap", t, q, qd, tau, ["joint1", "joint2"])
    with pytest.raises(InputError, match=r"log\.topic: no topic '/states' in the file \(topics: /joint_states\)"):
        load_scenario(log_scenario(tmp_path, {"file": path.name, "format": "mcap", "topic": "/states",
                                              "steps": {"resample": 0.01}}))
