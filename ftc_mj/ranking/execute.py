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
from pathlib import Path
from typing import Any

import pyarrow as pa
import yaml

from ftc_mj.ranking.entries import Bench, Entry
from ftc_mj.ranking.suite import POPULATIONS, REFERENCE, TASKS
from ftc_mj.campaign import execute as campaign_execute
from ftc_mj.campaign.population import digest
from ftc_mj.outputs.files import parquet_bytes, write_atomic


@dataclass
class Chunk:
    """One campaign: entries of one task, robot and population."""

    task: str
    robot: str
    population: str
    protocol: str
    directory: Path
    entries: list[Entry]

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
    content = {"version": suite.version, "protocol": suite.spec.protocol.model_dump(mode="json"),
               "faults": suite.spec.faults.model_dump(mode="json"),
               "tier": suite.tier(tier).model_dump(mode="json"),
               "robot": suite.spec.robots[robot].model_dump(mode="json"), "task": task, "population": population,
               "scenario": resolved, "model": hashlib.sha256(model.read_bytes()).hexdigest() if model.is_file() else ""}
    return digest(content, 16)


def find_done(out: Path, task: str, robot: str, population: str, protocol: str) -> dict[str, Found]:
    """Identity -> where its rows are, over the finished campaigns of this protocol in ``out``."""
    found: dict[str, Found] = {}
    for manifest in sorted((out / "runs" / task / robot / population).glob("*/entries.json")):
        content = json.loads(manifest.read_text())
        results = manifest.parent / "results"
        if content.get("protocol") != protocol or not (results / "campaign.json").is_file():
            continue
        for identity, name in content["entries"].items():
            found.setdefault(identity, Found(results, _variant(task, name)))
    return found


def _variant(task: str, name: str) -> str:
    return f"{REFERENCE}.{name}" if task == "diagnosis" else name


def plan(bench: Bench, tier: str, out: Path) -> tuple[dict[tuple[str, str, str, str], Found], list[Chunk]]:
    """What is done, by (task, robot, population, entry name), and the campaigns that make the rest."""
    done: dict[tuple[str, str, str, str], Found] = {}
    chunks = []
    for task in TASKS:
        entries = bench.of(task)
        if not entries:
            continue
        for robot in bench.suite.spec.robots:
            for population in POPULATIONS:
                protocol = protocol_digest(bench, robot, task, population, tier)
                found = find_done(out, task, robot, population, protocol)
                missing = []
                for entry in entries:
                    where = found.get(entry.identity(robot))
                    if where is None:
                        missing.append(entry)
                    else:
                        done[task, robot, population, entry.name] = where
                if missing:
                    name = digest({"protocol": protocol, "entries": sorted(e.identity(robot) for e in missing)}, 12)
                    chunks.append(Chunk(task, robot, population, protocol,
                                        out / "runs" / task / robot / population / name, missing))
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
        progress: Callable[[int, int], None] = lambda done, total: None) -> dict[str, Any]:
    """Simulate what is missing into ``out``; what was done and simulated, and the wall time."""
    start = time.perf_counter()
    done, chunks = plan(bench, tier, out)
    workers = workers or campaign_execute.default_workers()
    campaigns, tasks, owner = [], [], {}
    for chunk in chunks:
        campaign = campaign_execute.load(write_chunk(bench, chunk, tier))
        finished = campaign_execute.prepare_directory(campaign, chunk.results)
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
    for task, rows in campaign_execute.results(tasks, workers, None):
        _write_part(owner[id(task)].results, task, rows)
        simulated += len(task.runs)
        progress(simulated, total)
    for chunk, campaign in campaigns:  # nothing left to simulate: runs.parquet and campaign.json
        campaign_execute.execute(campaign, chunk.results, workers=1)
        for entry in chunk.entries:
            done[chunk.task, chunk.robot, chunk.population, entry.name] = Found(chunk.results,
                                                                               _variant(chunk.task, entry.name))
    return {"done": done, "campaigns": len(campaigns), "simulated_runs": total,
            "simulated_members": sum(len(t.runs) * len(t.variants) for t in tasks),
            "wall_time": time.perf_counter() - start}


def _joints(bench: Bench, robot: str) -> int:
    return bench.suite.joints(robot)


def _write_part(out: Path, task: campaign_execute.Task, rows: list[dict]) -> None:
    """One batch's rows, as the campaign writes them (its resuming reads the run ids of every part)."""
    name = task.runs[0][1] + "-" + task.runs[-1][1] + f"-{len(task.runs)}"
    write_atomic(out / "parts" / f"{name}.parquet", parquet_bytes(pa.Table.from_pylist(rows)))
