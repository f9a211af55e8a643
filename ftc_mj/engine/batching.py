"""Batching: which fields of a scenario may differ between the members of one batch, and how the members'
values are stacked into the arrays the engine steps.

Members share the scenario's structure (robot, grid, terms and their expressions, faults, sensor effects,
methods and the forms of their laws); what may differ is the declared list :data:`FIELD_KINDS`, each kind
with the paths that name it, how a member's value is validated and where it goes in
:class:`~ftc_mj.engine.members.Members`. :func:`member_field` parses a dotted path (as ``--set`` and a
campaign write it) into a typed :class:`MemberField`, or refuses it: a path outside the list would change the
batch's structure.

:func:`stack` turns one validated gain configuration per member into one configuration whose gains are
``(members, n)`` arrays, the form every plugin receives (:class:`ftc_mj.methods.plugin.Method`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from ftc_mj.config.errors import InputError
from ftc_mj.methods.gains import GainConfig

#: The kinds of field that may differ between members (see :data:`FIELD_KINDS`).
FieldKind = Literal["seed", "initial", "observer_initial", "parameter", "mass_scale", "gain"]

#: Where a gain belongs: a variant's observer, its controller, or one of its monitors.
MethodRole = Literal["observer", "controller", "monitor"]


@dataclass(frozen=True)
class FieldKindInfo:
    """One kind of batchable field: the paths that name it, how a member's value is validated, where it goes."""

    kind: FieldKind
    paths: tuple[str, ...]
    validated: str
    goes_to: str


#: Every kind of field that may differ between the members of a batch; ``I`` is a joint's 0-based index.
FIELD_KINDS: tuple[FieldKindInfo, ...] = (
    FieldKindInfo("seed", ("seed",), "an integer >= 0, as the scenario's seed", "Members.seeds"),
    FieldKindInfo("initial", ("initial.q", "initial.qd", "initial.q.I", "initial.qd.I"),
                  "the initial state's schema: one finite number per joint", "Members.q0, Members.qd0"),
    FieldKindInfo("observer_initial",
                  ("observer_initial.q_hat", "observer_initial.qd_hat", "observer_initial.q_hat.I",
                   "observer_initial.qd_hat.I", "variants.V.observer_initial.q_hat",
                   "variants.V.observer_initial.qd_hat", "variants.V.observer_initial.q_hat.I",
                   "variants.V.observer_initial.qd_hat.I"),
                  "the observer initial estimate's schema: one finite number per joint",
                  "MemberVariant.q_hat0, MemberVariant.qd_hat0 (of every variant that uses it)"),
    FieldKindInfo("parameter", ("parameters.NAME",),
                  "a finite number, one of the scenario's parameters; positive where it is a term's rate",
                  "Members.parameters"),
    FieldKindInfo("mass_scale", ("nominal.mass_scale", "plant.mass_scale"), "a positive number",
                  "Members.nominal_mass_scale, Members.plant_mass_scale"),
    FieldKindInfo("gain",
                  ("variants.V.observer.gains.G", "variants.V.controller.gains.G",
                   "variants.V.monitors.M.gains.G", "... .gains.G.I"),
                  "merged into the method's gains and validated by its plugin's Config (n_joints in context), "
                  "as compiling the scenario does; a gain that selects the law's form (a choice) cannot differ",
                  "MemberVariant.observer, MemberVariant.controller, MemberVariant.monitors[i]"),
)

#: The one line that refuses a path outside :data:`FIELD_KINDS`.
NOT_BATCHABLE = ("cannot differ between the members of a batch (only the seed, initial states, parameters, "
                 "mass scales and gains can)")


@dataclass(frozen=True)
class MemberField:
    """A batchable field, parsed from its dotted path (:func:`member_field`)."""

    path: str
    kind: FieldKind
    #: initial: ``q`` or ``qd``; observer_initial: ``q_hat`` or ``qd_hat``; parameter: its name; mass_scale:
    #: ``nominal`` or ``plant``; gain: the gain's name.
    name: str
    #: initial and observer_initial: one joint's element (None: the whole vector).
    element: int | None = None
    #: observer_initial of one variant (None: the scenario's), and the variant of a gain.
    variant: str | None = None
    #: A gain's method and, for a monitor, its name.
    role: MethodRole | None = None
    monitor: str | None = None
    #: A gain's path inside its method's ``gains`` (``mu``, or ``rho.1`` for one joint's element).
    key: str = ""

    @property
    def section(self) -> str:
        """The dotted path of the section the field changes (what its value is validated with)."""
        if self.kind == "gain":
            method = f"monitors.{self.monitor}" if self.role == "monitor" else self.role
            return f"variants.{self.variant}.{method}"
        if self.kind == "observer_initial" and self.variant is not None:
            return f"variants.{self.variant}.observer_initial"
        return self.path.split(".")[0]


def _joint(index: list[str]) -> tuple[bool, int | None]:
    """Whether the path's tail is empty or one joint index, and the index."""
    if not index:
        return True, None
    if len(index) == 1 and index[0].isdigit():
        return True, int(index[0])
    return False, None


def batchable(path: str) -> MemberField | None:
    """The batchable field named by ``path``; None for a path outside :data:`FIELD_KINDS`."""
    parts = path.split(".")
    if any(not part for part in parts):
        return None
    match parts:
        case ["seed"]:
            return MemberField(path, "seed", "seed")
        case ["initial", ("q" | "qd") as name, *index]:
            ok, element = _joint(index)
            return MemberField(path, "initial", name, element) if ok else None
        case ["observer_initial", ("q_hat" | "qd_hat") as name, *index]:
            ok, element = _joint(index)
            return MemberField(path, "observer_initial", name, element) if ok else None
        case ["variants", variant, "observer_initial", ("q_hat" | "qd_hat") as name, *index]:
            ok, element = _joint(index)
            return MemberField(path, "observer_initial", name, element, variant) if ok else None
        case ["parameters", name] if name.isidentifier() and name.isascii():
            return MemberField(path, "parameter", name)
        case [("nominal" | "plant") as model, "mass_scale"]:
            return MemberField(path, "mass_scale", model)
        case ["variants", variant, ("observer" | "controller") as role, "gains", gain, *rest]:
            return MemberField(path, "gain", gain, variant=variant, role=role, key=".".join([gain, *rest]))
        case ["variants", variant, "monitors", monitor, "gains", gain, *rest]:
            return MemberField(path, "gain", gain, variant=variant, role="monitor", monitor=monitor,
                               key=".".join([gain, *rest]))
    return None


def member_field(path: str, file: str) -> MemberField:
    """The batchable field named by ``path``.

    Raises:
        InputError: the path is outside :data:`FIELD_KINDS` (it would change the batch's structure).
    """
    field = batchable(path)
    if field is None:
        raise InputError(file, path, NOT_BATCHABLE)
    return field


def stack(configs: Sequence[GainConfig], n_joints: int) -> GainConfig:
    """One configuration for a batch of members from one validated configuration per member.

    Per-joint gains and single numbers both become contiguous ``(members, n)`` arrays; a field that is None
    must be None for every member, and a choice (a string such as ``compensation``) must be the same for every
    member, since it selects the law's form rather than a value. The result is not validated again: each
    member's values were.

    Raises:
        ValueError: a field given for some members only, or a choice that differs, naming the field.
    """
    first = configs[0]
    values: dict[str, Any] = {}
    for name in type(first).model_fields:
        column = [getattr(config, name) for config in configs]
        if all(value is None for value in column):
            values[name] = None
        elif any(value is None for value in column):
            raise ValueError(f"{name}: given for some members and not for others")
        elif isinstance(column[0], np.ndarray):
            values[name] = np.stack([np.asarray(value, dtype=float) for value in column])
        elif isinstance(column[0], GainConfig):  # a plugin's gains inside another's (a supervisor's controllers)
            values[name] = stack(column, n_joints)
        elif isinstance(column[0], (bool, str)):
            if any(value != column[0] for value in column):
                raise ValueError(f"{name}: differs between members ({column[0]!r}, ...); it selects the law's form")
            values[name] = column[0]
        else:
            # One per member and joint (not one column to broadcast): an exponent of one element would take
            # NumPy's scalar fast paths (x ** 0.5 as sqrt), which differ in the last bit from the general power
            # a batch of many members computes, and member k would not be its own run.
            values[name] = np.repeat(np.asarray(column, dtype=float)[:, None], n_joints, axis=1)
    return type(first).model_construct(**values)


def stack_select(config: GainConfig, chosen: slice | np.ndarray) -> GainConfig:
    """The members ``chosen`` (a slice or indices) of a stacked configuration."""
    values = {name: (value[chosen] if isinstance(value, np.ndarray) else
                     stack_select(value, chosen) if isinstance(value, GainConfig) else value) for name, value in config}
    return type(config).model_construct(**values)


def stack_states(values: Sequence[np.ndarray | None]) -> np.ndarray | None:
    """One state vector per member as ``(members, n)``; None when every member's is None (an estimate that
    starts from each member's first reading).

    Raises:
        ValueError: given for some members and not for others.
    """
    if all(value is None for value in values):
        return None
    if any(value is None for value in values):
        raise ValueError("given for some members and not for others")
    return np.stack(values)
