"""The robot's MuJoCo model: the ``robot`` section of a scenario, where the model comes from (a file, a
``package://`` name, or a MuJoCo Menagerie robot), how it is made a testbed robot (URDF through
:mod:`ftc_mj.robot.urdf`; an MJCF used as it is, or rebuilt by :mod:`ftc_mj.robot.mjcf`), the checks the loop
relies on (one joint, actuator and position sensor per DOF), and the ``sensordata`` addresses of the joint
sensors."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import mujoco
import numpy as np
from pydantic import Field

from ftc_mj.robot import cost, mjcf, urdf, visuals
from ftc_mj.robot.packages import resolve_package_uri, split_package_uri
from ftc_mj.config.errors import InputError
from ftc_mj.config.paths import input_file_problem
from ftc_mj.config.types import FiniteFloat, NonNegativeFloat, PositiveFloat, Strict

#: The options that rebuild a model; an MJCF in the testbed's form is used as it is without them.
_REBUILD_OPTIONS = ("joints", "lock", "torque_limits", "armature", "contacts")


class RobotSpec(Strict):
    #: MJCF or URDF file (``.urdf``), relative to the scenario file, or ``package://NAME/...`` (a ROS package).
    model: str | None = None
    #: Instead of ``model``: a MuJoCo Menagerie robot by name (``universal_robots_ur5e``), through the
    #: ``mujoco-menagerie`` package (downloaded on first use; a local checkout from ``MENAGERIE_ROOT``).
    menagerie: str | None = None
    #: Instead of ``model``: a robot shipped with ftc_mj, by name (``puma560``, ``two_link``, ``ur5e``,
    #: ``panda``; ``puma560.urdf`` for a URDF): found wherever the scenario file is (:data:`BUILTIN_MODELS`).
    builtin: str | None = None
    #: The Menagerie entry point (an XML of the robot's folder); default: the robot alone (its default model).
    menagerie_entry: str | None = None
    #: The controlled joints, by name, in the model's order. With an MJCF it rebuilds the model as a testbed
    #: robot (:mod:`ftc_mj.robot.mjcf`); default: every movable joint that is not locked.
    joints: list[str] | None = Field(default=None, min_length=1)
    #: Joints to lock, by name: angle [rad] (position [m] for a prismatic joint).
    lock: dict[str, FiniteFloat] = {}
    #: |torque| limit of the controlled joints' motors: one value or one per joint; overrides URDF efforts.
    #: ``model`` (MJCF): the model's own actuator force ranges.
    torque_limits: PositiveFloat | list[PositiveFloat] | Literal["model"] | None = None
    #: Reflected rotor inertia of the free joints [kg m^2], one value or one per free joint (URDF has none).
    armature: NonNegativeFloat | list[NonNegativeFloat] | None = None
    #: A rebuilt MJCF's contacts: ``off`` (the testbed's convention) or ``keep``. URDF robots have none.
    contacts: Literal["off", "keep"] | None = None
    #: Sensors the controller may read: joint encoders always; tachometers only where the chapter assumes
    #: them (Chapter 2). A method whose ``requires`` names a sensor not listed here is refused at load time.
    sensors: list[Literal["position", "velocity"]] = ["position"]
    #: Refuse a model whose visual mesh files are missing. Default: the geoms drawn with them are dropped, with
    #: one warning line, where the dynamics do not depend on them (:mod:`ftc_mj.robot.visuals`).
    strict_meshes: bool = False


class PlantSpec(Strict):
    """The simulated robot's deviations from its model file: a mismatch the controller's model does not know
    (``nominal.mass_scale`` is the controller side's). Each member of a batch may have its own values, applied
    through ``mujoco.batch``'s per-simulation model fields."""

    #: Scales every body's mass and inertia and the joint armature of the simulated robot (1 = as in the file).
    mass_scale: PositiveFloat = 1.0


#: The folder of the robots ``robot.builtin`` names.
BUILTIN_MODELS = Path(__file__).resolve().parents[2] / "models"


def builtin_model(name: str, file: str) -> Path:
    """The shipped model file ``robot.builtin`` names (``.xml`` unless the name gives its suffix)."""
    path = BUILTIN_MODELS / (name if Path(name).suffix else f"{name}.xml")
    known = sorted(p.stem if p.suffix == ".xml" else p.name for p in BUILTIN_MODELS.glob("*.*")
                   if p.suffix in (".xml", ".urdf"))
    if Path(name).name != name or not path.is_file():
        raise InputError(file, "robot.builtin", f"no shipped robot {name!r} (shipped: {', '.join(known)})")
    return path


def load_robot(scenario_path: Path, robot: RobotSpec, file: str) -> tuple[Path, mujoco.MjModel]:
    """The robot's model file and its checked MjModel."""
    if robot.builtin is not None:
        if robot.model is not None or robot.menagerie is not None:
            raise InputError(file, "robot.builtin", "give one of robot.builtin, robot.model and robot.menagerie")
        robot = robot.model_copy(update={"model": str(builtin_model(robot.builtin, file))})
    if robot.menagerie is not None:
        if robot.model is not None:
            raise InputError(file, "robot.menagerie", "give either robot.model or robot.menagerie, not both")
        model_path = _menagerie_xml(robot, file)
        model = _load_mjcf(model_path, robot, file, f"Menagerie's {robot.menagerie!r}", rebuild=True)
    elif robot.model is None:
        raise InputError(file, "robot.model", "required field is missing (or give robot.menagerie)")
    else:
        model_path = _model_file(scenario_path, robot.model, file)
        if urdf.is_urdf(model_path):
            model = _load_urdf(model_path, robot, file)
        else:
            model = _load_mjcf(model_path, robot, file, repr(robot.model), rebuild=robot.joints is not None)
    n = model.nv
    if model.nq != n or model.nu != n:
        raise InputError(file, "robot.model", f"needs one hinge/slide joint and one actuator per DOF (nq={model.nq}, "
                                              f"nv={n}, nu={model.nu}); or give robot.joints to make it a testbed "
                                              "robot")
    if position_sensor_addresses(model) is None:
        raise InputError(file, "robot.model", "needs one jointpos sensor per joint (or give robot.joints to make it a "
                                              "testbed robot: motors and sensors are then added)")
    if "velocity" in robot.sensors and velocity_sensor_addresses(model) is None:
        raise InputError(file, "robot.sensors", "velocity sensing needs one jointvel sensor per joint in the model")
    return model_path, model


def model_files(model_path: Path, file: str) -> list[Path]:
    """The files a model reads: the model file, its includes and the mesh and texture files it names that
    exist (what no output of a run may replace)."""
    if urdf.is_urdf(model_path):
        return urdf.files(model_path)
    return cost.mjcf_files(model_path, file, "robot.model")


#: How to get the ROS robot descriptions the shipped URDF and real-log scenarios use.
ROBOTS_EXTRA = ("it comes with the robots extra: pip install -e \".[robots]\" in the repository "
                "(or pip install example-robot-data)")


def _model_file(scenario_path: Path, name: str, file: str) -> Path:
    """The model file ``name`` gives: relative to the scenario file's folder, or a ``package://`` name."""
    package = split_package_uri(name)
    if package is not None:
        found = resolve_package_uri(name)
        if found is None:
            hint = (f"; {ROBOTS_EXTRA}" if package[0] == "example-robot-data" else "")
            raise InputError(file, "robot.model", f"{name!r} not found (ROS packages are looked up in "
                                                  "ROS_PACKAGE_PATH, AMENT_PREFIX_PATH and those installed with "
                                                  f"Python packages){hint}")
        problem = input_file_problem(found)
        if problem is not None:
            raise InputError(file, "robot.model", f"{name!r} ({found}) {problem}")
        return found
    model_path = cost.resolved(scenario_path.parent / name)
    problem = input_file_problem(model_path)
    if problem is not None:
        raise InputError(file, "robot.model", f"model file {name!r} {problem}: looked for {str(model_path)!r} "
                                              "(relative to the scenario's folder; a shipped robot can be named "
                                              "anywhere as robot.builtin)")
    return model_path


def _menagerie_xml(robot: RobotSpec, file: str) -> Path:
    """The XML of a Menagerie robot's entry point (downloaded on first use by ``mujoco-menagerie``)."""
    import mujoco_menagerie

    try:
        entry = mujoco_menagerie.get(robot.menagerie)
    except mujoco_menagerie.UnknownRobotError as exc:
        raise InputError(file, "robot.menagerie", str(exc)) from None
    try:
        return entry.xml(robot.menagerie_entry or entry.default_model)
    except mujoco_menagerie.UnknownEntryPointError as exc:
        raise InputError(file, "robot.menagerie_entry", str(exc)) from None
    except (mujoco_menagerie.MenagerieError, OSError) as exc:
        raise InputError(file, "robot.menagerie", f"cannot get {robot.menagerie!r}: {exc} (a local Menagerie "
                                                  "checkout is read from MENAGERIE_ROOT)") from None


def _load_urdf(model_path: Path, robot: RobotSpec, file: str) -> mujoco.MjModel:
    if robot.contacts == "keep":
        raise InputError(file, "robot.contacts", "a URDF robot has no contacts here (its <collision> shapes are not "
                                                 "used)")
    return urdf.load_model(model_path, joints=robot.joints, lock=robot.lock, torque_limits=robot.torque_limits,
                           armature=robot.armature, strict_meshes=robot.strict_meshes, source=file, field="robot")


def _load_mjcf(model_path: Path, robot: RobotSpec, file: str, name: str, rebuild: bool) -> mujoco.MjModel:
    """An MJCF model: as it is in the testbed's form, or rebuilt as a testbed robot."""
    if robot.armature is not None:
        raise InputError(file, "robot.armature", "is for URDF models only; an MJCF model sets it in its file")
    if not rebuild:
        for option in _REBUILD_OPTIONS:
            if getattr(robot, option) not in (None, {}):
                raise InputError(file, f"robot.{option}", "is for URDF models only, or for an MJCF rebuilt as a "
                                                          "testbed robot (give robot.joints)")
    cost.mjcf_files(model_path, file, "robot.model")  # its bounds, before MuJoCo's parser (which does not stop)
    try:
        spec = mujoco.MjSpec.from_file(str(model_path))
    except ValueError as exc:
        raise InputError(file, "robot.model", f"MuJoCo cannot load {name}: {_first_line(exc)}") from None
    contacts_on = not spec.option.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT and (
        not rebuild or robot.contacts == "keep")
    dropped = visuals.drop_missing_meshes(spec, contacts_on=contacts_on, strict=robot.strict_meshes, model=name,
                                          source=file, field="robot.model")
    if not rebuild:
        try:
            # A model with every file there is compiled from its file, as MuJoCo's own loader does.
            model = spec.compile() if dropped else mujoco.MjModel.from_xml_path(str(model_path))
        except ValueError as exc:
            raise InputError(file, "robot.model", f"MuJoCo cannot load {name}: {_first_line(exc)}") from None
    else:
        model = mjcf.rebuild(spec, joints=robot.joints, lock=robot.lock, torque_limits=robot.torque_limits,
                             contacts=robot.contacts or "off", name=name, source=file)
    visuals.warn_dropped(file, "robot.model", name, dropped)
    return model


def _first_line(exc: Exception) -> str:
    return str(exc).strip().splitlines()[0] if str(exc).strip() else "cannot compile"


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
