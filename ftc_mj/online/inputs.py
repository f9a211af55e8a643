"""How a monitor's inputs map to the robot: joint names and units, as the scenario's ``log`` section says.

A stream's samples come in the source's joint order and units, like a log's rows: a JointState message names
its joints, a CSV row holds them in the order of ``log.joints``. :class:`InputMap` takes them to the robot's
joint order and to SI units with the ``log`` section's ``joints`` and ``scale`` (``scale.torque``: e.g. motor
constants that turn currents into N m), each value multiplied as the replay multiplies it
(:func:`ftc_mj.logs.trajectory.compile_log`), so a stream and its replay see the same numbers. A scenario
without a ``log`` section maps the robot's own joint names, unscaled.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ftc_mj.config.types import per_joint
from ftc_mj.logs.readers import SIGNALS
from ftc_mj.logs.trajectory import joint_names
from ftc_mj.online.grid import SampleError
from ftc_mj.scenario.definition import Scenario


@dataclass
class InputMap:
    """The source's joints (``source_joints``, its column order) and the factors on its signals."""

    #: The robot's joints, in its order.
    robot_joints: list[str]
    #: The source's joints in its order (a CSV's columns; JointState messages may name them in any order).
    source_joints: list[str]
    #: Factor to seconds.
    time_scale: float
    #: Per robot joint, the factor on each signal (``position``, ``velocity``, ``torque``).
    scales: dict[str, np.ndarray]

    @classmethod
    def of(cls, scenario: Scenario) -> InputMap:
        """The map of ``scenario``'s ``log`` section (its robot's joints, unscaled, without one)."""
        robot = joint_names(scenario.model)
        n, file = len(robot), str(scenario.path)
        spec = scenario.spec.log
        if spec is None:
            return cls(robot, robot, 1.0, {name: np.ones(n) for name in SIGNALS})
        source = list(robot) if spec.joints is None else list(spec.joints)
        order = np.array([source.index(name) for name in robot])  # the log's checked: every robot joint is there
        scales = {name: per_joint(getattr(spec.scale, name), n, file, f"log.scale.{name}")[order] for name in SIGNALS}
        return cls(robot, source, spec.scale.time, scales)

    @property
    def source_order(self) -> np.ndarray:
        """For each robot joint, its column in the source's order."""
        return self.order(self.source_joints)

    def order(self, names: Sequence[str]) -> np.ndarray:
        """For each robot joint, its index in ``names`` (a message's joint names).

        Raises:
            SampleError: a name is not one of the source's joints, is given twice, or a robot joint is missing.
        """
        index: dict[str, int] = {}
        for i, name in enumerate(names):
            if name not in self.source_joints:
                raise SampleError("name", f"{name!r} is not a joint of the robot ({', '.join(self.source_joints)})")
            if name in index:
                raise SampleError("name", f"{name!r} is given twice")
            index[name] = i
        missing = [name for name in self.robot_joints if name not in index]
        if missing:
            raise SampleError("name", f"{', '.join(missing)} missing: every joint of the robot is needed")
        return np.array([index[name] for name in self.robot_joints])

    def to_robot(self, signal: str, values: Sequence[float] | np.ndarray, order: np.ndarray) -> np.ndarray:
        """The source's ``values`` of ``signal`` (in the order ``order`` was made for) in the robot's joint
        order and SI units."""
        return np.asarray(values, dtype=float)[order] * self.scales[signal]
