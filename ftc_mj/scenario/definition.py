"""A scenario: the top-level schema (:class:`ScenarioSpec`), what it compiles to (:class:`Scenario`, its
:class:`Variant` and :class:`Monitor` entries), and :func:`compile_scenario`, which checks and compiles a
validated spec once the robot is known.

Each section's schema and compile function live beside its concept; this module only assembles them:

* ``robot``: :mod:`ftc_mj.robot.model`; ``nominal``: :mod:`ftc_mj.robot.nominal`;
* ``terms``: :mod:`ftc_mj.effects.terms` (sign convention and profiles there); ``actuator_faults``:
  :mod:`ftc_mj.effects.faults`; ``sensors``: :mod:`ftc_mj.effects.sensors`; ``profile``:
  :mod:`ftc_mj.effects.profiles`;
* ``variants.*.observer`` / ``.controller`` / ``.monitors``: :mod:`ftc_mj.methods.registry`;
* ``metrics``: :mod:`ftc_mj.analysis.metrics`; ``diagnosis``: :mod:`ftc_mj.analysis.diagnosis`;
* ``figures``: :mod:`ftc_mj.outputs.layout`;
* ``log`` (a recorded trajectory instead of the simulated robot): :mod:`ftc_mj.logs.schema`, compiled by
  :func:`ftc_mj.logs.trajectory.compile_log`.

Reading a file (YAML, ``--set``) is :mod:`ftc_mj.scenario.loading`.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Literal

import mujoco
import numpy as np
import sympy
from pydantic import AfterValidator, Field, StrictBool, field_validator, model_validator

from ftc_mj.analysis.diagnosis import Diagnoser, DiagnosisSpec, compile_diagnoser
from ftc_mj.analysis.metrics import MetricsSpec
from ftc_mj.config import expressions
from ftc_mj.config.errors import InputError
from ftc_mj.config.types import (
    ExpressionText,
    FiniteFloat,
    PositiveFloat,
    Strict,
    parse_expression,
    per_joint,
)
from ftc_mj.effects.faults import (
    ActuatorFault,
    ActuatorFaultSpec,
    compile_actuator_fault,
)
from ftc_mj.effects.sensors import Channel, SensorsSpec, compile_channel
from ftc_mj.effects.terms import CompiledTerm, TermSpec, compile_terms, terms_function
from ftc_mj.logs.controller import LogController
from ftc_mj.logs.schema import LogSpec
from ftc_mj.logs.trajectory import Log, compile_log, joint_names
from ftc_mj.methods.gains import GainConfig
from ftc_mj.methods.registry import (
    MethodSpec,
    compile_method,
    controller_types,
    observer_types,
)
from ftc_mj.outputs.layout import (
    Figure,
    FigureSpec,
    check_figure_names,
    compile_figures,
)
from ftc_mj.outputs.palette import parse_colour
from ftc_mj.robot.check import torque_limits
from ftc_mj.robot.model import PlantSpec, RobotSpec, load_robot
from ftc_mj.robot.nominal import NominalSpec


class InitialState(Strict):
    q: list[FiniteFloat] = Field(description="Joint positions at t = 0, one per joint [rad] (required).")
    qd: list[FiniteFloat] | None = Field(None, description="Joint velocities at t = 0 [rad/s]; default: zero.")


class ObserverInitial(Strict):
    q_hat: list[FiniteFloat] | None = Field(None,
        description="Initial position estimate; defaults to the first measurement.")
    qd_hat: list[FiniteFloat] | None = Field(None, description="Initial velocity estimate; defaults to zero.")


def _plain_names(named: dict[str, Any], what: str) -> dict[str, Any]:
    """Names of variants and monitors: letters, digits, '_' and '-' (a monitor's result is "variant.monitor")."""
    for name in named:
        if not name or not all(c.isalnum() or c in "_-" for c in name):
            raise ValueError(f"{what} name {name!r} may use only letters, digits, '_' and '-'")
    return named


#: Which velocity the controller uses (in e_dot and in Psi of its equivalent control): the tachometer reading
#: or the observer's estimate x2_hat.
ControllerVelocity = Literal["measured", "estimated"]


class VariantSpec(Strict):
    observer: MethodSpec = Field(description="The observer: ``type`` (a registered observer) and its ``gains`` "
                                 "(required; gains default to the method's own).")
    controller: MethodSpec | None = Field(None,
        description="Required, except with a ``log`` section, where it is refused: the log's torque is the command.")
    observer_initial: ObserverInitial | None = Field(None, description="This variant's initial estimate; "
                                                     "default: the scenario's ``observer_initial``.")
    controller_velocity: ControllerVelocity | None = Field(None,
        description="Overrides the scenario's ``controller_velocity`` for this variant.")
    monitors: dict[str, MethodSpec] = Field({},
        description="Further observers that run beside ``observer`` on the same measurements and commands but feed nothing: an open-loop comparison of estimators on one closed-loop trajectory. Each is reported as the variant ``<variant>.<name>`` (its tracking metrics are the host's).")
    colour: Annotated[str, AfterValidator(parse_colour)] | None = Field(None,
        description="The variant's colour in every figure and the viewer: a palette name (red, blue, ...) or \"#rrggbb\". Default: the first palette colour free after the earlier variants, in the file's order (:func:`ftc_mj.outputs.palette.declared_colours`).")

    @field_validator("monitors")
    @classmethod
    def _monitor_names(cls, monitors: dict[str, MethodSpec]) -> dict[str, MethodSpec]:
        return _plain_names(monitors, "monitor")


class DivergenceSpec(Strict):
    max_position: PositiveFloat = Field(100.0, description="A row whose |q| exceeds this stops as diverged [rad].")
    max_velocity: PositiveFloat = Field(1000.0, description="A row whose |qd| exceeds this stops as diverged "
                                        "[rad/s].")


#: The largest seed: NumPy keeps a batch's seeds as int64 (``seed + k`` for member k).
MAX_SEED = 2**63 - 1
#: A run's seed: an integer from 0 to :data:`MAX_SEED`.
Seed = Annotated[int, Field(ge=0, le=MAX_SEED)]


class ScenarioSpec(Strict):
    name: Annotated[str, Field(min_length=1, pattern=r"^[A-Za-z0-9_.-]+$")] = Field(
        description="The scenario's name: letters, digits, '_', '.' and '-' (required).")
    description: str = Field("", description="Free text shown by ``--help``-like listings; default empty.")
    robot: RobotSpec = Field(description="The robot: an MJCF or URDF ``model`` path or a ``builtin`` name, its "
                             "joints and sensors (required).")
    seed: Seed = Field(0,
        description="Every random element of a run derives from it (:mod:`ftc_mj.effects.randomness`).")
    duration: PositiveFloat | None = Field(None,
        description="Required, except with a ``log`` section (default: the whole log).")
    control_dt: PositiveFloat = Field(1e-3, description="Control period [s]: the observers and controllers "
                                      "run once per period (zero-order hold).")
    timestep: PositiveFloat | None = Field(None,
        description="Physics timestep; control_dt must be an integer multiple of it. Defaults to control_dt.")
    initial: InitialState | None = Field(None,
        description="Required, except with a ``log`` section, where it is refused (the log's first sample is the start).")
    observer_initial: ObserverInitial = Field(ObserverInitial(), description="The observers' initial "
                                              "estimate; default: the first reading and zero velocity.")
    controller_velocity: ControllerVelocity | None = Field(None,
        description="The velocity the controllers use: ``measured`` (needs ``robot.sensors`` to list ``velocity``) or ``estimated`` (the observer's x2_hat). Default: measured with tachometers, estimated without.")
    reference: list[ExpressionText] | None = Field(None,
        description="Required, except with a ``log`` section, where it is refused (a log has no reference: NaN).")
    terms: list[TermSpec] = Field([], description="Friction, disturbance and fault terms acting on the true "
                                  "robot; default: none.")
    actuator_faults: list[ActuatorFaultSpec] = Field([], description="Faults of what the actuators deliver "
                                                     "(loss of effectiveness, bias, lock...); default: none.")
    faults_after_torque_limit: StrictBool = Field(True,
        description="Whether an actuator fault acts on what the torque-limited motor gives (default: a floating joint gets no torque whatever the command) or on the command, the motor's limit clipping after it (false: a float on a joint commanded beyond its limit then receives the excess with the opposite sign; kept only so that suite v1's runs stay as they were computed).")
    sensors: SensorsSpec = Field(SensorsSpec(), description="Sensor effects (noise, quantisation, faults) of "
                                 "the encoders and tachometers; default: exact readings.")
    nominal: NominalSpec = Field(NominalSpec(), description="The controllers' and observers' model of the "
                                 "robot (mass mismatch); default: the true one.")
    plant: PlantSpec = Field(PlantSpec(), description="The simulated robot's own changes (mass scale); "
                             "default: the model as written.")
    parameters: dict[str, FiniteFloat] = Field({},
        description="Named numbers the terms' expressions may use, e.g. ``fault_scale``; each member of a batch may have its own values (:mod:`ftc_mj.engine.members`).")
    variants: Annotated[dict[str, VariantSpec], Field(min_length=1)] = Field(
        description="The observer-controller pairs run side by side, by name (required, at least one).")
    metrics: MetricsSpec = Field(MetricsSpec(), description="Evaluation windows and tolerances of the metrics; "
                                 "every key has a default.")
    diagnosis: DiagnosisSpec | None = Field(None, description="Fault detection and isolation on the "
                                            "observers' residuals; default: none.")
    divergence: DivergenceSpec = Field(DivergenceSpec(), description="When a row counts as diverged; "
                                       "default: |q| > 100 rad or |qd| > 1000 rad/s.")
    figures: list[FigureSpec] = Field([],
        description="The figures of ``python -m ftc_mj.figures`` and the recording's layout; default: the core quantities.")
    output: str | None = Field(None, description="Recording path, relative to the working directory.")
    log: LogSpec | None = Field(None,
        description="A recorded trajectory replayed instead of the simulated robot (:mod:`ftc_mj.logs.schema`).")

    @model_validator(mode="after")
    def _figures(self) -> "ScenarioSpec":
        check_figure_names(self)
        return self

    @field_validator("parameters")
    @classmethod
    def _parameter_names(cls, parameters: dict[str, float]) -> dict[str, float]:
        for name in parameters:
            if not expressions.is_free_name(name):
                raise ValueError(f"{name!r} cannot name a parameter: use letters, digits and _, not a variable "
                                 "(t, q1, qd1, ...), a constant or a function of the expression language")
        return parameters

    @model_validator(mode="after")
    def _rate_parameters(self) -> "ScenarioSpec":
        """A term's rate given by a parameter: the parameter exists and is positive (a member's own value of it
        is checked by :func:`rate_parameter_problem` too)."""
        for index, term in enumerate(self.terms):
            if isinstance(term.rate, str):
                if term.rate not in self.parameters:
                    raise ValueError(f"terms.{index}.rate: {term.rate!r} is not one of the parameters")
                problem = rate_parameter_problem(self.terms, term.rate, self.parameters[term.rate])
                if problem is not None:
                    raise ValueError(f"parameters.{term.rate} {problem}")
        return self

    @field_validator("variants")
    @classmethod
    def _variant_names(cls, variants: dict[str, VariantSpec]) -> dict[str, VariantSpec]:
        return _plain_names(variants, "variant")


def rate_parameter_problem(terms: list[TermSpec], name: str, value: float) -> str | None:
    """What is wrong with ``value`` for the parameter ``name`` where a term's rate is that parameter (a rate
    must be positive); None when nothing is."""
    for index, term in enumerate(terms):
        if term.rate == name and value <= 0:
            return f"is the rate of terms.{index}: it must be positive, not {value:g}"
    return None


@dataclass
class Monitor:
    """An observer that runs beside a variant's own and feeds nothing (``variants.NAME.monitors``)."""

    name: str
    observer_type: type
    observer_config: GainConfig


@dataclass
class Variant:
    """A compiled variant: its observer, controller and monitors (plugin classes and validated gains), its
    observer's initial estimate and the velocity its controller reads."""

    name: str
    observer_type: type
    observer_config: GainConfig
    controller_type: type
    controller_config: GainConfig
    q_hat0: np.ndarray | None
    qd_hat0: np.ndarray
    monitors: list[Monitor] = field(default_factory=list)
    #: ``measured`` (the tachometer reading) or ``estimated`` (the observer's x2_hat): the controller's velocity.
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
    #: Every term's value as one compiled function (:func:`ftc_mj.effects.terms.terms_function`).
    terms_function: expressions.StateFunction | None = None
    actuator_faults: list[ActuatorFault] = field(default_factory=list)
    #: Sensor effects on the encoders and the tachometers; None: perfect.
    position_sensor: Channel | None = None
    velocity_sensor: Channel | None = None
    diagnoser: Diagnoser | None = None
    #: The figures (the ``figures`` section, or the defaults) for the variants that run.
    figures: list[Figure] = field(default_factory=list)
    #: The replayed log (the ``log`` section), or None: the robot is simulated.
    log: Log | None = None
    #: The files the scenario was read from (the file, its bases, the model file with its includes and meshes,
    #: a replayed log): what no output may replace.
    inputs: tuple[Path, ...] = ()
    #: The file's content after ``--set`` (YAML types), read only through :meth:`written`.
    _written: dict[str, Any] = field(default_factory=dict, repr=False)

    def written(self, *path: str) -> Any:
        """The value at ``path`` (keys) as the file wrote it, after ``--set`` (YAML types), or None where it
        wrote none; the whole document without ``path``. What a campaign's paths are checked against, and
        every variant the file declares (``load_scenario``'s ``variants`` may run fewer)."""
        node: Any = self._written
        for key in path:
            node = node.get(key) if isinstance(node, dict) else None
        return node

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def times(self) -> np.ndarray:
        """The control instants k * control_dt of a run."""
        return time_grid(self.spec.duration, self.spec.control_dt)

    @property
    def measures_velocity(self) -> bool:
        """Whether the controller side may read the tachometers (with a log: whether it holds velocities)."""
        if self.log is not None:
            return self.log.velocity is not None
        return "velocity" in self.spec.robot.sensors

    def _faults(self) -> list[tuple[float, np.ndarray]]:
        """(onset, joint mask) of every fault: fault terms with an onset and actuator faults. Sensor effects
        are not faults for the detection metrics."""
        faults = [(term.onset, term.joints) for term in self.terms if term.kind == "fault" and term.onset is not None]
        return faults + [(fault.profile.onset, fault.joints) for fault in self.actuator_faults]

    @property
    def torque_limits(self) -> np.ndarray | None:
        """Per joint, the |torque| limit at which MuJoCo clips the command (inf: none); None when a log is
        replayed (its torques were never clipped here)."""
        if self.log is not None:
            return None
        return torque_limits(self.model)[: self.n_joints]

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
    def colours(self) -> dict[str, str]:
        """The colour of every variant and monitor the file declares (its ``colour``, else the palette's), the
        same whichever variants run (:func:`ftc_mj.outputs.palette.declared_colours`)."""
        from ftc_mj.outputs.palette import declared_colours

        return declared_colours(self.written("variants") or {})

    @property
    def output_path(self) -> Path:
        return Path(self.spec.output or f"recordings/{self.spec.name}.rrd")


#: At most this many physics steps per control period (a timestep far below the control period is a mistake).
MAX_SUBSTEPS = 10_000
#: Series a run keeps per joint, variant and monitor (float64), for the memory check; a generous count.
SERIES_PER_JOINT = 24
#: A run's series may take at most this share of the machine's memory.
MEMORY_SHARE = 0.5


def machine_memory() -> int:
    """Physical memory of this machine [bytes]."""
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def series_bytes(spec: ScenarioSpec, n: int) -> float:
    """The memory one member's kept series take, all variants and monitors (a generous estimate): what the
    run-size check refuses beyond and what the engine sizes its chunks of members by."""
    periods = spec.duration / spec.control_dt
    estimators = sum(1 + len(variant.monitors) for variant in spec.variants.values())
    return periods * estimators * n * 8 * SERIES_PER_JOINT


def _check_run_size(spec: ScenarioSpec, n: int, file: str) -> None:
    """Refuse a run whose control periods or kept series cannot fit, before anything is allocated."""
    periods = spec.duration / spec.control_dt
    if not math.isfinite(periods):  # the ratio of two finite numbers can overflow: say so, not "inf GiB"
        raise InputError(file, "duration", f"{spec.duration:g} s is too long: more control periods of "
                         f"{spec.control_dt:g} s than a number can hold (shorten the run)")
    needed = series_bytes(spec, n)
    available = MEMORY_SHARE * machine_memory()
    if needed > available:
        raise InputError(file, "duration", f"{spec.duration:g} s is {periods:.3g} control periods of {spec.control_dt:g} s, "
                         f"whose series would need {needed / 2**30:.3g} GiB, more than half of this machine's "
                         f"{machine_memory() / 2**30:.3g} GiB (shorten the run or lengthen control_dt)")


def compile_variant_methods(file: str, name: str, variant: VariantSpec, n: int
                            ) -> tuple[tuple[type, GainConfig], tuple[type, GainConfig], list[Monitor]]:
    """A variant's observer, controller and monitors: plugin classes and validated gains."""
    field = f"variants.{name}"
    observer = compile_method(file, f"{field}.observer", variant.observer, observer_types(), "observer", n)
    if variant.controller is None:  # a log's variant: its torque is the command
        controller = (LogController, LogController.Config())
    else:
        controller = compile_method(file, f"{field}.controller", variant.controller, controller_types(), "controller", n)
    monitors = [Monitor(monitor, *compile_method(file, f"{field}.monitors.{monitor}", method, observer_types(),
                                                 "observer", n))
                for monitor, method in variant.monitors.items()]
    return observer, controller, monitors


def observer_start(spec: ScenarioSpec, name: str, n: int, file: str) -> tuple[np.ndarray | None, np.ndarray]:
    """Variant ``name``'s observer initial estimate (its own ``observer_initial``, else the scenario's):
    q_hat(0) (None: the first reading) and qd_hat(0)."""
    return observer_estimates(spec.variants[name].observer_initial, spec.observer_initial, name, n, file)


def observer_estimates(own: ObserverInitial | None, shared: ObserverInitial, name: str, n: int, file: str
                       ) -> tuple[np.ndarray | None, np.ndarray]:
    """q_hat(0) (None: the first reading) and qd_hat(0) of variant ``name`` from its own ``observer_initial``
    when it has one (all of it: a field it leaves out takes its default, not the scenario's), else from the
    scenario's ``shared`` one."""
    initial = own or shared
    field = f"variants.{name}.observer_initial" if own else "observer_initial"
    return (joint_values(initial.q_hat, n, file, f"{field}.q_hat", default=None),
            joint_values(initial.qd_hat, n, file, f"{field}.qd_hat"))


def joint_values(values: list[float] | None, n: int, file: str, field: str,
                 default: float | None = 0.0) -> np.ndarray | None:
    """A state field with one value per joint (``initial.q``, ``observer_initial.qd_hat``, ...); ``default`` for
    every joint when absent (None: stays None)."""
    if values is None:
        return None if default is None else np.full(n, default)
    return per_joint(list(values), n, file, field)


def time_grid(duration: float, control_dt: float) -> np.ndarray:
    """The control instants k * control_dt of a run of ``duration``."""
    return np.arange(int(round(duration / control_dt))) * control_dt


#: The sections that describe the simulated robot's run, refused beside a ``log`` section (which replaces it).
SIMULATION_ONLY = ("initial", "reference", "terms", "actuator_faults", "sensors", "plant", "timestep",
                   "controller_velocity")


def _log_run(spec: ScenarioSpec, path: Path, model: mujoco.MjModel, file: str) -> Log:
    """The ``log`` section compiled (:func:`~ftc_mj.logs.trajectory.compile_log`), after refusing what only a
    simulation has; ``control_dt`` and ``duration`` become the log's grid period and length."""
    for name in SIMULATION_ONLY:
        if name in spec.model_fields_set:
            raise InputError(file, name, "a log replaces the simulated robot: remove this section")
    if "sensors" in spec.robot.model_fields_set:
        raise InputError(file, "robot.sensors", "with a log the sensors are what the log holds: remove it")
    for name, variant in spec.variants.items():
        if variant.controller is not None:
            raise InputError(file, f"variants.{name}.controller", "a log has no controller: the logged torque is "
                             "what was applied (give only observer and monitors)")
        if variant.controller_velocity is not None:
            raise InputError(file, f"variants.{name}.controller_velocity", "a log has no controller: remove it")
    dt = spec.log.steps.resample
    if "control_dt" in spec.model_fields_set and spec.control_dt != dt:
        raise InputError(file, "control_dt", f"with a log the observers' period is log.steps.resample ({dt:g} s)")
    log = compile_log(spec.log, path, joint_names(model), spec.duration, file)
    spec.control_dt, spec.duration = dt, log.steps * dt
    return log


def check_on_grid(reference: expressions.TimeFunctions, terms: list[CompiledTerm], times: np.ndarray,
                  parameters: dict[str, float], file: str) -> None:
    """Refuse a reference, or a term's value of time and parameters alone, that is NaN or infinite at an instant
    of the run (:func:`~ftc_mj.config.expressions.first_nonfinite`), with the scenario's parameter values: the
    reference with its first and second derivatives (the controllers use all three), a term only where its
    profile is on. A term's value that depends on the state has values only along the trajectory and is not
    checked here (the loop's divergence check is what catches it); nor are a campaign member's own parameters."""
    values = np.array([[parameters[name] for name in reference.parameters]]) if reference.parameters else None
    with np.errstate(all="ignore"):
        evaluated = reference.evaluate(times, values)
    labels = ("", "its time derivative ", "its second time derivative ")
    for label, exprs, grid in zip(labels, (reference.exprs, reference.first, reference.second), evaluated):
        bad = ~np.isfinite(grid.reshape(len(times), -1))
        if bad.any():
            sample, joint = np.argwhere(bad)[0]
            raise InputError(file, f"reference.{joint}", f"{label}is not finite at t = {times[sample]:g} s of the "
                             f"run ({exprs[joint]})")
    variables = {expressions.symbol(name) for name in ("t", *parameters)}
    for index, term in enumerate(terms):
        active = None if term.time_profile is None else term.time_profile.active(times)
        for joint, expr in enumerate(term.exprs):
            if not expr.free_symbols <= variables:
                continue  # a function of the state: known only along the trajectory
            at = expressions.first_nonfinite(expr, times, parameters, where=active)
            if at is not None:
                raise InputError(file, f"terms.{index}.value.{joint}", f"is not finite at t = {at:g} s ({expr}), "
                                 "while the term is on")


def compile_scenario(path: Path, spec: ScenarioSpec, written: dict[str, Any] | None = None) -> Scenario:
    """Check and compile a validated spec read from ``path``: the robot first (it fixes the number of joints
    and the joint names), then every section by its own compile function. ``written``: the file's fields as
    written, after ``--set`` (:meth:`Scenario.written`)."""
    file = str(path)
    model_path, model = load_robot(path, spec.robot, file)
    n = model.nv
    log = _log_run(spec, path, model, file) if spec.log is not None else None
    if log is None:
        _check_simulation_sections(spec, file)
    timestep, substeps = _physics_steps(spec, file)
    _check_run_size(spec, n, file)
    q0, qd0, reference = _start_and_reference(spec, log, n, file)
    terms = compile_terms(spec.terms, file, n, list(spec.parameters))
    times = time_grid(spec.duration, spec.control_dt)
    if log is None:  # a log has no reference (NaN) and no terms
        check_on_grid(reference, terms, times, spec.parameters, file)
    actuator_faults = [compile_actuator_fault(fault, file, f"actuator_faults.{index}", model, times)
                       for index, fault in enumerate(spec.actuator_faults)]
    position_sensor, velocity_sensor = _sensor_channels(spec, model, len(times), file)
    sensors = _readable_sensors(spec, log)
    variants = [compile_variant(spec, name, n, sensors, log is not None, file) for name in spec.variants]
    model.opt.timestep = timestep
    scenario = Scenario(
        path=path, spec=spec, model_path=model_path, model=model, n_joints=n, timestep=timestep,
        substeps=substeps, q0=q0, qd0=qd0, reference=reference, terms=terms, variants=variants,
        terms_function=terms_function(terms, n, list(spec.parameters)), actuator_faults=actuator_faults,
        position_sensor=position_sensor, velocity_sensor=velocity_sensor, log=log, _written=written or {},
    )
    if spec.diagnosis is not None:
        scenario.diagnoser = compile_diagnoser(spec.diagnosis, spec.control_dt, spec.metrics.estimation_window_start,
                                                file, n, scenario.fault_onsets)
    names, signals = _figure_lines(variants)
    scenario.figures = compile_figures(spec, model, names, file, signals)
    return scenario


def _check_simulation_sections(spec: ScenarioSpec, file: str) -> None:
    """What a simulated run needs (a log gives them): a duration, an initial state, a reference, controllers."""
    for required in ("duration", "initial", "reference"):
        if getattr(spec, required) is None:
            raise InputError(file, required, "required field is missing (or give a log section)")
    for name, variant in spec.variants.items():
        if variant.controller is None:
            raise InputError(file, f"variants.{name}.controller", "required field is missing")


def _physics_steps(spec: ScenarioSpec, file: str) -> tuple[float, int]:
    """The physics timestep and the whole number of physics steps per control period (at most
    :data:`MAX_SUBSTEPS`); a duration of at least one control period."""
    timestep = spec.timestep if spec.timestep is not None else spec.control_dt
    ratio = spec.control_dt / timestep
    substeps = round(ratio)
    if substeps < 1 or abs(ratio - substeps) > 1e-9 * max(ratio, 1.0):
        raise InputError(file, "control_dt", f"{spec.control_dt} is not an integer multiple of the timestep {timestep}")
    if substeps > MAX_SUBSTEPS:
        raise InputError(file, "timestep", f"{timestep:g} s gives {substeps:.3g} physics steps per control period of "
                         f"{spec.control_dt:g} s; at most {MAX_SUBSTEPS} are allowed")
    if spec.duration < spec.control_dt:
        raise InputError(file, "duration", f"{spec.duration} is shorter than one control period")
    return timestep, substeps


def _start_and_reference(spec: ScenarioSpec, log: Log | None, n: int, file: str
                         ) -> tuple[np.ndarray, np.ndarray, expressions.TimeFunctions]:
    """q(0), qd(0) and the reference: the scenario's, or a log's first sample and no reference (NaN)."""
    if log is not None:
        q0 = log.position[0].copy()
        qd0 = np.zeros(n) if log.velocity is None else log.velocity[0].copy()
        return q0, qd0, expressions.TimeFunctions([sympy.nan] * n)
    q0 = joint_values(spec.initial.q, n, file, "initial.q")
    qd0 = joint_values(spec.initial.qd, n, file, "initial.qd")
    if len(spec.reference) != n:
        raise InputError(file, "reference", f"has {len(spec.reference)} values, the robot has {n} joints")
    reference_exprs = [parse_expression(text, ["t", *spec.parameters], file, f"reference.{i}")
                       for i, text in enumerate(spec.reference)]
    # Only the parameters the reference uses: without any, one reference serves every member.
    used = {symbol.name for expr in reference_exprs for symbol in expr.free_symbols}
    return q0, qd0, expressions.TimeFunctions(reference_exprs, [name for name in spec.parameters if name in used])


def _sensor_channels(spec: ScenarioSpec, model: mujoco.MjModel, steps: int, file: str
                     ) -> tuple[Channel | None, Channel | None]:
    """The encoders' and the tachometers' effects (None: perfect), each delay shorter than the run."""
    position = compile_channel(spec.sensors.position, file, "sensors.position", model)
    if spec.sensors.velocity is not None and "velocity" not in spec.robot.sensors:
        raise InputError(file, "sensors.velocity", "the robot has no velocity sensors (robot.sensors)")
    velocity = compile_channel(spec.sensors.velocity, file, "sensors.velocity", model)
    for name, channel in (("position", position), ("velocity", velocity)):
        if channel is not None and channel.delay_samples >= steps:  # its history would outgrow the run
            raise InputError(file, f"sensors.{name}.delay_samples", f"{channel.delay_samples} is not shorter than "
                             f"the run ({steps} control periods)")
    return position, velocity


def _readable_sensors(spec: ScenarioSpec, log: Log | None) -> set[str]:
    """What the controller side may read: the robot's sensors, or what the log holds."""
    if log is not None:
        return {"position"} | ({"velocity"} if log.velocity is not None else set())
    return set(spec.robot.sensors) | {"position"}


def compile_variant(spec: ScenarioSpec, name: str, n: int, sensors: set[str], replay: bool, file: str) -> Variant:
    """Variant ``name``: its methods (each given the sensors it requires), its controller's velocity and its
    observer's start; ``replay``: the scenario replays a log (no controller reads anything)."""
    variant, field = spec.variants[name], f"variants.{name}"
    (observer_type, observer_config), (controller_type, controller_config), monitors = compile_variant_methods(
        file, name, variant, n)
    plugins = [("observer", observer_type), ("controller", controller_type)]
    plugins += [(f"monitors.{m.name}", m.observer_type) for m in monitors]
    for kind, plugin in plugins:
        missing = set(plugin.requires) - sensors
        if missing and replay:
            raise InputError(file, f"{field}.{kind}.type", f"{plugin.name} needs {', '.join(sorted(missing))}, "
                             "which the log does not hold (log.columns.velocity, or the messages' velocity)")
        if missing:
            raise InputError(file, f"{field}.{kind}.type", f"{plugin.name} needs {', '.join(sorted(missing))} "
                             f"sensors, robot.sensors has {sorted(sensors)}")
    q_hat0, qd_hat0 = observer_start(spec, name, n, file)
    return Variant(name=name, observer_type=observer_type, observer_config=observer_config,
                   controller_type=controller_type, controller_config=controller_config, q_hat0=q_hat0,
                   qd_hat0=qd_hat0, monitors=monitors,
                   controller_velocity=_controller_velocity(spec, name, sensors, replay, file))


def _controller_velocity(spec: ScenarioSpec, name: str, sensors: set[str], replay: bool, file: str) -> str:
    """``measured`` or ``estimated``: the variant's, else the scenario's, else measured where tachometers are."""
    variant = spec.variants[name]
    velocity = variant.controller_velocity or spec.controller_velocity
    if replay:  # no controller reads anything
        return "estimated"
    if velocity is None:
        return "measured" if "velocity" in sensors else "estimated"
    if velocity == "measured" and "velocity" not in sensors:
        field = f"variants.{name}.controller_velocity" if variant.controller_velocity else "controller_velocity"
        raise InputError(file, field, "measured needs velocity sensors (robot.sensors)")
    return velocity


def _figure_lines(variants: list[Variant]) -> tuple[list[str], dict[str, tuple]]:
    """Every line a figure may draw (variants and ``variant.monitor``) and the signals each one's methods
    record."""
    names = [name for v in variants for name in (v.name, *(f"{v.name}.{m.name}" for m in v.monitors))]
    signals = {v.name: (getattr(v.observer_type, "signal_names", None), getattr(v.controller_type, "signal_names", None))
               for v in variants}
    signals.update({f"{v.name}.{m.name}": (getattr(m.observer_type, "signal_names", None),)
                    for v in variants for m in v.monitors})
    return names, signals
