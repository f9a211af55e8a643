"""A log compiled for a run (:class:`Log`): its signals checked, scaled, in the robot's joint order and on
the observers' grid (:func:`compile_log`, the ``log`` section's compile function; the section's fields and what
resampling does: :mod:`ftc_mj.logs.schema`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ftc_mj.config.errors import InputError
from ftc_mj.config.types import per_joint
from ftc_mj.logs.events import Event, compile_events
from ftc_mj.logs.readers import SIGNALS, Recording, read_csv, read_joint_states
from ftc_mj.logs.schema import LogSpec


@dataclass
class Log:
    """The logged trajectory on the grid ``times`` = k DT (from the log's first time): ``(steps, n)`` per
    signal in the robot's joint order; ``velocity`` None where the log holds none."""

    file: Path
    times: np.ndarray
    position: np.ndarray
    velocity: np.ndarray | None
    torque: np.ndarray
    dt: float
    #: The log's own time of the grid's first instant [s].
    start: float
    #: The log's own steps [s]: the shortest, the median and the longest.
    logged_steps: tuple[float, float, float]
    #: The labelled windows of ``log.events``, joints as indices.
    events: list[Event] = field(default_factory=list)

    @property
    def steps(self) -> int:
        return len(self.times)


def joint_names(model) -> list[str]:
    """The robot's joint of each DOF, by name (the order of every per-joint series)."""
    return [model.joint(int(model.dof_jntid[d])).name for d in range(model.nv)]


def compile_log(spec: LogSpec, scenario_path: Path, robot_joints: list[str], duration: float | None,
                file: str) -> Log:
    """Read the log of the section ``spec`` of the scenario ``file`` (at ``scenario_path``) for a robot whose
    joints are ``robot_joints``; ``duration`` (None: the whole log) of it on the grid of ``spec.steps``.

    Raises:
        InputError: the section does not fit the robot (the scenario's field), or the log holds something
            that cannot be replayed (the log file, the field that points into it).
    """
    path = Path(spec.file)
    if not path.is_absolute():
        path = scenario_path.parent / path
    if not path.exists():
        raise InputError(file, "log.file", f"no such file or folder: {str(path)!r}")
    joints = list(robot_joints) if spec.joints is None else list(spec.joints)
    for j, name in enumerate(joints):
        if name not in robot_joints:
            raise InputError(file, f"log.joints.{j}", f"{name!r} is not a joint of the robot "
                             f"({', '.join(robot_joints)})")
        if joints.index(name) != j:
            raise InputError(file, f"log.joints.{j}", f"{name!r} is listed twice")
    missing = [name for name in robot_joints if name not in joints]
    if missing:
        raise InputError(file, "log.joints", f"the log must hold every joint of the robot; {', '.join(missing)} "
                         "is not listed")
    n = len(joints)
    if spec.format == "csv":
        for name in SIGNALS:
            listed = getattr(spec.columns, name)
            if listed is not None and len(listed) != n:
                raise InputError(file, f"log.columns.{name}", f"has {len(listed)} columns for {n} joints (log.joints)")
        recording = read_csv(path, spec.columns, spec.delimiter)
    else:
        recording = read_joint_states(path, spec.format, spec.topic, joints, spec.clock)
    scales = {name: per_joint(getattr(spec.scale, name), n, file, f"log.scale.{name}") for name in SIGNALS}
    _check(recording)
    if recording.torque is None:
        where = "log.columns.torque" if spec.format == "csv" else "log.topic"
        raise InputError(file, where, "the log holds no torque (or current): every observer needs the torque that "
                         "was applied")
    order = [joints.index(name) for name in robot_joints]  # robot joint j is log column order[j]

    def signal(name: str) -> np.ndarray | None:
        values = getattr(recording, name)
        return None if values is None else values[:, order] * scales[name][order]

    times = recording.times * spec.scale.time
    dt = spec.steps.resample
    relative = times - times[0]
    available = math.floor(relative[-1] / dt + 1e-9) + 1  # grid instants within the log
    steps = available
    if duration is not None:
        steps = int(round(duration / dt))
        if steps > available:
            raise InputError(file, "duration", f"{duration:g} s is longer than the log ({available} periods of "
                             f"{dt:g} s, {available * dt:g} s)")
    if steps < 2:
        raise InputError(file, "log.steps.resample", f"the log spans {relative[-1]:g} s: less than two periods "
                         f"of {dt:g} s")
    grid = np.arange(steps) * dt  # the run's time grid (ftc_mj.scenario.definition.time_grid)
    differences = np.diff(times)
    events = compile_events(spec.events, list(robot_joints), file)
    log_end = (available - 1) * dt
    for e, event in enumerate(events):
        if event.start >= log_end:
            raise InputError(file, f"log.events.{e}.start", f"{event.start:g} s is after the log's end "
                             f"({log_end:g} s)")
    # A run shortened by `duration` scores only the events it reaches: the others did not happen in it.
    events = [event for event in events if event.start < grid[-1]]
    return Log(path, grid, resample(grid, relative, signal("position")), _maybe(grid, relative, signal("velocity")),
               resample(grid, relative, signal("torque")), dt, float(times[0]),
               (float(differences.min()), float(np.median(differences)), float(differences.max())), events)


def resample(grid: np.ndarray, times: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Each column of ``values`` (sampled at ``times``) at ``grid``, linearly interpolated; a grid instant
    equal to a sample time takes that sample's value exactly."""
    out = np.empty((len(grid), values.shape[1]))
    for j in range(values.shape[1]):
        out[:, j] = np.interp(grid, times, values[:, j])
    return out


def _maybe(grid: np.ndarray, times: np.ndarray, values: np.ndarray | None) -> np.ndarray | None:
    return None if values is None else resample(grid, times, values)


def _check(recording: Recording) -> None:
    """Every used value is a finite number and the time increases strictly, or the one-line error naming the
    first sample that is not."""
    file, sample, first = recording.file, recording.sample, recording.first
    if len(recording.times) < 2:
        raise InputError(file, recording.fields["time"][0], f"the log has {len(recording.times)} sample: at least "
                         "two are needed")
    for name in ("time", *SIGNALS):
        values = recording.times[:, None] if name == "time" else getattr(recording, name)
        if values is None:
            continue
        bad = ~np.isfinite(values)
        if bad.any():
            k, j = np.argwhere(bad)[0]
            raise InputError(file, recording.fields[name][j], f"{sample} {k + first}: {values[k, j]} is not a finite "
                             "number")
    steps = np.diff(recording.times)
    if np.any(steps <= 0):
        k = int(np.flatnonzero(steps <= 0)[0]) + 1
        raise InputError(file, recording.fields["time"][0], f"{sample} {k + first}: the time does not increase "
                         f"({recording.times[k]:.9g} after {recording.times[k - 1]:.9g})")
