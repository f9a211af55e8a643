"""Actuator faults: what the actuators deliver instead of the commanded torque.

Kinds (per faulty joint, u the command, w(t) in [0, 1] the fault's time profile, :mod:`ftc_mj.effects.profiles`):

* ``loss_of_effectiveness``: delivers (1 - alpha(t)) u; ``alpha`` an expression of t, in [0, 1];
* ``bias``:                  delivers u + offset(t) [N m];
* ``lock``:                  delivers the command frozen at the instant the fault comes on (lock-in-place);
* ``float``:                 delivers nothing;
* ``saturation``:            delivers u clipped to [-limit, limit] [N m].

The profile blends the healthy and the faulty actuator: delivered = (1 - w(t)) u + w(t) faulty(u), so an
incipient or ramped loss of effectiveness grows smoothly, and any kind can be abrupt, intermittent or end.
Several faults may act on one joint: they are applied in the scenario's order, each to what the previous
one delivers. The additive faults of the dissertation are plant ``terms`` with ``kind: fault``.

The fault acts on the plant through ``qfrc_applied`` as delivered - commanded: the command in ``ctrl``
(and the recorded ``tau``) stays what the controller asked for, so no controller can see the fault. Where the
motor limits its torque (``ctrlrange``, :attr:`~ftc_mj.scenario.definition.Scenario.torque_limits`), the fault
acts on what the limited motor gives, u = clip(command), its output is clipped again (a bias included), and
delivered - u adds to MuJoCo's own clip(command): a floating joint then gets no torque whatever the command.
(Acting on the command itself, a float on a joint commanded beyond its limit would receive clip(command) -
command, the excess with the opposite sign: a scenario's ``faults_after_torque_limit: false``.)
Everything that depends only on time (profiles, alpha(t), offset(t), the instants a lock freezes) is
tabulated on the run's time grid before the loop; a step only combines the command with table rows.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

from dataclasses import dataclass
from typing import Literal

import mujoco
import numpy as np

from ftc_mj.effects.profiles import AbruptSpec, Profile, ProfileSpec, compile_profile
from ftc_mj.config import expressions
from ftc_mj.config.errors import InputError
from ftc_mj.config.types import (
    ExpressionText,
    JointSelection,
    PositiveFloat,
    Strict,
    joint_indices,
    joint_mask,
    parse_expression,
    per_selected,
    tagged_union,
)


class _FaultSpec(Strict):
    #: A name for the fault (default: its kind and index).
    name: str | None = None
    #: Faulty joints, 1-based or by name; all when absent.
    joints: JointSelection = None
    #: How the fault comes on and goes: a time profile (default: abrupt from 0 s).
    profile: ProfileSpec = AbruptSpec()


class LossOfEffectivenessSpec(_FaultSpec):
    kind: Literal["loss_of_effectiveness"]
    #: Fraction of the command lost, an expression of t: one for all the fault's joints or one per joint.
    alpha: ExpressionText | list[ExpressionText]


class BiasSpec(_FaultSpec):
    kind: Literal["bias"]
    #: Torque added to the command [N m], an expression of t: one for all the fault's joints or one per joint.
    offset: ExpressionText | list[ExpressionText]


class LockSpec(_FaultSpec):
    kind: Literal["lock"]


class FloatSpec(_FaultSpec):
    kind: Literal["float"]


class SaturationSpec(_FaultSpec):
    kind: Literal["saturation"]
    #: |delivered torque| <= limit [N m], one number for all the fault's joints or one per joint.
    limit: PositiveFloat | list[PositiveFloat]


KINDS = {"loss_of_effectiveness": LossOfEffectivenessSpec, "bias": BiasSpec, "lock": LockSpec, "float": FloatSpec,
         "saturation": SaturationSpec}
ActuatorFaultSpec = tagged_union("kind", KINDS)


@dataclass
class ActuatorFault:
    """A compiled actuator fault.

    Attributes:
        name: for display.
        kind: one of :data:`KINDS`.
        joints: boolean mask of the faulty joints, ``(n,)``.
        profile: its time profile.
        parameter: ``(N, n)`` on the scenario's time grid for ``loss_of_effectiveness`` (alpha) and ``bias``
            (offset), ``(n,)`` for ``saturation`` (limit); zero (limit: inf) on the other joints; None otherwise.
    """

    name: str
    kind: str
    joints: np.ndarray
    profile: Profile
    parameter: np.ndarray | None = None

    def weights(self, times: np.ndarray) -> np.ndarray:
        """w(t) on the grid, ``(N, n)``, zero on the joints the fault does not touch."""
        return self.profile.evaluate(times, len(self.joints)) * self.joints

    def on(self, times: np.ndarray) -> np.ndarray:
        """Per sample and joint, whether the fault is on, ``(N, n)``."""
        return self.profile.active(times)[:, None] & self.joints


class ActuatorFaults:
    """The actuator faults of one run: each period, the delivered torque from the commanded one.

    Attributes after :meth:`apply`: ``delivered`` (what the actuators deliver) and ``torque`` (delivered -
    commanded, the generalized force the fault adds), both ``shape``: ``(rows, n)`` in a batch.
    """

    def __init__(self, faults: list[ActuatorFault], times: np.ndarray, shape: int | tuple[int, ...],
                 limits: np.ndarray | None = None):
        self.delivered = np.zeros(shape)
        self.torque = np.zeros(shape)
        #: Per joint, the motor's |torque| limit the faults act after (inf: none); None: on the command.
        self.limits = None if limits is None or np.isinf(limits).all() else np.asarray(limits, dtype=float)
        self._limited = np.zeros(shape)
        self._actions = [_action(fault, times, shape) for fault in faults]
        #: Per sample, whether any actuator fault is on.
        self.active = np.zeros(len(times), dtype=bool)
        for fault in faults:
            self.active |= fault.on(times).any(axis=1)

    def apply(self, k: int, command: np.ndarray) -> None:
        """Fill ``delivered`` and ``torque`` for sample ``k`` of the grid and the command ``command``."""
        if self.limits is not None:  # what the limited motor gives (MuJoCo clips ctrl alike)
            command = np.clip(command, -self.limits, self.limits, out=self._limited)
        np.copyto(self.delivered, command)
        for action in self._actions:
            if action.on[k]:
                action(k, self.delivered)
        if self.limits is not None:  # a bias neither: the motor gives at most its limit
            np.clip(self.delivered, -self.limits, self.limits, out=self.delivered)
        np.subtract(self.delivered, command, out=self.torque)


class _Action(ABC):
    """One fault's per-step effect on the torque ``u`` it receives (in place)."""

    def __init__(self, fault: ActuatorFault, times: np.ndarray, shape: int | tuple[int, ...]):
        self.weights = fault.weights(times)
        self.on_joints = fault.on(times)
        #: Plain bools: the loop's check costs no NumPy call.
        self.on: list[bool] = self.on_joints.any(axis=1).tolist()
        self._scratch = np.zeros(shape)

    @abstractmethod
    def __call__(self, k: int, u: np.ndarray) -> None:
        """Apply the fault of control step ``k`` to ``u`` in place."""


class _Scale(_Action):
    """u <- (1 - w alpha) u: loss of effectiveness (float is alpha = 1)."""

    def __init__(self, fault: ActuatorFault, times: np.ndarray, shape: int | tuple[int, ...], alpha: np.ndarray | float):
        super().__init__(fault, times, shape)
        self.factor = 1.0 - self.weights * alpha

    def __call__(self, k: int, u: np.ndarray) -> None:
        np.multiply(u, self.factor[k], out=u)


class _Offset(_Action):
    """u <- u + w offset: bias."""

    def __init__(self, fault: ActuatorFault, times: np.ndarray, shape: int | tuple[int, ...]):
        super().__init__(fault, times, shape)
        self.offset = self.weights * fault.parameter

    def __call__(self, k: int, u: np.ndarray) -> None:
        np.add(u, self.offset[k], out=u)


class _Blend(_Action):
    """u <- (1 - w) u + w faulty(u), for the kinds whose faulty output depends on the torque they receive.
    Written so, w = 1 gives faulty(u) exactly and w = 0 gives u exactly."""

    def __init__(self, fault: ActuatorFault, times: np.ndarray, shape: int | tuple[int, ...]):
        super().__init__(fault, times, shape)
        self.keep = 1.0 - self.weights

    @abstractmethod
    def faulty(self, k: int, u: np.ndarray, out: np.ndarray) -> None:
        """The fully faulty actuator's output for the received torque ``u``, into ``out``."""

    def __call__(self, k: int, u: np.ndarray) -> None:
        self.faulty(k, u, self._scratch)
        np.multiply(self._scratch, self.weights[k], out=self._scratch)
        np.multiply(u, self.keep[k], out=u)
        np.add(u, self._scratch, out=u)


class _Lock(_Blend):
    """Holds the torque received at the sample the fault comes on (again at each start of an intermittent one)."""

    def __init__(self, fault: ActuatorFault, times: np.ndarray, shape: int | tuple[int, ...]):
        super().__init__(fault, times, shape)
        before = np.vstack([np.zeros((1, len(fault.joints)), dtype=bool), self.on_joints[:-1]])
        self.freezes = self.on_joints & ~before
        self.freeze_at: list[bool] = self.freezes.any(axis=1).tolist()
        self.frozen = np.zeros(shape)

    def faulty(self, k: int, u: np.ndarray, out: np.ndarray) -> None:
        if self.freeze_at[k]:
            np.copyto(self.frozen, u, where=self.freezes[k])
        np.copyto(out, self.frozen)


class _Saturate(_Blend):
    """Clips the torque received to [-limit, limit]."""

    def __init__(self, fault: ActuatorFault, times: np.ndarray, shape: int | tuple[int, ...]):
        super().__init__(fault, times, shape)
        self.upper = np.asarray(fault.parameter, dtype=float)
        self.lower = -self.upper

    def faulty(self, k: int, u: np.ndarray, out: np.ndarray) -> None:
        np.clip(u, self.lower, self.upper, out=out)


def _action(fault: ActuatorFault, times: np.ndarray, shape: int | tuple[int, ...]) -> _Action:
    if fault.kind == "loss_of_effectiveness":
        return _Scale(fault, times, shape, fault.parameter)
    if fault.kind == "float":
        return _Scale(fault, times, shape, 1.0)
    if fault.kind == "bias":
        return _Offset(fault, times, shape)
    if fault.kind == "lock":
        return _Lock(fault, times, shape)
    if fault.kind == "saturation":
        return _Saturate(fault, times, shape)
    raise ValueError(f"unknown actuator fault kind {fault.kind!r}")


# ------------------------------------------------------------------------------------------------ compiling


def compile_actuator_fault(spec: ActuatorFaultSpec, file: str, field: str, model: mujoco.MjModel,
                           times: np.ndarray) -> ActuatorFault:
    """A fault with its time-dependent parameter (alpha, offset) tabulated on the run's time grid."""
    n = model.nv
    indices = joint_indices(spec.joints, model, file, f"{field}.joints")
    parameter = None
    if spec.kind in ("loss_of_effectiveness", "bias"):
        key = "alpha" if spec.kind == "loss_of_effectiveness" else "offset"
        parameter = _time_table(getattr(spec, key), indices, n, times, file, f"{field}.{key}")
        if key == "alpha" and ((parameter < 0) | (parameter > 1)).any():
            row = int(np.flatnonzero(((parameter < 0) | (parameter > 1)).any(axis=1))[0])
            raise InputError(file, f"{field}.alpha", f"must stay within [0, 1]; it is outside at t = {times[row]:g}")
    elif spec.kind == "saturation":
        parameter = np.full(n, np.inf)
        parameter[indices] = per_selected(spec.limit, indices, file, f"{field}.limit")
    return ActuatorFault(name=spec.name or f"{spec.kind}{field.rsplit('.', 1)[-1]}", kind=spec.kind,
                         joints=joint_mask(indices, n), parameter=parameter,
                         profile=compile_profile(spec.profile, file, f"{field}.profile", n))


def _time_table(values: ExpressionText | list[ExpressionText], indices: list[int], n: int, times: np.ndarray,
                file: str, field: str) -> np.ndarray:
    """Expressions of t for the selected joints, evaluated on the time grid: ``(N, n)``, 0 elsewhere."""
    texts = per_selected(values, indices, file, field)
    single = not isinstance(values, list)
    exprs = [parse_expression(text, ["t"], file, field if single else f"{field}.{i}") for i, text in enumerate(texts)]
    table = np.zeros((len(times), n))
    with np.errstate(all="ignore"):
        table[:, indices] = expressions.TimeFunctions(exprs).evaluate(times)[0]
    if not np.isfinite(table).all():
        row = int(np.flatnonzero(~np.isfinite(table).all(axis=1))[0])
        raise InputError(file, field, f"is not a finite number at t = {times[row]:g}")
    return table
