"""MJCF robots as they come (MuJoCo Menagerie's and the like) made into testbed robots with MjSpec.

An arm in Menagerie form has position servos (or other actuators), joint damping, friction loss and armature,
collision geoms and no joint sensors. Given the joints to control, :func:`rebuild` makes it a robot of the
testbed's form (``models/README.md``), leaving the file unchanged on disk:

* the controlled joints, in the model's order; every other hinge or slide joint locked at its value (its
  ``lock`` value, else the model's reference position ``qpos0``): removed, its body frozen there
  (:func:`ftc_mj.robot.editing.lock_joints`), with the tendons and equality constraints on it;
* the model's actuators, sensors and keyframes removed; a torque motor ``motor<k>`` and the joint sensors per
  controlled joint (:func:`ftc_mj.robot.editing.add_motors_and_sensors`); torque limits as the scenario says
  (none, given numbers, or ``model``: the removed actuators' force ranges times their gear);
* contacts off unless the scenario keeps them; the ``implicitfast`` integrator (see ``models/README.md``);
* everything else kept: masses, inertias, joint damping, friction loss, armature, stiffness and ranges. The
  controller's nominal model has the rigid-body terms only (M(q), with armature, and C, G): damping, friction
  loss, stiffness and limits act on the simulated arm alone, a part of the true lumped uncertainty.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Literal

import mujoco
import numpy as np

from ftc_mj.robot import editing
from ftc_mj.config.errors import InputError

_MOVABLE = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


def rebuild(
    spec: mujoco.MjSpec,
    *,
    joints: Sequence[str] | None,
    lock: Mapping[str, float],
    torque_limits: float | Sequence[float] | Literal["model"] | None,
    contacts: Literal["off", "keep"],
    name: str,
    source: str,
    field: str = "robot",
) -> mujoco.MjModel:
    """The testbed's model of the MJCF ``spec`` (edited in place), named ``name`` in messages.

    Args:
        joints: the controlled joints, in the model's order; None: every hinge and slide joint not locked.
        lock: joints to hold, by name, at a value [rad or m]; the other joints not controlled are held at
            their reference position ``qpos0``.
        torque_limits: |torque| limit of the motors [N m or N]: one value, one per controlled joint, ``model``
            (each joint's actuator force range times its gear, where the model limits it) or None (no limit).
        contacts: ``off`` (the testbed's convention) or ``keep`` (the model's own collision settings).
        source, field: the scenario file and the ``robot`` section's path, for errors.

    Raises:
        InputError: naming ``source`` and the option's field.
    """
    original = _compile(spec, name, source, field)
    controlled, held = _choose_joints(original, joints, dict(lock), name, source, field)
    limits = _torque_limits(original, controlled, torque_limits, name, source, field)
    for actuator in list(spec.actuators):
        spec.delete(actuator)
    for sensor in list(spec.sensors):  # replaced by the testbed's own joint sensors
        spec.delete(sensor)
    for key in list(spec.keys):  # their qpos and ctrl have the removed joints and actuators
        spec.delete(key)
    editing.lock_joints(spec, original, held)
    for joint in controlled:  # ctrl is the joint torque: no gravity compensation through the actuator
        spec.joint(joint).actgravcomp = 0
    editing.add_motors_and_sensors(spec, controlled, limits)
    if contacts == "off":
        editing.disable_contacts(spec)
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    model = _compile(spec, name, source, field)
    compiled = [model.joint(i).name for i in range(model.njnt)]
    if compiled != controlled:  # the actuators, sensors and scenario vectors assume this order
        raise RuntimeError(f"{name}: MuJoCo ordered the joints {compiled}, expected {controlled}")
    return model


def _compile(spec: mujoco.MjSpec, name: str, source: str, field: str) -> mujoco.MjModel:
    try:
        return spec.compile()
    except ValueError as exc:
        lines = [line.strip() for line in str(exc).strip().splitlines() if line.strip()]
        raise InputError(source, field, f"MuJoCo cannot compile {name}: {'; '.join(lines[:2])}") from None


def _choose_joints(model: mujoco.MjModel, joints: Sequence[str] | None, lock: dict[str, float], name: str,
                   source: str, field: str) -> tuple[list[str], dict[str, float]]:
    """The controlled joints (checked, in the model's order) and every other joint's value to hold."""
    names = [model.joint(j).name for j in range(model.njnt)]
    for j, joint in enumerate(names):
        kind = int(model.jnt_type[j])
        if kind == int(mujoco.mjtJoint.mjJNT_FREE):
            raise InputError(source, field, f"{name}: joint {joint!r} is a free joint (a floating base): the testbed "
                                            "simulates fixed-base arms")
        if kind not in _MOVABLE:
            raise InputError(source, field, f"{name}: joint {joint!r} is a ball joint: the testbed controls hinge and "
                                            "slide joints only")
        if not joint:
            raise InputError(source, field, f"{name}: joint {j} has no name (needed to control or lock it)")
    for joint, value in lock.items():
        if joint not in names:
            raise InputError(source, f"{field}.lock.{joint}", f"{name} has no joint {joint!r} (joints: "
                                                              f"{', '.join(names)})")
        _check_within_range(model, names.index(joint), value, f"{field}.lock.{joint}", source)
    if joints is None:
        controlled = [joint for joint in names if joint not in lock]
    else:
        for k, joint in enumerate(joints):
            if joint not in names:
                raise InputError(source, f"{field}.joints.{k}", f"{name} has no joint {joint!r} (joints: "
                                                                f"{', '.join(names)})")
            if joint in lock:
                raise InputError(source, f"{field}.joints.{k}", f"joint {joint!r} is also in {field}.lock")
        if len(set(joints)) != len(joints):
            raise InputError(source, f"{field}.joints", "names a joint twice")
        in_order = [joint for joint in names if joint in joints]
        if list(joints) != in_order:
            raise InputError(source, f"{field}.joints", f"must follow the model's joint order (its qpos order): "
                                                        f"{in_order}")
        controlled = list(joints)
    if not controlled:
        raise InputError(source, f"{field}.lock", f"locks every joint of {name}: nothing to control")
    held = {joint: lock.get(joint, float(model.qpos0[model.jnt_qposadr[names.index(joint)]]))
            for joint in names if joint not in controlled}
    for joint in held:
        if joint not in lock:
            _check_within_range(model, names.index(joint), held[joint], f"{field}.lock", source,
                                f"joint {joint!r} is not controlled, so it is held at its reference position: ")
    problem = editing.leading_joints_only(model, held)
    if problem is not None:
        raise InputError(source, f"{field}.lock", f"{name}: joint {problem!r} comes after a controlled joint of "
                                                  "the same body, so it cannot be held (lock that one too)")
    return controlled, held


def _check_within_range(model: mujoco.MjModel, joint: int, value: float, element: str, source: str,
                        prefix: str = "") -> None:
    if model.jnt_limited[joint]:
        low, high = model.jnt_range[joint]
        if not low <= value <= high:
            raise InputError(source, element, f"{prefix}{value} is outside the range of joint "
                                              f"{model.joint(joint).name!r} [{low:g}, {high:g}]")


def _torque_limits(model: mujoco.MjModel, controlled: list[str], torque_limits, name: str, source: str,
                   field: str) -> list[float | None]:
    if torque_limits is None:
        return [None] * len(controlled)
    if torque_limits != "model":
        return editing.per_joint(torque_limits, controlled, source, f"{field}.torque_limits")
    limits: list[float | None] = []
    for joint in controlled:
        j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint)
        found = [float(np.max(np.abs(model.actuator_forcerange[a])) * abs(model.actuator_gear[a, 0]))
                 for a in range(model.nu)
                 if model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT and model.actuator_trnid[a, 0] == j
                 and model.actuator_forcelimited[a]]
        if model.jnt_actfrclimited[j]:
            found.append(float(np.max(np.abs(model.jnt_actfrcrange[j]))))
        limits.append(min(found) if found and min(found) > 0 else None)
    return limits
