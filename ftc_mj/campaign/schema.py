"""The campaign file: a base scenario, the variants to compare, and a population of runs.

A campaign is untrusted input like a scenario: it is read with the scenario's YAML loader (duplicate keys are
errors), validated by a strict schema (unknown keys are errors), and every problem is one
:class:`~ftc_mj.config.errors.InputError` naming the file, the field and what is wrong. Example::

    name: ch5_monte_carlo
    scenario: ../scenarios/puma_fault.yaml
    variants: [proposed, nftsmc_tosmo]          # default: all of the scenario's
    set: {sensors.position.noise_std: 1.0e-5}   # the same for every run: any field, any YAML value
    cases:                                      # structural alternatives, each a label, numbers, fields
      - {label: healthy, values: {fault_size: 0}, set: {actuator_faults: []}}
    grid:                                       # a sweep: every combination of the values
      terms.2.onset: [10.0, 12.5]
    samples:                                    # draws per field, the same for every variant
      runs: 1000
      method: sobol                             # random | sobol | halton
      fields:
        parameters.fault_scale: {uniform: [0.5, 1.5]}
        plant.mass_scale: {normal: [1.0, 0.05]}
    replicates: 2                               # seeds per point
    report: {metrics: [rms_error_converged], claims: [...]}

The population (:mod:`ftc_mj.campaign.population`) is cases x grid x samples x replicates; every run is
simulated for every variant (a paired comparison).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, Literal

import yaml
from pydantic import AfterValidator, Field, StrictBool, StrictInt, StrictStr, field_validator, model_validator

from ftc_mj.analysis.metrics import METRICS
from ftc_mj.config.errors import InputError, validate
from ftc_mj.config.yaml import read_yaml_mapping
from ftc_mj.config.types import FiniteFloat, PositiveFloat, Strict
from ftc_mj.scenario.definition import MAX_SEED

PositiveInt = Annotated[StrictInt, Field(gt=0)]
NonNegativeInt = Annotated[StrictInt, Field(ge=0)]
#: A seed of the campaign (of its runs, of its draws): 0 to the scenario's largest seed.
SeedInt = Annotated[StrictInt, Field(ge=0, le=MAX_SEED)]
#: A dotted path into the scenario, as ``--set`` takes it.
FieldPath = Annotated[StrictStr, Field(pattern=r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z0-9_]+)*$")]
Name = Annotated[StrictStr, Field(pattern=r"^[A-Za-z0-9_][A-Za-z0-9_.-]*$")]

#: Multiples of the scenario's own threshold at which the detection statistics are kept (ROC points).
DEFAULT_THRESHOLD_SCALES = (0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0)
DEFAULT_REPORT_METRICS = ("rms_error_converged", "max_error_converged", "fault_peak_error", "recovery_time",
                          "rms_velocity_error", "rms_luaf_error", "observer_convergence_time", "chattering",
                          "detection_delay")


def _known_metric(metric: str) -> str:
    if metric not in METRICS:
        raise ValueError(f"unknown metric {metric!r}")
    return metric


#: A metric of :data:`ftc_mj.analysis.metrics.METRICS`, by name.
MetricName = Annotated[StrictStr, AfterValidator(_known_metric)]

class Distribution(Strict):
    """Exactly one of: ``uniform: [low, high]``, ``log_uniform: [low, high]`` (0 < low), ``normal: [mean, std]``,
    ``choice: [value, ...]``."""

    #: Uniform between ``[low, high]``.
    uniform: tuple[FiniteFloat, FiniteFloat] | None = None
    #: Log-uniform between ``[low, high]``, 0 < low (a value that spans decades).
    log_uniform: tuple[PositiveFloat, PositiveFloat] | None = None
    #: Normal with ``[mean, std]``.
    normal: tuple[FiniteFloat, PositiveFloat] | None = None
    #: One of the listed values, equally likely (numbers, names or mappings).
    choice: Annotated[list[Any], Field(min_length=1)] | None = None
    #: Other fields that take the same value in each run (e.g. a gain shared by every variant); the column
    #: is the field's own.
    also: list[FieldPath] = []

    @model_validator(mode="after")
    def _exactly_one(self) -> "Distribution":
        given = [name for name in ("uniform", "log_uniform", "normal", "choice") if getattr(self, name) is not None]
        if len(given) != 1:
            raise ValueError("give exactly one of uniform, log_uniform, normal, choice")
        for name in ("uniform", "log_uniform"):
            bounds = getattr(self, name)
            if bounds is not None and not bounds[0] < bounds[1]:
                raise ValueError(f"{name}: low {bounds[0]:g} must be below high {bounds[1]:g}")
        return self

    def value(self, u: float) -> Any:
        """The value at the quantile ``u`` in [0, 1) (inverse transform: works for random and low-discrepancy
        points alike)."""
        from scipy.stats import norm

        if self.uniform is not None:
            low, high = self.uniform
            return float(low + u * (high - low))
        if self.log_uniform is not None:
            low, high = self.log_uniform
            return float(math.exp(math.log(low) + u * (math.log(high) - math.log(low))))
        if self.normal is not None:
            mean, std = self.normal
            return float(mean + std * norm.ppf(min(max(u, 1e-12), 1 - 1e-12)))
        return self.choice[min(int(u * len(self.choice)), len(self.choice) - 1)]


class SamplesSpec(Strict):
    #: Number of sampled points; ``--runs`` overrides it (run k is the same whatever the number).
    runs: PositiveInt
    #: ``random``: independent uniform points, point k from its own stream; ``sobol``/``halton``: scrambled
    #: low-discrepancy points (scipy.stats.qmc), whose first N are the same whatever N.
    method: Literal["random", "sobol", "halton"] = "sobol"
    #: Seed of the sampled points (scrambling, or the random streams of ``random``).
    seed: SeedInt = 0
    #: The sampled fields by dotted path (as ``--set`` takes them), each with its distribution.
    fields: Annotated[dict[FieldPath, Distribution], Field(min_length=1)]


class CaseSpec(Strict):
    """A structural alternative: a label (a column), numbers to report it by (columns), and fields to set."""

    #: The case's name, a column of the results.
    label: Name
    #: Columns to report the case by: numbers (a fault's size) or names (its kind).
    values: dict[Name, FiniteFloat | StrictStr] = {}
    #: Fields this case sets, by dotted path, any YAML value (e.g. the ``actuator_faults`` list).
    set: dict[FieldPath, Any] = {}


class ClaimSpec(Strict):
    """An ordering to test over the population: ``better`` has a lower ``metric`` than ``worse``."""

    #: The claim's name in the report.
    name: StrictStr
    #: The metric compared (lower is better).
    metric: MetricName
    #: The variant claimed to have the lower metric.
    better: StrictStr
    #: The variant it is compared with.
    worse: StrictStr
    #: 1-based joints (all when absent).
    joints: list[Annotated[StrictInt, Field(ge=1)]] | None = None


class DiagnosisStatsSpec(Strict):
    #: Multiples of the scenario's threshold at which alarms, false alarms and delays are kept per run.
    threshold_scales: Annotated[list[PositiveFloat], Field(min_length=1)] = list(DEFAULT_THRESHOLD_SCALES)

    @field_validator("threshold_scales")
    @classmethod
    def _with_one(cls, scales: list[float]) -> list[float]:
        if 1.0 not in scales:
            raise ValueError("must contain 1 (the scenario's own threshold)")
        return sorted(set(scales))


class HeatmapSpec(Strict):
    #: The metric drawn per grid cell (its mean over the cell's runs).
    metric: MetricName = "rms_error_converged"
    #: The 1-based joint whose metric is drawn.
    joint: Annotated[StrictInt, Field(ge=1)] = 1


class ReportSpec(Strict):
    #: Metrics tabulated and plotted per variant and joint.
    metrics: list[MetricName] = list(DEFAULT_REPORT_METRICS)
    #: Paired differences are taken against this variant (default: the first).
    reference: StrictStr | None = None
    #: The column that measures the fault's size (a case value or a varied field), for P_d against size.
    fault_size: StrictStr | None = None
    #: A column that names the fault's kind: P_d against size is drawn per kind (sizes of different kinds
    #: are not comparable).
    fault_kind: StrictStr | None = None
    #: The false-alarm probability at which P_d against size is drawn.
    false_alarm_probability: Annotated[float, Field(gt=0, lt=1, allow_inf_nan=False)] = 0.05
    #: Orderings tested over the population, each with a verdict (holds, reversed, inconclusive).
    claims: list[ClaimSpec] = []
    #: The heat map of a 2-D numeric grid.
    heatmap: HeatmapSpec = HeatmapSpec()
    #: Bootstrap resamples of the means' and the paired differences' confidence intervals.
    bootstrap: Annotated[StrictInt, Field(ge=100)] = 2000


class CampaignSpec(Strict):
    #: The campaign's name; the results directory defaults to ``results/<name>/``.
    name: Name
    #: Free text.
    description: str = ""
    #: The base scenario, relative to the campaign file.
    scenario: StrictStr
    #: The scenario's variants to run (default: all).
    variants: Annotated[list[StrictStr], Field(min_length=1)] | None = None
    #: Another duration for every run [s] (default: the scenario's).
    duration: PositiveFloat | None = None
    #: Seed of run k's random streams: seed + its sample index x replicates + its replicate (default: the
    #: scenario's seed). The grid's points and the cases share seeds (common random numbers).
    seed: SeedInt | None = None
    #: Each case its own draws, rather than the common random numbers: its own seeds (seed + (sample index x
    #: cases + case index) x replicates + replicate) and its own sampled points (point sample index x cases +
    #: case index), so that the cases' runs are independent.
    case_draws: StrictBool = False
    #: Fields set in every run, by dotted path as ``--set`` takes them, any YAML value.
    set: dict[FieldPath, Any] = {}
    #: Structural alternatives; every case is run on every point of the grid and the samples.
    cases: list[CaseSpec] = []
    #: A sweep: every combination of the listed values of each field (dotted paths).
    grid: dict[FieldPath, Annotated[list[Any], Field(min_length=1)]] = {}
    #: Sampled points: their number, method, seed and each field's distribution.
    samples: SamplesSpec | None = None
    #: Seeds per point (each replicate its own seed).
    replicates: PositiveInt = 1
    #: The threshold multiples at which detection statistics are kept.
    diagnosis: DiagnosisStatsSpec = DiagnosisStatsSpec()
    #: What the report tabulates, compares and tests.
    report: ReportSpec = ReportSpec()

    @model_validator(mode="after")
    def _consistent(self) -> "CampaignSpec":
        sampled = set(self.samples.fields) if self.samples is not None else set()
        if self.samples is not None:
            for distribution in self.samples.fields.values():
                sampled |= set(distribution.also)
        for path in ("seed",):
            if path in self.grid or path in sampled:
                raise ValueError("seed cannot be swept or sampled: use replicates")
        both = sampled & set(self.grid)
        if both:
            raise ValueError(f"{sorted(both)[0]} is both in grid and in samples")
        labels = [case.label for case in self.cases]
        if len(set(labels)) != len(labels):
            raise ValueError("cases: two cases have the same label")
        for path, values in self.grid.items():
            if len({yaml.safe_dump(v) for v in values}) != len(values):
                raise ValueError(f"grid.{path}: a value is given twice")
        return self


def load_campaign(path: str | Path, runs: int | None = None) -> CampaignSpec:
    """Read and validate a campaign file; ``runs`` overrides ``samples.runs``.

    Raises:
        InputError: naming the file and the field.
    """
    file = str(path)
    raw = read_yaml_mapping(Path(path), "a campaign")
    spec = validate(CampaignSpec, raw, file)
    if runs is not None:
        if spec.samples is None:
            raise InputError(file, "--runs", "the campaign samples nothing: its population is its grid, cases "
                             "and replicates")
        if runs < 1:
            raise InputError(file, "--runs", f"must be at least 1, not {runs}")
        spec.samples.runs = runs
    return spec
