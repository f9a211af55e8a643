r"""The controller plugin protocol and the sliding-mode structure the dissertation's laws share.

Every law of Chapters 2-5 has the form of (2.24), (2.32), (3.26), (3.47), (3.51), (4.16), (4.43), (5.25):

.. math::

    u = -M(x_1) \left(u_{eq} + u_c + u_{sw}\right)

with a sliding surface s, an equivalent control :math:`u_{eq} = \Psi(\hat x) + (\text{surface terms}) - \ddot x_d`,
a compensation :math:`u_c` taken from the observer, and a switching law :math:`u_{sw} = K \operatorname{sign}(s)`.
:class:`SlidingModeController` implements that frame; a concrete law supplies only the surface (and its terms
in :math:`u_{eq}`) and the switching gain K. (5.25) prints :math:`u = -M(x_1)(u_{eq} + u_{sw})` with the
compensation inside :math:`u_{eq}` (5.26); the frame keeps it apart, so that a scenario can choose it.

| law | surface | compensation | K |
|---|---|---|---|
| ``smc`` | :math:`\dot e + c e`, (3.46) | any | :math:`\Delta + \mu` |
| ``ntsmc`` | (3.50), time-varying terminal term | any | :math:`\Delta + \mu` |
| ``nftsmc`` | integral NFTSM (2.22), (4.15), (5.15) | any | :math:`\Delta + \mu` |
| ``a_nftsmc`` | as ``nftsmc`` | any | :math:`\hat K + \mu`, (2.36) |
| ``sigmoid_nftsmc`` | (3.18), sigmoid-blended linear/terminal | any | :math:`\Delta + \mu` |

(:math:`\Delta` is the gain ``bound``, :math:`\mu` the gain ``mu``.) The printed laws write
:math:`M(x)` or :math:`g(\hat x)^{-1}` and :math:`\Psi(x)`; we use M at the measured position (M depends only
on :math:`x_1`, which is measured). The velocity in :math:`\dot e` and in :math:`\Psi` is the scenario's
explicit choice (``controller_velocity``): the tachometer reading where the robot has tachometers and the
chapter feeds the controller measured states (Chapter 2: (2.22)-(2.35) are written on :math:`x_2`), else the
observer's :math:`\hat x_2` (Chapters 3-5, positions only). It does not depend on which observer is plugged in.

A controller sees the reference, the measured positions, the observer's estimates and the nominal model;
never MjData. The math runs over arrays whose last axis is the joint.
"""

from __future__ import annotations

from abc import abstractmethod
from typing import Literal

import numpy as np

from ftc_mj.methods.gains import GainConfig, NonNegativeJoints, PositiveJoints
from ftc_mj.methods.observers.base import Observer
from ftc_mj.methods.plugin import Method
from ftc_mj.robot.nominal import StepModel

#: What a law takes from the observer: the whole velocity-equation injection (Chapters 3-5), only the LUaF
#: estimate (Appendix-D-type comparators), or nothing (the switching gain covers the whole LUaF).
Compensation = Literal["injection", "estimate", "none"]


class SwitchingConfig(GainConfig):
    r"""What every law's switching part takes: ``mu`` (:math:`\mu`, the margin of every reaching condition) and
    the compensation :math:`u_c`. Laws with a fixed gain add ``bound`` (:class:`BoundedSwitchingConfig`)."""

    mu: PositiveJoints
    compensation: Compensation = "injection"


class BoundedSwitchingConfig(SwitchingConfig):
    r"""A fixed switching gain ``bound`` + ``mu``: :math:`\Delta_d` of (3.28), K of (2.27), :math:`\Xi` of
    (4.18), :math:`\Lambda` of (4.45), :math:`\Delta_\delta` of (5.27): the bound the switching term must
    dominate."""

    bound: NonNegativeJoints


class Controller(Method):
    """Computes the joint torque command once per control period."""

    def __init__(self, config: GainConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        #: The sliding variable, recorded beside the torque.
        self.sliding = np.zeros(self.shape)
        self.tau = np.zeros(self.shape)

    def reset(self) -> None:
        self.sliding[:] = 0.0
        self.tau[:] = 0.0

    @abstractmethod
    def compute(
        self,
        t: float,
        q_ref: np.ndarray,
        qd_ref: np.ndarray,
        qdd_ref: np.ndarray,
        q_meas: np.ndarray,
        observer: Observer,
        model: StepModel,
    ) -> np.ndarray:
        """Return the torque command (the controller's own ``tau`` array, valid until the next call).

        The reference rows ``q_ref``, ``qd_ref``, ``qdd_ref`` (``(n,)``, or ``(members, n)`` where the reference
        has parameters) and ``q_meas`` are the engine's buffers, the same objects every period and written anew
        each period: read them in the call, copy what must outlive it."""


class SlidingModeController(Controller):
    r""":math:`u = -M(x_1) (u_{eq} + u_c + u_{sw})` with
    :math:`u_{eq} = \Psi(\hat x) + (\text{surface terms}) - \ddot x_d`.

    Subclasses define :meth:`surface`; the switching gain is ``bound + mu`` unless they override
    :meth:`switching_gain` (the adaptive law does).
    """

    def __init__(self, config: SwitchingConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        self.compensation: Compensation = config.compensation
        self._gain = getattr(config, "bound", 0.0) + config.mu

    @abstractmethod
    def surface(self, t: float, e: np.ndarray, e_dot: np.ndarray) -> np.ndarray:
        r"""Update ``self.sliding`` from the tracking errors and return the surface's terms in :math:`u_{eq}`
        (the part of :math:`\dot s` that is not :math:`\ddot e`). ``e_dot`` is the controller's velocity
        (measured or the observer's estimate, see the module docstring) minus the reference's."""

    def switching_gain(self) -> np.ndarray:
        r"""The gain K of the switching law :math:`K \operatorname{sign}(s)`, called once per period after
        :meth:`surface`."""
        return self._gain

    def switching(self) -> np.ndarray:
        return self.switching_gain() * np.sign(self.sliding)

    def observer_compensation(self, observer: Observer) -> np.ndarray | None:
        r""":math:`u_c`: the observer's injection, its LUaF estimate, or None (no compensation)."""
        if self.compensation == "injection":
            return observer.injection
        if self.compensation == "estimate":
            return observer.luaf_hat
        return None

    def compute(self, t, q_ref, qd_ref, qdd_ref, q_meas, observer, model):
        e = q_meas - q_ref
        # x2: the tachometer reading where the scenario feeds the controller measured velocity (Chapter 2),
        # else the observer's x2_hat; Psi at the same state (StepModel.psi_control).
        e_dot = model.control_velocity(observer.qd_hat) - qd_ref
        surface_terms = self.surface(t, e, e_dot)
        # -u = -(u_eq + u_c + u_sw), formed directly: b - a is -(a - b) exactly and M (-u) is -(M u) bit for bit,
        # so tau = M (-u) is the law's -M u without a separate negation.
        negative_u = qdd_ref - (model.psi_control + surface_terms)  # -u_eq
        compensation = self.observer_compensation(observer)
        if compensation is not None:
            negative_u -= compensation
        negative_u -= self.switching()
        return model.apply_M(negative_u, out=self.tau)
