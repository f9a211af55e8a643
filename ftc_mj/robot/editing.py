"""MjSpec edits that make a robot model a testbed robot, shared by the URDF route (:mod:`ftc_mj.robot.urdf`)
and the MJCF route (:mod:`ftc_mj.robot.mjcf`): the conventions of ``models/README.md``.

* :func:`lock_joints`: locked joints removed, their body frozen where the joint at the given value puts it
  (exact: a change of the body's frame, no constraint), with what refers to them (tendons, equalities);
* :func:`add_motors_and_sensors`: per controlled joint, in order, a ``<motor>`` ``motor<k>`` (gear 1, ``ctrl``
  = torque; ``ctrlrange`` = +-limit when there is one) and a ``<jointpos>`` sensor ``<joint>_pos``, then a
  ``<jointvel>`` sensor ``<joint>_vel`` per joint (read only with ``robot.sensors: [position, velocity]``);
* :func:`disable_contacts`: contacts off (flag and every geom's ``contype``/``conaffinity``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import mujoco
import numpy as np

from ftc_mj.config.errors import InputError

_HINGE, _SLIDE = mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE


def per_joint(value: float | Sequence[float] | None, joints: Sequence[str], source: str,
              field: str) -> list[float] | None:
    """One value for every controlled joint (a single number) or one each (a list of the right length)."""
    if value is None:
        return None
    if isinstance(value, (int, float)):
        return [float(value)] * len(joints)
    if len(value) != len(joints):
        raise InputError(source, field, f"has {len(value)} values, the robot has {len(joints)} free joints "
                                        f"({', '.join(joints)})")
    return [float(v) for v in value]


def lock_joints(spec: mujoco.MjSpec, compiled: mujoco.MjModel, lock: Mapping[str, float]) -> None:
    """Remove the joints of ``lock``, each body frozen where its joint at that value [rad or m] puts it.

    ``compiled`` is ``spec`` compiled before any edit: joint anchors and axes are read from it in their body's
    frame, whatever form the file wrote them in. A locked joint must come before every free joint of its body
    (MuJoCo moves a body by its joints in order, so only a leading joint's motion is a change of the body's
    frame); callers check that. Tendons on a locked joint and equality constraints on a locked joint or such
    a tendon are removed too.
    """
    for name, value in lock.items():
        joint = spec.joint(name)
        index = mujoco.mj_name2id(compiled, mujoco.mjtObj.mjOBJ_JOINT, name)
        offset = value - float(compiled.qpos0[compiled.jnt_qposadr[index]])
        anchor, axis = np.asarray(compiled.jnt_pos[index], dtype=float), np.asarray(compiled.jnt_axis[index], dtype=float)
        body = joint.parent
        frame = _body_quat(spec, body)
        shift = np.zeros(3)
        if joint.type == _HINGE:  # turn about the axis through the anchor: the anchor stays where it is
            turn, turned_anchor, quat = np.zeros(4), np.zeros(3), np.zeros(4)
            mujoco.mju_axisAngle2Quat(turn, axis, offset)
            mujoco.mju_rotVecQuat(turned_anchor, anchor, turn)
            mujoco.mju_mulQuat(quat, frame, turn)
            mujoco.mju_rotVecQuat(shift, anchor - turned_anchor, frame)
            body.quat = quat
            body.alt.type = mujoco.mjtOrientation.mjORIENTATION_QUAT
        else:  # slide: the origin moves along the axis
            mujoco.mju_rotVecQuat(shift, axis * offset, frame)
        body.pos = np.asarray(body.pos, dtype=float) + shift
    removed = set(lock)
    tendons = {t.name for t in spec.tendons
               if any(w.type == mujoco.mjtWrap.mjWRAP_JOINT and w.target.name in removed for w in t.path)}
    for equality in list(spec.equalities):
        names = {equality.name1, equality.name2} - {""}
        if (equality.type == mujoco.mjtEq.mjEQ_JOINT and names & removed) or \
                (equality.type == mujoco.mjtEq.mjEQ_TENDON and names & tendons):
            spec.delete(equality)
    for tendon in [t for t in spec.tendons if t.name in tendons]:
        spec.delete(tendon)
    for name in lock:
        spec.delete(spec.joint(name))


def _body_quat(spec: mujoco.MjSpec, body: mujoco.MjsBody) -> np.ndarray:
    """The body's orientation in its parent (or frame) as a unit quaternion, whatever form the file used."""
    if body.alt.type == mujoco.mjtOrientation.mjORIENTATION_QUAT:
        quat = np.asarray(body.quat, dtype=float)
    else:
        quat = np.asarray(spec.resolve_orientation(degree=spec.compiler.degree, sequence=spec.compiler.eulerseq,
                                                   orientation=body.alt), dtype=float)
    return quat / np.linalg.norm(quat)


def leading_joints_only(compiled: mujoco.MjModel, lock: Mapping[str, float]) -> str | None:
    """The first locked joint that comes after a free joint of its body (which cannot be locked by a change of
    the body's frame), or None."""
    for body in range(compiled.nbody):
        start, count = compiled.body_jntadr[body], compiled.body_jntnum[body]
        names = [compiled.joint(j).name for j in range(start, start + count)]
        free_seen = False
        for name in names:
            if name not in lock:
                free_seen = True
            elif free_seen:
                return name
    return None


def add_motors_and_sensors(spec: mujoco.MjSpec, joints: Sequence[str], limits: Sequence[float | None]) -> None:
    """A torque motor and an encoder per controlled joint, in order, then a tachometer per joint.

    The joints' own actuator force limits are switched off: the motor's ``ctrlrange`` is the one limit."""
    for k, (name, limit) in enumerate(zip(joints, limits)):
        spec.joint(name).actfrclimited = mujoco.mjtLimited.mjLIMITED_FALSE
        motor = spec.add_actuator(name=f"motor{k + 1}", target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        # Every field a motor has, not the file's default actuator (a <position> default would add a servo).
        motor.dyntype, motor.gaintype = mujoco.mjtDyn.mjDYN_NONE, mujoco.mjtGain.mjGAIN_FIXED
        motor.biastype = mujoco.mjtBias.mjBIAS_NONE
        motor.gainprm, motor.biasprm, motor.dynprm = _unit_gain(len(motor.gainprm)), np.zeros(len(motor.biasprm)), \
            _unit_gain(len(motor.dynprm))
        motor.gear = [1.0, 0, 0, 0, 0, 0]
        motor.forcelimited = motor.actlimited = mujoco.mjtLimited.mjLIMITED_FALSE
        motor.actdim = 0
        motor.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE if limit is None else mujoco.mjtLimited.mjLIMITED_TRUE
        if limit is not None:
            motor.ctrlrange = [-limit, limit]
        _exact(spec.add_sensor(name=f"{name}_pos", type=mujoco.mjtSensor.mjSENS_JOINTPOS,
                               objtype=mujoco.mjtObj.mjOBJ_JOINT, objname=name))
    for name in joints:  # tachometers after all encoders, as in models/*.xml
        _exact(spec.add_sensor(name=f"{name}_vel", type=mujoco.mjtSensor.mjSENS_JOINTVEL,
                               objtype=mujoco.mjtObj.mjOBJ_JOINT, objname=name))


def _unit_gain(size: int) -> np.ndarray:
    gain = np.zeros(size)
    gain[0] = 1.0
    return gain


def _exact(sensor: mujoco.MjsSensor) -> None:
    """No noise and no cutoff, whatever the file's default sensor says: the scenario corrupts readings."""
    sensor.noise, sensor.cutoff = 0.0, 0.0


def disable_contacts(spec: mujoco.MjSpec) -> None:
    """No contacts: the flag, and every geom out of collision (so no collision pair is even considered)."""
    for geom in spec.geoms:
        geom.contype = geom.conaffinity = 0
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
