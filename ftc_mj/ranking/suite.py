"""A benchmark suite (``suites/v1.yaml``): the robots, the fault library, the sensor conditions, the model
mismatch and the seeds, and how they become campaign populations.

Per robot and task two populations (:data:`POPULATIONS`): ``healthy`` runs, whose only randomness is the seed
and the controller model's mass scale (for the false alarms), and ``faults``: one campaign case per fault of
the library, kind x size x (onset, joint), the same seeds and mass scales as each other (common random
numbers). Every run of a task is simulated in the robot's scenario reduced to the suite's protocol: the
scenario's plant, reference, initial state and kept healthy terms, the suite's encoders, diagnosis and
metrics windows, and no fault but the case's.

* **diagnosis**: one variant, ``reference``, the robot's reference loop (the Chapter 5 controller with the
  high-speed TOSMO); every entry's observer is a monitor of it, so that every observer sees the same
  trajectory, diagnosed alike (each on its own LUaF estimate). The robot has tachometers (for the observers
  that need them); the loop's controller uses its observer's velocity.
* **tracking**: one variant per entry, its observer driving its controller.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import Field, StrictBool, StrictInt, StrictStr, model_validator

from ftc_mj.config.errors import InputError, validate
from ftc_mj.config.inheritance import resolve_bases
from ftc_mj.config.types import PositiveFloat, Strict
from ftc_mj.config.yaml import read_yaml_mapping
from ftc_mj.methods.registry import MethodSpec

SUITES = Path(__file__).resolve().parent / "suites"
TASKS = ("diagnosis", "tracking")
POPULATIONS = ("healthy", "faults")
TIERS = ("quick", "full")
#: The reference loop's variant name in a diagnosis scenario (its monitors are ``reference.<entry>``).
REFERENCE = "reference"

PositiveInt = Annotated[StrictInt, Field(gt=0)]
Fraction = Annotated[float, Field(gt=0, lt=1)]
Share = Annotated[float, Field(gt=0, le=1)]
Name = Annotated[StrictStr, Field(pattern=r"^[A-Za-z0-9_][A-Za-z0-9_-]*$")]


class LoopSpec(Strict):
    observer: MethodSpec
    controller: MethodSpec


class ProtocolSpec(Strict):
    seed: Annotated[StrictInt, Field(ge=0)]
    mass_scale: tuple[PositiveFloat, PositiveFloat]
    encoders: dict[str, Any]
    diagnosis: dict[str, Any]
    metrics: dict[str, Any]
    onsets: Annotated[list[PositiveFloat], Field(min_length=1)]
    fault_length: PositiveFloat
    tracking_onsets: PositiveInt = 1

    @model_validator(mode="after")
    def _consistent(self) -> "ProtocolSpec":
        if not self.mass_scale[0] < self.mass_scale[1]:
            raise ValueError("mass_scale: low must be below high")
        if self.tracking_onsets > len(self.onsets):
            raise ValueError("tracking_onsets: more than there are onsets")
        return self


class FaultLibrary(Strict):
    loss_of_effectiveness: list[Share] = []
    bias: list[PositiveFloat] = []
    #: What a bias's size multiplies: the faulty joint's ``torque_scale`` (suite v1) or its ``residual_unit``,
    #: the healthy residual's 99th percentile (suite v2: sizes from undetectable to easy on every robot).
    bias_relative_to: Literal["torque_scale", "residual_unit"] = "torque_scale"
    saturation: list[Fraction] = []
    lock: StrictBool = False
    float: StrictBool = False


class TierSpec(Strict):
    duration: PositiveFloat
    healthy_runs: PositiveInt
    fault_runs: PositiveInt
    tracking_healthy_runs: PositiveInt
    tracking_fault_runs: PositiveInt
    #: Healthy runs the thresholds are calibrated on (suite v2; never scored).
    calibration_runs: Annotated[StrictInt, Field(ge=0)] = 0
    #: Runs reserved for tuning (suite v2: their seeds are a tuning's, never scored).
    tune_runs: Annotated[StrictInt, Field(ge=0)] = 0


class PopulationSeeds(Strict):
    #: Run k of the population has seed ``seed + k``.
    seed: Annotated[StrictInt, Field(ge=0)]
    #: The seed of its scrambled Sobol points (the controller model's mass scales).
    sobol_seed: Annotated[StrictInt, Field(ge=0)]


class CalibrationSpec(Strict):
    """Suite v2's diagnosis protocol: windows scored alike healthy and faulty, thresholds calibrated per entry on
    healthy runs the scoring never sees (:mod:`ftc_mj.ranking.windows`)."""

    #: The common false-alarm probability per window and joint at which every entry's threshold is set.
    false_alarm: Fraction
    #: Window lengths [s]: each (fault joint, onset) of the protocol and each length is a stratum.
    windows: Annotated[list[PositiveFloat], Field(min_length=1)]
    #: oracle_fault's white noise, as a share of the robot's smallest residual unit.
    oracle_noise: PositiveFloat = 0.01


class SuiteRobot(Strict):
    #: The robot's shipped scenario, relative to the suite file.
    scenario: StrictStr
    #: The reference loop: a variant of the scenario, or an observer and a controller.
    loop: StrictStr | LoopSpec
    #: Names of the scenario's terms kept as healthy uncertainty (the others, e.g. additive faults, go).
    terms: list[StrictStr] = []
    fault_joints: Annotated[list[Annotated[StrictInt, Field(ge=1)]], Field(min_length=1)]
    torque_scale: Annotated[list[PositiveFloat], Field(min_length=1)]
    #: Per fault joint, the healthy residual's 99th percentile over the scored windows [N m] (suite v2: the unit
    #: of the bias sizes; ``python -m ftc_mj.ranking.sizing SUITE`` measures it).
    residual_unit: list[PositiveFloat] = []
    #: What the robot's nominal model leaves out (the declared healthy uncertainty), in words.
    uncertainty: StrictStr = ""
    #: Per controlled joint, the |torque| [N m] its motor delivers at most in the tracking task: every entry's
    #: command is clipped to it by the plant, as an actuator would (MuJoCo's ``ctrlrange``), and the actuator
    #: faults act on what the limited motor gives. Diagnosis runs keep the scenario's own limits.
    torque_limit: list[PositiveFloat] = []

    @model_validator(mode="after")
    def _per_joint(self) -> "SuiteRobot":
        if len(self.torque_scale) != len(self.fault_joints):
            raise ValueError("torque_scale: one per fault joint")
        if self.residual_unit and len(self.residual_unit) != len(self.fault_joints):
            raise ValueError("residual_unit: one per fault joint")
        return self


class SuiteSpec(Strict):
    version: Name
    description: str = ""
    protocol: ProtocolSpec
    faults: FaultLibrary
    tiers: dict[Literal["quick", "full"], TierSpec]
    robots: Annotated[dict[Name, SuiteRobot], Field(min_length=1)]
    #: Suite v2: calibrated thresholds on scored windows (absent: suite v1's per-run statistics).
    calibration: CalibrationSpec | None = None
    #: Suite v2: each population's own seeds (``tune``, ``calibrate``, ``healthy``, ``faults``), disjoint.
    populations: dict[Literal["tune", "calibrate", "healthy", "faults"], PopulationSeeds] = {}
    #: Whether a newer suite replaces this one (said in its leaderboards).
    superseded_by: StrictStr = ""

    @model_validator(mode="after")
    def _onsets_per_robot(self) -> "SuiteSpec":
        for name, robot in self.robots.items():
            if len(robot.fault_joints) != len(self.protocol.onsets):
                raise ValueError(f"robots.{name}.fault_joints: one per protocol onset ({len(self.protocol.onsets)})")
        if self.calibration is None:
            return self
        missing = [p for p in POPULATIONS_V2 if p not in self.populations]
        if missing:
            raise ValueError(f"populations: {', '.join(missing)} missing (each population has its own seeds)")
        for tier_name, tier in self.tiers.items():
            if tier.calibration_runs < 1:
                raise ValueError(f"tiers.{tier_name}.calibration_runs: at least 1 with a calibration")
        _disjoint_seeds(self)
        for name, robot in self.robots.items():
            if self.faults.bias_relative_to == "residual_unit" and not robot.residual_unit:
                raise ValueError(f"robots.{name}.residual_unit: needed for biases relative to it")
        return self


#: Suite v2's populations, each with its own seeds: ``tune`` (a tuning's), ``calibrate`` (the thresholds'),
#: ``healthy`` and ``faults`` (the scored ones).
POPULATIONS_V2 = ("tune", "calibrate", "healthy", "faults")


def seed_ranges(spec: "SuiteSpec") -> dict[str, range]:
    """Each population's seeds over the suite's largest tier (each fault case its own draws)."""
    largest = {"tune": "tune_runs", "calibrate": "calibration_runs", "healthy": "healthy_runs",
               "faults": "fault_runs"}
    out = {}
    for population, seeds in spec.populations.items():
        count = max(max(getattr(t, largest[population]), getattr(t, "tracking_" + largest[population], 0))
                    for t in spec.tiers.values())
        if population == "faults":  # each fault case its own draws
            count *= _case_count(spec)
        out[population] = range(seeds.seed, seeds.seed + max(count, 1))
    return out


def _case_count(spec: "SuiteSpec") -> int:
    """The fault cases of a robot: the library's kinds and sizes on each (onset, joint)."""
    library = spec.faults
    kinds = (len(library.loss_of_effectiveness) + len(library.bias) + len(library.saturation) + int(library.lock)
             + int(library.float))
    return kinds * len(spec.protocol.onsets)


def _disjoint_seeds(spec: "SuiteSpec") -> None:
    ranges = list(seed_ranges(spec).items())
    for i, (a, first) in enumerate(ranges):
        for b, second in ranges[i + 1:]:
            if first.start < second.stop and second.start < first.stop:
                raise ValueError(f"populations.{b}.seed: its seeds {second.start}-{second.stop - 1} overlap "
                                 f"{a}'s {first.start}-{first.stop - 1}")
    sobol = [seeds.sobol_seed for seeds in spec.populations.values()]
    if len(set(sobol)) != len(sobol):
        raise ValueError("populations: each population needs its own sobol_seed")


class Suite:
    """A loaded suite: its spec, its file, and each robot's scenario resolved (bases merged)."""

    def __init__(self, path: Path, spec: SuiteSpec):
        self.path = path
        self.spec = spec
        self.scenarios: dict[str, Path] = {}
        self.resolved: dict[str, dict] = {}
        for name, robot in spec.robots.items():
            scenario = (path.parent / robot.scenario).resolve()
            if not scenario.is_file():
                raise InputError(str(path), f"robots.{name}.scenario", f"no such file: {robot.scenario}")
            self.scenarios[name] = scenario
            self.resolved[name] = resolve_bases(scenario, ("robot.model",)).raw
            variants = self.resolved[name].get("variants") or {}
            if isinstance(robot.loop, str) and robot.loop not in variants:
                raise InputError(str(path), f"robots.{name}.loop", f"{robot.loop!r} is not a variant of "
                                 f"{robot.scenario} (its variants: {', '.join(variants)})")
            limit, joints = robot.torque_limit, len(self.resolved[name].get("reference") or [])
            if limit and len(limit) != joints:
                raise InputError(str(path), f"robots.{name}.torque_limit", f"{len(limit)} values for {joints} "
                                 "controlled joints (one per joint)")
            known = [term.get("name") for term in self.resolved[name].get("terms") or []]
            for term in robot.terms:
                if term not in known:
                    raise InputError(str(path), f"robots.{name}.terms", f"{term!r} is not a term of {robot.scenario}")

    @property
    def version(self) -> str:
        return self.spec.version

    def joints(self, robot: str) -> int:
        """The robot's number of controlled joints (its reference's length)."""
        return len(self.resolved[robot]["reference"])

    def tier(self, tier: str) -> TierSpec:
        if tier not in self.spec.tiers:
            raise InputError(str(self.path), "tiers", f"the suite has no tier {tier!r} (its tiers: "
                             f"{', '.join(self.spec.tiers)})")
        return self.spec.tiers[tier]

    # -------------------------------------------------------------------------------------------- scenarios

    def loop(self, robot: str) -> dict[str, Any]:
        """The reference loop's observer and controller, as a scenario's variant."""
        loop = self.spec.robots[robot].loop
        if isinstance(loop, str):
            variant = self.resolved[robot]["variants"][loop]
            return {"observer": variant["observer"], "controller": variant["controller"]}
        return loop.model_dump(mode="json")

    def stage(self, robot: str) -> dict[str, Any]:
        """The robot's scenario without what the protocol replaces (a base file for :meth:`scenario`)."""
        return {"base": str(self.scenarios[robot]), "variants": None, "terms": None, "parameters": None,
                "actuator_faults": None, "sensors": None, "diagnosis": None, "metrics": None, "figures": None}

    @property
    def calibrated(self) -> bool:
        """Whether the suite scores diagnosis on calibrated windows (suite v2) rather than per run (v1)."""
        return self.spec.calibration is not None

    def populations(self, task: str) -> tuple[str, ...]:
        """The populations a task simulates: v2's diagnosis adds the calibration runs."""
        if task == "diagnosis" and self.calibrated:
            return ("calibrate",) + POPULATIONS
        return POPULATIONS

    def scenario(self, robot: str, task: str, tier: str, variants: dict[str, Any]) -> dict[str, Any]:
        """The task's scenario on ``base: stage.yaml`` (:meth:`stage`) with the given variants."""
        protocol, base = self.spec.protocol, self.resolved[robot]
        kept = [term for term in base.get("terms") or [] if term.get("name") in self.spec.robots[robot].terms]
        out: dict[str, Any] = {
            "base": "stage.yaml",
            "name": f"bench_{self.version}_{task}_{robot}",
            "description": f"Benchmark suite {self.version}, task {task}, robot {robot}.",
            "duration": self.tier(tier).duration,
            "robot": {"sensors": ["position", "velocity"]},
            "controller_velocity": "estimated",
            "actuator_faults": [],
            "sensors": {"position": dict(protocol.encoders)},
            "diagnosis": dict(protocol.diagnosis),
            "metrics": dict(protocol.metrics),
            "variants": variants,
        }
        if kept:
            out["terms"] = kept
        limit = self.spec.robots[robot].torque_limit
        if task == "tracking" and limit:
            out["robot"]["torque_limits"] = list(limit)
            if not base["robot"].get("joints"):  # an MJCF in the testbed's form: limits need it rebuilt
                out["robot"]["joints"] = self._joint_names(robot)
        elif not self.calibrated:  # suite v1's runs as computed before faults acted after the motor's limit
            out["faults_after_torque_limit"] = False
        return out

    def _joint_names(self, robot: str) -> list[str]:
        """The joints of the robot's model, in its order (a model in the testbed's form: every joint)."""
        import mujoco

        model = mujoco.MjModel.from_xml_path(str((self.scenarios[robot].parent / self.resolved[robot]["robot"]["model"])
                                                 .resolve()))
        return [model.joint(j).name for j in range(model.njnt)]

    # -------------------------------------------------------------------------------------------- populations

    def fault_cases(self, robot: str, task: str) -> list[dict[str, Any]]:
        """The fault library as campaign cases on ``robot`` (kind x size x (onset, joint)); the tracking task
        uses the first ``protocol.tracking_onsets`` onsets."""
        protocol, library, spec = self.spec.protocol, self.spec.faults, self.spec.robots[robot]
        count = len(protocol.onsets) if task == "diagnosis" else protocol.tracking_onsets
        cases = []
        units = spec.residual_unit or spec.torque_scale
        for onset, joint, scale, unit in list(zip(protocol.onsets, spec.fault_joints, spec.torque_scale,
                                                  units))[:count]:
            profile = {"onset": onset, "end": onset + protocol.fault_length}
            bias_unit = unit if library.bias_relative_to == "residual_unit" else scale
            kinds: list[tuple[str, float, dict[str, Any]]] = []
            kinds += [("loss_of_effectiveness", a, {"alpha": a}) for a in library.loss_of_effectiveness]
            kinds += [("bias", b, {"offset": b * bias_unit}) for b in library.bias]
            kinds += [("saturation", s, {"limit": s * scale}) for s in library.saturation]
            kinds += [(kind, 1.0, {}) for kind in ("lock", "float") if getattr(library, kind)]
            for kind, size, values in kinds:
                fault = {"kind": kind, "joints": [joint], **values, "profile": profile}
                label = f"{kind}_{size:g}_j{joint}_t{onset:g}"
                cases.append({"label": label, "values": {"kind": kind, "fault_size": size, "fault_joint": joint,
                                                          "onset": onset},
                              "set": {"actuator_faults": [fault]}})
        return cases

    def runs(self, task: str, population: str, tier: str) -> int:
        """The runs of a population (a fault population's per case: its draws)."""
        tiers = self.tier(tier)
        if population == "calibrate":
            return tiers.calibration_runs
        if task == "diagnosis":
            return tiers.healthy_runs if population == "healthy" else tiers.fault_runs
        return tiers.tracking_healthy_runs if population == "healthy" else tiers.tracking_fault_runs

    def campaign(self, robot: str, task: str, population: str, tier: str, variants: list[str]) -> dict[str, Any]:
        """The campaign of one population (on ``scenario.yaml`` beside it)."""
        protocol, runs = self.spec.protocol, self.runs(task, population, tier)
        low, high = protocol.mass_scale
        if self.spec.populations:  # each population its own seeds and mass scales, disjoint (checked)
            seed, sobol_seed = self.spec.populations[population].seed, self.spec.populations[population].sobol_seed
        else:  # v1: healthy and faulty runs on seeds of their own, the mass scales shared
            seed, sobol_seed = protocol.seed + (0 if population == "faults" else 100_000), 0
        out: dict[str, Any] = {
            "name": f"bench_{self.version}_{tier}_{task}_{robot}_{population}",
            "scenario": "scenario.yaml",
            "variants": variants,
            "seed": seed,
            "samples": {"runs": runs, "method": "sobol", "seed": sobol_seed,
                        "fields": {"nominal.mass_scale": {"uniform": [low, high]}}},
            "diagnosis": {"threshold_scales": [1.0]},
            "report": {"metrics": ["rms_error_converged"]},
        }
        if population == "faults":
            out["cases"] = self.fault_cases(robot, task)
            if self.spec.populations:  # v2: each case its own draws (seeds and mass scales)
                out["case_draws"] = True
        return out


def load_suite(name_or_path: str | Path, file: str = "") -> Suite:
    """A shipped suite by version (``v1``) or a suite file.

    Raises:
        InputError: naming the suite file and the field (``file`` and ``suite`` for an unknown version).
    """
    text = str(name_or_path)
    path = Path(text) if text.endswith((".yaml", ".yml")) else SUITES / f"{text}.yaml"
    if not path.is_file():
        shipped = sorted(p.stem for p in SUITES.glob("*.yaml") if not p.stem.endswith(("-entries", "-tuned")))
        raise InputError(file or text, "suite", f"no suite {text!r} (shipped: {', '.join(shipped)})")
    raw = read_yaml_mapping(path, "a benchmark suite")
    return Suite(path.resolve(), validate(SuiteSpec, raw, str(path)))
