"""The tuning file: which variant's gains to tune, within which bounds, on which population, for which cost,
under which constraints. Example::

    name: ch5_proposed
    campaign: ../campaigns/ch5_monte_carlo.yaml   # the population of conditions (its scenario, set, samples)
    variant: proposed
    duration: 20.0                 # optional: shorter runs than the campaign's
    conditions: 12                 # training: the population's first runs
    held_out: 64                   # the check: the runs after them (other seeds and draws)
    gains:                         # dotted paths of batchable gains, bounds, log scale where a gain spans decades
      variants.proposed.controller.gains.mu: {low: 0.05, high: 5.0, log: true}
    cost:
      weights: {rms_error_converged: 1.0, chattering: 0.1}   # each metric relative to the scenario's own gains
      aggregate: mean_cvar         # mean, or mean + CVaR of the worst `fraction` of the conditions
      fraction: 0.2
    constraints: {divergence: true, false_alarms: 0, detection_delay: 1.0}
    optimizer: {population: 8, generations: 10, sigma: 0.25, seed: 0}

A condition's cost is sum_m w_m * mean over joints of metric_m / the same with the scenario's gains on the same
condition: the scenario's gains cost sum_m w_m on every condition, and a cost below that is an improvement.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import Field, StrictBool, StrictInt, StrictStr, field_validator, model_validator

from ftc_mj.analysis.metrics import METRICS
from ftc_mj.campaign.schema import FieldPath, Name
from ftc_mj.engine.batching import batchable
from ftc_mj.config.errors import InputError, validate
from ftc_mj.config.yaml import read_yaml_mapping
from ftc_mj.config.types import NonNegativeFloat, PositiveFloat, Strict

PositiveInt = Annotated[StrictInt, Field(gt=0)]


class GainBounds(Strict):
    #: Lower bound of the search (the scenario's own gain must lie within the bounds).
    low: Annotated[float, Field(allow_inf_nan=False)]
    #: Upper bound of the search.
    high: Annotated[float, Field(allow_inf_nan=False)]
    #: Search the logarithm (a gain that spans decades); needs 0 < low.
    log: StrictBool = False

    @model_validator(mode="after")
    def _ordered(self) -> "GainBounds":
        if not (math.isfinite(self.low) and math.isfinite(self.high) and self.low < self.high):
            raise ValueError(f"low {self.low:g} must be below high {self.high:g}")
        if self.log and self.low <= 0:
            raise ValueError("a log-scale gain needs low > 0")
        return self

    def to_unit(self, value: float) -> float:
        if self.log:
            return (math.log(value) - math.log(self.low)) / (math.log(self.high) - math.log(self.low))
        return (value - self.low) / (self.high - self.low)

    def from_unit(self, u: float) -> float:
        u = min(max(u, 0.0), 1.0)
        if self.log:
            return math.exp(math.log(self.low) + u * (math.log(self.high) - math.log(self.low)))
        return self.low + u * (self.high - self.low)


class CostSpec(Strict):
    #: Metric -> weight; a condition costs the sum of weight x (metric's mean over the joints) / (the same with the
    #: scenario's gains).
    weights: Annotated[dict[StrictStr, PositiveFloat], Field(min_length=1)]
    #: ``mean`` over the conditions, or ``mean_cvar``: the mean plus the mean of the worst ``fraction``.
    aggregate: Literal["mean", "mean_cvar"] = "mean"
    #: The worst fraction of the conditions whose mean is CVaR.
    fraction: Annotated[float, Field(gt=0, le=1, allow_inf_nan=False)] = 0.2

    @field_validator("weights")
    @classmethod
    def _metrics(cls, weights: dict[str, float]) -> dict[str, float]:
        for metric in weights:
            if metric not in METRICS:
                raise ValueError(f"unknown metric {metric!r}")
        return weights


class ConstraintsSpec(Strict):
    #: No run may diverge.
    divergence: StrictBool = True
    #: At most this many false alarms in a run (all joints); none: not constrained.
    false_alarms: Annotated[StrictInt, Field(ge=0)] | None = None
    #: Every fault detected within this many seconds (a missed one violates it); none: not constrained.
    detection_delay: PositiveFloat | None = None


class OptimizerSpec(Strict):
    #: Candidates per generation (CMA-ES's lambda, at least 2: its update ranks candidates); default
    #: 4 + 3 ln(dimension).
    population: Annotated[StrictInt, Field(ge=2)] | None = None
    #: CMA-ES generations, each one batch of ``population`` candidates on the same conditions.
    generations: PositiveInt = 10
    #: Initial step size in the unit box of the bounds.
    sigma: Annotated[float, Field(gt=0, le=1, allow_inf_nan=False)] = 0.25
    #: The optimizer's seed (NumPy's RandomState, which takes 32 bits).
    seed: Annotated[StrictInt, Field(ge=0, le=2**32 - 1)] = 0
    #: Added to a candidate's cost per violating condition, as a share of the conditions (explicit penalty).
    penalty: NonNegativeFloat = 10.0


class TuningSpec(Strict):
    #: The tuning's name; the results directory defaults to ``results/tuning/<name>/``.
    name: Name
    #: Free text.
    description: str = ""
    #: A campaign file, relative to this one: its scenario, `set` and population are the conditions.
    campaign: StrictStr
    #: The scenario variant whose gains are tuned.
    variant: StrictStr
    #: Another duration for every run [s] (default: the campaign's).
    duration: PositiveFloat | None = None
    #: The first this many runs of the campaign's population train the gains.
    conditions: PositiveInt
    #: The next this many runs check the best gains against the scenario's.
    held_out: PositiveInt
    #: The tuned gains by dotted path (``variants.V.observer.gains.*``, ``.controller.gains.*``) with their bounds.
    gains: Annotated[dict[FieldPath, GainBounds], Field(min_length=1)]
    #: What a candidate's condition costs and how the conditions are aggregated.
    cost: CostSpec
    #: What a candidate may not do on a condition; each violation is penalised.
    constraints: ConstraintsSpec = ConstraintsSpec()
    #: CMA-ES's population, generations, step size, seed and penalty.
    optimizer: OptimizerSpec = OptimizerSpec()

    @model_validator(mode="after")
    def _batchable_gains(self) -> "TuningSpec":
        for path in self.gains:
            field = batchable(path)
            if field is None or field.kind != "gain" or field.role == "monitor" or field.variant != self.variant:
                raise ValueError(f"gains: {path} is not a gain of variant {self.variant} "
                                 f"(variants.{self.variant}.observer.gains.* or .controller.gains.*)")
        return self


def load_tuning(path: Path, generations: int | None = None, fields: dict[str, Any] | None = None) -> TuningSpec:
    """Read and validate a tuning file; ``generations`` overrides the optimizer's, ``fields`` (dotted path ->
    value: the command line's size options, e.g. ``optimizer.population``) the file's before validation."""
    file = str(path)
    raw = read_yaml_mapping(path, "a tuning")
    for dotted, value in (fields or {}).items():
        node = raw
        *parents, leaf = dotted.split(".")
        for part in parents:
            if not isinstance(node.get(part), dict):
                node[part] = {}
            node = node[part]
        node[leaf] = value
    spec = validate(TuningSpec, raw, file)
    if generations is not None:
        if generations < 1:
            raise InputError(file, "--generations", f"must be at least 1, not {generations}")
        spec.optimizer.generations = generations
    return spec
