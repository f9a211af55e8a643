"""Running a campaign: groups of runs as batches of members, on a local process pool or a Dask cluster, with
results written atomically as each batch finishes so that an interrupted campaign resumes where it stopped.

Layout of a results directory::

    DIR/campaign.json       the campaign as resolved, versions, counts, wall time, throughput (at the end)
    DIR/fingerprint         what the directory was made from (a campaign changed since is refused)
    DIR/parts/*.parquet     one file per finished batch
    DIR/runs.parquet        every run and variant, in run order (at the end)

A batch is a task: the base scenario with its group's structure, the runs' member values, and what to keep.
The task is plain data, so it runs alike in this process, in a worker process and on a Dask worker; a member
of a batch is the same run as the single run (the batched engine's guarantee), so results do not depend on
the batch size, the number of workers or the scheduler.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import multiprocessing
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from ftc_mj.analysis.diagnosis import detection_statistics
from ftc_mj.campaign.partition import partition
from ftc_mj.campaign.population import Run, fingerprint, population, population_size
from ftc_mj.campaign.schema import CampaignSpec
from ftc_mj.engine.members import members_from_overrides
from ftc_mj.results import VariantResult
from ftc_mj.engine.runner import run_batch
from ftc_mj.config.errors import InputError
from ftc_mj.config.paths import input_file_problem
from ftc_mj.outputs.files import parquet_bytes, write_atomic
from ftc_mj.scenario.loading import UnknownVariant, load_scenario
from ftc_mj.scenario.definition import MAX_SEED, MEMORY_SHARE, Scenario, machine_memory, series_bytes

#: Memory for the series of one batch in a worker of a Dask cluster [bytes], on a machine other than the local
#: one (the batch engine steps members in chunks that fit).
CLUSTER_WORKER_MEMORY = 3 * 1024**3
#: Default largest batch: beyond it the per-period Python work is amortised and only memory grows.
MAX_BATCH = 128


@dataclass(frozen=True)
class Task:
    """One batch: runs of one group, all variants."""

    scenario: str
    variants: tuple[str, ...]
    duration: float | None
    structure: dict[str, Any]
    runs: tuple[tuple[int, str, dict[str, Any]], ...]  # (index, run_id, member values)
    scales: tuple[float, ...]
    nthread: int = 1
    memory_budget: int = CLUSTER_WORKER_MEMORY


@dataclass
class Campaign:
    """A loaded campaign: its spec, base scenario path, runs and groups (checked: every run compiles)."""

    path: Path
    spec: CampaignSpec
    scenario_path: Path
    runs: list[Run]
    variants: list[str]
    n_joints: int
    member_bytes: int
    fingerprint: str
    #: The base scenario (the campaign's ``set`` applied), compiled.
    scenario: Scenario
    #: The command line that ran it, recorded in ``campaign.json`` ("" when run from Python).
    command: str = ""
    groups: dict[str, list[Run]] = field(default_factory=dict)

    @property
    def control_periods(self) -> int:
        """Control periods of one run of one variant."""
        return len(self.scenario.times)

    @property
    def inputs(self) -> tuple[Path, ...]:
        """The files the campaign was read from (the campaign, its scenario, the scenario's bases and model):
        what no output may replace or hold."""
        return (self.path.resolve(), *self.scenario.inputs)


def load(path: str | Path, runs: int | None = None, variants: list[str] | None = None,
         duration: float | None = None, assignments: dict[str, Any] | None = None) -> Campaign:
    """Read a campaign, expand its population and check every run before anything runs: each group's
    scenario compiles and each run's member values pass the scenario's schema and the methods' gain checks.
    ``assignments`` (scenario field -> value, the command line's ``--set``) join the campaign's ``set``.

    Raises:
        InputError: naming the campaign file and the field (a drawn value that is refused names its run).
    """
    from ftc_mj.campaign.schema import load_campaign

    path = Path(path)
    file = str(path)
    spec = load_campaign(path, runs)
    narrowed = variants is not None
    if variants is not None:  # a tuning evaluates one variant on the campaign's population
        spec.variants = list(variants)
    if duration is not None:
        spec.duration = duration
    if assignments:
        spec.set = {**spec.set, **assignments}
    scenario_path = (path.parent / spec.scenario).resolve()
    problem = input_file_problem(scenario_path)
    if problem is not None:
        raise InputError(file, "scenario", f"no such file: {spec.scenario}" if problem == "not found"
                         else f"{spec.scenario} {problem}")
    try:
        base = compiled_scenario(str(scenario_path), tuple(spec.variants or ()), spec.duration, frozen(spec.set))
    except UnknownVariant as exc:  # the campaign chose it (a tuning that narrows the campaign names its own)
        if narrowed:
            raise
        raise InputError(file, f"variants.{spec.variants.index(exc.name)}", f"unknown variant {exc.name!r} "
                         f"(the scenario's: {', '.join(exc.known)})") from None
    _check_paths(spec, base, file)
    variants = [v.name for v in base.variants]
    base_seed = spec.seed if spec.seed is not None else base.spec.seed
    _check_size(spec, population_size(spec), len(variants), base.n_joints, file)
    all_runs = population(spec, base_seed)
    campaign = Campaign(path=path, spec=spec, scenario_path=scenario_path, runs=all_runs, variants=variants,
                        n_joints=base.n_joints, member_bytes=int(series_bytes(base.spec, base.n_joints)),
                        fingerprint=fingerprint(spec, base), scenario=base)
    if not narrowed:  # a tuning evaluates its own variant: the campaign's report is not made
        _check_report(spec, base, all_runs, file)
    highest = max((run.seed for run in all_runs), default=0)
    if highest > MAX_SEED:
        raise InputError(file, "seed" if spec.seed is not None else "replicates", f"the runs' seeds reach {highest}, "
                         f"beyond the largest seed {MAX_SEED} (seed + sample x replicates + replicate)")
    ids = [run.run_id for run in all_runs]
    if len(set(ids)) != len(ids):
        raise InputError(file, "samples", "two runs have the same values and seed (a choice with too few values "
                         "and no replicates?)")
    for run in all_runs:
        campaign.groups.setdefault(run.group, []).append(run)
    for runs_of_group in campaign.groups.values():
        _check_group(campaign, runs_of_group, file)
    return campaign


#: Seconds to wait for a Dask scheduler to answer before a campaign starts.
SCHEDULER_TIMEOUT = 5.0


def check_scheduler_address(address: str, file: str) -> None:
    """Refuse a ``--scheduler`` that is not a Dask address (``tcp://HOST:PORT``, ``tls://...``, ...)."""
    from distributed.comm import parse_address
    from distributed.comm.addressing import parse_host_port

    try:
        scheme, location = parse_address(address)
        if scheme in ("tcp", "tls"):
            parse_host_port(location)
    except (ValueError, TypeError) as exc:
        raise InputError(file, "--scheduler", f"{address!r} is not a scheduler's address, e.g. "
                         f"tcp://127.0.0.1:8786 ({exc})") from None


def check_scheduler(address: str, file: str) -> None:
    """Refuse, before any work, a ``--scheduler`` where nothing listens (a TCP or TLS address: one connection
    within :data:`SCHEDULER_TIMEOUT`; other transports are tried when the campaign starts)."""
    import socket

    from distributed.comm import parse_address
    from distributed.comm.addressing import parse_host_port

    check_scheduler_address(address, file)
    scheme, location = parse_address(address)
    if scheme not in ("tcp", "tls"):
        return
    host, port = parse_host_port(location)
    try:
        socket.create_connection((host, port), timeout=SCHEDULER_TIMEOUT).close()
    except OSError as exc:
        raise InputError(file, "--scheduler", f"nothing answers at {address} "
                         f"({exc.strerror or exc or 'timed out'})") from None


def _check_report(spec: CampaignSpec, scenario: Scenario, runs: list[Run], file: str) -> None:
    """Everything the report names exists, before the first run: the claims' and the reference's variants
    (monitors as ``variant.monitor``), the joints of the claims and the heat map, the columns of
    ``fault_size`` and ``fault_kind``."""
    report, n = spec.report, scenario.n_joints
    names = [name for v in scenario.variants for name in (v.name, *(f"{v.name}.{m.name}" for m in v.monitors))]
    known = ", ".join(names)
    if report.reference is not None and report.reference not in names:
        raise InputError(file, "report.reference", f"unknown variant {report.reference!r} (the campaign's: {known})")
    for index, claim in enumerate(report.claims):
        for role in ("better", "worse"):
            if getattr(claim, role) not in names:
                raise InputError(file, f"report.claims.{index}.{role}", f"unknown variant {getattr(claim, role)!r} "
                                 f"(the campaign's: {known})")
        for position, joint in enumerate(claim.joints or ()):
            if joint > n:
                raise InputError(file, f"report.claims.{index}.joints.{position}", f"joint {joint}: the robot has {n}")
    if report.heatmap.joint > n:
        raise InputError(file, "report.heatmap.joint", f"joint {report.heatmap.joint}: the robot has {n}")
    columns = {name for run in runs for name in run.columns()}
    for option in ("fault_size", "fault_kind"):
        column = getattr(report, option)
        if column is not None and column not in columns:
            raise InputError(file, f"report.{option}", f"{column!r} is not a column of the runs (a case value or a "
                             f"varied field: {', '.join(sorted(columns)) or 'none'})")


def frozen(values: dict[str, Any]) -> str:
    """Values as the hashable text a cached scenario is keyed by."""
    return json.dumps(values, sort_keys=True)


@lru_cache(maxsize=8)
def compiled_scenario(path: str, variants: tuple[str, ...], duration: float | None, structure: str) -> Scenario:
    """A group's compiled scenario (cached: a worker runs many batches of few groups)."""
    return load_scenario(path, variants=list(variants), duration=duration, assignments=json.loads(structure))


def _check_paths(spec: CampaignSpec, scenario: Scenario, file: str) -> None:
    """Every varied or set path names a field of the scenario (as written or with its defaults)."""
    documents = [scenario.written(), scenario.spec.model_dump(mode="json")]
    fields = [("set", p) for p in spec.set] + [("grid", p) for p in spec.grid]
    fields += [(f"cases.{i}.set", p) for i, case in enumerate(spec.cases) for p in case.set]
    if spec.samples is not None:
        fields += [("samples.fields", p) for p in spec.samples.fields]
        fields += [(f"samples.fields.{p}.also", q) for p, d in spec.samples.fields.items() for q in d.also]
    for where, path in fields:
        if field_value(documents, path) is None:
            raise InputError(file, f"{where}.{path}", f"is not a field of the scenario {spec.scenario}")


def field_value(documents: list[Any], path: str) -> Any:
    """The value at a dotted path in the first of ``documents`` that has it (e.g. the scenario as written, then
    with its defaults); None where none has."""
    for node in documents:
        for part in path.split("."):
            if isinstance(node, dict) and part in node:
                node = node[part]
            elif isinstance(node, list) and part.isdigit() and int(part) < len(node):
                node = node[int(part)]
            else:
                break
        else:
            return node
    return None


def _check_size(spec: CampaignSpec, runs: int, variants: int, n_joints: int, file: str) -> None:
    """Refuse, before expanding it, a population whose results table would not fit in half of the machine's
    memory (8 bytes a value; about 40 metric and statistics columns per joint plus two per threshold multiple)."""
    fields = len(spec.grid) + (len(spec.samples.fields) if spec.samples is not None else 0)
    columns = 8 + fields + n_joints * (40 + 2 * len(spec.diagnosis.threshold_scales))
    table = runs * variants * columns * 8
    memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    if table > memory / 2:
        factors = {"samples.runs": spec.samples.runs if spec.samples is not None else 0, "replicates": spec.replicates,
                   "grid": math.prod(len(v) for v in spec.grid.values()), "cases": len(spec.cases)}
        raise InputError(file, max(factors, key=factors.get),  # the largest factor of the population
                         f"{runs} runs x {variants} variants need about {table / 1e9:.3g} GB of results, more than "
                         "half of this machine's memory")


def _check_group(campaign: Campaign, runs: list[Run], file: str) -> None:
    """The group's scenario compiles and every run's member values are accepted; a refusal names the run."""
    spec = campaign.spec
    try:
        scenario = compiled_scenario(str(campaign.scenario_path), tuple(campaign.variants), spec.duration,
                             frozen(runs[0].structure))
    except InputError as exc:
        raise InputError(file, _describe(runs[0]), f"{exc.field}: {exc.problem}") from None
    try:
        members_from_overrides(scenario, [run.member for run in runs])
    except (InputError, ValueError):
        for run in runs:  # find the run that drew it
            try:
                members_from_overrides(scenario, [run.member])
            except InputError as exc:
                raise InputError(file, _describe(run), f"{exc.field}: {exc.problem.removeprefix('member 0: ')}") \
                    from None
            except ValueError as exc:
                raise InputError(file, _describe(run), str(exc)) from None
        raise


def _describe(run: Run) -> str:
    drawn = ", ".join(f"{k}={v}" for k, v in {**({"case": run.case} if run.case else {}), **run.values}.items())
    return f"run {run.index} ({run.run_id}{': ' + drawn if drawn else ''})"


# ------------------------------------------------------------------------------------------------ one batch


def run_task(task: Task) -> list[dict[str, Any]]:
    """Simulate one batch; one row per run and variant (and monitor): status, metrics per joint, detection
    statistics. What a worker runs."""
    scenario = compiled_scenario(task.scenario, task.variants, task.duration, frozen(task.structure))
    members = members_from_overrides(scenario, [member for _, _, member in task.runs])
    detection, keep_detection = detection_keeper(scenario, task.scales)
    outcomes = run_batch(scenario, members, memory_budget=task.memory_budget, nthread=task.nthread,
                         on_result=keep_detection)
    onsets = scenario.joint_fault_onsets
    rows = []
    for outcome in outcomes:
        index, run_id, member = task.runs[outcome.member]
        row: dict[str, Any] = {"run": index, "run_id": run_id, "variant": outcome.variant, "status": outcome.status,
                               "diverged_at": outcome.diverged_at, "seed": member["seed"]}
        values = {**outcome.metrics, "fault_onset": onsets,
                  **detection.get((outcome.member, outcome.variant), {})}
        for name, per_joint in values.items():
            for j, value in enumerate(np.asarray(per_joint, dtype=float).tolist()):
                row[f"{name}.{j + 1}"] = value
        rows.append(row)
    return rows


def detection_keeper(scenario: Scenario, scales: Sequence[float]) -> tuple[
        dict[tuple[int, str], dict[str, np.ndarray]], Callable[[int, list[VariantResult]], None]]:
    """Where each member's threshold-free detection statistics go, by (member, variant), and the ``on_result``
    callback of :func:`~ftc_mj.engine.runner.run_batch` that computes them (nothing without a diagnoser)."""
    diagnoser, scales = scenario.diagnoser, list(scales)
    detection: dict[tuple[int, str], dict[str, np.ndarray]] = {}

    def keep_detection(member: int, results: list[VariantResult]) -> None:
        if diagnoser is None:
            return
        for result in results:
            for one in (result, *result.monitors):
                detection[member, one.name] = detection_statistics(
                    one.diagnosis, diagnoser.persistence, scenario.joint_fault_onsets, scales,
                    scenario.n_joints)

    return detection, keep_detection


# ------------------------------------------------------------------------------------------------ a campaign


@dataclass
class Progress:
    """What the caller shows: ``update`` called with (runs done, runs in all) after each batch; ``note`` with
    one line about the directory (a part that was unreadable and is simulated again)."""

    update: Callable[[int, int], None] = lambda done, total: None
    note: Callable[[str], None] = lambda line: None


#: The file in a results directory that a running campaign holds locked (an advisory lock: the operating
#: system releases it when the process ends, however it ends).
LOCK = "lock"


@contextlib.contextmanager
def directory_lock(out: Path, file: str, holder: str = "campaign run") -> Iterator[None]:
    """Hold ``out``'s lock while the block runs: a second campaign (or tuning, ``holder``) on the same
    directory is refused instead of simulating everything again beside the first. Without ``fcntl`` (not
    POSIX) nothing is locked."""
    try:
        import fcntl
    except ImportError:
        yield
        return
    if out.exists() and not out.is_dir():
        raise InputError(file, "--out", f"{out} is a file, not a directory")
    out.mkdir(parents=True, exist_ok=True)
    with open(out / LOCK, "a+") as handle:
        try:
            fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise InputError(file, "--out", f"{out} is in use by another {holder} (it holds {out / LOCK}); "
                             "wait for it to end") from None
        try:
            yield
        finally:
            fcntl.flock(handle.fileno(), fcntl.LOCK_UN)


def default_workers() -> int:
    return max(1, len(os.sched_getaffinity(0)))


def worker_memory(workers: int, scheduler: str | None = None) -> int:
    """Memory for the series of one batch in each of ``workers`` workers [bytes]: on the local machine, an equal part
    of the share of its memory a run may take (:data:`~ftc_mj.scenario.definition.MEMORY_SHARE`); on the cluster at
    ``scheduler``, :data:`CLUSTER_WORKER_MEMORY`."""
    if scheduler is not None:
        return CLUSTER_WORKER_MEMORY
    return int(MEMORY_SHARE * machine_memory() / max(workers, 1))


def tasks_for(campaign: Campaign, pending: list[Run], batch_size: int | None, workers: int,
              scheduler: str | None = None) -> list[Task]:
    """The pending runs as batches of one group each: ``batch_size`` members, or by default the largest batches
    that give every worker the same share (:func:`member_tasks`)."""
    return member_tasks(campaign, [(run.index, run.run_id, run, run.member) for run in pending], batch_size, workers,
                        scheduler)


def member_tasks(campaign: Campaign, members: list[tuple[int, str, Run, dict[str, Any]]], batch_size: int | None,
                 workers: int, scheduler: str | None = None) -> list[Task]:
    """Members ``(index, id, run, member values)`` (a run's, or a run's with other gains, as a tuning asks) as
    batches of one group each; see :func:`tasks_for`. By default (``batch_size`` None) the batches are those
    of :func:`~ftc_mj.campaign.partition.partition`: the same share of members for every worker, each batch
    as large as a worker steps at once (:func:`worker_memory`, at most :data:`MAX_BATCH`), largest first; with
    ``batch_size``, each group is cut in order into batches of that many members (the last one smaller)."""
    by_group: dict[str, list] = {}
    for member in members:
        by_group.setdefault(member[2].group, []).append(member)
    groups = list(by_group.values())
    memory = worker_memory(workers, scheduler)
    if batch_size is None:
        cap = max(1, min(MAX_BATCH, memory // max(campaign.member_bytes, 1)))
        chunks = [groups[b.group][b.start:b.stop] for b in partition([len(g) for g in groups], workers, cap)]
    else:
        chunks = [group[start:start + batch_size] for group in groups for start in range(0, len(group), batch_size)]
    nthread = max(1, default_workers() // workers)
    spec = campaign.spec
    return [Task(scenario=str(campaign.scenario_path), variants=tuple(campaign.variants), duration=spec.duration,
                 structure=chunk[0][2].structure,
                 runs=tuple((index, run_id, values) for index, run_id, _, values in chunk),
                 scales=tuple(spec.diagnosis.threshold_scales), nthread=nthread, memory_budget=memory)
            for chunk in chunks]


def check_directory(campaign: Campaign, out: Path) -> None:
    """Refuse, writing nothing, a results directory that is a file, holds something else, or holds another
    campaign's results."""
    file = str(campaign.path)
    marker = out / "fingerprint"
    if out.exists() and not out.is_dir():
        raise InputError(file, "--out", f"{out} is a file, not a directory")
    if out.is_dir() and any(entry.name != LOCK for entry in out.iterdir()):
        if not marker.is_file():
            raise InputError(file, "--out", f"{out} is not empty and holds no campaign's results")
        if marker.read_text().strip() != campaign.fingerprint:
            raise InputError(file, "--out", f"{out} holds the results of another campaign (or of this one before it "
                             "changed); choose another --out or remove it")


def prepare_directory(campaign: Campaign, out: Path, note: Callable[[str], None] = lambda line: None) -> set[str]:
    """Create or check the results directory; the run ids already done (from its parts). ``note`` is told of
    each part that cannot be read (removed: its runs are simulated again).

    Raises:
        InputError: the directory holds another campaign, or something that is not a campaign's results.
    """
    check_directory(campaign, out)
    marker = out / "fingerprint"
    (out / "parts").mkdir(parents=True, exist_ok=True)
    if not marker.is_file():
        write_atomic(marker, (campaign.fingerprint + "\n").encode())
    done: set[str] = set()
    for part in sorted((out / "parts").glob("*.parquet")):
        try:
            done.update(pq.read_table(part, columns=["run_id"]).column("run_id").to_pylist())
        except (OSError, pa.ArrowInvalid):
            part.unlink()  # a part is written atomically: an unreadable one is not ours to keep
            note(f"{part} could not be read (truncated or damaged): removed, its runs are simulated again")
    return done


def execute(campaign: Campaign, out: Path, *, batch_size: int | None = None, workers: int | None = None,
            scheduler: str | None = None, progress: Progress = Progress()) -> dict[str, Any]:
    """Run what is missing of the campaign into ``out``, then write ``runs.parquet`` and ``campaign.json``;
    returns the summary written to ``campaign.json``."""
    start = time.perf_counter()
    check_directory(campaign, out)  # before the lock file is made in it
    with directory_lock(out, str(campaign.path)):
        return _execute(campaign, out, start, batch_size, workers, scheduler, progress)


def _execute(campaign: Campaign, out: Path, start: float, batch_size: int | None, workers: int | None,
             scheduler: str | None, progress: Progress) -> dict[str, Any]:
    done = prepare_directory(campaign, out, progress.note)
    pending = [run for run in campaign.runs if run.run_id not in done]
    workers = workers or (default_workers() if scheduler is None else 1)
    tasks = tasks_for(campaign, pending, batch_size, workers, scheduler)
    total, finished = len(campaign.runs), len(campaign.runs) - len(pending)
    progress.update(finished, total)
    for task, rows in results(tasks, workers, scheduler):
        _write_part(out, task, rows)
        finished += len(task.runs)
        progress.update(finished, total)
    simulated = time.perf_counter() - start
    table = collect(campaign, out)
    write_atomic(out / "runs.parquet", parquet_bytes(table))
    summary = _summary(campaign, table, simulated, len(pending), scheduler, workers)
    write_atomic(out / "campaign.json", (json.dumps(summary, indent=2, default=_json_default) + "\n").encode())
    return summary


def results(tasks: list[Task], workers: int, scheduler: str | None,
            work: Callable[[Task], Any] = run_task) -> Iterator[tuple[Task, Any]]:
    """Each task with its rows (what ``work`` makes of it: :func:`run_task` by default), as they finish: in this
    process (one worker), on a process pool, or on the Dask cluster at ``scheduler``."""
    if scheduler is not None:
        from dask.distributed import Client, as_completed

        with Client(scheduler, timeout="20s") as client:
            futures = {client.submit(work, task, pure=False): task for task in tasks}
            for future in as_completed(futures):
                yield futures[future], future.result()
        return
    if workers == 1 or len(tasks) <= 1:
        for task in tasks:
            yield task, work(task)
        return
    context = multiprocessing.get_context("spawn")  # no fork of a process holding MuJoCo's thread pools
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=context, initializer=_ignore_interrupts)
    try:
        running: dict[Future, Task] = {pool.submit(work, task): task for task in tasks}
        while running:
            finished, _ = wait(running, return_when=FIRST_COMPLETED)
            for future in finished:
                yield running.pop(future), future.result()
    except BaseException:
        # Interrupted (Ctrl-C, a worker's error, the caller stopped): stop the batches in flight at once
        # instead of letting every queued one run to its end; what finished is already saved.
        _stop(pool)
        raise
    pool.shutdown(wait=True)


def _ignore_interrupts() -> None:
    """In a worker: Ctrl-C (sent to the whole process group) is the parent's to handle, which ends the workers
    (:func:`_stop`); a worker of its own would print a traceback and take its next batch."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _stop(pool: ProcessPoolExecutor) -> None:
    """Cancel what has not started and end the worker processes now (the pool's own shutdown would wait)."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        if process.is_alive():
            process.terminate()
    for process in processes:
        process.join(timeout=5)


def _write_part(out: Path, task: Task, rows: list[dict]) -> None:
    name = task.runs[0][1] + "-" + task.runs[-1][1] + f"-{len(task.runs)}"
    write_atomic(out / "parts" / f"{name}.parquet", parquet_bytes(pa.Table.from_pylist(rows)))


def collect(campaign: Campaign, out: Path) -> pa.Table:
    """Every run of the population from the parts, with its varied fields, in run order then variant order."""
    tables = [pq.read_table(part) for part in sorted((out / "parts").glob("*.parquet"))]
    table = pa.concat_tables(tables, promote_options="default") if tables else pa.table({})
    rows = {(row["run_id"], row["variant"]): row for row in table.to_pylist()}
    variants = _variant_order(campaign, {variant for _, variant in rows})
    ordered = []
    for run in campaign.runs:
        for variant in variants:
            row = rows.get((run.run_id, variant))
            if row is None:
                continue
            metrics = {k: v for k, v in row.items() if k not in _LEADING}
            ordered.append({"run": run.index, "run_id": run.run_id, "variant": variant, "status": row["status"],
                            "diverged_at": row["diverged_at"], "seed": run.seed, **run.columns(), **metrics})
    return pa.Table.from_pylist(ordered)


_LEADING = ("run", "run_id", "variant", "status", "diverged_at", "seed")


def _variant_order(campaign: Campaign, present: Iterable[str]) -> list[str]:
    """The scenario's variants, each followed by its monitors (``<variant>.<monitor>``)."""
    present = set(present)
    order = []
    for variant in campaign.variants:
        order.append(variant)
        order.extend(sorted(name for name in present if name.startswith(variant + ".")))
    return [name for name in order if name in present]


def _summary(campaign: Campaign, table: pa.Table, seconds: float, simulated_runs: int, scheduler: str | None,
             workers: int) -> dict[str, Any]:
    from importlib.metadata import version

    statuses = table.column("status").to_pylist() if table.num_rows else []
    per_run = campaign.control_periods
    substeps = campaign.scenario.substeps
    return {
        "name": campaign.spec.name,
        "campaign": str(campaign.path),
        "command": campaign.command,
        "scenario": str(campaign.scenario_path),
        "resolved": campaign.spec.model_dump(mode="json"),
        "fingerprint": campaign.fingerprint,
        "variants": campaign.variants,
        # Every variant's colour as in the scenario's run figures and recordings, for the report's figures.
        "colours": campaign.scenario.colours,
        "runs": len(campaign.runs),
        "groups": len(campaign.groups),
        "rows": table.num_rows,
        "status_counts": {status: statuses.count(status) for status in sorted(set(statuses))},
        "versions": {name: version(name) for name in ("ftc_mj", "mujoco", "numpy", "scipy", "pyarrow")},
        "scheduler": scheduler or "local",
        "workers": workers,
        "wall_time": seconds,
        "simulated_runs": simulated_runs,
        "runs_per_second": simulated_runs / seconds if seconds > 0 else None,
        # Control periods simulated over all members (every variant a member), and physics steps per period:
        # throughput comparable with the bare batched physics (benchmarks/batch_cost.py).
        "control_steps": simulated_runs * len(campaign.variants) * per_run,
        "physics_substeps": substeps,
    }


def _json_default(value: Any) -> Any:
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    return str(value)


# ------------------------------------------------------------------------------------------------ one run again


def find_run(directory: Path, run_id: str) -> tuple[dict[str, Any], Run]:
    """The campaign summary of a results directory and its run ``run_id``, rebuilt from the campaign as
    resolved when it ran (the campaign file may have changed since)."""
    from ftc_mj.campaign.schema import CampaignSpec

    info = directory / "campaign.json"
    if not info.is_file():
        raise InputError(str(directory), "", "no campaign.json: not a finished campaign's results directory")
    summary = json.loads(info.read_text())
    spec = CampaignSpec.model_validate(summary["resolved"])
    scenario_path = Path(summary["scenario"])
    if not scenario_path.is_file() or fingerprint(spec, compiled_scenario(str(scenario_path), tuple(spec.variants or ()),
                                                                  spec.duration, frozen(spec.set))) != summary["fingerprint"]:
        raise InputError(str(directory), "scenario", f"{scenario_path} has changed since the campaign ran: the run "
                         "cannot be replayed as it was")
    seed = spec.seed if spec.seed is not None else load_scenario(scenario_path).spec.seed
    for run in population(spec, seed):
        if run.run_id == run_id:
            return summary, run
    raise InputError(str(directory), "RUN_ID", f"no run {run_id!r} in this campaign")


def replay_arguments(directory: Path, run_id: str, *, variants: Sequence[str] = (), out: Path | None = None,
                     json_path: Path | None = None) -> list[str]:
    """The arguments of the run command (``ftc-mj run``) that simulate one run of a campaign alone, with its
    table, recording and ``--json``: every field the run set given as ``--set``, so that its metrics equal the
    run's row bit for bit."""
    summary, run = find_run(directory, run_id)
    argv = [summary["scenario"], "--out", str(out or directory / "replay" / f"{run_id}.rrd")]
    for path, value in run.assignments().items():
        argv += ["--set", f"{path}={json.dumps(value)}"]  # JSON is YAML; floats keep every bit (repr)
    resolved = summary["resolved"]
    if resolved.get("duration") is not None:
        argv += ["--duration", repr(resolved["duration"])]
    chosen = list(variants) or summary["variants"]
    unknown = [v for v in chosen if v not in summary["variants"]]
    if unknown:
        raise InputError(str(directory), "--variant", f"unknown variant {unknown[0]!r} (the campaign's: "
                         f"{', '.join(summary['variants'])})")
    argv += ["--variant", *chosen]
    if json_path is not None:
        argv += ["--json", str(json_path)]
    return argv
