"""What a control engineer checks on a robot before its first run: per joint its limits, armature, damping,
friction loss, the nominal model's M(q0) and the torques the reference needs; and the warnings of a robot
and gains that do not fit.

The numbers (:func:`check_robot`):

* M(q0), the controller's nominal mass matrix (eq. (5.2), :mod:`ftc_mj.robot.nominal`, armature included)
  at the initial posture: its diagonal M_jj and its smallest eigenvalue;
* gravity torque G(q0), and along the reference the inverse dynamics of the nominal model,
  tau_ref = M(q_r) (qdd_r - Psi(q_r, qd_r)) = M qdd_r + C qd_r + G, its peak per joint against the torque
  limit;
* ``armature_needed``: the reflected rotor inertia (N^2 J_rotor of a motor behind a gear of ratio N) that
  would satisfy the sampling criterion below, where it fails.

The warnings (heuristics, not proofs):

* **damping against the control period.** The plant's joint damping d_j (and any other passive force the
  nominal model leaves out) is part of the lumped uncertainty, Delta_j = -d_j qd_j / M_jj. The observer
  estimates it from past samples and the controller cancels it one control period dt later, while the true
  term answers to the velocity within the period: the cancellation is a sampled feedback of gain
  alpha_j = d_j dt / M_jj per period (the share of a velocity change the damping removes in one period), and
  a one-period-delayed cancellation of a first-order term diverges once alpha_j > 1 (the discrete loop's pole
  -alpha_j leaves the unit circle). Warned from alpha_j > 0.5, a margin for the observer's own lag; the
  armature that brings it to 0.5 is 2 d_j dt - M_jj.
* **the observer's rate bound.** The TOSMOs (3.11), (5.6) assume |dDelta/dt| <= D. The damping alone makes
  the rate (d_j / M_jj) |qdd_j|, at least (d_j / M_jj) max |qdd_r|: warned where that exceeds the observer's D,
  unless the nominal model holds the damping (``nominal.friction.from_model.damping``, the default).
* **friction loss against the rate bound.** A friction loss f_j steps Delta_j by 2 f_j / M_jj at each
  velocity reversal; an observer whose estimate moves at most about D per second needs 2 f_j / (M_jj D)
  seconds to follow: warned above 1 s.
* **a wrist without armature.** M_jj below 1/1000 of the largest diagonal entry and no armature: the
  sliding-mode gains act in acceleration (u = -M (u_eq + u_sw), (5.26)), so the same switching gain is a
  torque M_jj (bound + mu) on that joint, and every torque the nominal model misses (damping, friction loss,
  a URDF that carries no motor inertia) is amplified by 1/M_jj.
* **torque limits.** The peak of |tau_ref| (or |G(q0)|) above the joint's limit: the command is clipped for
  as long as the reference needs more.
* **no armature at all.** URDF has no element for it; real geared joints have 0.01-1 kg m^2
  (MuJoCo Menagerie's UR5e and Panda: 0.1).
* **units.** A body whose radius of gyration sqrt(I_max / m) is above 3 m or below 0.1 mm (inertia given in
  g mm^2 or mass in g), for bodies of at least 10 g that are not point masses.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import mujoco
import numpy as np

from ftc_mj.robot.friction import FrictionSpec, JointFriction
from ftc_mj.robot.nominal import nominal_batch

#: alpha = d dt / M above which the sampling warning is given (the delayed cancellation diverges at 1).
SAMPLING_MARGIN = 0.5
#: Seconds an observer of rate bound D may take to follow a friction-loss step 2 f / M_jj.
FRICTION_CATCH_UP = 1.0
#: M_jj below this share of the largest diagonal entry is a wrist "orders of magnitude" lighter.
LIGHT_JOINT_SHARE = 1e-3
#: Radius of gyration bounds [m] outside which a body's mass or inertia look like wrong units.
GYRATION_RANGE = (1e-4, 3.0)
#: Bodies lighter than this [kg] are not checked for units (placeholders such as 1e-6 kg frames).
UNITS_MIN_MASS = 0.01


@dataclass(frozen=True)
class JointCheck:
    name: str
    kind: str  # "hinge" or "slide"
    range: tuple[float, float] | None  # None: unlimited
    torque_limit: float | None  # None: unlimited
    armature: float
    damping: float
    frictionloss: float
    mass_diagonal: float  # M_jj(q0) of the nominal model
    gravity: float  # G_j(q0)
    peak_reference_torque: float | None  # max |tau_ref_j| along the reference; None without one
    sampling_ratio: float  # alpha_j = d_j dt / M_jj (0 without a control period)
    armature_needed: float  # 0 where the sampling criterion holds


@dataclass(frozen=True)
class RobotCheck:
    joints: list[JointCheck]
    min_eigenvalue: float  # of M(q0)
    control_dt: float | None
    warnings: list[str] = field(default_factory=list)
    #: What the nominal model takes of the model file's joint terms and its own friction (one line each).
    nominal_terms: list[str] = field(default_factory=list)


def check_robot(
    model: mujoco.MjModel,
    *,
    q0: np.ndarray | None = None,
    reference: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
    reference_times: np.ndarray | None = None,
    control_dt: float | None = None,
    observer_rate_bounds: Sequence[tuple[str, np.ndarray]] = (),
    mass_scale: float = 1.0,
    friction: FrictionSpec | None = None,
) -> RobotCheck:
    """The check of a testbed robot (one motor per joint), see the module docstring.

    Args:
        q0: the initial posture; default the model's ``qpos0``.
        reference: q_r, qd_r, qdd_r on ``reference_times``, each ``(samples, n)``; None: no reference checks.
        control_dt: the control period [s]; None: no sampling check.
        observer_rate_bounds: (variant name, the observer's D per joint) for each variant whose observer
            assumes a bound on the uncertainty's rate.
        mass_scale: the nominal model's mass scale (``nominal.mass_scale``).
        friction: the nominal model's joint friction (``nominal.friction``); None: its default, the model
            file's damping and friction loss.
    """
    n = model.nv
    friction = FrictionSpec() if friction is None else friction
    q0 = np.array(model.qpos0 if q0 is None else q0, dtype=float)
    M0, psi0 = _nominal(model, mass_scale, q0[None], np.zeros((1, n)))
    M0 = M0[0]
    gravity = -M0 @ psi0[0]  # at rest Psi = -M^-1 G
    peak = None
    if reference is not None:
        q_r, qd_r, qdd_r = (np.asarray(x, dtype=float) for x in reference)
        M, psi = _nominal(model, mass_scale, q_r, qd_r)
        tau = np.einsum("kij,kj->ki", M, qdd_r - psi)
        peak = np.abs(tau).max(axis=0)
        peak_at = np.abs(tau).argmax(axis=0)
    limits = _torque_limits(model)
    diagonal = np.diag(M0).copy()
    damping = np.array(model.dof_damping, dtype=float)
    alpha = damping * control_dt / diagonal if control_dt else np.zeros(n)
    needed = np.where(alpha > SAMPLING_MARGIN, damping * (control_dt or 0.0) / SAMPLING_MARGIN - diagonal, 0.0)
    joints = []
    for j in range(n):
        joint = int(model.dof_jntid[j])
        kind = "slide" if model.jnt_type[joint] == mujoco.mjtJoint.mjJNT_SLIDE else "hinge"
        span = tuple(float(v) for v in model.jnt_range[joint]) if model.jnt_limited[joint] else None
        joints.append(JointCheck(
            name=model.joint(joint).name, kind=kind, range=span, torque_limit=limits[j],
            armature=float(model.dof_armature[j]), damping=float(damping[j]),
            frictionloss=float(model.dof_frictionloss[j]), mass_diagonal=float(diagonal[j]), gravity=float(gravity[j]),
            peak_reference_torque=None if peak is None else float(peak[j]), sampling_ratio=float(alpha[j]),
            armature_needed=float(needed[j])))
    warnings = []
    for j, c in enumerate(joints):
        if c.sampling_ratio > SAMPLING_MARGIN:
            warnings.append(
                f"joint {c.name!r}: damping {c.damping:g} N m s/rad on M_jj = {c.mass_diagonal:.3g} kg m^2 is a "
                f"lumped-uncertainty pole of {c.damping / c.mass_diagonal:.3g} 1/s against the control rate "
                f"{1 / control_dt:g} 1/s: d dt / M = {c.sampling_ratio:.2g} > {SAMPLING_MARGIN} (the observer's "
                f"cancellation, one period late, diverges near 1; heuristic); an armature of "
                f"{c.armature_needed + c.armature:.3g} kg m^2 (robot.armature) or a shorter control_dt fits")
        for variant, bound in observer_rate_bounds:
            catch_up = 2 * c.frictionloss / (c.mass_diagonal * bound[j])
            if catch_up > FRICTION_CATCH_UP:
                warnings.append(f"joint {c.name!r}: friction loss {c.frictionloss:g} N m on M_jj = "
                                f"{c.mass_diagonal:.3g} kg m^2 steps the uncertainty by 2 f / M_jj = "
                                f"{2 * c.frictionloss / c.mass_diagonal:.3g} rad/s^2 at each velocity reversal; "
                                f"the observer of variant {variant!r} (D = {bound[j]:g}) needs about "
                                f"{catch_up:.2g} s to follow it (heuristic: 2 f / (M_jj D))")
        if reference is not None and c.damping > 0 and not friction.from_model.damping:
            rate = c.damping / c.mass_diagonal * float(np.abs(qdd_r[:, j]).max())
            for variant, bound in observer_rate_bounds:
                if rate > bound[j]:
                    warnings.append(f"joint {c.name!r}: the damping alone makes the uncertainty change at "
                                    f"{rate:.3g} rad/s^3 along the reference, above the observer's D = "
                                    f"{bound[j]:g} of variant {variant!r} (heuristic: (d / M_jj) max |qdd_r|)")
    largest = float(diagonal.max())
    for c in joints:
        if c.armature == 0 and c.mass_diagonal < LIGHT_JOINT_SHARE * largest:
            warnings.append(f"joint {c.name!r}: M_jj = {c.mass_diagonal:.3g} kg m^2, {largest / c.mass_diagonal:.2g} "
                            "times below the heaviest joint's, and no armature: a torque the nominal model misses "
                            f"moves it 1/M_jj = {1 / c.mass_diagonal:.3g} rad/s^2 per N m, and a switching gain "
                            f"of 1 rad/s^2 is {c.mass_diagonal:.2g} N m there (robot.armature adds a motor's "
                            "reflected inertia)")
    for j, c in enumerate(joints):
        if c.torque_limit is None:
            continue
        if abs(c.gravity) > c.torque_limit:
            warnings.append(f"joint {c.name!r}: gravity alone needs {abs(c.gravity):.3g} N m at the initial posture, "
                            f"above its torque limit {c.torque_limit:g} N m")
        elif c.peak_reference_torque is not None and c.peak_reference_torque > c.torque_limit:
            when = "" if reference_times is None else f" (at t = {reference_times[peak_at[j]]:.3g} s)"
            warnings.append(f"joint {c.name!r}: the reference needs {c.peak_reference_torque:.3g} N m{when} "
                            f"(nominal inverse dynamics, gravity included), above its torque limit "
                            f"{c.torque_limit:g} N m: the command is clipped")
    for term, present, used in (("damping", model.dof_damping, friction.from_model.damping),
                                ("frictionloss", model.dof_frictionloss, friction.from_model.frictionloss)):
        if np.any(present[:n]) and not used:
            joints_with = ", ".join(repr(joints[j].name) for j in np.flatnonzero(present[:n]))
            warnings.append(f"the model file's joint {term} ({joints_with}) is missing from the nominal model "
                            f"(nominal.friction.from_model.{term}: false): it acts on the plant only, a healthy "
                            "lumped uncertainty every observer must estimate and a benchmark must declare")
    if not np.any(model.dof_armature):
        warnings.append("no joint has armature (a URDF cannot carry it): geared motors add N^2 J_rotor, typically "
                        "0.01-1 kg m^2 per joint (Menagerie's UR5e and Panda: 0.1); robot.armature sets it")
    warnings += _unit_warnings(model)
    eigenvalues = np.linalg.eigvalsh(0.5 * (M0 + M0.T))
    return RobotCheck(joints=joints, min_eigenvalue=float(eigenvalues[0]), control_dt=control_dt,
                      warnings=warnings, nominal_terms=nominal_terms(model, friction))


def nominal_terms(model: mujoco.MjModel, friction: FrictionSpec) -> list[str]:
    """Which of the model file's joint terms the nominal model uses, and its friction per joint
    (:mod:`ftc_mj.robot.friction`)."""
    used = {True: "used", False: "not used (nominal.friction.from_model)"}
    lines = [f"armature {'present' if model.dof_armature.any() else 'none'} in the model file: used (in M(q))",
             f"damping {'present' if model.dof_damping.any() else 'none'} in the model file: "
             f"{used[friction.from_model.damping]}",
             f"frictionloss {'present' if model.dof_frictionloss.any() else 'none'} in the model file: "
             f"{used[friction.from_model.frictionloss]}"]
    joint_friction = JointFriction.of(friction, model)
    if joint_friction.is_zero:
        return lines + ["nominal friction F(qd): none (the rigid-body model alone)"]
    lines.append(f"nominal friction F(qd) = b qd + c s(qd) + o, s = tanh(qd / {friction.velocity_scale:g})"
                 + (f" with a deadband of {friction.deadband:g} rad/s" if friction.deadband else "")
                 + f", at the {friction.velocity} velocity:")
    names = [model.joint(int(model.dof_jntid[j])).name for j in range(model.nv)]
    lines += [f"  {name}: {line}" for name, line in zip(names, joint_friction.describe())]
    return lines


def _nominal(model: mujoco.MjModel, mass_scale: float, q: np.ndarray, qd: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray]:
    """M(q) and Psi(q, qd) of the nominal model at each row of ``q``, ``qd``."""
    batch = nominal_batch(model, np.full(len(q), mass_scale), nthread=1)
    batch.qpos[:], batch.qvel[:], batch.applied[:] = q, qd, 0.0
    batch.evaluate()
    return batch.mass_matrices().copy(), batch.qacc.copy()


def torque_limits(model: mujoco.MjModel) -> np.ndarray:
    """Each joint's |torque| limit [N m or N] as an array, inf where the command is not clipped: the limit
    MuJoCo applies to the command (``ctrlrange`` times the gear, ``forcerange``), as :func:`_torque_limits`."""
    return np.array([np.inf if limit is None else limit for limit in _torque_limits(model)], dtype=float)


def _torque_limits(model: mujoco.MjModel) -> list[float | None]:
    """Each joint's |torque| limit: its motor's control range (the testbed's form: motor k drives joint k)."""
    limits: list[float | None] = [None] * model.nv
    for a in range(model.nu):
        if model.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_JOINT:
            continue
        dof = int(model.jnt_dofadr[model.actuator_trnid[a, 0]])
        gear = abs(float(model.actuator_gear[a, 0]))
        found = [float(np.max(np.abs(model.actuator_ctrlrange[a]))) * gear] if model.actuator_ctrllimited[a] else []
        if model.actuator_forcelimited[a]:
            found.append(float(np.max(np.abs(model.actuator_forcerange[a]))))
        if found:
            limits[dof] = min(found) if limits[dof] is None else min(limits[dof], *found)
    return limits


def _unit_warnings(model: mujoco.MjModel) -> list[str]:
    low, high = GYRATION_RANGE
    warnings = []
    for b in range(1, model.nbody):
        mass = float(model.body_mass[b])
        if mass < UNITS_MIN_MASS or not np.any(model.body_inertia[b]):  # a placeholder, or a point mass
            continue
        radius = float(np.sqrt(np.max(model.body_inertia[b]) / mass))
        if not low <= radius <= high:
            warnings.append(f"body {model.body(b).name!r}: mass {mass:.3g} kg with principal inertia "
                            f"{np.max(model.body_inertia[b]):.3g} kg m^2, a radius of gyration of {radius:.3g} m: "
                            "mass or inertia look like wrong units (kg and kg m^2 expected)")
    return warnings
