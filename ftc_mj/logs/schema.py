"""The scenario's ``log`` section: a recorded trajectory that replaces the simulated robot.

With a ``log`` section the run has no simulated plant and no controller: the encoders' readings are the
logged positions (and the tachometers' the logged velocities, where the log holds them), and the torque the
observers and monitors are told was applied is the logged one. Every variant then names only an
``observer`` (and ``monitors``); its controller is the log (reported as ``log``). A simulation-only section
(``initial``, ``reference``, ``terms``, ``actuator_faults``, ``sensors``, ``plant``, ``timestep``) is refused
beside it. ``duration`` is optional: the log's length by default, at most that.

Fields:

* ``file``: the log, relative to the scenario file.
* ``format``: ``csv`` (with ``columns``), ``rosbag2`` (a bag folder or its ``.db3`` / ``.mcap`` file) or
  ``mcap`` (a ROS 2 MCAP file), the last two ``sensor_msgs/msg/JointState`` messages on ``topic``.
* ``joints``: the robot joints the log holds, by name: for a CSV in the order of its position (velocity,
  torque) columns, for JointState messages the names matched against each message's ``name``. Default: the
  robot's joints in its order. Every controlled joint must be in the log.
* ``scale``: multiplies each logged signal, one number or one per joint: e.g. ``torque`` the motor constants
  that turn logged currents into joint torques [N m / A]; ``time`` (one number) turns the log's time unit into
  seconds.
* ``steps``: how the observers step on the log's times. ``{resample: DT}``: on a uniform grid of period DT
  from the log's first time, every signal linearly interpolated (a sample that lies on the grid is taken as
  it is, so a log written on the grid replays its own values bit for bit). The observers' discretisation is
  then the one of simulation: a sliding-mode observer's chattering amplitude, of the order of its gain times
  DT, is that of a run at DT. Interpolation between quantised or irregularly spaced positions adds what the
  log did not hold: between two samples the position moves on a straight line, so its second difference,
  which a sliding-mode observer's injection follows, is zero inside a step and concentrated at the samples;
  resampling well below the log's own period does not add information. (Stepping on the log's own times, a
  period per step, is not offered: the built-in observers fold the period into constants when they are made,
  e.g. the TOSMO's dt k3 and the SOSMO's filter weight, so a period that changes per step would need them
  changed.)
* ``events``: labelled windows ``{start, end, joints, label}`` of what happened to the arm (e.g. pushes read
  off the logged torques); the diagnosis is then scored against them (:mod:`ftc_mj.logs.events`).
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, StrictInt, model_validator

from ftc_mj.config.types import FiniteFloat, PositiveFloat, Strict
from ftc_mj.logs.events import EventSpec

#: A CSV column: its 0-based index, or its name in the file's header row.
ColumnRef = Annotated[StrictInt, Field(ge=0)] | Annotated[str, Field(min_length=1)]


class ColumnsSpec(Strict):
    """Which CSV columns hold what; a signal per joint in the order of ``log.joints``."""

    #: The time column, by 0-based index or header name.
    time: ColumnRef
    #: The position columns, one per joint.
    position: Annotated[list[ColumnRef], Field(min_length=1)]
    #: The velocity columns, one per joint, where logged.
    velocity: list[ColumnRef] | None = None
    #: Joint torques, or motor currents with ``scale.torque`` their torque constants.
    torque: list[ColumnRef] | None = None


class ScaleSpec(Strict):
    """Factors on the logged signals (one number, or one per joint in the order of ``log.joints``)."""

    #: Factor to seconds.
    time: PositiveFloat = 1.0
    #: Factor to rad (or m).
    position: FiniteFloat | list[FiniteFloat] = 1.0
    #: Factor to rad/s (or m/s).
    velocity: FiniteFloat | list[FiniteFloat] = 1.0
    #: Factor to N m (a motor constant times a gear ratio, for currents).
    torque: FiniteFloat | list[FiniteFloat] = 1.0


class ResampleSpec(Strict):
    #: The period of the uniform grid the observers step on [s].
    resample: PositiveFloat


class LogSpec(Strict):
    #: The log file, relative to the scenario.
    file: Annotated[str, Field(min_length=1)]
    #: ``csv``, or ``rosbag2`` / ``mcap`` files of ``sensor_msgs/msg/JointState``.
    format: Literal["csv", "rosbag2", "mcap"]
    #: CSV only.
    columns: ColumnsSpec | None = None
    #: CSV only: the field separator.
    delimiter: Annotated[str, Field(min_length=1, max_length=1)] = ","
    #: rosbag2 and MCAP only: the topic of the JointState messages.
    topic: str = "/joint_states"
    #: rosbag2 and MCAP only: a message's time is its ``header`` stamp, or when it was ``received`` (recorded).
    clock: Literal["header", "received"] = "header"
    #: The robot joints the log holds, in its order (matched by name in JointState messages); default: all.
    joints: Annotated[list[str], Field(min_length=1)] | None = None
    #: Factors on the logged signals.
    scale: ScaleSpec = ScaleSpec()
    #: The uniform grid the observers step on (linear interpolation).
    steps: ResampleSpec
    #: Labelled windows (pushes, contacts) the diagnosis is scored against (:mod:`ftc_mj.logs.events`).
    events: list[EventSpec] = []

    @model_validator(mode="after")
    def _format_fields(self) -> "LogSpec":
        if self.format == "csv" and self.columns is None:
            raise ValueError("a csv log needs columns (time, position, and velocity and torque where logged)")
        if self.format != "csv" and self.columns is not None:
            raise ValueError(f"columns are for a csv log; a {self.format} log holds JointState messages")
        return self
