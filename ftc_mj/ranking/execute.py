"""Running a bench: what is missing becomes campaigns, run on one process pool; what is done is found again.

Layout of an output directory::

    OUT/runs/<task>/<robot>/<population>/<set>/   one campaign: stage.yaml, scenario.yaml, campaign.yaml,
                                                   entries.json and results/ (the campaign's directory)

A campaign holds the entries of one task, robot and population that were missing together when a bench
ran: as monitors of the reference loop (diagnosis: one simulation of the loop serves them all) or as
variants (tracking). ``entries.json`` names each entry by its identity (task and scenario section: method
and gains, not its name) and the protocol it ran under (the suite's protocol, faults, tier and robot, the
robot's resolved scenario and its model file's content). An entry is done on a robot when a finished
campaign (``results/campaign.json``) of the same protocol holds its identity; it is not simulated again,
whatever else the bench holds. A campaign's directory is named by its protocol and entries, so that an
interrupted bench resumes it (the campaign's resuming by run id) when run again with the same entries.

Run ids are the campaign's (:mod:`ftc_mj.campaign.population`): they depend on the run's values and seed
only, not on the entries, so that every campaign of a population has the same runs.
"""

from __future__ import annotations

import hashlib
import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import yaml

from ftc_mj.ranking import windows
from ftc_mj.config.errors import InputError
from ftc_mj.ranking.entries import Bench, Entry
from ftc_mj.ranking.suite import REFERENCE, TASKS
from ftc_mj.campaign import execute as campaign_execute
from ftc_mj.campaign.population import digest
from ftc_mj.outputs.files import parquet_bytes, write_atomic
from ftc_mj.robot.check import torque_limits


@dataclass
class Chunk:
    """One campaign: entries of one task, robot and population."""

    task: str
    robot: str
    population: str
    protocol: str
    directory: Path
    entries: list[Entry]
    #: Whether its runs are reduced to windows (suite v2's diagnosis, :mod:`ftc_mj.ranking.windows`), not rows.
    windowed: bool = False

    @property
    def results(self) -> Path:
        return self.directory / "results"


@dataclass(frozen=True)
class Found:
    """Where one entry's rows on one robot and population are: a finished campaign and the row's variant."""

    results: Path
    variant: str


def protocol_digest(bench: Bench, robot: str, task: str, population: str, tier: str) -> str:
    """What the runs of one population are made of, the entries aside."""
    suite = bench.suite
    resolved = suite.resolved[robot]
    model = (suite.scenarios[robot].parent / resolved["robot"]["model"]).resolve()
    robot_spec = suite.spec.robots[robot].model_dump(mode="json")
    content = {"version": suite.version, "protocol": suite.spec.protocol.model_dump(mode="json"),
               "faults": suite.spec.faults.model_dump(mode="json"),
               "tier": suite.tier(tier).model_dump(mode="json"),
               "robot": robot_spec, "task": task, "population": population,
               "scenario": resolved, "model": hashlib.sha256(model.read_bytes()).hexdigest() if model.is_file() else ""}
    if suite.calibrated:  # v2: a population's runs depend on its own seeds and run count, and its faults alone
        content["tier"] = {"duration": suite.tier(tier).duration, "runs": suite.runs(task, population, tier)}
        content["seeds"] = suite.spec.populations[population].model_dump(mode="json")
        content["sanity"] = suite.spec.calibration.oracle_noise * min(suite.spec.robots[robot].residual_unit or
                                                                      suite.spec.robots[robot].torque_scale)
        content["robot"] = {k: v for k, v in robot_spec.items() if k in ("scenario", "loop", "terms")}
        if task == "tracking":  # the plant's torque limits, the actuator faults acting after them
            content["torque_limit"] = robot_spec.get("torque_limit") or []
        if population == "faults":
            content["cases"] = suite.fault_cases(robot, task)
            if task == "diagnosis" and model.is_file() and np.isfinite(torque_limits(
                    mujoco.MjModel.from_xml_path(str(model)))).any():
                # Actuator faults act on what the limited motor gives (the runs before the fix gave a floating
                # joint commanded beyond its limit the excess with the opposite sign): those runs are redone.
                content["faults_after_torque_limit"] = True
            content["draws"] = "per case, seeds and mass scales"  # the campaign's case_draws
        else:
            content.pop("faults")
    return digest(content, 16)


def find_done(out: Path, task: str, robot: str, population: str, protocol: str) -> dict[str, Found]:
    """Identity -> where its rows are, over the finished campaigns of this protocol in ``out``.

    Raises:
        InputError: an ``entries.json`` or a finished ``runs.parquet`` that cannot be read (:func:`damaged`).
    """
    found: dict[str, Found] = {}
    for manifest in sorted((out / "runs" / task / robot / population).glob("*/entries.json")):
        results = manifest.parent / "results"
        reading = manifest
        try:
            content = json.loads(manifest.read_text(encoding="utf-8"))
            if content.get("protocol") != protocol or not any((results / name).is_file() for name in FINISHED):
                continue
            entries = dict(content["entries"])
            if (results / "campaign.json").is_file():
                reading = results / "runs.parquet"
                pq.read_metadata(reading)  # a truncated table fails here, before anything is simulated
        except (OSError, ValueError, KeyError, TypeError, AttributeError, pa.ArrowException) as error:
            raise damaged(reading, error) from None
        for identity, name in entries.items():
            found.setdefault(identity, Found(results, _variant(task, name, (results / WINDOWS).is_file())))
        for name in windows.SANITY:
            found.setdefault(name, Found(results, name))
    return found


#: What a finished chunk holds: a campaign's summary (rows) or the windows' reduction (suite v2's diagnosis).
FINISHED = ("campaign.json", WINDOWS := "windows.npz")


def damaged(path: Path, error: Exception) -> InputError:
    """The one-line error of a file of a bench's results that cannot be read: its campaign's folder is to be
    removed, and its runs are then simulated again."""
    folder = path.parent if path.name == "entries.json" else path.parent.parent
    reason = (getattr(error, "strerror", None) or str(error).strip().splitlines()[0]) if str(error).strip() \
        else type(error).__name__
    return InputError(str(path), "", f"cannot be read (truncated or damaged: {reason}): remove {folder} and run "
                      "the same command again (its runs are simulated again)")


def _variant(task: str, name: str, windowed: bool = False) -> str:
    return f"{REFERENCE}.{name}" if task == "diagnosis" and not windowed else name


def plan(bench: Bench, tier: str, out: Path, only: tuple[str, ...] | None = None
         ) -> tuple[dict[tuple[str, str, str, str], Found], list[Chunk]]:
    """What is done, by (task, robot, population, entry name), and the campaigns that make the rest (of the
    populations ``only``, by default all)."""
    done: dict[tuple[str, str, str, str], Found] = {}
    chunks = []
    for task in TASKS:
        entries = bench.of(task)
        if not entries:
            continue
        windowed = task == "diagnosis" and bench.suite.calibrated
        for robot in bench.suite.spec.robots:
            for population in bench.suite.populations(task):
                if only is not None and population not in only:
                    continue
                protocol = protocol_digest(bench, robot, task, population, tier)
                found = find_done(out, task, robot, population, protocol)
                missing = []
                for entry in entries:
                    where = found.get(entry.identity(robot))
                    if where is None:
                        missing.append(entry)
                    else:
                        done[task, robot, population, entry.name] = where
                if windowed and not missing and windows.SANITY[0] in found:
                    for name in windows.SANITY:
                        done[task, robot, population, name] = found[name]
                elif windowed and not missing:  # entries found (a chunk of rows?) but no sanity rows: none
                    missing = list(entries)
                if missing:
                    name = digest({"protocol": protocol, "entries": sorted(e.identity(robot) for e in missing)}, 12)
                    chunks.append(Chunk(task, robot, population, protocol,
                                        out / "runs" / task / robot / population / name, missing, windowed))
    return done, chunks


def write_chunk(bench: Bench, chunk: Chunk, tier: str) -> Path:
    """The campaign's files; its path."""
    suite, robot = bench.suite, chunk.robot
    if chunk.task == "diagnosis":
        variant = {**suite.loop(robot), "monitors": {e.name: e.sections[robot] for e in chunk.entries}}
        variants = {REFERENCE: variant}
    else:
        variants = {e.name: e.sections[robot] for e in chunk.entries}
    files = {
        "stage.yaml": suite.stage(robot),
        "scenario.yaml": suite.scenario(robot, chunk.task, tier, variants),
        "campaign.yaml": suite.campaign(robot, chunk.task, chunk.population, tier, list(variants)),
    }
    chunk.directory.mkdir(parents=True, exist_ok=True)
    for name, content in files.items():
        write_atomic(chunk.directory / name, yaml.safe_dump(content, sort_keys=False).encode())
    manifest = {"protocol": chunk.protocol, "entries": {e.identity(robot): e.name for e in chunk.entries}}
    write_atomic(chunk.directory / "entries.json", (json.dumps(manifest, indent=2) + "\n").encode())
    return chunk.directory / "campaign.yaml"


def run(bench: Bench, tier: str, out: Path, *, workers: int | None = None,
        progress: Callable[[int, int], None] = lambda done, total: None,
        only: tuple[str, ...] | None = None,
        planned: tuple[dict[tuple[str, str, str, str], Found], list[Chunk]] | None = None) -> dict[str, Any]:
    """Simulate what is missing into ``out`` (of the populations ``only``, by default all); what was done and
    simulated, and the wall time. ``planned``: :func:`plan`'s answer for the same arguments, made already."""
    start = time.perf_counter()
    done, chunks = plan(bench, tier, out, only) if planned is None else planned
    workers = workers or campaign_execute.default_workers()
    campaigns, tasks, owner = [], [], {}
    for chunk in chunks:
        campaign = campaign_execute.load(write_chunk(bench, chunk, tier))
        finished = (_windows_done(chunk.results) if chunk.windowed
                    else campaign_execute.prepare_directory(campaign, chunk.results))
        pending = [r for r in campaign.runs if r.run_id not in finished]
        for task in campaign_execute.tasks_for(campaign, pending, None, workers):
            owner[id(task)] = chunk
            tasks.append(task)
        campaigns.append((chunk, campaign))
    # The costliest batches first (members x joints x periods), so that the pool ends together.
    tasks.sort(key=lambda t: -len(t.runs) * _joints(bench, owner[id(t)].robot) * len(t.variants))
    total = sum(len(t.runs) for t in tasks)
    simulated = 0
    progress(0, total)
    batches: dict[bool, list] = {False: [], True: []}
    for task in tasks:
        batches[owner[id(task)].windowed].append(task)
    reductions = {id(t): _reduction(bench, owner[id(t)]) for t in batches[True]}
    streams = [campaign_execute.results(batches[False], workers, None)]
    for reduction, group in _by_reduction(batches[True], reductions):
        streams.append(campaign_execute.results(group, workers, None, partial(windows.run_windows,
                                                                              reduction=reduction)))
    for stream in streams:
        for task, rows in stream:
            chunk = owner[id(task)]
            if chunk.windowed:
                write_atomic(chunk.results / "parts" / f"{_part_name(task)}.npz", windows.save(rows))
            else:
                _write_part(chunk.results, task, rows)
            simulated += len(task.runs)
            progress(simulated, total)
    for chunk, campaign in campaigns:  # nothing left to simulate: runs.parquet and campaign.json
        if chunk.windowed:
            _collect_windows(chunk, campaign)
            for name in windows.SANITY:
                done.setdefault((chunk.task, chunk.robot, chunk.population, name), Found(chunk.results, name))
        else:
            campaign_execute.execute(campaign, chunk.results, workers=1)
        for entry in chunk.entries:
            done[chunk.task, chunk.robot, chunk.population, entry.name] = Found(chunk.results,
                                                                               _variant(chunk.task, entry.name,
                                                                                        chunk.windowed))
    return {"done": done, "campaigns": len(campaigns), "simulated_runs": total,
            "simulated_members": sum(len(t.runs) * len(t.variants) for t in tasks),
            "wall_time": time.perf_counter() - start}


def _joints(bench: Bench, robot: str) -> int:
    return bench.suite.joints(robot)


def _part_name(task: campaign_execute.Task) -> str:
    return task.runs[0][1] + "-" + task.runs[-1][1] + f"-{len(task.runs)}"


def _write_part(out: Path, task: campaign_execute.Task, rows: list[dict]) -> None:
    """One batch's rows, as the campaign writes them (its resuming reads the run ids of every part)."""
    write_atomic(out / "parts" / f"{_part_name(task)}.parquet", parquet_bytes(pa.Table.from_pylist(rows)))


# ------------------------------------------------------------------------------------ suite v2's windows


def _reduction(bench: Bench, chunk: Chunk) -> windows.Reduction:
    suite = bench.suite
    calibration, robot = suite.spec.calibration, suite.spec.robots[chunk.robot]
    dt = float(suite.resolved[chunk.robot].get("control_dt", 0.001))
    unit = min(robot.residual_unit or robot.torque_scale)
    return windows.Reduction(entries=tuple(e.name for e in chunk.entries),
                             oracle_noise=calibration.oracle_noise * unit,
                             block_samples=max(1, round(windows.BLOCK / dt)))


def _by_reduction(tasks: list, reductions: dict[int, windows.Reduction]) -> list[tuple[windows.Reduction, list]]:
    groups: dict[windows.Reduction, list] = {}
    for task in tasks:
        groups.setdefault(reductions[id(task)], []).append(task)
    return list(groups.items())


def _windows_done(results: Path) -> set[str]:
    """The run ids of a windows chunk's finished parts (an unreadable part is removed: simulated again)."""
    done: set[str] = set()
    (results / "parts").mkdir(parents=True, exist_ok=True)
    for part in sorted((results / "parts").glob("*.npz")):
        try:
            done.update(windows.load(part)["run_id"].tolist())
        except (OSError, ValueError, KeyError):
            part.unlink()
    return done


def _collect_windows(chunk: Chunk, campaign: campaign_execute.Campaign) -> None:
    """Every part of a windows chunk, in run order, with each run's case values, as ``windows.npz``."""
    parts = [windows.load(part) for part in sorted((chunk.results / "parts").glob("*.npz"))]
    write_atomic(chunk.results / WINDOWS, windows.save(merged_windows(parts, campaign)))


def merged_windows(parts: list[dict[str, Any]], campaign: campaign_execute.Campaign) -> dict[str, np.ndarray]:
    """Reductions of a campaign's batches (:func:`ftc_mj.ranking.windows.run_windows`) as one, in run order,
    with each run's draw, case values and mass scale, and the time grid (what
    :class:`~ftc_mj.ranking.calibrated.Population` reads)."""
    merged = {name: np.concatenate([part[name] for part in parts]) for name in parts[0]}
    order = np.argsort(merged["run"], kind="stable")
    merged = {name: values[order] for name, values in merged.items()}
    by_index = {run.index: run for run in campaign.runs}
    runs = [by_index[int(i)] for i in merged["run"]]
    # The draw a run shares with other runs (the clusters of the bootstrap): its sample, which every case of it
    # has; with each case its own draws (suite v2), the run itself.
    cases = 1 if campaign.spec.case_draws else max(1, len(campaign.spec.cases))
    merged["draw"] = np.array([run.index // cases for run in runs])
    for field in ("kind", "fault_size", "fault_joint", "onset"):
        values = [run.case_values.get(field) for run in runs]
        if any(v is not None for v in values):
            merged[f"case/{field}"] = np.array(values)
    merged["mass_scale"] = np.array([run.values.get("nominal.mass_scale", 1.0) for run in runs])
    merged["times"] = np.array([campaign.scenario.spec.control_dt, float(len(campaign.scenario.times))])
    return merged
