"""Scenario files: the YAML schema, its validation and compilation.

A scenario is untrusted input. It is read with ``yaml.safe_load``, checked against a strict pydantic schema
(unknown keys are errors), its expressions are parsed by :mod:`ftc_mj.expressions` (never evaluated as
Python), and every plugin's gains are validated by the plugin's own schema. Any problem raises
:class:`~ftc_mj.errors.InputError` naming the file, the field path and what is wrong.

Sign convention of plant terms: a term with value f and ``sign`` s enters the true plant as

* ``space: torque``:        M(q) qdd + C(q, qd) qd + G(q) = tau + s f
* ``space: acceleration``:  qdd = M(q)^-1 (tau - C qd - G) + s f    (applied as the torque s M(q) f)

so Chapter 5's (5.1) has friction and disturbance with s = -1 (torque) and the fault with s = +1
(acceleration). A term with an ``onset`` Tf is multiplied per joint by the profile 1 - exp(-rate (t - Tf))
for t >= Tf (abrupt, i.e. a step, when ``rate`` is absent) and is zero before.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import mujoco
import numpy as np
import yaml
from pydantic import BaseModel, ConfigDict, Field, StrictFloat, StrictInt, StrictStr, ValidationError, field_validator

from ftc_mj import expressions, urdf
from ftc_mj.errors import InputError
from ftc_mj.gains import GainConfig
from ftc_mj.registry import PluginError, controller_types, observer_types

PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegativeFloat = Annotated[float, Field(ge=0, allow_inf_nan=False)]
FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]
# Strict: a YAML boolean must not pass as the number 1.
ExpressionText = StrictStr | StrictInt | StrictFloat

REPO_ROOT = Path(__file__).resolve().parents[1]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class UrdfOptions(_Strict):
    """Options of a URDF robot (``ftc_mj/urdf.py``); an MJCF model states them in its own file."""

    #: Joints to lock, by name: angle [rad] (position [m] for a prismatic joint).
    lock: dict[str, FiniteFloat] = {}
    #: |torque| limit of the free joints' motors, one value or one per free joint; overrides URDF efforts.
    torque_limits: PositiveFloat | list[PositiveFloat] | None = None
    #: Reflected rotor inertia of the free joints [kg m^2], one value or one per free joint (URDF has none).
    armature: NonNegativeFloat | list[NonNegativeFloat] | None = None


class RobotSpec(UrdfOptions):
    #: MJCF or URDF file (``.urdf``), relative to the scenario file.
    model: str
    #: Sensors the controller may read: joint encoders always; tachometers only where the chapter assumes
    #: them (Chapter 2). A method whose ``requires`` names a sensor not listed here is refused at load time.
    sensors: list[Literal["position", "velocity"]] = ["position"]


class InitialState(_Strict):
    q: list[FiniteFloat]
    qd: list[FiniteFloat] | None = None


class ObserverInitial(_Strict):
    #: Initial position estimate; defaults to the first measurement.
    q_hat: list[FiniteFloat] | None = None
    #: Initial velocity estimate; defaults to zero.
    qd_hat: list[FiniteFloat] | None = None


class TermSpec(_Strict):
    """A friction, disturbance or fault term: per-joint expressions of t, q1..qn, qd1..qn."""

    kind: Literal["friction", "disturbance", "fault"]
    space: Literal["torque", "acceleration"]
    sign: Literal[1, -1]
    value: list[ExpressionText]
    onset: NonNegativeFloat | None = None
    #: Evolution rate of 1 - exp(-rate (t - onset)), one number or one per joint; abrupt when absent.
    rate: PositiveFloat | list[PositiveFloat] | None = None
    name: str | None = None


class MethodSpec(_Strict):
    type: str
    gains: dict[str, Any] = {}


class VariantSpec(_Strict):
    observer: MethodSpec
    controller: MethodSpec
    observer_initial: ObserverInitial | None = None


class NominalSpec(_Strict):
    #: Scales masses, inertias and armature of the controller's model (1 = exact model).
    mass_scale: PositiveFloat = 1.0


class MetricsSpec(_Strict):
    #: Tracking metrics "after convergence" are taken from this time on [s].
    window_start: NonNegativeFloat
    #: Estimation metrics (velocity, LUaF) are taken from this time on [s].
    estimation_window_start: NonNegativeFloat
    #: Interval excluded after each fault onset [s].
    fault_settle: NonNegativeFloat = 1.0
    #: |e| tolerance of convergence_time [rad].
    tracking_tolerance: PositiveFloat = 0.01
    #: |velocity error| tolerance of observer_convergence_time [rad/s].
    velocity_tolerance: PositiveFloat = 0.05
    #: |LUaF estimation error| tolerance of luaf_convergence_time [rad/s^2].
    luaf_tolerance: PositiveFloat = 0.5
    #: |sliding variable| tolerance of reaching_time (units of the surface, rad/s for every built-in law).
    sliding_tolerance: PositiveFloat = 0.01


class DivergenceSpec(_Strict):
    max_position: PositiveFloat = 100.0
    max_velocity: PositiveFloat = 1000.0


class ScenarioSpec(_Strict):
    name: Annotated[str, Field(min_length=1, pattern=r"^[A-Za-z0-9_.-]+$")]
    description: str = ""
    robot: RobotSpec
    seed: int = 0
    duration: PositiveFloat
    control_dt: PositiveFloat = 1e-3
    #: Physics timestep; control_dt must be an integer multiple of it. Defaults to control_dt.
    timestep: PositiveFloat | None = None
    initial: InitialState
    observer_initial: ObserverInitial = ObserverInitial()
    reference: list[ExpressionText]
    terms: list[TermSpec] = []
    nominal: NominalSpec = NominalSpec()
    variants: Annotated[dict[str, VariantSpec], Field(min_length=1)]
    metrics: MetricsSpec
    divergence: DivergenceSpec = DivergenceSpec()
    #: Recording path, relative to the working directory.
    output: str | None = None

    @field_validator("variants")
    @classmethod
    def _variant_names(cls, variants: dict[str, VariantSpec]) -> dict[str, VariantSpec]:
        for name in variants:
            if not name or not all(c.isalnum() or c in "_-" for c in name):
                raise ValueError(f"variant name {name!r} may use only letters, digits, '_' and '-'")
        return variants


@dataclass
class CompiledTerm:
    """A plant term ready for the loop."""

    name: str
    kind: str
    space: str
    sign: float
    function: expressions.StateFunction
    onset: float | None
    rate: np.ndarray | None  # per joint; None = abrupt
    #: Joints whose value is not identically zero (a fault "on joint 1" has zeros elsewhere).
    joints: np.ndarray

    def profile(self, t: float) -> np.ndarray | float | None:
        """The time profile omega(t - Tf) per joint (5.1): None (off) before the onset, then
        1 - exp(-rate (t - Tf)), or 1 when abrupt."""
        if self.onset is None:
            return 1.0
        if t < self.onset:
            return None
        if self.rate is None:
            return 1.0
        return 1.0 - np.exp(-self.rate * (t - self.onset))


@dataclass
class Variant:
    name: str
    observer_type: type
    observer_config: GainConfig
    controller_type: type
    controller_config: GainConfig
    q_hat0: np.ndarray | None
    qd_hat0: np.ndarray


@dataclass
class Scenario:
    """A validated, compiled scenario."""

    path: Path
    spec: ScenarioSpec
    model_path: Path
    model: mujoco.MjModel
    n_joints: int
    timestep: float
    substeps: int
    q0: np.ndarray
    qd0: np.ndarray
    reference: expressions.TimeFunctions
    terms: list[CompiledTerm]
    variants: list[Variant]

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def measures_velocity(self) -> bool:
        """Whether the controller side may read the tachometers."""
        return "velocity" in self.spec.robot.sensors

    @property
    def fault_onsets(self) -> list[float]:
        return sorted({term.onset for term in self.terms if term.kind == "fault" and term.onset is not None})

    @property
    def joint_fault_onsets(self) -> np.ndarray:
        """Per joint, the earliest onset of a fault term acting on it; NaN for a healthy joint."""
        onsets = np.full(self.n_joints, np.inf)
        for term in self.terms:
            if term.kind == "fault" and term.onset is not None:
                onsets[term.joints] = np.minimum(onsets[term.joints], term.onset)
        onsets[np.isinf(onsets)] = np.nan
        return onsets

    @property
    def output_path(self) -> Path:
        return Path(self.spec.output or f"recordings/{self.spec.name}.rrd")


# ----------------------------------------------------------------------------------------------- loading


class _UniqueKeyLoader(yaml.SafeLoader):
    """safe_load that rejects duplicate keys instead of silently keeping the last one."""


def _construct_mapping(loader: yaml.SafeLoader, node: yaml.MappingNode, deep: bool = False) -> dict:
    seen = set()
    for key_node, _ in node.value:
        if key_node.tag == "tag:yaml.org,2002:merge":  # "<<: *anchor": merged keys may be overridden
            continue
        key = loader.construct_object(key_node, deep=deep)
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f"duplicate key {key!r}", key_node.start_mark
            )
        seen.add(key)
    return loader.construct_mapping(node, deep)


_UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)


def load_scenario(
    path: str | Path, overrides: list[str] = (), duration: float | None = None, variants: list[str] = ()
) -> Scenario:
    """Read, validate and compile a scenario file.

    Args:
        path: the YAML file.
        overrides: ``key.path=value`` strings (the command line's ``--set``), applied before validation.
        duration: overrides ``duration``.
        variants: keep only these variants (all when empty).

    Raises:
        InputError: on any problem, naming the file and the field.
    """
    path = Path(path)
    file = str(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = "not UTF-8 text" if isinstance(exc, UnicodeDecodeError) else exc.strerror or str(exc)
        raise InputError(file, "", f"cannot read the file: {reason}") from None
    try:
        raw = yaml.load(text, Loader=_UniqueKeyLoader)  # noqa: S506 - a SafeLoader subclass
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise InputError(file, where, f"invalid YAML: {problem}") from None
    if not isinstance(raw, dict):
        raise InputError(file, "", "a scenario must be a YAML mapping")
    raw = _unshared(raw)
    for item in overrides:
        _apply_override(raw, item, file)
    if duration is not None:
        raw["duration"] = duration
    try:
        spec = ScenarioSpec.model_validate(raw)
    except ValidationError as exc:
        raise _input_error(file, "", exc) from None
    if variants:
        unknown = [v for v in variants if v not in spec.variants]
        if unknown:
            raise InputError(file, "variants", f"unknown variant {unknown[0]!r} (known: {', '.join(spec.variants)})")
        spec.variants = {name: spec.variants[name] for name in variants}
    return _compile(path, spec)


def _unshared(node: Any) -> Any:
    """A copy in which no two places share an object: YAML aliases (``*name``) load as one shared dict, and an
    override of one variant must not change the others."""
    if isinstance(node, dict):
        return {key: _unshared(value) for key, value in node.items()}
    if isinstance(node, list):
        return [_unshared(value) for value in node]
    return node


def _apply_override(raw: dict, item: str, file: str) -> None:
    key, sep, value_text = item.partition("=")
    key = key.strip()
    if not sep or not key:
        raise InputError(file, f"--set {item}", "expected key.path=value")
    try:
        value = yaml.safe_load(value_text)
    except yaml.YAMLError:
        raise InputError(file, key, f"--set value {value_text!r} is not a valid YAML scalar") from None
    parts = key.split(".")
    node: Any = raw
    for depth, part in enumerate(parts):
        last = depth == len(parts) - 1
        if isinstance(node, list):
            if not part.isdigit() or int(part) >= len(node):
                raise InputError(file, key, f"--set: {part!r} is not an index of the list at this level")
            index: Any = int(part)
        elif isinstance(node, dict):
            index = part
            if not last and index not in node:
                node[index] = {}
        else:
            raise InputError(file, key, f"--set: {'.'.join(parts[:depth])!r} is not a mapping or list")
        if last:
            node[index] = value
        else:
            node = node[index]


def _is_union_tag(part: Any) -> bool:
    """pydantic puts the union member it tried into an error's location ('constrained-float',
    'list[constrained-float]', 'str', 'function-after[...]'); those are not fields a user can write."""
    return isinstance(part, str) and ("[" in part or "-" in part or part in {"str", "int", "float", "bool", "list"})


def _input_error(file: str, prefix: str, exc: ValidationError) -> InputError:
    # Group the errors by the value they concern (the location up to the first union tag): a value that fits
    # no member of a union gives one error per member, and counts as one problem.
    groups: dict[tuple, list[dict]] = {}
    for error in exc.errors():
        loc = error["loc"]
        cut = next((i for i, part in enumerate(loc) if _is_union_tag(part)), len(loc))
        groups.setdefault(tuple(loc[:cut]), []).append(error)
    first_group = next(iter(groups.values()))
    # The member error that got furthest into the value (e.g. a bad list element) says the most.
    best = max(first_group, key=lambda error: len(error["loc"]))
    loc = ".".join(str(part) for part in best["loc"] if not _is_union_tag(part))
    field = ".".join(p for p in (prefix, loc) if p)
    message = best["msg"].removeprefix("Value error, ")
    if best["type"] == "extra_forbidden":
        message = "unknown key"
    elif best["type"] == "missing":
        message = "required field is missing"
    if len(groups) > 1:
        message += f" (and {len(groups) - 1} more problem{'s' if len(groups) > 2 else ''})"
    return InputError(file, field, message)


# -------------------------------------------------------------------------------------------- compiling


def _compile(path: Path, spec: ScenarioSpec) -> Scenario:
    file = str(path)
    model_path = (path.parent / spec.robot.model).resolve()
    if not model_path.is_file():
        raise InputError(file, "robot.model", f"model file {spec.robot.model!r} not found")
    model = _load_model(model_path, spec.robot, file)
    n = model.nv
    if model.nq != n or model.nu != n:
        raise InputError(file, "robot.model", f"needs one hinge/slide joint and one actuator per DOF (nq={model.nq}, nv={n}, nu={model.nu})")
    if position_sensor_addresses(model) is None:
        raise InputError(file, "robot.model", "needs one jointpos sensor per joint")
    if "velocity" in spec.robot.sensors and velocity_sensor_addresses(model) is None:
        raise InputError(file, "robot.sensors", "velocity sensing needs one jointvel sensor per joint in the model")

    timestep = spec.timestep if spec.timestep is not None else spec.control_dt
    ratio = spec.control_dt / timestep
    substeps = round(ratio)
    if substeps < 1 or abs(ratio - substeps) > 1e-9 * max(ratio, 1.0):
        raise InputError(file, "control_dt", f"{spec.control_dt} is not an integer multiple of the timestep {timestep}")
    if spec.duration < spec.control_dt:
        raise InputError(file, "duration", f"{spec.duration} is shorter than one control period")

    def vector(values: list[float] | None, field: str, default: float | None = 0.0) -> np.ndarray | None:
        if values is None:
            return None if default is None else np.full(n, default)
        if len(values) != n:
            raise InputError(file, field, f"has {len(values)} values, the robot has {n} joints")
        return np.asarray(values, dtype=float)

    q0 = vector(spec.initial.q, "initial.q")
    qd0 = vector(spec.initial.qd, "initial.qd")

    if len(spec.reference) != n:
        raise InputError(file, "reference", f"has {len(spec.reference)} values, the robot has {n} joints")
    reference = expressions.TimeFunctions(
        [_parse(text, ["t"], file, f"reference.{i}") for i, text in enumerate(spec.reference)]
    )

    state_vars = expressions.state_variables(n)
    terms = []
    for index, term in enumerate(spec.terms):
        field = f"terms.{index}"
        if len(term.value) != n:
            raise InputError(file, f"{field}.value", f"has {len(term.value)} values, the robot has {n} joints")
        exprs = [_parse(text, state_vars, file, f"{field}.value.{j}") for j, text in enumerate(term.value)]
        rate = None
        if term.rate is not None:
            if term.onset is None:
                raise InputError(file, f"{field}.rate", "an evolution rate needs an onset")
            rate = vector(term.rate if isinstance(term.rate, list) else [term.rate] * n, f"{field}.rate")
        terms.append(
            CompiledTerm(
                name=term.name or f"{term.kind}{index}",
                kind=term.kind,
                space=term.space,
                sign=float(term.sign),
                function=expressions.StateFunction(exprs, n),
                onset=term.onset,
                rate=rate,
                joints=np.array([expr.is_zero is not True for expr in exprs]),
            )
        )

    sensors = set(spec.robot.sensors) | {"position"}
    variants = []
    for name, variant in spec.variants.items():
        field = f"variants.{name}"
        observer_type, observer_config = _plugin(file, f"{field}.observer", variant.observer, observer_types(), "observer", n)
        controller_type, controller_config = _plugin(file, f"{field}.controller", variant.controller, controller_types(), "controller", n)
        for kind, plugin in (("observer", observer_type), ("controller", controller_type)):
            missing = set(plugin.requires) - sensors
            if missing:
                raise InputError(file, f"{field}.{kind}.type", f"{plugin.name} needs {', '.join(sorted(missing))} sensors, robot.sensors has {sorted(sensors)}")
        initial = variant.observer_initial or spec.observer_initial
        initial_field = f"{field}.observer_initial" if variant.observer_initial else "observer_initial"
        variants.append(
            Variant(
                name=name,
                observer_type=observer_type,
                observer_config=observer_config,
                controller_type=controller_type,
                controller_config=controller_config,
                q_hat0=vector(initial.q_hat, f"{initial_field}.q_hat", default=None),
                qd_hat0=vector(initial.qd_hat, f"{initial_field}.qd_hat"),
            )
        )

    model.opt.timestep = timestep
    return Scenario(
        path=path,
        spec=spec,
        model_path=model_path,
        model=model,
        n_joints=n,
        timestep=timestep,
        substeps=substeps,
        q0=q0,
        qd0=qd0,
        reference=reference,
        terms=terms,
        variants=variants,
    )


def _load_model(model_path: Path, robot: RobotSpec, file: str) -> mujoco.MjModel:
    """The robot's MjModel: a URDF through ftc_mj.urdf, anything else as MJCF."""
    if urdf.is_urdf(model_path):
        return urdf.load_model(model_path, lock=robot.lock, torque_limits=robot.torque_limits,
                               armature=robot.armature, source=file, field="robot")
    for option in UrdfOptions.model_fields:
        if getattr(robot, option) not in (None, {}):
            raise InputError(file, f"robot.{option}", "is for URDF models only; an MJCF model sets it in its file")
    try:
        return mujoco.MjModel.from_xml_path(str(model_path))
    except ValueError as exc:
        first_line = str(exc).strip().splitlines()[0] if str(exc).strip() else "cannot compile"
        raise InputError(file, "robot.model", f"MuJoCo cannot load {robot.model!r}: {first_line}") from None


def _parse(text: ExpressionText, variables: list[str], file: str, field: str):
    try:
        return expressions.parse(text, variables)
    except expressions.ExpressionError as exc:
        raise InputError(file, field, str(exc)) from None


def _plugin(file: str, field: str, method: MethodSpec, known: Mapping[str, type], kind: str, n: int):
    if method.type not in known:
        raise InputError(file, f"{field}.type", f"unknown {kind} {method.type!r} (known: {', '.join(sorted(known))})")
    try:
        plugin = known[method.type]
    except PluginError as exc:
        raise InputError(file, f"{field}.type", str(exc)) from None
    try:
        config = plugin.Config.model_validate(method.gains, context={"n_joints": n})
    except ValidationError as exc:
        raise _input_error(file, f"{field}.gains", exc) from None
    return plugin, config


def position_sensor_addresses(model: mujoco.MjModel) -> np.ndarray | None:
    """sensordata addresses of the jointpos sensors, in joint order, or None if a joint has none."""
    return _joint_sensor_addresses(model, mujoco.mjtSensor.mjSENS_JOINTPOS)


def velocity_sensor_addresses(model: mujoco.MjModel) -> np.ndarray | None:
    """sensordata addresses of the jointvel sensors (tachometers), in joint order, or None if a joint has none."""
    return _joint_sensor_addresses(model, mujoco.mjtSensor.mjSENS_JOINTVEL)


def _joint_sensor_addresses(model: mujoco.MjModel, sensor_type: mujoco.mjtSensor) -> np.ndarray | None:
    addresses = {}
    for sensor in range(model.nsensor):
        if model.sensor_type[sensor] == sensor_type:
            joint = model.sensor_objid[sensor]
            addresses[int(model.jnt_dofadr[joint])] = int(model.sensor_adr[sensor])
    if sorted(addresses) != list(range(model.nv)):
        return None
    return np.array([addresses[dof] for dof in range(model.nv)])

