"""Joint friction and damping in the controller's nominal model (the scenario's ``nominal.friction``).

The nominal model of eq. (5.2) is the rigid body alone, M(q) qdd + C(q, qd) qd + G(q) = tau. A real arm (and a
MuJoCo model with joint ``damping`` or ``frictionloss``) also loses a torque F(qd) in its joints, which a
rigid-body model leaves in the lumped uncertainty every observer then estimates: on a geared arm it is the
largest part of it (tens of N m on a UR10e's shoulder). With this section the nominal model is

    M(q) qdd + C(q, qd) qd + G(q) + F(qd) = tau,    Psi(q, qd) = -M(q)^-1 (C(q, qd) qd + G(q) + F(qd))

per joint j (no coupling between joints):

    F_j(qd_j) = b_j qd_j + c_j s(qd_j) + o_j,      s(v) = sign(v) tanh(max(|v| - delta, 0) / epsilon)

b viscous [N m s/rad], c Coulomb [N m], o a constant offset [N m] (what a gear's or a current sensor's
asymmetry leaves, the friction model of Mamedov and Mikhel, "Practical aspects of model-based collision
detection", Frontiers in Robotics and AI 7, 2020, and of their ``ext_observer`` code: tanh(50 qd), i.e.
epsilon = 0.02 rad/s), s a smooth sign: tanh with the velocity scale epsilon (so that F is Lipschitz, which
an observer integrating it needs) and an optional deadband delta [rad/s] below which the Coulomb part is zero
(velocity noise at rest then does not flip +-c).

**The model file's own terms.** MuJoCo's joint ``damping`` d_j is a viscous torque d_j qd_j, and its
``frictionloss`` f_j a dry friction of at most f_j: by default (``from_model``) they are added to b_j and c_j,
so a nominal model holds what the model file says of its joints (Menagerie's UR5e: 200 N m s/rad on joints
1-3). The joint ``armature`` (reflected rotor inertia) is always in M(q): the nominal model is a copy of the
model's bodies and joints, armature included (:func:`~ftc_mj.robot.nominal.rigid_body_model`).

**The velocity it is evaluated at** (``velocity``): ``estimate``, the velocity of the point where the
nominal model is evaluated (the observer's x2_hat; the readings for an observer built on tachometers, and for
a controller on measured velocity), or ``measured``, the tachometers' readings for every point (needs
``robot.sensors`` to list ``velocity``).

Every observer and controller gets F through the nominal model: Psi holds it (the engine evaluates the nominal
batch with the applied force -F at every point), and :class:`~ftc_mj.robot.nominal.StepModel` hands the
friction torque itself, ``friction``, to the observers whose equations subtract it separately (the
momentum observer: dp/dt = tau + C^T qd - G - F).
"""

from __future__ import annotations

from typing import Any, Literal

import mujoco
import numpy as np
from pydantic import Field

from ftc_mj.config.errors import InputError
from ftc_mj.config.types import FiniteFloat, NonNegativeFloat, PositiveFloat, Strict, per_joint

#: epsilon of the smooth sign by default [rad/s]: tanh(50 qd), Mamedov and Mikhel's choice.
DEFAULT_VELOCITY_SCALE = 0.02


class FromModelSpec(Strict):
    """Which of the model file's joint terms the nominal model takes in (each by default)."""

    #: The joints' ``damping`` [N m s/rad], added to the viscous coefficient.
    damping: bool = True
    #: The joints' ``frictionloss`` [N m], added to the Coulomb coefficient.
    frictionloss: bool = True


class FrictionSpec(Strict):
    """Per-joint friction of the nominal model: F_j = b_j qd_j + c_j s(qd_j) + o_j (module docstring)."""

    viscous: NonNegativeFloat | list[NonNegativeFloat] = Field(
        0.0, description="b_j, viscous friction [N m s/rad], one number or one per joint; added to the model "
        "file's damping (from_model.damping).")
    coulomb: NonNegativeFloat | list[NonNegativeFloat] = Field(
        0.0, description="c_j, Coulomb friction [N m], one number or one per joint; added to the model file's "
        "frictionloss (from_model.frictionloss).")
    offset: FiniteFloat | list[FiniteFloat] = Field(
        0.0, description="o_j, a constant torque [N m], one number or one per joint.")
    velocity_scale: PositiveFloat = Field(
        DEFAULT_VELOCITY_SCALE, description="epsilon of the smooth sign tanh(v / epsilon) [rad/s].")
    deadband: NonNegativeFloat = Field(
        0.0, description="delta [rad/s]: below |qd| = delta the Coulomb part is zero; default none.")
    velocity: Literal["estimate", "measured"] = Field(
        "estimate", description="The velocity F is evaluated at: the evaluation point's (the observer's "
        "estimate) or the tachometers' readings (needs robot.sensors: [position, velocity]).")
    from_model: FromModelSpec = Field(
        FromModelSpec(), description="The model file's joint damping and friction loss taken in (both by "
        "default); its armature is always in M(q).")


class JointFriction:
    """F(qd) of :class:`FrictionSpec` for one robot, coefficients compiled per joint."""

    def __init__(self, viscous: np.ndarray, coulomb: np.ndarray, offset: np.ndarray,
                 velocity_scale: float = DEFAULT_VELOCITY_SCALE, deadband: float = 0.0):
        self.viscous = np.asarray(viscous, dtype=float)
        self.coulomb = np.asarray(coulomb, dtype=float)
        self.offset = np.asarray(offset, dtype=float)
        self.velocity_scale, self.deadband = float(velocity_scale), float(deadband)

    @classmethod
    def of(cls, spec: FrictionSpec, model: mujoco.MjModel, file: str = "", field: str = "nominal.friction"
           ) -> JointFriction:
        """The friction of ``spec`` for ``model``'s joints, the model file's terms added as ``from_model`` says.
        Raises :class:`~ftc_mj.config.errors.InputError` where a list has another length than the joints."""
        n = model.nv
        viscous = per_joint(spec.viscous, n, file, f"{field}.viscous").astype(float)
        coulomb = per_joint(spec.coulomb, n, file, f"{field}.coulomb").astype(float)
        offset = per_joint(spec.offset, n, file, f"{field}.offset").astype(float)
        if spec.from_model.damping:
            viscous = viscous + model.dof_damping
        if spec.from_model.frictionloss:
            coulomb = coulomb + model.dof_frictionloss
        return cls(viscous, coulomb, offset, spec.velocity_scale, spec.deadband)

    @property
    def is_zero(self) -> bool:
        """Whether F is zero at every velocity (nothing to add to the rigid-body model)."""
        return not (self.viscous.any() or self.coulomb.any() or self.offset.any())

    def smooth_sign(self, velocity: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """s(v) = sign(v) tanh(max(|v| - delta, 0) / epsilon), elementwise."""
        if self.deadband == 0.0:
            out = np.divide(velocity, self.velocity_scale, out=out)
            return np.tanh(out, out=out)
        magnitude = np.abs(velocity, out=out)
        magnitude -= self.deadband
        np.maximum(magnitude, 0.0, out=magnitude)
        magnitude /= self.velocity_scale
        np.tanh(magnitude, out=magnitude)
        magnitude *= np.sign(velocity)
        return magnitude

    def torque(self, velocity: np.ndarray, out: np.ndarray | None = None,
               scratch: np.ndarray | None = None) -> np.ndarray:
        """F(qd) for velocities ``(..., n)``, into ``out``; with ``out`` and ``scratch`` (both of the velocities'
        shape) given, without allocating."""
        out = self.smooth_sign(velocity, out=out)
        out *= self.coulomb
        out += self.offset
        out += np.multiply(self.viscous, velocity, out=scratch)
        return out

    def regressor(self, velocity: np.ndarray) -> np.ndarray:
        """The friction regressor: ``(samples, n, 3 n)`` Y with F = Y theta, theta = (b_1, c_1, o_1, ..., b_n,
        c_n, o_n); only joint j's three columns are non-zero in its row."""
        velocity = np.asarray(velocity, dtype=float)
        samples, n = velocity.shape
        Y = np.zeros((samples, n, 3 * n))
        sign = self.smooth_sign(velocity)
        for j in range(n):
            Y[:, j, 3 * j] = velocity[:, j]
            Y[:, j, 3 * j + 1] = sign[:, j]
            Y[:, j, 3 * j + 2] = 1.0
        return Y

    def describe(self) -> list[str]:
        """One line per joint: its coefficients."""
        return [f"b {b:g} N m s/rad, c {c:g} N m, o {o:g} N m"
                for b, c, o in zip(self.viscous, self.coulomb, self.offset)]


class NominalFriction:
    """What the engine does with the nominal friction each period: F at every evaluation point of the nominal
    batch, its negative as the batch's applied force (so that the batch's acceleration is the Psi of the module
    docstring), and F at the true state for the truth (the LUaF relative to this nominal model).

    ``velocity``: the batch's ``qvel`` ``(points, n)``, read each period; ``applied``: the batch's applied force."""

    def __init__(self, friction: JointFriction, velocity: np.ndarray, applied: np.ndarray,
                 readings: tuple[np.ndarray, np.ndarray] | None = None):
        """``readings``: (the rows' measured velocities, each point's row) where F is evaluated at the
        readings (``velocity: measured``), else None."""
        self.friction = friction
        self._applied, self._readings = applied, readings
        # Measured velocities are gathered into a buffer of their own: the batch's qvel stays the estimate.
        self._velocity = velocity if readings is None else np.zeros(applied.shape)
        self._scratch = np.zeros(applied.shape)
        #: F at every point, ``(points, n)``: views of it are the :class:`StepModel`'s ``friction``.
        self.torque = np.zeros(applied.shape)
        #: F at the true state of every row (for the truths), or None until :meth:`at_true_state` is called.
        self.true_torque: np.ndarray | None = None

    def apply(self) -> None:
        """F at every point from this period's velocities; the batch's applied force is -F."""
        if self._readings is not None:
            measured, point_rows = self._readings
            np.take(measured, point_rows, axis=0, out=self._velocity)
        self.friction.torque(self._velocity, out=self.torque, scratch=self._scratch)
        np.negative(self.torque, out=self._applied)

    def at_true_state(self, qd_true: np.ndarray, scale: np.ndarray | None = None) -> np.ndarray:
        """F at the true velocities ``(rows, n)`` divided by each row's mass scale c (``(rows, 1)`` or None),
        into :attr:`true_torque`: what the truth's right-hand side subtracts (Psi + M^-1 tau =
        M_plant^-1 (tau / c - C qd - G - F / c))."""
        if self.true_torque is None:
            self.true_torque, self._true_scratch = np.zeros(qd_true.shape), np.zeros(qd_true.shape)
        self.friction.torque(qd_true, out=self.true_torque, scratch=self._true_scratch)
        if scale is not None:
            self.true_torque /= scale
        return self.true_torque


def nominal_friction(model: mujoco.MjModel, spec: FrictionSpec, batch: Any, points: int,
                     measured: np.ndarray | None, point_rows: np.ndarray, file: str = "") -> NominalFriction | None:
    """The engine's :class:`NominalFriction` for a nominal batch whose first ``points`` points are the Psi
    points (each of the row ``point_rows[p]``), or None where F is zero (the rigid-body model as before, at no
    cost). ``measured``: the rows' tachometer readings, or None without them (then ``velocity: measured`` is
    refused)."""
    friction = JointFriction.of(spec, model, file)
    if friction.is_zero:
        return None
    readings = None
    if spec.velocity == "measured":
        if measured is None:
            raise InputError(file, "nominal.friction.velocity",
                             "measured needs tachometers: robot.sensors: [position, velocity]")
        readings = (measured, np.asarray(point_rows, dtype=np.intp))
    return NominalFriction(friction, batch.qvel[:points], batch.applied[:points], readings)
