"""Members: the B runs of a batch, stepped together, and their values.

A run of a scenario is a batch of members; a single run is one member. Members share the compiled scenario's
structure and may differ in the fields of :data:`ftc_mj.engine.batching.FIELD_KINDS`, each with the member
axis first:

* ``seed``: each member its own random streams, ``SeedSequence(seed_k, spawn_key=(stream,))``; by default
  ``seed_k = seed + k``, so that member k of a batch is the same run whatever B and the thread count, and
  member 0 is the scenario's own run;
* ``initial.q``, ``initial.qd`` and the observers' initial estimates;
* ``parameters``: the named numbers the terms' expressions use;
* ``nominal.mass_scale`` (the controller's model) and ``plant.mass_scale`` (the simulated robot, through
  ``mujoco.batch``'s per-simulation model fields);
* every method's gains, per variant and monitor.

Every member starts from the compiled scenario's values (its :class:`~ftc_mj.scenario.definition.Variant` configs,
q0, qd0, parameters, mass scales); nothing is compiled again. :func:`members_from_overrides` changes them by
dotted paths, as ``--set`` takes them (``{"variants.proposed.controller.gains.mu": 2.0,
"parameters.fault_scale": 0.5}``); each override is validated against the section it changes, as compiling
the scenario validates that section: a gain merged into its method's gains and validated by the plugin's
``Config`` (the same arrays, bit for bit), a parameter as a finite number (positive where it is a term's
rate), a state as one finite number per joint, a seed as an integer >= 0, a mass scale as a positive number.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from dataclasses import field as dataclass_field
from functools import cache
from typing import Annotated, Any

import numpy as np
from pydantic import BaseModel, TypeAdapter

from ftc_mj.config.errors import InputError, validate
from ftc_mj.config.types import FiniteFloat
from ftc_mj.config.yaml import set_path, unshared
from ftc_mj.engine.batching import MemberField, member_field, stack, stack_select, stack_states
from ftc_mj.methods.gains import GainConfig
from ftc_mj.robot.model import PlantSpec
from ftc_mj.robot.nominal import NominalSpec
from ftc_mj.scenario.definition import (InitialState, ObserverInitial, Scenario, ScenarioSpec, joint_values,
                                  observer_estimates, rate_parameter_problem)


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
    overrides: list[dict[str, Any]] = dataclass_field(default_factory=list)

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


def single(scenario: Scenario) -> Members:
    """The scenario as written: one member."""
    return replicates(scenario, 1)


def replicates(scenario: Scenario, count: int) -> Members:
    """``count`` members that differ only in their seed: ``seed + k`` for member k."""
    return _Columns(scenario, count).members()


def members_from_overrides(scenario: Scenario, overrides: Sequence[Mapping[str, Any]]) -> Members:
    """One member per mapping of dotted paths to values, each applied to the scenario as compiled. A member
    whose mapping sets no ``seed`` gets ``seed + k`` (k its index), as :func:`replicates` does: each member has
    its own random streams, and member 0 is the scenario's own run.

    An override of a variant that the file declares but ``load_scenario`` left out is accepted and unused.

    Raises:
        InputError: a path that may not differ within a batch (:func:`~ftc_mj.engine.batching.member_field`),
            or a value its section refuses, naming the member and the field.
    """
    columns = _Columns(scenario, len(overrides))
    fields: dict[str, MemberField | None] = {}
    for k, member in enumerate(overrides):
        try:
            changes = []
            for path, value in member.items():
                if path not in fields:
                    fields[path] = _bind(scenario, member_field(path, columns.file))
                if fields[path] is not None:
                    changes.append((fields[path], value))
            columns.apply(k, changes)
        except InputError as exc:
            raise InputError(exc.file, exc.field, f"member {k}: {exc.problem}") from None
    members = columns.members()
    members.overrides = [dict(member) for member in overrides]
    return members


def _bind(scenario: Scenario, field: MemberField) -> MemberField | None:
    """Check ``field`` against the scenario's structure; None for a gain or estimate of a variant the file
    declares but the scenario does not run.

    Raises:
        InputError: an unknown parameter, variant or monitor, or a gain that selects the law's form.
    """
    file, spec = str(scenario.path), scenario.spec
    if field.kind == "parameter" and field.name not in spec.parameters:
        raise InputError(file, field.path, "set the scenario's parameters, do not add any")
    if field.variant is None:
        return field
    if field.variant not in spec.variants:
        if scenario.written("variants", field.variant) is not None:
            return None
        raise InputError(file, field.path, f"no variant {field.variant!r} (known: {', '.join(spec.variants)})")
    if field.kind == "gain":
        variant = next(v for v in scenario.variants if v.name == field.variant)
        if field.role == "monitor":
            monitor = next((m for m in variant.monitors if m.name == field.monitor), None)
            if monitor is None:
                raise InputError(file, field.path, f"variant {field.variant} has no monitor {field.monitor!r}")
            config = monitor.observer_config
        else:
            config = variant.observer_config if field.role == "observer" else variant.controller_config
        if field.name in type(config).model_fields and isinstance(getattr(config, field.name), (bool, str)):
            raise InputError(file, field.path, "cannot differ between the members of a batch: it selects the "
                             "law's form")
    return field


@cache
def _adapter(model: type[BaseModel], name: str) -> TypeAdapter:
    """The validator of one field of a schema section (its type and constraints)."""
    info = model.model_fields[name]
    return TypeAdapter(Annotated[(info.annotation, *info.metadata)])


#: A parameter's value: the type of the scenario's ``parameters``.
_PARAMETER = TypeAdapter(FiniteFloat)


def _validated(adapter: TypeAdapter, value: Any, file: str, path: str) -> Any:
    return validate(adapter, value, file, path)


def _set_element(values: list | None, field: MemberField, value: Any, file: str) -> list:
    """``values`` with ``field``'s element (or all of it) replaced by ``value``."""
    if field.element is None:
        return unshared(value)
    if not isinstance(values, list) or field.element >= len(values):
        given = "no values" if not isinstance(values, list) else f"{len(values)} values"
        raise InputError(file, field.path, f"{field.section}.{field.name} has {given}: it has no element "
                         f"{field.element} to set")
    values = list(values)
    values[field.element] = value
    return values


class _Columns:
    """The members' values before stacking, each member starting from the compiled scenario's."""

    def __init__(self, scenario: Scenario, count: int):
        spec, n = scenario.spec, scenario.n_joints
        self.scenario, self.spec, self.n, self.file = scenario, spec, n, str(scenario.path)
        self.count = count
        # Unsigned: seed + k stays exact up to 2**64 - 1 (a seed near MAX_SEED = 2**63 - 1 would wrap in int64).
        self.seeds = np.uint64(spec.seed) + np.arange(count, dtype=np.uint64)
        self.q0 = np.repeat(scenario.q0[None], count, axis=0)
        self.qd0 = np.repeat(scenario.qd0[None], count, axis=0)
        self.parameter_index = {name: i for i, name in enumerate(spec.parameters)}
        self.parameters = np.repeat(np.array([list(spec.parameters.values())], dtype=float).reshape(1, -1),
                                    count, axis=0)
        self.mass_scale = {"nominal": np.full(count, spec.nominal.mass_scale),
                           "plant": np.full(count, spec.plant.mass_scale)}
        # Per section of gains (its dotted path): the plugin class and one configuration per member.
        self.gains: dict[str, tuple[type, list[GainConfig]]] = {}
        self.estimates: list[tuple[list[np.ndarray | None], list[np.ndarray]]] = []
        for variant in scenario.variants:
            prefix = f"variants.{variant.name}"
            self.gains[f"{prefix}.observer"] = (variant.observer_type, [variant.observer_config] * count)
            self.gains[f"{prefix}.controller"] = (variant.controller_type, [variant.controller_config] * count)
            for monitor in variant.monitors:
                self.gains[f"{prefix}.monitors.{monitor.name}"] = (monitor.observer_type,
                                                                   [monitor.observer_config] * count)
            self.estimates.append(([variant.q_hat0] * count, [variant.qd_hat0] * count))

    def apply(self, k: int, changes: list[tuple[MemberField, Any]]) -> None:
        """Member ``k``'s overrides, in their order, each section validated once with all of its changes."""
        file, spec = self.file, self.spec
        initial: dict[str, Any] | None = None
        estimates: dict[str | None, dict[str, Any] | None] = {}
        gains: dict[str, dict[str, Any]] = {}
        for field, value in changes:
            if field.kind == "seed":
                self.seeds[k] = _validated(_adapter(ScenarioSpec, "seed"), value, file, field.path)
            elif field.kind == "parameter":
                number = _validated(_PARAMETER, value, file, field.path)
                problem = rate_parameter_problem(spec.terms, field.name, number)
                if problem is not None:
                    raise InputError(file, field.path, problem)
                self.parameters[k, self.parameter_index[field.name]] = number
            elif field.kind == "mass_scale":
                model = NominalSpec if field.name == "nominal" else PlantSpec
                self.mass_scale[field.name][k] = _validated(_adapter(model, "mass_scale"), value, file, field.path)
            elif field.kind == "initial":
                if initial is None:
                    qd = spec.initial.qd if spec.initial.qd is not None else [0.0] * self.n
                    initial = {"q": list(spec.initial.q), "qd": list(qd)}
                initial[field.name] = _set_element(initial[field.name], field, value, file)
            elif field.kind == "observer_initial":
                if field.variant not in estimates:
                    own = spec.observer_initial if field.variant is None else \
                        spec.variants[field.variant].observer_initial
                    estimates[field.variant] = {} if own is None else own.model_dump()
                section = estimates[field.variant]
                section[field.name] = _set_element(section.get(field.name), field, value, file)
            else:
                if field.section not in gains:
                    gains[field.section] = unshared(self._method(field).gains)
                section = gains[field.section]
                try:
                    set_path(section, field.key, unshared(value), file)
                except InputError as exc:
                    raise InputError(file, field.path, exc.problem.removeprefix("--set: ")) from None
        if initial is not None:
            self._initial(k, initial)
        if estimates:
            self._estimates(k, estimates)
        for path, section in gains.items():
            plugin, configs = self.gains[path]
            configs[k] = validate(plugin.Config, section, file, f"{path}.gains", context={"n_joints": self.n})

    def _method(self, field: MemberField) -> Any:
        """The :class:`~ftc_mj.methods.registry.MethodSpec` a gain field belongs to."""
        variant = self.spec.variants[field.variant]
        if field.role == "monitor":
            return variant.monitors[field.monitor]
        return variant.observer if field.role == "observer" else variant.controller

    def _initial(self, k: int, raw: dict[str, Any]) -> None:
        state = validate(InitialState, raw, self.file, "initial")
        self.q0[k] = joint_values(state.q, self.n, self.file, "initial.q")
        self.qd0[k] = joint_values(state.qd, self.n, self.file, "initial.qd")

    def _estimates(self, k: int, raw: dict[str | None, dict[str, Any] | None]) -> None:
        """The observers' initial estimates of every variant once member ``k`` changed the scenario's
        ``observer_initial`` or a variant's own (``raw``, by variant; None for the scenario's)."""
        def section(variant: str | None) -> ObserverInitial | None:
            field = "observer_initial" if variant is None else f"variants.{variant}.observer_initial"
            return validate(ObserverInitial, raw[variant], self.file, field)

        shared = section(None) if None in raw else self.spec.observer_initial
        for v, variant in enumerate(self.scenario.variants):
            own = section(variant.name) if variant.name in raw else self.spec.variants[variant.name].observer_initial
            q_hat0, qd_hat0 = observer_estimates(own, shared, variant.name, self.n, self.file)
            self.estimates[v][0][k] = q_hat0
            self.estimates[v][1][k] = qd_hat0

    def members(self) -> Members:
        """The members' values stacked, member axis first."""
        def stacked(path: str) -> GainConfig:
            _, configs = self.gains[path]
            try:
                return stack(configs, self.n)
            except ValueError as exc:
                raise InputError(self.file, f"{path}.gains", f"members: {exc}") from None

        variants = []
        for variant, (q_hat0, qd_hat0) in zip(self.scenario.variants, self.estimates):
            prefix = f"variants.{variant.name}"
            try:
                q_hat0_stacked = stack_states(q_hat0)
            except ValueError as exc:
                raise InputError(self.file, f"{prefix}.observer_initial.q_hat", f"members: {exc}") from None
            variants.append(MemberVariant(
                observer=stacked(f"{prefix}.observer"),
                controller=stacked(f"{prefix}.controller"),
                monitors=[stacked(f"{prefix}.monitors.{monitor.name}") for monitor in variant.monitors],
                q_hat0=q_hat0_stacked,
                qd_hat0=np.stack(qd_hat0),
            ))
        return Members(seeds=self.seeds, q0=self.q0, qd0=self.qd0, parameters=self.parameters,
                       nominal_mass_scale=self.mass_scale["nominal"], plant_mass_scale=self.mass_scale["plant"],
                       variants=variants)
