r"""Active fault-tolerant control: controllers that read the diagnosis and change the loop on its decisions.

Active FTC couples fault detection and diagnosis with a reconfiguration mechanism that changes the controller
once a fault is detected or isolated (Zhang and Jiang, "Bibliographical review on reconfigurable
fault-tolerant control systems", Annual Reviews in Control 32, 2008; Blanke, Kinnaert, Lunze and Staroswiecki,
"Diagnosis and Fault-Tolerant Control", 3rd ed., Springer 2016, ch. 7), where passive FTC keeps one robust
controller for every fault it must tolerate. A controller here declares ``reads_diagnosis``; the engine then
steps the scenario's causal diagnosis inside the loop, before the controllers, and hands each of them its
variant's component as ``self.diagnosis`` (:class:`~ftc_mj.analysis.causal.CausalDiagnoser`, one row per
member: ``alarm``, ``isolated``, ``fault_estimate``, ``alarm_time``). Three of the field's standard patterns
follow.

**:class:`EventCompensatedNFTSMC`** (``event_nftsmc``): the dissertation's AFTC made event-driven. The NFTSMC
of (5.25)-(5.27) without compensation and with a switching gain that covers the healthy uncertainty
(``bound_healthy``, :math:`\Delta_h`) until the diagnosis detects a fault; from then on the observer's
compensation :math:`u_c` of (5.26) and the gain ``bound`` (:math:`\Delta_\delta` of (5.27)):

.. math::

    u = -M(x_1) \left(u_{eq} + \delta\, u_c + u_{sw}\right), \quad
    u_{sw} = \left((1 - \delta) \Delta_h + \delta \Delta_\delta + \mu\right) \operatorname{sign}(\hat s)

with :math:`\delta_j(t) \in \{0, 1\}` the latched decision: ``engage: any`` switches every joint at the first
alarm (the fault's acceleration reaches the joints :math:`M(q)^{-1}` couples), ``joint`` each joint at its
own.

**:class:`Supervisor`** (``supervisor``): a supervisor over two controller plugins, ``nominal`` until the
diagnosis isolates a fault on any joint and ``reconfigured`` from then on (controller switching, Blanke et
al. 2016, section 7.5; Zhang and Jiang 2008, section 4). By default the reconfigured controller takes over
from its initial state, which for an integral sliding surface is the surface started at zero at the switch
(the integral sliding mode's own initialisation, no reaching phase: Utkin and Shi, "Integral sliding mode in
systems operating under uncertainty conditions", CDC 1996); ``transfer: warm`` runs it from the start beside
the nominal one instead (warm standby, Astrom and Hagglund, "Advanced PID Control", 2006, section 3.6), whose
integral then holds what the nominal loop's errors integrated to. Per member,
:math:`\tau = \tau_{\mathrm{nominal}}` before the first isolation on any joint,
:math:`\tau = \tau_{\mathrm{reconfigured}}` from then on.

**:class:`EffectivenessAccommodation`** (``loe_accommodation``): accommodation of an estimated loss of
effectiveness. An actuator that delivers :math:`(1 - \alpha) \tau` leaves the torque-space fault estimate
:math:`f = -\alpha \tau`; :math:`\alpha_j` is estimated by recursive least squares with forgetting
:math:`\lambda` on :math:`f_j` and the command from the joint's isolation on (both through the same
first-order low-pass filter, :math:`\bar f` and :math:`\bar u`: a sliding-mode command chatters far beyond
the observer's bandwidth, and the regression must see the part of it the estimate answers), and the command
of the inner controller on that joint is divided by :math:`1 - \hat\alpha` (the effectiveness-factor
redesign of Zhang and Jiang, "Active fault-tolerant control system against partial actuator failures", IEE
Proc. Control Theory Appl. 149(1), 2002, with a scalar effectiveness per joint). With the filter's pole
:math:`a = \exp(-T / T_f)`, per joint from its isolation at period :math:`k_0`:

.. math::

    \bar f_k = a \bar f_{k-1} + (1 - a) f_k, \quad \bar u_k = a \bar u_{k-1} + (1 - a) \tau_{k-1}

    \hat\alpha_k = \min\left(\max\left(-\frac{\sum_{i=k_0}^{k} \lambda^{k-i} \bar f_i \bar u_i}
    {\sum_{i=k_0}^{k} \lambda^{k-i} \bar u_i^2}, 0\right), \alpha_{\mathrm{max}}\right), \quad
    \tau_k = \frac{\tau_{\mathrm{inner},k}}{1 - \hat\alpha_k}

(:math:`\alpha_{\mathrm{max}}` the gain ``max_loss``; :math:`f_k` answers the command applied over the last period).
It needs the diagnosis in torque space.

Every switch is latched: a decision is not taken back within the run (a diagnoser's alarm may clear while the
fault stays). The decisions' times are recorded as the signal ``reconfigured`` (0 before, 1 after, per joint).
"""

from __future__ import annotations

from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import ValidationInfo, model_validator

from ftc_mj.methods.controllers.base import Controller
from ftc_mj.methods.controllers.nftsmc import NFTSMC, NFTSMCConfig
from ftc_mj.methods.gains import GainConfig, NonNegativeJoints
from ftc_mj.methods.observers.base import Observer
from ftc_mj.methods.primitives import exp
from ftc_mj.robot.nominal import StepModel


class DiagnosisReader:
    """What a controller that reads the diagnosis has: the flag the engine looks for, the component it is
    given, and the signal of its decisions."""

    #: The engine steps the diagnosis in the loop and sets :attr:`diagnosis` before the first period.
    reads_diagnosis: ClassVar[bool] = True
    diagnosis: Any = None

    def _decisions(self, shape: tuple[int, ...]) -> None:
        self.reconfigured = np.zeros(shape)
        self.signals["reconfigured"] = self.reconfigured


class EventNFTSMCConfig(NFTSMCConfig):
    r"""The NFTSMC's gains with ``compensation`` (applied from detection on) and ``bound`` (its switching bound
    then, :math:`\Delta_\delta` of (5.27)); ``bound_healthy``: the bound before detection, without compensation (the
    uncompensated comparator's, which covers the healthy LUaF); ``engage``: every joint at the first alarm
    (``any``) or each at its own (``joint``)."""

    bound_healthy: NonNegativeJoints
    engage: Literal["any", "joint"] = "any"


class EventCompensatedNFTSMC(DiagnosisReader, NFTSMC):
    r"""NFTSMC (5.25)-(5.27) whose compensation :math:`u_c` and switching bound are switched at detection (the
    module docstring)."""

    name: ClassVar[str] = "event_nftsmc"
    signal_names: ClassVar[frozenset[str] | None] = frozenset({"reconfigured"})
    Config: ClassVar[type[EventNFTSMCConfig]] = EventNFTSMCConfig

    def __init__(self, config: EventNFTSMCConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        self._decisions(self.shape)
        self._engaged = np.zeros(self.shape, dtype=bool)
        self._healthy_gain = config.bound_healthy + config.mu
        self._switching_gain = np.zeros(self.shape)
        self._gated = np.zeros(self.shape)

    def reset(self) -> None:
        super().reset()
        self._engaged[:] = False
        self.reconfigured[:] = 0.0

    def compute(self, t, q_ref, qd_ref, qdd_ref, q_meas, observer, model):
        isolated = self.diagnosis.isolated
        if self.config.engage == "any":
            self._engaged[:] = isolated.any(axis=-1, keepdims=True)
        else:
            self._engaged[:] = isolated
        self.reconfigured[:] = self._engaged
        return super().compute(t, q_ref, qd_ref, qdd_ref, q_meas, observer, model)

    def observer_compensation(self, observer: Observer) -> np.ndarray | None:
        compensation = super().observer_compensation(observer)
        if compensation is None:
            return None
        np.multiply(compensation, self._engaged, out=self._gated)  # u_c on the engaged joints, 0 elsewhere
        return self._gated

    def switching_gain(self) -> np.ndarray:
        np.copyto(self._switching_gain, np.where(self._engaged, self._gain, self._healthy_gain))
        return self._switching_gain


class ControllerChoice(GainConfig):
    """A controller plugin inside another: its ``type`` (a registered controller's name) and its ``gains``,
    validated by that plugin's schema."""

    type: str
    gains: GainConfig

    @model_validator(mode="before")
    @classmethod
    def _plugin_gains(cls, value: Any, info: ValidationInfo) -> Any:
        if isinstance(value, dict) and isinstance(value.get("gains", {}), dict):
            plugin = _controller_type(value.get("type"))
            if getattr(plugin, "reads_diagnosis", False):
                raise ValueError(f"{value.get('type')!r} reads the diagnosis itself: nest a plain controller")
            value = {**value, "gains": plugin.Config.model_validate(value.get("gains", {}), context=info.context)}
        return value

    def build(self, n_joints: int, dt: float, members: int | None) -> Controller:
        return _controller_type(self.type)(self.gains, n_joints, dt, members)


def _controller_type(name: Any) -> type[Controller]:
    from ftc_mj.methods.registry import controller_types  # the registry lists this module's classes

    known = controller_types()
    if not isinstance(name, str) or name not in known:
        raise ValueError(f"unknown controller type {name!r} (known: {', '.join(sorted(known))})")
    return known[name]


class SupervisorConfig(GainConfig):
    """The controller before (``nominal``) and after (``reconfigured``) a fault is isolated; ``transfer``:
    ``warm``, the reconfigured controller runs from the start and takes over with the state it has (an integral
    surface then holds what the nominal loop's errors integrated to), or ``restart``, it takes over from its
    initial state (its ``reset``: an integral surface starts at zero at the switch)."""

    nominal: ControllerChoice
    reconfigured: ControllerChoice
    transfer: Literal["warm", "restart"] = "restart"


class Supervisor(DiagnosisReader, Controller):
    """Switches from one controller plugin to another when the diagnosis isolates a fault (the module
    docstring). The sliding variable recorded is the active controller's."""

    name: ClassVar[str] = "supervisor"
    signal_names: ClassVar[frozenset[str] | None] = frozenset({"reconfigured"})
    Config: ClassVar[type[SupervisorConfig]] = SupervisorConfig

    def __init__(self, config: SupervisorConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        self.nominal = config.nominal.build(n_joints, dt, members)
        self.reconfigured_controller = config.reconfigured.build(n_joints, dt, members)
        self._decisions(self.shape)
        self._switched = np.zeros(self.shape[:-1] + (1,), dtype=bool)
        self._now = np.zeros_like(self._switched)
        # restart: a twin left at its initial state, whose per-member arrays are copied into the rows that switch
        # (a method's state is its (members, n) arrays, which its reset sets: the plugin contract).
        self._initial = None
        if config.transfer == "restart":
            self._initial = config.reconfigured.build(n_joints, dt, members)
            self._initial.reset()

    def reset(self) -> None:
        super().reset()
        self.nominal.reset()
        self.reconfigured_controller.reset()
        self._switched[:] = False
        self.reconfigured[:] = 0.0

    def compute(self, t, q_ref, qd_ref, qdd_ref, q_meas, observer, model):
        np.any(self.diagnosis.isolated, axis=-1, keepdims=True, out=self._now)
        if self._initial is not None and (self._now & ~self._switched).any():
            self._restart((self._now & ~self._switched)[..., 0])
        np.logical_or(self._switched, self._now, out=self._switched)
        before = self.nominal.compute(t, q_ref, qd_ref, qdd_ref, q_meas, observer, model)
        after = self.reconfigured_controller.compute(t, q_ref, qd_ref, qdd_ref, q_meas, observer, model)
        np.copyto(self.tau, np.where(self._switched, after, before))
        np.copyto(self.sliding, np.where(self._switched, self.reconfigured_controller.sliding, self.nominal.sliding))
        self.reconfigured[:] = self._switched
        return self.tau

    def _restart(self, rows: np.ndarray) -> None:
        """The reconfigured controller's state of ``rows`` (a member mask) back to its initial values."""
        for name, value in vars(self.reconfigured_controller).items():
            initial = getattr(self._initial, name, None)
            if isinstance(value, np.ndarray) and value.shape == self.shape and isinstance(initial, np.ndarray):
                value[rows] = initial[rows]


class AccommodationConfig(GainConfig):
    r"""The controller whose command is accommodated; the least-squares forgetting factor per period
    (``forgetting``, :math:`0 < \lambda \le 1`: memory of about :math:`T / (1 - \lambda)` seconds); the time
    constant :math:`T_f` of the low-pass filter on the fault estimate and the command [s]; the largest loss of
    effectiveness believed (``max_loss``, :math:`\alpha_{\mathrm{max}}`: :math:`1 - \hat\alpha` is kept at least
    :math:`1 - \alpha_{\mathrm{max}}`)."""

    controller: ControllerChoice
    forgetting: float = 0.999
    filter_time_constant: float = 0.05
    max_loss: float = 0.8

    @model_validator(mode="after")
    def _ranges(self) -> "AccommodationConfig":
        forgetting, max_loss = np.asarray(self.forgetting), np.asarray(self.max_loss)
        if not (np.all(forgetting > 0) and np.all(forgetting <= 1)):
            raise ValueError(f"forgetting must be in (0, 1], not {self.forgetting}")
        if not np.all(np.asarray(self.filter_time_constant) > 0):
            raise ValueError(f"filter_time_constant must be positive, not {self.filter_time_constant}")
        if not (np.all(max_loss >= 0) and np.all(max_loss < 1)):
            raise ValueError(f"max_loss must be in [0, 1), not {self.max_loss}")
        return self


class EffectivenessAccommodation(DiagnosisReader, Controller):
    r""":math:`\tau_j = \tau_{\mathrm{inner},j} / (1 - \hat\alpha_j)` on the isolated joints, :math:`\hat\alpha_j` by
    recursive least squares from the torque-space fault estimate (the module docstring). :math:`\hat\alpha` is
    recorded as the signal ``loss_estimate``."""

    name: ClassVar[str] = "loe_accommodation"
    signal_names: ClassVar[frozenset[str] | None] = frozenset({"reconfigured", "loss_estimate"})
    Config: ClassVar[type[AccommodationConfig]] = AccommodationConfig

    def __init__(self, config: AccommodationConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        self.inner = config.controller.build(n_joints, dt, members)
        self._decisions(self.shape)
        self.loss_estimate = np.zeros(self.shape)
        self.signals["loss_estimate"] = self.loss_estimate
        self._cross, self._power = np.zeros(self.shape), np.zeros(self.shape)
        self._applied = np.zeros(self.shape)  # the command applied last period
        self._filtered_fault, self._filtered_command = np.zeros(self.shape), np.zeros(self.shape)
        self._forgetting = config.forgetting
        self._pole = exp(-self.dt / np.asarray(config.filter_time_constant))  # exactly discretised
        self._max_loss = config.max_loss

    def reset(self) -> None:
        super().reset()
        self.inner.reset()
        for values in (self._cross, self._power, self._applied, self._filtered_fault, self._filtered_command,
                       self.loss_estimate, self.reconfigured):
            values[:] = 0.0

    def compute(self, t, q_ref, qd_ref, qdd_ref, q_meas, observer, model):
        diagnosis = self.diagnosis
        if diagnosis.diagnoser.space != "torque":
            raise ValueError("loe_accommodation needs the diagnosis in torque space (diagnosis.space: torque)")
        isolated = diagnosis.isolated
        # The estimate f of this period answers the command applied over the last one: f = -alpha tau_applied.
        a = self._pole
        fault, command = self._filtered_fault, self._filtered_command
        fault[:] = a * fault + (1.0 - a) * np.nan_to_num(diagnosis.fault_estimate)
        command[:] = a * command + (1.0 - a) * self._applied
        lam = self._forgetting
        self._cross[:] = np.where(isolated, lam * self._cross - fault * command, 0.0)
        self._power[:] = np.where(isolated, lam * self._power + command * command, 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(self._power > 0, self._cross / self._power, 0.0)
        np.clip(ratio, 0.0, self._max_loss, out=self.loss_estimate)
        command = self.inner.compute(t, q_ref, qd_ref, qdd_ref, q_meas, observer, model)
        np.divide(command, 1.0 - self.loss_estimate, out=self.tau)
        np.copyto(self.sliding, self.inner.sliding)
        self._applied[:] = self.tau
        self.reconfigured[:] = isolated
        return self.tau
