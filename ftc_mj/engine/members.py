"""Members: the B runs of a batch, stepped together, and what may differ between them.

A run of a scenario is a batch of members; a single run is one member. Members share the scenario's
structure (robot, grid, terms and their expressions, faults, sensor effects, methods) and may differ in every
number the batch carries per member, each with the member axis first:

* ``seed``: each member its own random streams, ``SeedSequence(seed_k, spawn_key=(stream,))``; by default
  ``seed_k = seed + k``, so that member k of a batch is the same run whatever B and the thread count, and
  member 0 is the scenario's own run;
* ``initial.q``, ``initial.qd`` and the observers' initial estimates;
* ``parameters``: the named numbers the terms' expressions use;
* ``nominal.mass_scale`` (the controller's model) and ``plant.mass_scale`` (the simulated robot, through
  ``mujoco.batch``'s per-simulation model fields);
* every method's gains, per variant and monitor.

:func:`members_from_overrides` builds them from per-member overrides given by dotted paths, as ``--set``
takes them (``{"variants.proposed.controller.gains.mu": 2.0, "parameters.fault_scale": 0.5}``); a path outside
those is refused, since it would change the batch's structure.
"""

from __future__ import annotations

import copy
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pydantic import ValidationError

from ftc_mj.methods.gains import GainConfig, stack
from ftc_mj.config.errors import InputError, validation_error
from ftc_mj.config.yaml import set_path
from ftc_mj.spec.scenario import Scenario, ScenarioSpec, compile_variant_methods, joint_values, observer_start


@dataclass
class MemberVariant:
    """One variant's per-member values: stacked gain configurations and the observers' initial estimates."""

    observer: GainConfig
    controller: GainConfig
    monitors: list[GainConfig]
    q_hat0: np.ndarray | None  # (B, n); None: from each member's first reading
    qd_hat0: np.ndarray  # (B, n)


@dataclass
class Members:
    """What differs between the B members of a batch, member axis first (see the module docstring)."""

    seeds: np.ndarray  # (B,)
    q0: np.ndarray  # (B, n)
    qd0: np.ndarray  # (B, n)
    parameters: np.ndarray  # (B, p), in the order of the scenario's ``parameters``
    nominal_mass_scale: np.ndarray  # (B,)
    plant_mass_scale: np.ndarray  # (B,)
    variants: list[MemberVariant]  # in the scenario's order
    #: Per member, the overrides it was built from (for reports); empty for replicates.
    overrides: list[dict[str, Any]] = field(default_factory=list)

    @property
    def count(self) -> int:
        return len(self.seeds)

    def select(self, chosen: slice | np.ndarray) -> "Members":
        """The members ``chosen`` (a slice or indices), e.g. one chunk of a large batch."""
        def take(values: np.ndarray | None) -> np.ndarray | None:
            return None if values is None else values[chosen]

        variants = [
            MemberVariant(stack_select(v.observer, chosen), stack_select(v.controller, chosen),
                          [stack_select(m, chosen) for m in v.monitors], take(v.q_hat0), take(v.qd_hat0))
            for v in self.variants
        ]
        picked = range(self.count)[chosen] if isinstance(chosen, slice) else list(chosen)
        overrides = [self.overrides[i] for i in picked] if self.overrides else []
        return Members(take(self.seeds), take(self.q0), take(self.qd0), take(self.parameters),
                       take(self.nominal_mass_scale), take(self.plant_mass_scale), variants, overrides)


def stack_select(config: GainConfig, chosen: slice | np.ndarray) -> GainConfig:
    """The members ``chosen`` of a stacked configuration."""
    values = {name: (value[chosen] if isinstance(value, np.ndarray) else value) for name, value in config}
    return type(config).model_construct(**values)


#: Fields that may differ between the members of a batch, as dotted paths.
BATCHABLE = re.compile(
    r"seed|initial\.qd?(\.\d+)?|observer_initial\..+|parameters\.[A-Za-z_]\w*|(nominal|plant)\.mass_scale"
    r"|variants\.[^.]+\.((observer|controller)\.gains|monitors\.[^.]+\.gains|observer_initial)\..+"
)


def single(scenario: Scenario) -> Members:
    """The scenario as written: one member."""
    return replicates(scenario, 1)


def replicates(scenario: Scenario, count: int) -> Members:
    """``count`` members that differ only in their seed: ``seed + k`` for member k."""
    one = _values(scenario, scenario.spec)
    members = _stack([one] * count)
    members.seeds = scenario.spec.seed + np.arange(count)
    return members


def members_from_overrides(scenario: Scenario, overrides: Sequence[Mapping[str, Any]]) -> Members:
    """One member per mapping of dotted paths to values, each applied to the scenario as loaded. A member
    whose mapping sets no ``seed`` gets ``seed + k`` (k its index), as :func:`replicates` does: each member has
    its own random streams, and member 0 is the scenario's own run.

    Raises:
        InputError: a path that may not differ within a batch (:data:`BATCHABLE`), or a value the scenario's
            schema refuses, naming the member and the field.
    """
    file = str(scenario.path)
    values = []
    for k, member in enumerate(overrides):
        raw = copy.deepcopy(scenario.raw)
        raw["seed"] = scenario.spec.seed + k
        for key, value in member.items():
            if BATCHABLE.fullmatch(key) is None:
                raise InputError(file, key, f"member {k}: cannot differ between the members of a batch (only the "
                                 "seed, initial states, parameters, mass scales and gains can)")
            set_path(raw, key, value, file)
        try:
            spec = ScenarioSpec.model_validate(raw)
        except ValidationError as exc:
            raise validation_error(file, "", exc) from None
        if set(spec.parameters) != set(scenario.spec.parameters):
            raise InputError(file, "parameters", f"member {k}: set the scenario's parameters, do not add any")
        values.append(_values(scenario, spec))
    members = _stack(values)
    members.overrides = [dict(member) for member in overrides]
    return members


def _values(scenario: Scenario, spec: ScenarioSpec) -> Members:
    """One member's values from its validated spec (a batch of one)."""
    file, n = str(scenario.path), scenario.n_joints

    def vector(values: list[float] | None, field: str, default: float | None = 0.0) -> np.ndarray | None:
        return joint_values(values, n, file, field, default)

    variants = []
    for variant in scenario.variants:
        (_, observer), (_, controller), monitors = compile_variant_methods(file, variant.name,
                                                                           spec.variants[variant.name], n)
        q_hat0, qd_hat0 = observer_start(spec, variant.name, n, file)
        variants.append(MemberVariant(observer, controller, [m.observer_config for m in monitors],
                                      None if q_hat0 is None else q_hat0[None], qd_hat0[None]))
    return Members(
        seeds=np.array([spec.seed]),
        q0=vector(spec.initial.q, "initial.q")[None],
        qd0=vector(spec.initial.qd, "initial.qd")[None],
        parameters=np.array([[spec.parameters[name] for name in scenario.spec.parameters]], dtype=float),
        nominal_mass_scale=np.array([spec.nominal.mass_scale]),
        plant_mass_scale=np.array([spec.plant.mass_scale]),
        variants=variants,
    )


def _stack(members: list[Members]) -> Members:
    """Members of batches of one, as one batch (gains stacked per variant and monitor)."""
    def join(values: list[np.ndarray | None]) -> np.ndarray | None:
        if all(value is None for value in values):
            return None
        if any(value is None for value in values):
            raise ValueError("observer_initial.q_hat given for some members and not for others")
        return np.concatenate(values)

    n = members[0].q0.shape[1]
    variants = []
    for v in range(len(members[0].variants)):
        of_variant = [m.variants[v] for m in members]
        variants.append(MemberVariant(
            observer=stack([mv.observer for mv in of_variant], n),
            controller=stack([mv.controller for mv in of_variant], n),
            monitors=[stack([mv.monitors[i] for mv in of_variant], n) for i in range(len(of_variant[0].monitors))],
            q_hat0=join([mv.q_hat0 for mv in of_variant]),
            qd_hat0=join([mv.qd_hat0 for mv in of_variant]),
        ))
    return Members(
        seeds=np.concatenate([m.seeds for m in members]),
        q0=np.concatenate([m.q0 for m in members]),
        qd0=np.concatenate([m.qd0 for m in members]),
        parameters=np.concatenate([m.parameters for m in members]),
        nominal_mass_scale=np.concatenate([m.nominal_mass_scale for m in members]),
        plant_mass_scale=np.concatenate([m.plant_mass_scale for m in members]),
        variants=variants,
    )
