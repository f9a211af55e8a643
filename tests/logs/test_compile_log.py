"""A log section compiled for a robot (ftc_mj.logs.trajectory.compile_log) on small CSV and MCAP logs: the
compiled log's fields (its file, period, first time, logged steps), the time scale, the clock, the duration's
and the grid's edges, and each section that does not fit as its exact one line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from log_files import joint_state, write_mcap

from ftc_mj.config.errors import InputError
from ftc_mj.logs.schema import LogSpec
from ftc_mj.logs.trajectory import compile_log

ROBOT = ["joint1", "joint2"]
COLUMNS = {"time": "t", "position": ["q1", "q2"], "torque": ["i1", "i2"]}


def _csv(tmp_path: Path, times, name: str = "log.csv") -> Path:
    rows = [f"{t!r},{k},{-k},{10 * k},{-10 * k}" for k, t in enumerate(times)]
    path = tmp_path / name
    path.write_text("\n".join(["t,q1,q2,i1,i2", *rows]) + "\n")
    return path


def _compile(path: Path, robot=ROBOT, duration: float | None = None, **section):
    spec = LogSpec.model_validate({"file": str(path), "format": "csv", "columns": COLUMNS,
                                   "steps": {"resample": 0.1}, **section})
    return compile_log(spec, path.parent / "replay.yaml", robot, duration, "replay.yaml")


def _error(*args, **kwargs) -> str:
    with pytest.raises(InputError) as raised:
        _compile(*args, **kwargs)
    return str(raised.value)


def test_the_compiled_logs_fields(tmp_path):
    """Irregular times from 2 s, in milliseconds (scale 0.001): the grid from the first time, the log's own
    steps (shortest, median, longest) in seconds."""
    path = _csv(tmp_path, [2000.0, 2100.0, 2150.0, 2300.0, 2400.0])
    log = _compile(path, scale={"time": 0.001})
    assert log.file == path and log.dt == 0.1 and log.start == 2.0
    assert log.logged_steps == pytest.approx((0.05, 0.1, 0.15), rel=1e-12)
    np.testing.assert_allclose(log.times, [0.0, 0.1, 0.2, 0.3, 0.4], rtol=0, atol=1e-15)
    np.testing.assert_allclose(log.position[:, 0], [0.0, 1.0, 2 + 1 / 3, 3.0, 4.0], rtol=1e-12)
    assert log.velocity is None


def test_the_duration_and_the_grid_edges(tmp_path):
    """Five samples every 0.1 s: 0.5 s (five periods) is the longest duration; two periods are the fewest."""
    path = _csv(tmp_path, [0.0, 0.1, 0.2, 0.3, 0.4])
    assert _compile(path, duration=0.5).steps == 5
    assert _error(path, duration=0.6) == ("replay.yaml: duration: 0.6 s is longer than the log (5 periods of "
                                          "0.1 s, 0.5 s)")
    assert _compile(_csv(tmp_path, [0.0, 0.1], "two.csv")).steps == 2
    short = _csv(tmp_path, [0.0, 0.03, 0.06], "short.csv")
    assert _error(short) == "replay.yaml: log.steps.resample: the log spans 0.06 s: less than two periods of 0.1 s"


def test_sections_that_do_not_fit_the_robot(tmp_path):
    path = _csv(tmp_path, [0.0, 0.1, 0.2])
    missing = tmp_path / "nope.csv"
    assert _error(missing) == f"replay.yaml: log.file: no such file or folder: {str(missing)!r}"
    assert _error(path, joints=["joint1", "joint1"]) == "replay.yaml: log.joints.1: 'joint1' is listed twice"
    assert _error(path, robot=["joint1", "joint2", "joint3"], joints=["joint2", "joint1"]) == (
        "replay.yaml: log.joints: the log must hold every joint of the robot; joint3 is not listed")
    assert _error(path, robot=["joint0", "joint1", "joint2", "joint3"], joints=["joint1", "joint2"]) == (
        "replay.yaml: log.joints: the log must hold every joint of the robot; joint0, joint3 is not listed")
    assert _error(path, columns={**COLUMNS, "torque": ["i1", "i2", "i2"]}) == (
        "replay.yaml: log.columns.torque: has 3 columns for 2 joints (log.joints)")
    no_torque = "the log holds no torque (or current): every observer needs the torque that was applied"
    no_torque_columns = {"time": "t", "position": ["q1", "q2"]}
    assert _error(path, columns=no_torque_columns) == f"replay.yaml: log.columns.torque: {no_torque}"
    messages = [("/joint_states", k, joint_state(ROBOT, [0.1 * k, 0.0], stamp_ns=int(1.5e9 + 1e8 * k)))
                for k in range(3)]
    bag = write_mcap(tmp_path / "log.mcap", messages)
    spec = LogSpec.model_validate({"file": str(bag), "format": "mcap", "steps": {"resample": 0.1}})
    with pytest.raises(InputError) as raised:
        compile_log(spec, tmp_path / "replay.yaml", ROBOT, None, "replay.yaml")
    assert str(raised.value) == f"replay.yaml: log.topic: {no_torque}"


def test_joint_states_on_their_header_clock_by_default(tmp_path):
    """Stamped from 1.5 s, received (log time) from 0: the log starts at the header stamp."""
    messages = [("/joint_states", int(1e8 * k), joint_state(ROBOT, [0.1 * k, 0.0], [], [1.0, 2.0],
                                                             stamp_ns=int(1.5e9 + 1e8 * k))) for k in range(3)]
    spec = LogSpec.model_validate({"file": str(write_mcap(tmp_path / "log.mcap", messages)), "format": "mcap",
                                   "steps": {"resample": 0.1}})
    assert compile_log(spec, tmp_path / "replay.yaml", ROBOT, None, "replay.yaml").start == 1.5
