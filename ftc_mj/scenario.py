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
for t >= Tf (abrupt, i.e. a step, when ``rate`` is absent) and is zero before; or by any ``profile`` of
:mod:`ftc_mj.profiles`.

The sections ``actuator_faults``, ``sensors`` and ``diagnosis`` are defined in the modules of their concepts
(:mod:`ftc_mj.faults`, :mod:`ftc_mj.sensors`, :mod:`ftc_mj.diagnosis`) and compiled here, where joint names,
vector lengths, expressions and the time grid are known.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Literal

import mujoco
import numpy as np
import yaml
from pydantic import Field, ValidationError, field_validator

from ftc_mj import expressions, urdf
from ftc_mj.diagnosis import Diagnoser, DiagnosisSpec
from ftc_mj.errors import InputError
from ftc_mj.faults import ActuatorFault, ActuatorFaultSpec
from ftc_mj.gains import GainConfig
from ftc_mj.profiles import Profile, ProfileSpec
from ftc_mj.registry import PluginError, controller_types, observer_types
from ftc_mj.schema import ExpressionText, FiniteFloat, JointSelection, NonNegativeFloat, PositiveFloat
from ftc_mj.schema import Strict as _Strict
from ftc_mj.sensors import Channel, ChannelSpec, EncoderSpec, SensorsSpec

REPO_ROOT = Path(__file__).resolve().parents[1]


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
    #: Any time profile of :mod:`ftc_mj.profiles` (instead of ``onset`` and ``rate``).
    profile: ProfileSpec | None = None
    name: str | None = None


class MethodSpec(_Strict):
    type: str
    gains: dict[str, Any] = {}


def _plain_names(named: dict[str, Any], what: str) -> dict[str, Any]:
    """Names of variants and monitors: letters, digits, '_' and '-' (a monitor's result is "variant.monitor")."""
    for name in named:
        if not name or not all(c.isalnum() or c in "_-" for c in name):
            raise ValueError(f"{what} name {name!r} may use only letters, digits, '_' and '-'")
    return named


#: Which velocity the controller uses (in e_dot and in Psi of its equivalent control): the tachometer reading
#: or the observer's estimate x2_hat.
ControllerVelocity = Literal["measured", "estimated"]


class VariantSpec(_Strict):
    observer: MethodSpec
    controller: MethodSpec
    observer_initial: ObserverInitial | None = None
    #: Overrides the scenario's ``controller_velocity`` for this variant.
    controller_velocity: ControllerVelocity | None = None
    #: Further observers that run beside ``observer`` on the same measurements and commands but feed nothing:
    #: an open-loop comparison of estimators on one closed-loop trajectory. Each is reported as the variant
    #: ``<variant>.<name>`` (its tracking metrics are the host's).
    monitors: dict[str, MethodSpec] = {}

    @field_validator("monitors")
    @classmethod
    def _monitor_names(cls, monitors: dict[str, MethodSpec]) -> dict[str, MethodSpec]:
        return _plain_names(monitors, "monitor")


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
    #: fault_peak_error looks at [onset, onset + fault_window) after a joint's fault onset [s].
    fault_window: PositiveFloat = 2.0
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
    #: Every random element of a run derives from it (:mod:`ftc_mj.randomness`).
    seed: Annotated[int, Field(ge=0)] = 0
    duration: PositiveFloat
    control_dt: PositiveFloat = 1e-3
    #: Physics timestep; control_dt must be an integer multiple of it. Defaults to control_dt.
    timestep: PositiveFloat | None = None
    initial: InitialState
    observer_initial: ObserverInitial = ObserverInitial()
    #: The velocity the controllers use: ``measured`` (needs ``robot.sensors`` to list ``velocity``) or
    #: ``estimated`` (the observer's x2_hat). Default: measured with tachometers, estimated without.
    controller_velocity: ControllerVelocity | None = None
    reference: list[ExpressionText]
    terms: list[TermSpec] = []
    actuator_faults: list[ActuatorFaultSpec] = []
    sensors: SensorsSpec = SensorsSpec()
    nominal: NominalSpec = NominalSpec()
    variants: Annotated[dict[str, VariantSpec], Field(min_length=1)]
    metrics: MetricsSpec
    diagnosis: DiagnosisSpec | None = None
    divergence: DivergenceSpec = DivergenceSpec()
    #: Recording path, relative to the working directory.
    output: str | None = None

    @field_validator("variants")
    @classmethod
    def _variant_names(cls, variants: dict[str, VariantSpec]) -> dict[str, VariantSpec]:
        return _plain_names(variants, "variant")


@dataclass
class CompiledTerm:
    """A plant term ready for the loop."""

    name: str
    kind: str
    space: str
    sign: float
    function: expressions.StateFunction
    #: None: always on.
    time_profile: Profile | None
    #: Joints whose value is not identically zero (a fault "on joint 1" has zeros elsewhere).
    joints: np.ndarray

    @property
    def onset(self) -> float | None:
        return None if self.time_profile is None else self.time_profile.onset

    @property
    def rate(self) -> np.ndarray | None:
        """Per joint, for an incipient profile."""
        return None if self.time_profile is None else self.time_profile.rate

    def profile(self, t: float) -> np.ndarray | float | None:
        """The time profile per joint, e.g. omega(t - Tf) of (5.1): None while off (before the onset), then
        1 - exp(-rate (t - Tf)), or 1 when abrupt (see :class:`~ftc_mj.profiles.Profile`)."""
        return 1.0 if self.time_profile is None else self.time_profile.weight(t)


@dataclass
class Monitor:
    """An observer that runs beside a variant's own and feeds nothing (``variants.NAME.monitors``)."""

    name: str
    observer_type: type
    observer_config: GainConfig


@dataclass
class Variant:
    name: str
    observer_type: type
    observer_config: GainConfig
    controller_type: type
    controller_config: GainConfig
    q_hat0: np.ndarray | None
    qd_hat0: np.ndarray
    monitors: list[Monitor] = field(default_factory=list)
    #: "measured" (the tachometer reading) or "estimated" (the observer's x2_hat): the controller's velocity.
    controller_velocity: str = "estimated"


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
    actuator_faults: list[ActuatorFault] = field(default_factory=list)
    #: Sensor effects on the encoders and the tachometers; None: perfect.
    position_sensor: Channel | None = None
    velocity_sensor: Channel | None = None
    diagnoser: Diagnoser | None = None

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def times(self) -> np.ndarray:
        """The control instants k * control_dt of a run."""
        return time_grid(self.spec.duration, self.spec.control_dt)

    @property
    def measures_velocity(self) -> bool:
        """Whether the controller side may read the tachometers."""
        return "velocity" in self.spec.robot.sensors

    def _faults(self) -> list[tuple[float, np.ndarray]]:
        """(onset, joint mask) of every fault: fault terms with an onset and actuator faults. Sensor effects
        are not faults for the detection metrics."""
        faults = [(term.onset, term.joints) for term in self.terms if term.kind == "fault" and term.onset is not None]
        return faults + [(fault.profile.onset, fault.joints) for fault in self.actuator_faults]

    @property
    def fault_onsets(self) -> list[float]:
        return sorted({onset for onset, _ in self._faults()})

    @property
    def joint_fault_onsets(self) -> np.ndarray:
        """Per joint, the earliest onset of a fault acting on it; NaN for a healthy joint."""
        onsets = np.full(self.n_joints, np.inf)
        for onset, joints in self._faults():
            onsets[joints] = np.minimum(onsets[joints], onset)
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
        terms.append(
            CompiledTerm(
                name=term.name or f"{term.kind}{index}",
                kind=term.kind,
                space=term.space,
                sign=float(term.sign),
                function=expressions.StateFunction(exprs, n),
                time_profile=_term_profile(term, file, field, n),
                joints=np.array([expr.is_zero is not True for expr in exprs]),
            )
        )
    times = time_grid(spec.duration, spec.control_dt)
    actuator_faults = [_actuator_fault(fault, file, f"actuator_faults.{index}", model, times)
                       for index, fault in enumerate(spec.actuator_faults)]
    position_sensor = _channel(spec.sensors.position, file, "sensors.position", model)
    if spec.sensors.velocity is not None and "velocity" not in spec.robot.sensors:
        raise InputError(file, "sensors.velocity", "the robot has no velocity sensors (robot.sensors)")
    velocity_sensor = _channel(spec.sensors.velocity, file, "sensors.velocity", model)

    sensors = set(spec.robot.sensors) | {"position"}
    variants = []
    for name, variant in spec.variants.items():
        field = f"variants.{name}"
        observer_type, observer_config = _plugin(file, f"{field}.observer", variant.observer, observer_types(), "observer", n)
        controller_type, controller_config = _plugin(file, f"{field}.controller", variant.controller, controller_types(), "controller", n)
        monitors = [
            Monitor(monitor, *_plugin(file, f"{field}.monitors.{monitor}", method, observer_types(), "observer", n))
            for monitor, method in variant.monitors.items()
        ]
        plugins = [("observer", observer_type), ("controller", controller_type)]
        plugins += [(f"monitors.{m.name}", m.observer_type) for m in monitors]
        for kind, plugin in plugins:
            missing = set(plugin.requires) - sensors
            if missing:
                raise InputError(file, f"{field}.{kind}.type", f"{plugin.name} needs {', '.join(sorted(missing))} sensors, robot.sensors has {sorted(sensors)}")
        velocity = variant.controller_velocity or spec.controller_velocity
        if velocity is None:
            velocity = "measured" if "velocity" in sensors else "estimated"
        if velocity == "measured" and "velocity" not in sensors:
            velocity_field = f"{field}.controller_velocity" if variant.controller_velocity else "controller_velocity"
            raise InputError(file, velocity_field, "measured needs velocity sensors (robot.sensors)")
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
                monitors=monitors,
                controller_velocity=velocity,
            )
        )

    model.opt.timestep = timestep
    scenario = Scenario(
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
        actuator_faults=actuator_faults,
        position_sensor=position_sensor,
        velocity_sensor=velocity_sensor,
    )
    if spec.diagnosis is not None:
        scenario.diagnoser = _diagnoser(spec.diagnosis, spec, file, n, scenario.fault_onsets)
    return scenario


def time_grid(duration: float, control_dt: float) -> np.ndarray:
    """The control instants k * control_dt of a run of ``duration``."""
    return np.arange(int(round(duration / control_dt))) * control_dt


def _per_joint(values: float | list[float], n: int, file: str, field: str) -> np.ndarray:
    """One number for every joint, or a list with one per joint."""
    if not isinstance(values, list):
        return np.full(n, float(values))
    if len(values) != n:
        raise InputError(file, field, f"has {len(values)} values, the robot has {n} joints")
    return np.asarray(values, dtype=float)


def _joint_indices(selection: JointSelection, model: mujoco.MjModel, file: str, field: str) -> list[int]:
    """DOF indices of a joint selection (1-based numbers or MJCF names), in the order given; all when None."""
    n = model.nv
    if selection is None:
        return list(range(n))
    names = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j): int(model.jnt_dofadr[j]) for j in range(model.njnt)}
    indices: list[int] = []
    for position, item in enumerate(selection):
        if isinstance(item, str):
            if item not in names:
                raise InputError(file, f"{field}.{position}", f"unknown joint {item!r} (joints: {', '.join(name for name in names if name)})")
            index = names[item]
        elif item > n:
            raise InputError(file, f"{field}.{position}", f"joint {item} does not exist, the robot has {n} joints")
        else:
            index = item - 1
        if index in indices:
            raise InputError(file, f"{field}.{position}", f"joint {item!r} is listed twice")
        indices.append(index)
    return indices


def _joint_mask(indices: list[int], n: int) -> np.ndarray:
    mask = np.zeros(n, dtype=bool)
    mask[indices] = True
    return mask


def _profile(spec: ProfileSpec, file: str, field: str, n: int) -> Profile:
    rate = getattr(spec, "rate", None)
    if rate is not None:
        rate = _per_joint(rate, n, file, f"{field}.rate")
    return Profile.from_spec(spec, rate)


def _term_profile(term: TermSpec, file: str, field: str, n: int) -> Profile | None:
    """A plant term's profile: ``profile``, or the dissertation's ``onset`` with an optional ``rate``."""
    if term.profile is not None:
        if term.onset is not None or term.rate is not None:
            raise InputError(file, f"{field}.profile", "give either a profile or onset and rate, not both")
        return _profile(term.profile, file, f"{field}.profile", n)
    if term.rate is not None and term.onset is None:
        raise InputError(file, f"{field}.rate", "an evolution rate needs an onset")
    if term.onset is None:
        return None
    rate = None if term.rate is None else _per_joint(term.rate, n, file, f"{field}.rate")
    return Profile("abrupt" if rate is None else "incipient", onset=term.onset, rate=rate)


def _actuator_fault(spec: ActuatorFaultSpec, file: str, field: str, model: mujoco.MjModel,
                    times: np.ndarray) -> ActuatorFault:
    """A fault with its time-dependent parameter (alpha, offset) tabulated on the run's time grid."""
    n = model.nv
    indices = _joint_indices(spec.joints, model, file, f"{field}.joints")
    parameter = None
    if spec.kind in ("loss_of_effectiveness", "bias"):
        key = "alpha" if spec.kind == "loss_of_effectiveness" else "offset"
        parameter = _time_table(getattr(spec, key), indices, n, times, file, f"{field}.{key}")
        if key == "alpha" and ((parameter < 0) | (parameter > 1)).any():
            row = int(np.flatnonzero(((parameter < 0) | (parameter > 1)).any(axis=1))[0])
            raise InputError(file, f"{field}.alpha", f"must stay within [0, 1]; it is outside at t = {times[row]:g}")
    elif spec.kind == "saturation":
        parameter = np.full(n, np.inf)
        parameter[indices] = _per_selected(spec.limit, indices, file, f"{field}.limit")
    return ActuatorFault(name=spec.name or f"{spec.kind}{field.rsplit('.', 1)[-1]}", kind=spec.kind,
                         joints=_joint_mask(indices, n), parameter=parameter,
                         profile=_profile(spec.profile, file, f"{field}.profile", n))


def _per_selected(values: Any, indices: list[int], file: str, field: str) -> list:
    """One value for all selected joints, or a list with one per selected joint."""
    if not isinstance(values, list):
        return [values] * len(indices)
    if len(values) != len(indices):
        raise InputError(file, field, f"has {len(values)} values for {len(indices)} joints")
    return values


def _time_table(values: ExpressionText | list[ExpressionText], indices: list[int], n: int, times: np.ndarray,
                file: str, field: str) -> np.ndarray:
    """Expressions of t for the selected joints, evaluated on the time grid: ``(N, n)``, 0 elsewhere."""
    texts = _per_selected(values, indices, file, field)
    single = not isinstance(values, list)
    exprs = [_parse(text, ["t"], file, field if single else f"{field}.{i}") for i, text in enumerate(texts)]
    table = np.zeros((len(times), n))
    with np.errstate(all="ignore"):
        table[:, indices] = expressions.TimeFunctions(exprs).evaluate(times)[0]
    if not np.isfinite(table).all():
        row = int(np.flatnonzero(~np.isfinite(table).all(axis=1))[0])
        raise InputError(file, field, f"is not a finite number at t = {times[row]:g}")
    return table


def _channel(spec: ChannelSpec | None, file: str, field: str, model: mujoco.MjModel) -> Channel | None:
    if spec is None:
        return None
    n = model.nv
    resolution = np.zeros(n)
    if spec.resolution is not None:
        resolution = _per_joint(spec.resolution, n, file, f"{field}.resolution")
    if isinstance(spec, EncoderSpec) and spec.counts_per_rev is not None:
        resolution = 2.0 * np.pi / _per_joint(spec.counts_per_rev, n, file, f"{field}.counts_per_rev")
    stuck = spec.stuck
    return Channel(
        resolution=resolution,
        noise_std=_per_joint(spec.noise_std, n, file, f"{field}.noise_std"),
        bias=_per_joint(spec.bias, n, file, f"{field}.bias"),
        drift_rate=_per_joint(spec.drift_rate, n, file, f"{field}.drift_rate"),
        delay_samples=spec.delay_samples,
        stuck_onset=None if stuck is None else stuck.onset,
        stuck_end=None if stuck is None else stuck.end,
        stuck_joints=None if stuck is None else _joint_mask(
            _joint_indices(stuck.joints, model, file, f"{field}.stuck.joints"), n),
    )


def _diagnoser(spec: DiagnosisSpec, scenario: ScenarioSpec, file: str, n: int, fault_onsets: list[float]) -> Diagnoser:
    dt = scenario.control_dt
    bound = None
    if spec.threshold.bound is not None:
        texts = spec.threshold.bound
        if len(texts) != n:
            raise InputError(file, "diagnosis.threshold.bound", f"has {len(texts)} values, the robot has {n} joints")
        variables = expressions.state_variables(n)
        bound = expressions.StateFunction(
            [_parse(text, variables, file, f"diagnosis.threshold.bound.{j}") for j, text in enumerate(texts)], n)
    baseline = None
    if spec.baseline is not None:
        baseline = (spec.baseline.start, spec.baseline.end)
        if fault_onsets and spec.baseline.end > fault_onsets[0]:
            raise InputError(file, "diagnosis.baseline.end",
                             f"the baseline must be fault-free: it ends after the first fault onset ({fault_onsets[0]:g} s)")
    # Persistence time in whole samples, rounded up (a float just above an integer is that integer).
    persistence = spec.persistence.samples or math.ceil(spec.persistence.time / dt - 1e-9)
    start = spec.start
    if start is None:
        start = spec.baseline.end if spec.baseline is not None else scenario.metrics.estimation_window_start
    return Diagnoser(space=spec.space, dt=dt, start=start, k=spec.threshold.k, persistence=max(1, persistence),
                     fixed=_per_joint(spec.threshold.fixed, n, file, "diagnosis.threshold.fixed"), baseline=baseline,
                     filter_time_constant=spec.filter_time_constant, bound=bound)


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

