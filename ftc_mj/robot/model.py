"""The robot's MuJoCo model: the ``robot`` section of a scenario, loading an MJCF or URDF file (the latter
through :mod:`ftc_mj.robot.urdf`), the checks the loop relies on (one joint, actuator and position sensor per
DOF), and the ``sensordata`` addresses of the joint sensors."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import mujoco
import numpy as np

from ftc_mj.robot import urdf
from ftc_mj.spec.errors import InputError
from ftc_mj.spec.schema import FiniteFloat, NonNegativeFloat, PositiveFloat, Strict


class UrdfOptions(Strict):
    """Options of a URDF robot (``ftc_mj/robot/urdf.py``); an MJCF model states them in its own file."""

    #: Joints to lock, by name: angle [rad] (position [m] for a prismatic joint).
    lock: dict[str, FiniteFloat] = {}
    #: |torque| limit of the free joints' motors, one value or one per free joint; overrides URDF efforts.
    torque_limits: PositiveFloat | list[PositiveFloat] | None = None
    #: Reflected rotor inertia of the free joints [kg m^2], one value or one per free joint (URDF has none).
    armature: NonNegativeFloat | list[NonNegativeFloat] | None = None


class RobotSpec(UrdfOptions):
    #: MJCF or URDF file (``.urdf``), relative to the scenario file.
    model: str
    #: Sensors the controller may read: joint encoders always; tachometers only where the chapter assumes
    #: them (Chapter 2). A method whose ``requires`` names a sensor not listed here is refused at load time.
    sensors: list[Literal["position", "velocity"]] = ["position"]


class PlantSpec(Strict):
    """The simulated robot's deviations from its model file: a mismatch the controller's model does not know
    (``nominal.mass_scale`` is the controller side's). Each member of a batch may have its own values, applied
    through ``mujoco.batch``'s per-simulation model fields."""

    #: Scales every body's mass and inertia and the joint armature of the simulated robot (1 = as in the file).
    mass_scale: PositiveFloat = 1.0


def load_robot(scenario_path: Path, robot: RobotSpec, file: str) -> tuple[Path, mujoco.MjModel]:
    """The robot's model file (resolved against the scenario file's folder) and its checked MjModel."""
    model_path = (scenario_path.parent / robot.model).resolve()
    if not model_path.is_file():
        raise InputError(file, "robot.model", f"model file {robot.model!r} not found")
    model = _load_model(model_path, robot, file)
    n = model.nv
    if model.nq != n or model.nu != n:
        raise InputError(file, "robot.model", f"needs one hinge/slide joint and one actuator per DOF (nq={model.nq}, nv={n}, nu={model.nu})")
    if position_sensor_addresses(model) is None:
        raise InputError(file, "robot.model", "needs one jointpos sensor per joint")
    if "velocity" in robot.sensors and velocity_sensor_addresses(model) is None:
        raise InputError(file, "robot.sensors", "velocity sensing needs one jointvel sensor per joint in the model")
    return model_path, model


def _load_model(model_path: Path, robot: RobotSpec, file: str) -> mujoco.MjModel:
    """The robot's MjModel: a URDF through ftc_mj.robot.urdf, anything else as MJCF."""
    if urdf.is_urdf(model_path):
        return urdf.load_model(model_path, lock=robot.lock, torque_limits=robot.torque_limits,
                               armature=robot.armature, source=file, field="robot")
    for option in UrdfOptions.model_fields:
        if getattr(robot, option) not in (None, {}):
            raise InputError(file, f"robot.{option}", "is for URDF models only; an MJCF model sets it in its file")
    try:
        return mujoco.MjModel.from_xml_path(str(model_path))
    except ValueError as exc:
        first_line = str(exc).strip().splitlines()[0] if str(exc).strip() else "cannot compile"
        raise InputError(file, "robot.model", f"MuJoCo cannot load {robot.model!r}: {first_line}") from None


def position_sensor_addresses(model: mujoco.MjModel) -> np.ndarray | None:
    """sensordata addresses of the jointpos sensors, in joint order, or None if a joint has none."""
    return _joint_sensor_addresses(model, mujoco.mjtSensor.mjSENS_JOINTPOS)


def velocity_sensor_addresses(model: mujoco.MjModel) -> np.ndarray | None:
    """sensordata addresses of the jointvel sensors (tachometers), in joint order, or None if a joint has none."""
    return _joint_sensor_addresses(model, mujoco.mjtSensor.mjSENS_JOINTVEL)


def _joint_sensor_addresses(model: mujoco.MjModel, sensor_type: mujoco.mjtSensor) -> np.ndarray | None:
    addresses = {}
    for sensor in range(model.nsensor):
        if model.sensor_type[sensor] == sensor_type:
            joint = model.sensor_objid[sensor]
            addresses[int(model.jnt_dofadr[joint])] = int(model.sensor_adr[sensor])
    if sorted(addresses) != list(range(model.nv)):
        return None
    return np.array([addresses[dof] for dof in range(model.nv)])
