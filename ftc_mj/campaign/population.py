"""A campaign's population: cases x grid x samples x replicates, each run identified by its content.

Run k (0-based) is point ``(sample s, case c, grid point g, replicate r)`` with
``k = ((s C + c) G + g) R + r``, so the first N runs of a sampled campaign are its first N/(C G R) samples
whatever ``samples.runs``, and its seed is ``seed + s R + r``: the cases and the grid's points share seeds
(common random numbers: a sweep compares its points on the same noise), every sample and replicate has its own;
with ``case_draws`` it is ``seed + (s C + c) R + r`` and its sampled values are point s C + c: each case its
own draws, independent of the other cases'.

A run's fields split in two (:func:`ftc_mj.engine.batching.batchable`): what may differ between the members
of one batch (seed, initial states, parameters, mass scales, gains) and what is the batch's structure (a
fault's kind or onset, the sensors, ...). Runs with the same structure form a group: one compiled scenario,
its runs stepped together as members.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ftc_mj.campaign.schema import CampaignSpec, CaseSpec
from ftc_mj.engine.batching import batchable
from ftc_mj.scenario.definition import Scenario


@dataclass(frozen=True)
class Run:
    """One run of the population (all variants)."""

    index: int
    run_id: str
    seed: int
    #: The case's label (None without cases) and its report values.
    case: str | None
    case_values: dict[str, float | str]
    #: Every varied field (grid and samples) by dotted path, as set.
    values: dict[str, Any]
    #: What the batch's structure is made of: the campaign's ``set``, the case's and the structural values.
    structure: dict[str, Any] = field(hash=False)
    #: What its member of a batch gets: the batchable values and the seed.
    member: dict[str, Any] = field(hash=False)

    @property
    def group(self) -> str:
        """The key of the runs that share its structure (one scenario, one batch)."""
        return digest(self.structure)

    def columns(self) -> dict[str, Any]:
        """Its columns in ``runs.parquet``: the case, its values and every varied field (non-numbers as JSON)."""
        out: dict[str, Any] = {}
        if self.case is not None:
            out["case"] = self.case
        out.update(self.case_values)
        for path, value in self.values.items():
            out[path] = value if isinstance(value, (int, float, str)) and not isinstance(value, bool) else \
                json.dumps(value, sort_keys=True)
        return out

    def assignments(self) -> dict[str, Any]:
        """Every field this run sets, for a scenario of its own (:func:`ftc_mj.campaign.execute.replay_arguments`)."""
        return {**self.structure, **self.member}


def digest(content: Any, length: int = 12) -> str:
    text = json.dumps(content, sort_keys=True, separators=(",", ":"), default=float)
    return hashlib.sha256(text.encode()).hexdigest()[:length]


def unit_points(spec: CampaignSpec, count: int | None = None) -> np.ndarray:
    """The sampled points in the unit cube, ``(count, fields)`` (default ``samples.runs``); point s is the same
    whatever the count."""
    samples = spec.samples
    if samples is None:
        return np.zeros((1, 0))
    count = samples.runs if count is None else count
    d = len(samples.fields)
    if samples.method == "random":
        return np.array([np.random.default_rng(np.random.SeedSequence(samples.seed, spawn_key=(s,))).random(d)
                         for s in range(count)])
    # Imported here: scipy.stats costs a second to import, and a campaign's workers, which import this module
    # with the campaign's, never draw points.
    from scipy.stats import qmc

    engine = qmc.Sobol(d, scramble=True, seed=samples.seed) if samples.method == "sobol" else \
        qmc.Halton(d, scramble=True, seed=samples.seed)
    if samples.method == "sobol":
        # Sobol points come in powers of two for their balance; any prefix is still the same points.
        return engine.random_base2(max(0, math.ceil(math.log2(count))))[:count]
    return engine.random(count)


def population_size(spec: CampaignSpec) -> int:
    """The number of runs, without making them."""
    grid = math.prod(len(values) for values in spec.grid.values())
    samples = spec.samples.runs if spec.samples is not None else 1
    return samples * max(1, len(spec.cases)) * grid * spec.replicates


def population(spec: CampaignSpec, base_seed: int) -> list[Run]:
    """Every run of the campaign, in run order (see the module docstring)."""
    cases = spec.cases or [CaseSpec(label="_")]
    grid_paths = list(spec.grid)
    grid_points = list(itertools.product(*(spec.grid[path] for path in grid_paths))) or [()]
    sample_fields = list(spec.samples.fields.items()) if spec.samples is not None else []
    R, C, G = spec.replicates, len(cases), len(grid_points)
    samples = spec.samples.runs if spec.samples is not None else 1
    points = unit_points(spec, samples * C if spec.case_draws else None)
    also = {path: distribution.also for path, distribution in sample_fields}
    runs = []
    for s in range(samples):
        for c, case in enumerate(cases):
            draw = s * C + c if spec.case_draws else s
            u = points[draw]
            sampled = {path: distribution.value(float(x)) for (path, distribution), x in zip(sample_fields, u)}
            for g, point in enumerate(grid_points):
                values = {**dict(zip(grid_paths, point)), **sampled}
                for r in range(R):
                    seed = base_seed + draw * R + r
                    structure = {**spec.set, **case.set}
                    member: dict[str, Any] = {"seed": seed}
                    for path, value in values.items():
                        for target in (path, *also.get(path, ())):
                            (member if batchable(target) is not None else structure)[target] = value
                    label = case.label if spec.cases else None
                    content = {"set": spec.set, "case": case.set, "values": values, "seed": seed}
                    runs.append(Run(index=((s * C + c) * G + g) * R + r, run_id=digest(content), seed=seed,
                                    case=label, case_values=dict(case.values), values=values,
                                    structure=structure, member=member))
    return runs


def fingerprint(spec: CampaignSpec, scenario: Scenario) -> str:
    """What a results directory was made from: the campaign as resolved (but its number of sampled runs, which
    may grow, its description and report settings) and the base scenario as validated (with the campaign's
    ``set``; but its name, description, figures and output path, which change no run) with its robot file's
    content. A directory with another fingerprint holds another campaign."""
    content = spec.model_dump(mode="json")
    if content.get("samples"):
        content["samples"].pop("runs")
    content.pop("report")
    content.pop("description")
    if not content.get("case_draws"):  # the default: the fingerprint of a campaign written before the field
        content.pop("case_draws", None)
    content["scenario"] = scenario.spec.model_dump(mode="json", exclude={"name", "description", "figures", "output"})
    content["robot_file"] = hashlib.sha256(Path(scenario.model_path).read_bytes()).hexdigest()
    return digest(content, 24)
