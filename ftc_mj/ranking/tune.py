"""Tuning a bench's diagnosis entries on its suite's ``tune`` population (``ftc-mj tune`` on a bench tuning file).
Example::

    name: v2_quick
    bench: ../ftc_mj/ranking/suites/v2-entries.yaml   # the entries' bench file (relative to this one)
    tier: quick                    # the tier whose tune_runs are the tuning's draws
    robots: [two_link, puma560]    # default: every robot of the suite
    entries:                       # diagnosis entries of the bench; their gains there are the search's centre
      hs_tosmo: {gains: {D: {factor: 4}, gamma: {factor: 10}}}
      ndob: {gains: {X: {factor: 10}}}          # a per-joint gain: one common multiplier (per_joint: false)
    optimizer: {population: 6, generations: 6, sigma: 0.3, seed: 0}

**Objective**, the leaderboard's statistic on the ``tune`` population alone (:mod:`ftc_mj.ranking.calibrated`):
per robot, each of the tier's ``tune_runs`` draws (seed ``tune.seed + s``, the controller's mass scale from
``tune.sobol_seed``'s Sobol point s) is run healthy and under fault case ``s mod C`` of the suite's library
(its C cases in the suite's order); each candidate's thresholds are calibrated on the healthy runs' windows at
the suite's common false-alarm probability, and its value is P_d (the share of the faulty windows over their
thresholds) + AUC / (faulty windows + 1): AUC only breaks ties, since P_d moves in steps of one window and the
AUC term is below one step.

**Search**: CMA-ES (``cmaes``) per entry and robot over the unit box of log-scale bounds
[g / factor, g x factor] around the entry's gains g in the bench file (the design rule's), started at them. A
per-joint gain is one common multiplier of the design vector unless ``per_joint``. The tuned gains are the best
candidate's of all generations; the design gains' own value is measured beside (they stay if nothing beats them).

**Cost**: a monitor never acts on the plant, so each generation is one set of runs per robot (``2 x tune_runs``
reference-loop runs) whose monitors are every candidate of every entry, and the design gains once: the budget,
the same for every entry, is candidates x generations on those runs.

The output ``tuned.yaml`` (:func:`record`) holds the tuned and design gains per entry and robot, their objective
values, the budget and every seed the runs used: a bench entry's ``tuned_with`` names it, and the bench refuses
it when a seed is one the suite scores or calibrates on (:func:`ftc_mj.ranking.entries.check_tuning_seeds`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Annotated, Any, Callable

import numpy as np
import yaml
from pydantic import Field, StrictBool, StrictInt, StrictStr

from ftc_mj.campaign import execute as campaign_execute
from ftc_mj.campaign.population import Run
from ftc_mj.config.errors import InputError, validate
from ftc_mj.config.types import Strict
from ftc_mj.config.yaml import read_yaml_mapping
from ftc_mj.outputs.files import write_atomic
from ftc_mj.ranking import calibrated as cal
from ftc_mj.ranking import windows
from ftc_mj.ranking.execute import merged_windows
from ftc_mj.ranking.entries import TUNING_RECORD, Bench, load_bench, method_section
from ftc_mj.ranking.score import mann_whitney
from ftc_mj.ranking.sizing import ACTS
from ftc_mj.ranking.suite import REFERENCE, Name

PositiveInt = Annotated[StrictInt, Field(gt=0)]
#: The healthy case's kind in the tune population's campaign.
HEALTHY = "healthy"


class SearchSpec(Strict):
    #: The search spans [g / factor, g x factor] in log scale around the design gain g.
    factor: Annotated[float, Field(gt=1, allow_inf_nan=False)]
    #: A per-joint gain: each element its own search (true) or one common multiplier of the vector (false).
    per_joint: StrictBool = False


class EntrySearch(Strict):
    #: The entry's gains to tune, by name in its gains mapping, with their search.
    gains: Annotated[dict[StrictStr, SearchSpec], Field(min_length=1)]


class OptimizerSpec(Strict):
    #: Candidates per generation and entry (CMA-ES's lambda).
    population: Annotated[StrictInt, Field(ge=2)] = 6
    #: Generations: each one set of 2 x tune_runs reference-loop runs per robot.
    generations: PositiveInt = 6
    #: Initial step size in the unit box of the bounds (the design gains at its centre).
    sigma: Annotated[float, Field(gt=0, le=1, allow_inf_nan=False)] = 0.3
    #: The optimizer's seed.
    seed: Annotated[StrictInt, Field(ge=0, le=2**32 - 1)] = 0


class BenchTuningSpec(Strict):
    #: The tuning's name; the results directory defaults to ``results/tuning/<name>/``.
    name: Name
    #: Free text.
    description: str = ""
    #: The bench file whose diagnosis entries are tuned, relative to this file (default: the shipped one).
    bench: StrictStr | None = None
    #: The suite's tier whose ``tune_runs`` are the draws.
    tier: StrictStr = "quick"
    #: Robots of the suite to tune on (default: all).
    robots: list[StrictStr] | None = None
    #: Diagnosis entries of the bench, each with the gains to tune.
    entries: Annotated[dict[Name, EntrySearch], Field(min_length=1)]
    #: CMA-ES's budget, the same for every entry.
    optimizer: OptimizerSpec = OptimizerSpec()


def is_bench_tuning(raw: dict[str, Any]) -> bool:
    """Whether a tuning file's mapping is a bench tuning's (it names entries), not a campaign tuning's."""
    return "entries" in raw and "campaign" not in raw


@dataclass
class Dimension:
    """One coordinate of an entry's search: a gain (an element of it, or the whole vector) and its bounds."""

    gain: str
    element: int | None  # None: the scalar, or the vector's common multiplier
    factor: float

    def multiplier(self, u: float) -> float:
        """The unit coordinate ``u`` (0.5: the design gain) as the multiplier of the design value."""
        return math.exp((2.0 * min(max(u, 0.0), 1.0) - 1.0) * math.log(self.factor))


@dataclass
class Search:
    """One entry's CMA-ES on one robot."""

    entry: str
    robot: str
    kind: str
    design: dict[str, Any]
    dimensions: list[Dimension]
    optimizer: Any = None
    history: list[dict[str, Any]] = field(default_factory=list)
    design_value: dict[str, float] = field(default_factory=dict)

    def gains(self, unit: np.ndarray) -> dict[str, Any]:
        out = {name: (list(value) if isinstance(value, list) else value) for name, value in self.design.items()}
        for u, dim in zip(unit, self.dimensions):
            m = dim.multiplier(float(u))
            value = out[dim.gain]
            if isinstance(value, list):
                if dim.element is None:
                    out[dim.gain] = [float(f"{v * m:.6g}") for v in value]
                else:
                    value[dim.element] = float(f"{value[dim.element] * m:.6g}")
            else:
                out[dim.gain] = float(f"{value * m:.6g}")
        return out

    @property
    def best(self) -> dict[str, Any]:
        """The best candidate of every generation; the design gains when none beats them."""
        best = max(self.history, key=lambda row: row["value"], default=None)
        if best is None or best["value"] <= self.design_value["value"]:
            return {"gains": self.design, **self.design_value, "generation": None}
        return best


@dataclass
class Tuning:
    path: Path
    spec: BenchTuningSpec
    bench: Bench
    robots: list[str]
    searches: list[Search]
    #: Robot -> reference-loop runs that diverged (left out of the objective, as the leaderboard does).
    diverged: dict[str, int] = field(default_factory=dict)

    @property
    def draws(self) -> int:
        return self.bench.suite.tier(self.spec.tier).tune_runs

    def seeds(self) -> list[int]:
        """Every seed the tuning's runs use: the tune population's first ``tune_runs``."""
        first = self.bench.suite.spec.populations["tune"].seed
        return list(range(first, first + self.draws))


def load(path: Path, generations: int | None = None, population: int | None = None) -> Tuning:
    """Read a bench tuning file, its bench and suite; check the entries, the gains and the bounds' corners.

    Raises:
        InputError: naming the tuning file (or the bench file) and the field.
    """
    file = str(path)
    raw = read_yaml_mapping(path, "a tuning")
    spec = validate(BenchTuningSpec, raw, file)
    for option, value, target in (("--generations", generations, "generations"),
                                  ("--population", population, "population")):
        if value is not None:
            if value < (2 if target == "population" else 1):
                raise InputError("command line", option, f"must be at least {2 if target == 'population' else 1}, "
                                 f"not {value}")
            setattr(spec.optimizer, target, value)
    bench_path = (path.parent / spec.bench).resolve() if spec.bench is not None else None
    if bench_path is not None and not bench_path.is_file():
        raise InputError(file, "bench", f"no such file: {spec.bench}")
    bench = load_bench(bench_path)
    suite = bench.suite
    if not suite.calibrated:
        raise InputError(file, "bench", f"its suite {suite.version} has no calibration (a tuning on P_d at the "
                         "common false-alarm probability needs suite v2's windows)")
    tier = suite.tier(spec.tier)
    if tier.tune_runs < 2:
        raise InputError(file, "tier", f"the suite's tier {spec.tier!r} has {tier.tune_runs} tune_runs: at least 2")
    if "tune" not in suite.spec.populations:
        raise InputError(file, "bench", f"its suite {suite.version} has no tune population")
    robots = spec.robots if spec.robots is not None else list(suite.spec.robots)
    for index, robot in enumerate(robots):
        if robot not in suite.spec.robots:
            raise InputError(file, f"robots.{index}", f"{robot!r} is not a robot of the suite {suite.version} (its "
                             f"robots: {', '.join(suite.spec.robots)})")
    named = {e.name: e for e in bench.of("diagnosis")}
    searches = []
    for name, entry_search in spec.entries.items():
        if name not in named:
            raise InputError(file, f"entries.{name}", f"not a diagnosis entry of {bench.path.name} (its entries: "
                             f"{', '.join(named)})")
        entry = named[name]
        for robot in robots:
            section = entry.sections[robot]
            design = section["gains"]
            dimensions = []
            for gain, search in entry_search.gains.items():
                value = design.get(gain)
                values = value if isinstance(value, list) else [value]
                if not all(isinstance(v, (int, float)) and not isinstance(v, bool) and v > 0 for v in values):
                    raise InputError(file, f"entries.{name}.gains.{gain}", f"the entry's {gain} on {robot} is "
                                     f"{value!r}: a positive number (or one per joint) is tuned in log scale")
                if isinstance(value, list) and search.per_joint:
                    dimensions += [Dimension(gain, j, search.factor) for j in range(len(value))]
                else:
                    dimensions.append(Dimension(gain, None, search.factor))
            found = Search(name, robot, section["type"], design, dimensions)
            for corner in (0.0, 1.0):
                gains = found.gains(np.full(len(dimensions), corner))
                try:
                    method_section(str(bench.path), f"diagnosis.{name}.type", f"diagnosis.{name}.gains.{robot}",
                                   "observer", section["type"], gains, suite.joints(robot))
                except InputError as exc:
                    raise InputError(file, f"entries.{name}.gains", f"the {'lower' if corner == 0 else 'upper'} "
                                     f"bounds on {robot} are not valid gains: {exc.problem}") from None
            searches.append(found)
    return Tuning(path, spec, bench, robots, searches)


# ------------------------------------------------------------------------------------------------ the runs


def _campaign(tuning: Tuning, robot: str, variants: list[str]) -> dict[str, Any]:
    """The tune population as a campaign: the healthy case and the suite's fault cases on common draws (the
    tuning picks, per draw, the healthy run and one fault case's)."""
    suite = tuning.bench.suite
    seeds, (low, high) = suite.spec.populations["tune"], suite.spec.protocol.mass_scale
    healthy = {"label": "healthy", "values": {"kind": HEALTHY, "fault_size": 0.0, "fault_joint": 0, "onset": 0.0},
               "set": {"actuator_faults": []}}
    return {"name": f"tune_{suite.version}_{tuning.spec.tier}_{robot}", "scenario": "scenario.yaml",
            "variants": variants, "seed": seeds.seed,
            "samples": {"runs": tuning.draws, "method": "sobol", "seed": seeds.sobol_seed,
                        "fields": {"nominal.mass_scale": {"uniform": [low, high]}}},
            "cases": [healthy] + suite.fault_cases(robot, "diagnosis"),
            "diagnosis": {"threshold_scales": [1.0]}, "report": {"metrics": ["rms_error_converged"]}}


def chosen_runs(runs: list[Run], draws: int, cases: int) -> list[Run]:
    """Per draw s: its healthy run (case 0) and its run of fault case 1 + (s mod ``cases``)."""
    per_draw = cases + 1
    return [runs[s * per_draw + c] for s in range(draws) for c in (0, 1 + s % cases)]


def _write(folder: Path, files: dict[str, Any]) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    for name, content in files.items():
        write_atomic(folder / name, yaml.safe_dump(content, sort_keys=False).encode())


def _reduction(tuning: Tuning, robot: str, monitors: tuple[str, ...]) -> windows.Reduction:
    suite = tuning.bench.suite
    spec = suite.spec.robots[robot]
    dt = float(suite.resolved[robot].get("control_dt", 0.001))
    unit = min(spec.residual_unit or spec.torque_scale)
    return windows.Reduction(entries=monitors, oracle_noise=suite.spec.calibration.oracle_noise * unit,
                             block_samples=max(1, round(windows.BLOCK / dt)))


def _reduce(task: campaign_execute.Task, reductions: dict[str, windows.Reduction]) -> dict[str, Any]:
    """A batch's windows reduction, with its robot's (a generation's batches of every robot on one pool)."""
    return windows.run_windows(task, reductions[task.scenario])


def objective(name: str, healthy: cal.Population, faulty: cal.Population, layers: list[cal.Stratum], alpha: float,
              acts_at: float) -> dict[str, float]:
    """P_d at thresholds calibrated on ``healthy`` (the tune population's healthy runs) on ``faulty``'s windows,
    the AUC, and the value CMA-ES maximises: P_d + AUC / (faulty windows + 1) (the AUC breaks P_d's ties)."""
    with np.errstate(invalid="ignore", divide="ignore"):  # a diverging candidate's inf / inf: not detected
        w, _ = cal.windows(name, healthy, healthy, faulty, layers, alpha, acts_at)
    pd = float(np.mean(w.fault_z > 1.0)) if w.fault_z.size else 0.0
    auc = mann_whitney(w.healthy_z, w.fault_z) if w.healthy_z.size and w.fault_z.size else 0.5
    return {"pd": pd, "auc": float(auc), "value": pd + float(auc) / (w.fault_z.size + 1)}


def split(merged: dict[str, np.ndarray], healthy: np.ndarray) -> tuple[cal.Population, cal.Population]:
    """The healthy and the faulty runs of a merged windows reduction, as populations."""
    def take(mask: np.ndarray, cases: bool) -> cal.Population:
        data = {key: (values[mask] if key != "times" else values) for key, values in merged.items()
                if cases or not key.startswith("case/")}
        return cal.Population.of(data)

    return take(healthy, False), take(~healthy, True)


def optimise(tuning: Tuning, out: Path, workers: int,
             progress: Callable[[int, int, float], None] = lambda generation, total, seconds: None) -> dict[str, Any]:
    """Run the generations into ``out``; the record (also written as ``out/tuned.yaml``)."""
    from cmaes import CMA

    spec, suite = tuning.spec, tuning.bench.suite
    out.mkdir(parents=True, exist_ok=True)
    calibration = suite.spec.calibration
    for index, search in enumerate(tuning.searches):
        search.optimizer = CMA(mean=np.full(len(search.dimensions), 0.5), sigma=spec.optimizer.sigma,
                               bounds=np.tile([0.0, 1.0], (len(search.dimensions), 1)),
                               seed=spec.optimizer.seed + index, population_size=spec.optimizer.population)
    start, cpu = time.perf_counter(), _cpu_seconds()
    generations = spec.optimizer.generations
    for generation in range(generations):
        tasks, owners, asked = [], {}, {}
        for robot in tuning.robots:
            monitors: dict[str, dict[str, Any]] = {}
            for search in (s for s in tuning.searches if s.robot == robot):
                points = [search.optimizer.ask() for _ in range(spec.optimizer.population)]
                asked[search.entry, robot] = points
                for i, point in enumerate(points):
                    monitors[f"{search.entry}-c{i}"] = {"type": search.kind, "gains": search.gains(point)}
                if generation == 0:  # the design gains once: the runs are the same draws every generation
                    monitors[f"{search.entry}-design"] = {"type": search.kind, "gains": search.design}
            folder = out / "runs" / robot / f"g{generation:02d}"
            variants = {REFERENCE: {**suite.loop(robot), "monitors": monitors}}
            _write(folder, {"stage.yaml": suite.stage(robot),
                            "scenario.yaml": suite.scenario(robot, "diagnosis", spec.tier, variants),
                            "campaign.yaml": _campaign(tuning, robot, [REFERENCE])})
            campaign = campaign_execute.load(folder / "campaign.yaml")
            cases = len(campaign.spec.cases) - 1
            runs = chosen_runs(campaign.runs, tuning.draws, cases)
            reduction = _reduction(tuning, robot, tuple(monitors))
            for task in campaign_execute.tasks_for(campaign, runs, None, workers):
                owners[id(task)] = (robot, campaign, reduction)
                tasks.append(task)
        parts: dict[str, list] = {robot: [] for robot in tuning.robots}
        reductions = {task.scenario: owners[id(task)][2] for task in tasks}
        for task, reduced in campaign_execute.results(tasks, workers, None, partial(_reduce, reductions=reductions)):
            parts[owners[id(task)][0]].append(reduced)
        for robot in tuning.robots:
            campaign = next(owner[1] for owner in owners.values() if owner[0] == robot)
            merged = merged_windows(parts[robot], campaign)
            healthy_pop, faulty_pop = split(merged, merged["case/kind"] == HEALTHY)
            spec_robot = suite.spec.robots[robot]
            layers = cal.strata(suite.spec.protocol.onsets, spec_robot.fault_joints, calibration.windows)
            acts_at = ACTS * min(spec_robot.residual_unit or spec_robot.torque_scale)
            for search in (s for s in tuning.searches if s.robot == robot):
                if generation == 0:
                    search.design_value = objective(f"{search.entry}-design", healthy_pop, faulty_pop, layers,
                                                    calibration.false_alarm, acts_at)
                told = []
                for i, point in enumerate(asked[search.entry, robot]):
                    value = objective(f"{search.entry}-c{i}", healthy_pop, faulty_pop, layers,
                                      calibration.false_alarm, acts_at)
                    search.history.append({"generation": generation, "candidate": i, "point": point.tolist(),
                                           "gains": search.gains(point), **value})
                    told.append((point, -value["value"]))
                search.optimizer.tell(told)
            tuning.diverged[robot] = healthy_pop.diverged + faulty_pop.diverged
        progress(generation + 1, generations, time.perf_counter() - start)
        write_atomic(out / "history.yaml", yaml.safe_dump(_history(tuning), sort_keys=False).encode())
        # The record so far after every generation: a tuning stopped early leaves the best of the generations run.
        document = record(tuning, time.perf_counter() - start, _cpu_seconds() - cpu, generation + 1)
        write_record(out, document)
    return document


def write_record(out: Path, document: dict[str, Any]) -> None:
    write_atomic(out / "tuned.yaml", yaml.safe_dump(document, sort_keys=False, width=120).encode())


def _cpu_seconds() -> float:
    """CPU time of this process and of its finished workers (each generation's pool is joined) [s]."""
    import resource

    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def _history(tuning: Tuning) -> list[dict[str, Any]]:
    return [{"entry": s.entry, "robot": s.robot, **row} for s in tuning.searches for row in s.history]


def budget(tuning: Tuning, generations: int | None = None) -> dict[str, int]:
    """The budget, the same for every entry: candidates x generations on 2 x tune_runs runs per robot (the
    generations run so far, or the file's)."""
    optimizer = tuning.spec.optimizer
    generations = optimizer.generations if generations is None else generations
    runs = 2 * tuning.draws
    return {"candidates": optimizer.population, "generations": generations, "runs": runs,
            "draws": tuning.draws, "monitor_runs_per_entry_and_robot": optimizer.population * generations * runs,
            "simulations": generations * runs * len(tuning.robots)}


def budget_text(tuning: Tuning, generations: int | None = None) -> str:
    b = budget(tuning, generations)
    return (f"CMA-ES, {b['candidates']} candidates x {b['generations']} generations x {b['runs']} runs (the tune "
            f"population's {b['draws']} draws, healthy and faulty)")


def record(tuning: Tuning, seconds: float, cpu_seconds: float, generations: int) -> dict[str, Any]:
    """The tuned gains file: what ``tuned_with`` names (its ``seeds`` are checked against the scored ones)."""
    suite = tuning.bench.suite
    tune = suite.spec.populations["tune"]
    entries: dict[str, Any] = {}
    for search in tuning.searches:
        best = search.best
        mine = entries.setdefault(search.entry, {"type": search.kind, "gains": dict(tuning.spec.entries[
            search.entry].model_dump(mode="json")["gains"]), "design": {}, "tuned": {}, "objective": {}})
        mine["design"][search.robot] = search.design
        mine["tuned"][search.robot] = best["gains"]
        mine["objective"][search.robot] = {
            "design": {k: round(search.design_value[k], 4) for k in ("pd", "auc")},
            "tuned": {k: round(best[k], 4) for k in ("pd", "auc")},
            "generation": best["generation"]}
    return {"kind": TUNING_RECORD, "name": tuning.spec.name, "suite": suite.version, "tier": tuning.spec.tier,
            "bench": tuning.bench.path.name, "robots": tuning.robots,
            "objective": f"P_d at the common false-alarm probability {suite.spec.calibration.false_alarm:g} per "
                         "window and joint (thresholds calibrated on the tune population's healthy runs) + AUC / "
                         "(faulty windows + 1)",
            "budget": {**budget(tuning, generations), "text": budget_text(tuning, generations)},
            "population": "tune", "seeds": tuning.seeds(), "sobol_seed": tune.sobol_seed,
            "seconds": round(seconds, 1), "cpu_seconds": round(cpu_seconds, 1),
            "entries": entries}
