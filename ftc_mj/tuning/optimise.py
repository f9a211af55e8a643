"""CMA-ES over a variant's gains on a population of conditions, then a held-out check.

One generation is one batch of members: every candidate on every training condition (common random numbers:
the same conditions, seeds and draws for each), stepped together by the campaign engine
(:func:`ftc_mj.campaign.execute.member_tasks`), locally or on a Dask cluster. The optimizer is ``cmaes``'s
``CMA`` (ask/tell, box bounds) on the unit box of the gains' bounds (log scale where asked); a candidate's
value is its cost plus an explicit penalty per condition that violates a constraint, never a dropped
candidate.

Resumable: after each generation ``history.parquet`` (every candidate: generation, its point, its gains, cost,
penalised cost, violations, mean metrics) and ``state.pkl`` (the optimizer and its random state) are written
atomically; the same command on the same directory rebuilds the optimizer by replaying the recorded
generations (asking with the same seed gives the same candidates, checked, and they are told their recorded
values), so a resumed tuning is the tuning that was not interrupted.
"""

from __future__ import annotations

import math
import pickle
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from cmaes import CMA

from ftc_mj.campaign import execute
from ftc_mj.campaign.population import Run, digest
from ftc_mj.campaign.schema import load_campaign
from ftc_mj.campaign.population import population_size
from ftc_mj.engine.members import members_from_overrides
from ftc_mj.config.errors import InputError
from ftc_mj.outputs.files import parquet_bytes, write_atomic
from ftc_mj.tuning.schema import TuningSpec, load_tuning
from ftc_mj.scenario.loading import UnknownVariant

#: A diverged condition's cost, as a multiple of the scenario's gains' cost (sum of the weights).
DIVERGED_COST = 10.0


@dataclass
class Tuning:
    path: Path
    spec: TuningSpec
    campaign: execute.Campaign
    training: list[Run]
    held_out: list[Run]
    paths: list[str]
    baseline: dict[str, float]  # the scenario's gains

    @property
    def dimension(self) -> int:
        return len(self.paths)

    def gains(self, unit: np.ndarray) -> dict[str, float]:
        return {path: self.spec.gains[path].from_unit(float(u)) for path, u in zip(self.paths, unit)}

    def unit(self, gains: dict[str, float]) -> np.ndarray:
        return np.array([self.spec.gains[path].to_unit(gains[path]) for path in self.paths])

    @property
    def fingerprint(self) -> str:
        return digest({"tuning": self.spec.model_dump(mode="json", exclude={"description"}) | {
            "optimizer": self.spec.optimizer.model_dump(exclude={"generations"})},
            "campaign": self.campaign.fingerprint}, 24)


def prepare(path: Path, generations: int | None = None, fields: dict[str, Any] | None = None,
            assignments: dict[str, Any] | None = None) -> Tuning:
    """Read the tuning file and its campaign, pick the training and held-out conditions, and check that the
    gains exist, that the scenario's own lie within the bounds, and that the bounds' corners are valid gains.

    ``fields`` override the tuning file's (:func:`~ftc_mj.tuning.schema.load_tuning`), ``assignments`` (scenario
    field -> value) join the campaign's ``set``: the command line's smoke-test options.

    Raises:
        InputError: naming the tuning file (or the campaign file) and the field.
    """
    file = str(path)
    spec = load_tuning(path, generations, fields)
    campaign_path = (path.parent / spec.campaign).resolve()
    if not campaign_path.is_file():
        raise InputError(file, "campaign", f"no such file: {spec.campaign}")
    need = spec.conditions + spec.held_out
    campaign_spec = load_campaign(campaign_path)
    runs = None
    if campaign_spec.samples is not None:
        per_sample = population_size(campaign_spec) // campaign_spec.samples.runs
        runs = math.ceil(need / per_sample)
    try:
        campaign = execute.load(campaign_path, runs=runs, variants=[spec.variant], duration=spec.duration,
                                assignments=assignments)
    except UnknownVariant as exc:
        raise InputError(file, "variant", f"unknown variant {exc.name!r} (the scenario's: {', '.join(exc.known)})") \
            from None
    if len(campaign.runs) < need:
        raise InputError(file, "held_out", f"the campaign has {len(campaign.runs)} runs, fewer than conditions + "
                         f"held_out = {need}")
    paths = list(spec.gains)
    documents = [campaign.scenario.written(), campaign.scenario.spec.model_dump(mode="json")]
    baseline = {}
    for gain in paths:
        value = execute.field_value(documents, gain)
        if not isinstance(value, (int, float)) or isinstance(value, bool):
            raise InputError(file, f"gains.{gain}", "is not a number of the scenario (a gain given per joint is "
                             "tuned by its elements, e.g. .0)")
        bounds = spec.gains[gain]
        if not bounds.low <= value <= bounds.high:
            raise InputError(file, f"gains.{gain}", f"the scenario's value {value:g} is outside [{bounds.low:g}, "
                             f"{bounds.high:g}]: the search must contain the gains it is compared with")
        baseline[gain] = float(value)
    tuning = Tuning(path, spec, campaign, campaign.runs[:spec.conditions], campaign.runs[spec.conditions:need],
                    paths, baseline)
    scenario = execute.compiled_scenario(str(campaign.scenario_path), (spec.variant,), campaign.spec.duration,
                                 execute.frozen(tuning.training[0].structure))
    for corner in (0.0, 1.0):
        gains = tuning.gains(np.full(tuning.dimension, corner))
        try:
            members_from_overrides(scenario, [{**tuning.training[0].member, **gains}])
        except InputError as exc:
            raise InputError(file, "gains", f"the {'lower' if corner == 0 else 'upper'} bounds are not valid gains: "
                             f"{exc.field}: {exc.problem.removeprefix('member 0: ')}") from None
    return tuning


# ------------------------------------------------------------------------------------------------ evaluation


@dataclass
class Evaluation:
    """Candidates x conditions: each metric's mean over the joints, divergence, false alarms, worst delay."""

    metrics: dict[str, np.ndarray]  # (candidates, conditions)
    diverged: np.ndarray
    false_alarms: np.ndarray
    worst_delay: np.ndarray  # over faulty joints; inf where one is missed; NaN without a fault


def evaluate(tuning: Tuning, candidates: list[dict[str, float]], conditions: list[Run], workers: int,
             scheduler: str | None) -> Evaluation:
    """Every candidate on every condition, as members of batches."""
    k = len(conditions)
    members = [(i * k + j, f"{i}-{run.run_id}", run, {**run.member, **gains})
               for i, gains in enumerate(candidates) for j, run in enumerate(conditions)]
    tasks = execute.member_tasks(tuning.campaign, members, None, workers, scheduler)
    shape = (len(candidates), k)
    metric_names = list(tuning.spec.cost.weights)
    metrics = {m: np.full(shape, np.nan) for m in metric_names}
    diverged = np.zeros(shape, dtype=bool)
    false_alarms = np.zeros(shape)
    worst_delay = np.full(shape, np.nan)
    n = tuning.campaign.n_joints
    end = tuning.campaign.scenario.spec.duration
    for _, rows in execute.results(tasks, workers, scheduler):
        for row in rows:
            if row["variant"] != tuning.spec.variant:
                continue  # a monitor's
            i, j = divmod(row["run"], k)
            diverged[i, j] = row["status"] != "ok"
            for m in metric_names:
                values = np.array([row[f"{m}.{q}"] for q in range(1, n + 1)], dtype=float)
                metrics[m][i, j] = np.nanmean(values) if np.isfinite(values).any() else np.nan
            false_alarms[i, j] = np.nansum([row[f"false_alarms.{q}"] for q in range(1, n + 1)])
            # A fault whose onset is after the run's end never acted: neither detected nor missed.
            faulty = [q for q in range(1, n + 1) if row[f"fault_onset.{q}"] < end]
            if faulty:
                delays = [row[f"detection_delay.{q}"] for q in faulty]
                worst_delay[i, j] = max(d if math.isfinite(d) else math.inf for d in delays)
    return Evaluation(metrics, diverged, false_alarms, worst_delay)


def condition_costs(tuning: Tuning, evaluation: Evaluation, base: Evaluation) -> np.ndarray:
    """Per candidate and condition: sum_m w_m metric_m / the scenario's gains' metric_m on that condition
    (a ratio where both are defined; 1 where the baseline's is not; a diverged condition costs
    :data:`DIVERGED_COST` times the sum of the weights)."""
    weights = tuning.spec.cost.weights
    total = np.zeros(evaluation.diverged.shape)
    for metric, weight in weights.items():
        value, reference = evaluation.metrics[metric], base.metrics[metric][:1]
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.where(np.isfinite(reference) & (reference > 0), value / reference, 1.0)
        ratio = np.where(np.isfinite(ratio), ratio, DIVERGED_COST)  # a metric the baseline has and this has not
        total += weight * ratio
    return np.where(evaluation.diverged, DIVERGED_COST * sum(weights.values()), total)


def aggregate(tuning: Tuning, costs: np.ndarray) -> np.ndarray:
    """Per candidate: the mean over conditions, plus CVaR (the mean of the worst ``fraction``) if asked."""
    mean = costs.mean(axis=1)
    if tuning.spec.cost.aggregate == "mean":
        return mean
    worst = max(1, math.ceil(tuning.spec.cost.fraction * costs.shape[1]))
    return mean + np.sort(costs, axis=1)[:, -worst:].mean(axis=1)


def violations(tuning: Tuning, evaluation: Evaluation) -> np.ndarray:
    """Per candidate and condition: whether a constraint is violated."""
    c = tuning.spec.constraints
    bad = evaluation.diverged.copy() if c.divergence else np.zeros_like(evaluation.diverged)
    if c.false_alarms is not None:
        bad |= evaluation.false_alarms > c.false_alarms
    if c.detection_delay is not None:
        with np.errstate(invalid="ignore"):
            bad |= np.isfinite(evaluation.worst_delay) & (evaluation.worst_delay > c.detection_delay)
        bad |= np.isinf(evaluation.worst_delay)
    return bad


# ------------------------------------------------------------------------------------------------ the loop


def _save_parquet(path: Path, rows: list[dict]) -> None:
    write_atomic(path, parquet_bytes(pa.Table.from_pylist(rows)))


def _load_rows(path: Path) -> list[dict]:
    return pq.read_table(path).to_pylist() if path.is_file() else []


def check_directory(tuning: Tuning, out: Path) -> None:
    """Refuse an ``out`` that holds anything but this tuning's results (its lock file aside).

    Raises:
        InputError: naming the tuning file and ``--out``.
    """
    marker = out / "fingerprint"
    if out.is_dir() and any(entry.name != execute.LOCK for entry in out.iterdir()):
        if not marker.is_file():
            raise InputError(str(tuning.path), "--out", f"{out} is not empty and holds no tuning's results")
        if marker.read_text().strip() != tuning.fingerprint:
            raise InputError(str(tuning.path), "--out", f"{out} holds another tuning (or this one before it "
                             "changed); choose another --out or remove it")


def _prepare_directory(tuning: Tuning, out: Path) -> None:
    check_directory(tuning, out)
    marker = out / "fingerprint"
    out.mkdir(parents=True, exist_ok=True)
    if not marker.is_file():
        write_atomic(marker, (tuning.fingerprint + "\n").encode())


def _evaluation_rows(evaluation: Evaluation) -> list[dict]:
    """An evaluation as rows (candidate, condition), to save and to rebuild it on resuming."""
    rows = []
    for (i, j), diverged in np.ndenumerate(evaluation.diverged):
        rows.append({"candidate": i, "condition": j, "diverged": bool(diverged),
                     "false_alarms": float(evaluation.false_alarms[i, j]),
                     "worst_delay": float(evaluation.worst_delay[i, j]),
                     **{m: float(v[i, j]) for m, v in evaluation.metrics.items()}})
    return rows


def _evaluation_from_rows(rows: list[dict], metrics: list[str]) -> Evaluation:
    shape = (max(r["candidate"] for r in rows) + 1, max(r["condition"] for r in rows) + 1)
    out = Evaluation({m: np.full(shape, np.nan) for m in metrics}, np.zeros(shape, dtype=bool), np.zeros(shape),
                     np.full(shape, np.nan))
    for r in rows:
        i, j = r["candidate"], r["condition"]
        out.diverged[i, j], out.false_alarms[i, j], out.worst_delay[i, j] = r["diverged"], r["false_alarms"], \
            r["worst_delay"]
        for m in metrics:
            out.metrics[m][i, j] = r[m]
    return out


def _cached_evaluation(tuning: Tuning, path: Path, candidates: list[dict[str, float]], conditions: list[Run],
                       workers: int, scheduler: str | None) -> Evaluation:
    """An evaluation saved in ``path`` (from an earlier, interrupted call), or made and saved."""
    metrics = list(tuning.spec.cost.weights)
    if path.is_file():
        return _evaluation_from_rows(_load_rows(path), metrics)
    evaluation = evaluate(tuning, candidates, conditions, workers, scheduler)
    _save_parquet(path, _evaluation_rows(evaluation))
    return evaluation


def optimise(tuning: Tuning, out: Path, *, workers: int | None = None, scheduler: str | None = None,
             progress: Callable[[int, int, float], None] = lambda generation, total, best: None) -> dict[str, Any]:
    """Run (or resume) the tuning into ``out``; returns the report document (also written as report.json)."""
    workers = workers or (execute.default_workers() if scheduler is None else 1)
    _prepare_directory(tuning, out)
    start = time.perf_counter()
    spec = tuning.spec
    base = _cached_evaluation(tuning, out / "baseline.parquet", [tuning.baseline], tuning.training, workers, scheduler)
    # With two candidates a generation (one parent) CMA-ES's rank-mu learning rate is 0, and cmaes divides by it
    # in a minimum of three bounds (eq. 50 of Hansen's tutorial) that the two finite ones then decide: the
    # infinity is harmless, its RuntimeWarning is not the user's business.
    with np.errstate(divide="ignore"):
        optimizer = CMA(mean=tuning.unit(tuning.baseline), sigma=spec.optimizer.sigma,
                        bounds=np.array([[0.0, 1.0]] * tuning.dimension), seed=spec.optimizer.seed,
                        population_size=spec.optimizer.population)
    history = _load_rows(out / "history.parquet")
    evaluations = len(tuning.training)
    for generation in range(spec.optimizer.generations):
        points = [optimizer.ask() for _ in range(optimizer.population_size)]
        recorded = [row for row in history if row["generation"] == generation]
        if recorded:  # replay: the same candidates, told their recorded values
            stored = np.array([[row[f"x.{p}"] for p in tuning.paths] for row in recorded])
            if not np.array_equal(stored, np.array(points)):
                raise InputError(str(tuning.path), "--out", "the recorded generations do not replay (another "
                                 "cmaes version?); remove the directory to start again")
            optimizer.tell([(x, row["penalised"]) for x, row in zip(points, recorded)])
            continue
        candidates = [tuning.gains(x) for x in points]
        evaluation = evaluate(tuning, candidates, tuning.training, workers, scheduler)
        evaluations += len(candidates) * len(tuning.training)
        costs = condition_costs(tuning, evaluation, base)
        cost = aggregate(tuning, costs)
        violated = violations(tuning, evaluation).sum(axis=1)
        penalised = cost + spec.optimizer.penalty * violated / len(tuning.training)
        optimizer.tell([(x, float(v)) for x, v in zip(points, penalised)])
        for i, (x, gains) in enumerate(zip(points, candidates)):
            history.append({"generation": generation, "candidate": i, **{f"x.{p}": float(u) for p, u in zip(tuning.paths, x)},
                            **gains, "cost": float(cost[i]), "penalised": float(penalised[i]),
                            "violations": int(violated[i]),
                            **{f"mean.{m}": float(np.nanmean(v[i])) if np.isfinite(v[i]).any() else math.nan
                               for m, v in evaluation.metrics.items()}})
        _save_parquet(out / "history.parquet", history)
        state = {"optimizer": optimizer, "rng": optimizer._rng.get_state(), "generation": generation}
        write_atomic(out / "state.pkl", pickle.dumps(state))
        best = min(row["penalised"] for row in history)
        progress(generation + 1, spec.optimizer.generations, best)
    tuning_seconds = time.perf_counter() - start

    best_row = min(history, key=lambda row: (row["violations"] > 0, row["penalised"]))
    best_gains = {p: best_row[p] for p in tuning.paths}
    held_start = time.perf_counter()
    held = _cached_evaluation(tuning, out / f"held_out-{digest(best_gains)}.parquet", [tuning.baseline, best_gains],
                              tuning.held_out, workers, scheduler)
    held_seconds = time.perf_counter() - held_start
    return {"best_row": best_row, "best_gains": best_gains, "held": held, "history": history,
            "tuning_seconds": tuning_seconds, "held_seconds": held_seconds, "evaluations": evaluations,
            "workers": workers, "scheduler": scheduler or "local"}
