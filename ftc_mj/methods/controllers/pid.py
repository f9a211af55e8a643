r"""Independent joint PID with anti-windup and torque limits: the industrial baseline.

Each joint on its own, with :math:`e = x_1 - x_d` and :math:`\dot e` the controller's velocity minus
:math:`\dot x_d` (the tachometer reading or the observer's :math:`\hat x_2`,
:meth:`~ftc_mj.robot.nominal.StepModel.control_velocity`, as for every law):

.. math::

    v = -K_p e - K_i I - K_d \dot e, \quad
    \tau = \operatorname{sat}(v) = \min\left(\max(v, -\tau_{\mathrm{max}}), \tau_{\mathrm{max}}\right), \quad
    \dot I = e \ \text{(gated below)}

No model: the law ignores the nominal model (no M, no :math:`\Psi`, no gravity feed-forward) and the
observer's LUaF estimate; the integrator alone holds gravity and every other constant load (Spong, Hutchinson
and Vidyasagar, "Robot Modeling and Control", Wiley 2006, section 6.3, set-point tracking by independent joint
PD and PID compensators).

Anti-windup by conditional integration, also called clamping (Astrom and Hagglund, "Advanced PID Control",
ISA 2006, section 3.5 "Integrator windup"): the integrator holds while the command is saturated
(:math:`v \ne \tau`) and integrating would drive it further into saturation (the increment
:math:`-K_i T e` has the sign of v, i.e. :math:`v e < 0`):

.. math::

    I_{k+1} = \begin{cases} I_k, & v_k \ne \tau_k \text{ and } v_k e_k < 0 \\ I_k + T e_k, & \text{else}
    \end{cases}

It integrates again as soon as the error reverses or the command leaves the limit. ``anti_windup: none``
integrates always (the windup the comparison shows). Without ``torque_limit`` the command is never clipped
and the gate never closes.

The recorded sliding variable is zero (PID has no surface); the integral I is the signal ``integral``.
"""

from __future__ import annotations

from typing import ClassVar, Literal

import numpy as np

from ftc_mj.methods.controllers.base import Controller
from ftc_mj.methods.gains import GainConfig, NonNegativeJoints, PositiveJoints


class PIDConfig(GainConfig):
    r"""Per-joint gains :math:`K_p` [N m/rad], :math:`K_i` [N m/(rad s)], :math:`K_d` [N m s/rad];
    ``torque_limit`` :math:`\tau_{\mathrm{max}}` [N m] per joint (none: unlimited); ``anti_windup`` ``clamping``
    (conditional integration) or ``none``."""

    kp: PositiveJoints
    ki: NonNegativeJoints
    kd: NonNegativeJoints
    torque_limit: PositiveJoints | None = None
    anti_windup: Literal["clamping", "none"] = "clamping"


class PID(Controller):
    r""":math:`\tau = \operatorname{sat}(-K_p e - K_i \int e\, dt - K_d \dot e)` with conditional integration
    (Astrom and Hagglund 2006, section 3.5)."""

    name: ClassVar[str] = "pid"
    signal_names: ClassVar[frozenset[str] | None] = frozenset({"integral"})
    Config: ClassVar[type[PIDConfig]] = PIDConfig

    def __init__(self, config: PIDConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        limit = np.inf if config.torque_limit is None else config.torque_limit
        self._upper = np.broadcast_to(limit, self.shape).astype(float)
        self._lower = -self._upper
        self._clamping = config.anti_windup == "clamping"
        self.integral = np.zeros(self.shape)
        self._e = np.zeros(self.shape)
        self._e_dot = np.zeros(self.shape)
        self._v = np.zeros(self.shape)
        self._term = np.zeros(self.shape)
        self._hold = np.zeros(self.shape, dtype=bool)
        self._pushing = np.zeros(self.shape, dtype=bool)
        self.signals["integral"] = self.integral

    def reset(self) -> None:
        super().reset()
        self.integral[:] = 0.0

    def compute(self, t, q_ref, qd_ref, qdd_ref, q_meas, observer, model):
        c = self.config
        e, e_dot, v, term = self._e, self._e_dot, self._v, self._term
        np.subtract(q_meas, q_ref, out=e)
        np.subtract(model.control_velocity(observer.qd_hat), qd_ref, out=e_dot)
        np.multiply(c.kp, e, out=v)
        np.multiply(c.ki, self.integral, out=term)
        v += term
        np.multiply(c.kd, e_dot, out=term)
        v += term
        np.negative(v, out=v)
        np.clip(v, self._lower, self._upper, out=self.tau)
        np.multiply(self.dt, e, out=term)  # this period's increment of I (explicit Euler)
        if self._clamping:
            np.not_equal(v, self.tau, out=self._hold)  # saturated
            np.multiply(v, e, out=self._v)
            np.less(self._v, 0.0, out=self._pushing)  # -K_i dt e has the sign of v: deeper into saturation
            np.logical_and(self._hold, self._pushing, out=self._hold)
            np.copyto(term, 0.0, where=self._hold)
        self.integral += term
        return self.tau
