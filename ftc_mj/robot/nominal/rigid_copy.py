"""The nominal model's private copy of the robot's MjModel: the rigid-body model of eq. (5.2) alone
(:func:`rigid_body_model`), and its controlled mismatch (:func:`scale_masses`)."""

from __future__ import annotations

import copy
from collections.abc import Callable

import mujoco
import numpy as np


#: What the nominal model leaves out of MuJoCo's forward dynamics: constraints (joint limits, contacts,
#: friction loss), passive forces, actuators and sensors. What remains is qacc = M(q)^-1 (qfrc_applied - C(q, qd) qd -
#: G(q)), the rigid-body model of eq. (5.2).
_RIGID_BODY_ONLY = (
    mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    | mujoco.mjtDisableBit.mjDSBL_CONTACT
    | mujoco.mjtDisableBit.mjDSBL_SPRING
    | mujoco.mjtDisableBit.mjDSBL_DAMPER
    | mujoco.mjtDisableBit.mjDSBL_ACTUATION
    | mujoco.mjtDisableBit.mjDSBL_SENSOR
)
#: Joints :func:`rigid_body_model` rebuilds (a robot arm's); a model with others keeps its plain copy.
REBUILT_JOINTS = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
#: Random states at which a rebuilt rigid-body model must give the plain copy's numbers bit for bit.
_CHECK_STATES = 8


def rigid_body_model(model: mujoco.MjModel) -> mujoco.MjModel:
    """A private copy of ``model`` that computes the rigid-body model of eq. (5.2) alone: constraints, passive
    forces, actuators and sensors disabled (:data:`_RIGID_BODY_ONLY`).

    Where it can, the copy is rebuilt from the kinematic tree and inertias alone: bodies (frames, masses,
    inertias, gravity compensation) and hinge or slide joints (axes, anchors, reference positions, armature),
    without geoms, sites, cameras, lights, sensors or actuators, which the nominal model never uses but MuJoCo
    would still place at every evaluation (a sixth of a forward pass on the PUMA560). The rebuilt copy must
    give the plain copy's M, factorisation, C qd + G and acceleration under an applied force bit for bit at
    random states; where it does not, or the model has what is not rebuilt (other joints, tendons, equality
    constraints, flexes, mocap bodies), the plain copy is returned."""
    full = copy.deepcopy(model)
    full.opt.disableflags |= int(_RIGID_BODY_ONLY)
    if (model.ntendon or model.neq or model.nflex or model.nmocap
            or not np.isin(model.jnt_type, REBUILT_JOINTS).all()):
        return full
    spec = mujoco.MjSpec()
    spec.option.gravity = model.opt.gravity
    bodies = [spec.worldbody]
    for b in range(1, model.nbody):
        body = bodies[model.body_parentid[b]].add_body(
            pos=model.body_pos[b], quat=model.body_quat[b], mass=model.body_mass[b], ipos=model.body_ipos[b],
            iquat=model.body_iquat[b], inertia=model.body_inertia[b], explicitinertial=True,
            gravcomp=model.body_gravcomp[b])
        bodies.append(body)
        for joint in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b]):
            body.add_joint(type=mujoco.mjtJoint(model.jnt_type[joint]), axis=model.jnt_axis[joint],
                           pos=model.jnt_pos[joint], ref=model.qpos0[model.jnt_qposadr[joint]],
                           armature=model.dof_armature[model.jnt_dofadr[joint]])
    try:
        rigid = spec.compile()
    except ValueError:
        return full
    rigid.opt.disableflags, rigid.opt.enableflags = full.opt.disableflags, full.opt.enableflags
    return rigid if _same_dynamics(full, rigid) else full


def _same_dynamics(model: mujoco.MjModel, other: mujoco.MjModel) -> bool:
    """Whether two models give the same M, factorisation, bias and acceleration, bit for bit, at random states."""
    if (other.nq, other.nv, other.nM) != (model.nq, model.nv, model.nM):
        return False
    data, other_data = mujoco.MjData(model), mujoco.MjData(other)
    rng = np.random.default_rng(0)
    for _ in range(_CHECK_STATES):
        q, qd, force = rng.uniform(-np.pi, np.pi, model.nq), rng.normal(size=model.nv), rng.normal(size=model.nv)
        for m, d in ((model, data), (other, other_data)):
            d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, qd, force
            mujoco.mj_forward(m, d)
        if not all(np.array_equal(getattr(data, name), getattr(other_data, name))
                   for name in ("M", "qLD", "qLDiagInv", "qfrc_bias", "qacc")):
            return False
    return True


def scale_masses(fields: Callable[[str], np.ndarray], mass_scale: np.ndarray) -> None:
    """Multiply masses, inertias and joint armature by ``mass_scale`` (one per simulation), in place.

    ``fields(name)`` gives a model field with the simulations on its first axis (``Batch.expand``)."""
    scale = np.asarray(mass_scale, dtype=float)
    for name in ("body_mass", "body_inertia", "dof_armature"):
        values = fields(name)
        values *= scale.reshape((-1,) + (1,) * (values.ndim - 1))

