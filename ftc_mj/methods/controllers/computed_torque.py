r"""Computed-torque (inverse-dynamics) control with PD error feedback: the field's model-based FTC baseline.

With :math:`e = x_1 - x_d` and :math:`\dot e = x_2 - \dot x_d` (:math:`x_2` the controller's velocity, see
:mod:`.base`), the law is

.. math::

    \tau = M(x_1) \left(\ddot x_d - K_d \dot e - K_p e - u_c\right) + C(x_1, x_2)\, x_2 + g(x_1)

(Spong, Hutchinson and Vidyasagar, "Robot Modeling and Control", Wiley 2006, section 8.3 "Inverse dynamics";
Siciliano, Sciavicco, Villani and Oriolo, "Robotics: Modelling, Planning and Control", Springer 2009, section
8.5.2 "Inverse dynamics control"). Since :math:`\Psi = -M^{-1} (C \dot q + g)` (eq. (5.2)),
:math:`C x_2 + g = -M \Psi(x)` and the law is one product with M:

.. math::

    \tau = M(x_1) \left(\ddot x_d - \Psi(x) - K_d \dot e - K_p e - u_c\right)

On the plant (5.2), :math:`\ddot q = \Psi + M^{-1} \tau + \Delta`, with the exact model this leaves the error
dynamics

.. math::

    \ddot e + K_d \dot e + K_p e = \Delta - u_c

so without uncertainty e follows the linear PD dynamics, and with an observer's LUaF estimate as :math:`u_c`
(``compensation: estimate``) the residual is the estimation error: the usual "computed torque + disturbance
observer" fault-tolerant baseline (e.g. Chen, Ballance, Gawthrop and O'Reilly, IEEE TIE 47(4), 2000, for the
manipulator DOB). ``compensation: injection`` subtracts the observer's whole velocity-equation injection, as
the sliding-mode laws do; ``none`` (the default) is plain computed torque.

Design rule: :math:`K_d = 2 \sqrt{K_p}` per joint when ``kd`` is not given, which makes each joint's error
dynamics critically damped with the double pole :math:`-\sqrt{K_p}` (Spong et al., section 8.3:
:math:`\omega = \sqrt{K_p}`, :math:`\zeta = 1`).

The recorded sliding variable is :math:`s = \dot e + (K_p / K_d)\, e`, the PD feedback
:math:`(K_d \dot e + K_p e) / K_d` in velocity units: zero exactly where the PD term commands no correction.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from pydantic import model_validator

from ftc_mj.methods.controllers.base import Compensation, Controller
from ftc_mj.methods.gains import GainConfig, PositiveJoints


class ComputedTorqueConfig(GainConfig):
    r"""Per-joint PD gains :math:`K_p` [1/s^2] and :math:`K_d` [1/s] of the error dynamics; ``kd`` defaults to
    :math:`2 \sqrt{K_p}` (critical damping). ``compensation`` as for the sliding-mode laws; default ``none``."""

    kp: PositiveJoints
    kd: PositiveJoints | None = None
    compensation: Compensation = "none"

    @model_validator(mode="after")
    def _critically_damped(self) -> "ComputedTorqueConfig":
        if self.kd is None:
            object.__setattr__(self, "kd", 2.0 * np.sqrt(self.kp))
        return self


class ComputedTorque(Controller):
    r""":math:`\tau = M(x_1) (\ddot x_d - \Psi(x) - K_d \dot e - K_p e - u_c)`: inverse-dynamics control (Spong
    et al. section 8.3, Siciliano et al. section 8.5.2) with :math:`C x_2 + g = -M \Psi` of (5.2)."""

    name: ClassVar[str] = "computed_torque"
    signal_names: ClassVar[frozenset[str] | None] = frozenset()
    Config: ClassVar[type[ComputedTorqueConfig]] = ComputedTorqueConfig

    def __init__(self, config: ComputedTorqueConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        self.compensation: Compensation = config.compensation
        self._ratio = config.kp / config.kd  # of the recorded s = e_dot + (K_p / K_d) e
        self._e = np.zeros(self.shape)
        self._e_dot = np.zeros(self.shape)
        self._v = np.zeros(self.shape)
        self._term = np.zeros(self.shape)

    def compute(self, t, q_ref, qd_ref, qdd_ref, q_meas, observer, model):
        c = self.config
        e, e_dot, v, term = self._e, self._e_dot, self._v, self._term
        np.subtract(q_meas, q_ref, out=e)
        np.subtract(model.control_velocity(observer.qd_hat), qd_ref, out=e_dot)
        np.multiply(self._ratio, e, out=self.sliding)
        self.sliding += e_dot
        np.subtract(qdd_ref, model.psi_control, out=v)  # xdd_d + M^-1 (C x2 + g)
        np.multiply(c.kd, e_dot, out=term)
        v -= term
        np.multiply(c.kp, e, out=term)
        v -= term
        if self.compensation == "estimate":
            v -= observer.luaf_hat
        elif self.compensation == "injection":
            v -= observer.injection
        return model.apply_M(v, out=self.tau)
