"""The library's entry point: run a scenario, once or as a batch of members.

:func:`run_scenario` is what the command line, the studies and the benchmarks call: one member, every series
kept, a :class:`~ftc_mj.results.VariantResult` per variant, each followed by its monitors'::

    from ftc_mj import load_scenario, run_scenario

    scenario = load_scenario("scenarios/puma_fault.yaml", overrides=["seed=3"])
    results = run_scenario(scenario)
 :func:`run_batch` runs
many members of one scenario and returns their metrics: members are stepped together in chunks whose series
are reduced to metrics and dropped, so memory stays within ``memory_budget`` whatever B and the duration.
Both go through :func:`ftc_mj.engine.loop.simulate`.
"""

from __future__ import annotations

import dataclasses
import os
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from ftc_mj.analysis.diagnosis import diagnose_result, diagnosis_metrics
from ftc_mj.analysis.metrics import RecordedSeries, compute_metrics, onsets_per_joint, series_metrics
from ftc_mj.engine.loop import BatchRun, ChunkCallback, ProgressCallback, simulate
from ftc_mj.engine.members import Members, single
from ftc_mj.fast.crossovers import INTERLEAVED_ROWS, METRICS_ROWS
from ftc_mj.results import VariantResult
from ftc_mj.scenario.definition import Scenario, Variant, series_bytes

#: Default memory for the series of one chunk of members [bytes].
DEFAULT_MEMORY_BUDGET = 2 * 1024**3


#: Called once with the names of the variants a run steps together; returns the callback that the loop then
#: calls with the number of control steps done since the last call.
RunProgress = Callable[[str], ProgressCallback]


def run_scenario(
    scenario: Scenario,
    *,
    record_poses: bool = True,
    progress: RunProgress | None = None,
    nthread: int = 0,
    on_chunk: ChunkCallback | None = None,
) -> list[VariantResult]:
    """Every variant of the scenario as written (one member, all variants stepped together), with its whole
    series and diagnosis, in the scenario's order; each variant's monitors follow it (``<variant>.<monitor>``).

    Args:
        scenario: a compiled scenario (:func:`ftc_mj.scenario.loading.load_scenario`).
        record_poses: keep the body poses of the first variant, for the recording's 3-D view.
        progress: progress display, e.g. the command line's bar; None: none.
        nthread: threads of the physics batches (0: as many as cores and rows allow).
        on_chunk: sees the series as the run goes (:data:`ftc_mj.engine.loop.ChunkCallback`), e.g. to stream
            them to a viewer (:class:`ftc_mj.outputs.live.LiveRecording`).
    """
    advance = None if progress is None else progress(", ".join(v.name for v in scenario.variants))
    run = simulate(scenario, single(scenario), record_poses=record_poses, progress=advance, nthread=nthread,
                   on_chunk=on_chunk)
    results = []
    for v in range(len(scenario.variants)):
        result = variant_result(scenario, run, v, 0, poses=v == 0)
        results.append(result)
        results.extend(result.monitors)
    return results


def simulate_variant(scenario: Scenario, variant: Variant, *, record_poses: bool = False,
                     progress: ProgressCallback | None = None) -> VariantResult:
    """One variant of the scenario alone (one member): what :func:`run_scenario` gives for it."""
    alone = dataclasses.replace(scenario, variants=[variant])
    run = simulate(alone, single(alone), record_poses=record_poses, progress=progress)
    return variant_result(alone, run, 0, 0, poses=True)


@dataclass
class MemberOutcome:
    """The metrics of one variant (or monitor, named ``<variant>.<monitor>``) for one member."""

    member: int
    variant: str
    status: str
    diverged_at: float | None
    metrics: dict[str, np.ndarray]


def run_batch(
    scenario: Scenario,
    members: Members,
    *,
    memory_budget: int = DEFAULT_MEMORY_BUDGET,
    nthread: int = 0,
    progress: ProgressCallback | None = None,
    on_result: Callable[[int, list[VariantResult]], None] | None = None,
) -> list[MemberOutcome]:
    """Every variant for every member; metrics per member (in member order, then variant order).

    ``on_result(member, results)`` sees each member's whole results before they are dropped."""
    per_member = int(series_bytes(scenario.spec, scenario.n_joints))
    chunk = max(1, min(members.count, memory_budget // max(per_member, 1)))
    threads = nthread if nthread > 0 else os.cpu_count() or 1
    outcomes: list[MemberOutcome] = []
    for start in range(0, members.count, chunk):
        stop = min(members.count, start + chunk)
        if threads < 2 or (stop - start) * len(scenario.variants) < INTERLEAVED_ROWS:
            outcomes += _chunk_outcomes(scenario, members, start, stop, nthread, progress, on_result)
        else:
            outcomes += _interleaved(scenario, members, start, stop, threads, progress, on_result)
    return outcomes


def _interleaved(scenario: Scenario, members: Members, start: int, stop: int, threads: int,
                 progress: ProgressCallback | None,
                 on_result: Callable[[int, list[VariantResult]], None] | None) -> list[MemberOutcome]:
    """Members ``start:stop`` as two halves, each its own run in its own Python thread on half the threads.

    MuJoCo's step and the compiled kernels release the GIL, so one half's physics runs while the other's
    Python laws run: the cost above physics is paid beside it, not after it. A member's results do not depend on
    the members it is stepped with (the batch guarantee), so the halves give the outcomes of one run; the
    first half alone reports progress (both step through the same samples), and ``on_result`` is called in
    member order after both halves are done."""
    middle = (start + stop + 1) // 2
    halves = [(start, middle), (middle, stop)]
    kept: list[list[tuple[int, list[VariantResult]]]] = [[], []]

    stopping = threading.Event()

    def half(index: int) -> list[MemberOutcome]:
        first, last = halves[index]
        keep = None if on_result is None else (lambda member, results: kept[index].append((member, results)))
        shown = progress if index == 0 else None

        def advance(samples: int) -> None:  # a thread cannot be interrupted: it stops itself here
            if stopping.is_set():
                raise KeyboardInterrupt
            if shown is not None:
                shown(samples)

        return _chunk_outcomes(scenario, members, first, last, max(1, threads // 2), advance, keep)

    pool = ThreadPoolExecutor(max_workers=2, thread_name_prefix="ftc_mj-batch")
    try:
        futures = [pool.submit(half, index) for index in range(2)]
        outcomes = [outcome for future in futures for outcome in future.result()]
    except BaseException:  # Ctrl-C: raised at once; the halves stop at their next progress call
        stopping.set()
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()
    if on_result is not None:
        for member, results in kept[0] + kept[1]:
            on_result(member, results)
    return outcomes


def _chunk_outcomes(scenario: Scenario, members: Members, start: int, stop: int, nthread: int,
                    progress: ProgressCallback | None,
                    on_result: Callable[[int, list[VariantResult]], None] | None) -> list[MemberOutcome]:
    """Members ``start:stop`` as one run; their outcomes (the run's series dropped on return)."""
    run = simulate(scenario, members.select(slice(start, stop)), progress=progress, nthread=nthread)
    return member_outcomes(scenario, run, start, on_result)


def member_outcomes(scenario: Scenario, run: BatchRun, first: int = 0,
                    on_result: Callable[[int, list[VariantResult]], None] | None = None) -> list[MemberOutcome]:
    """The metrics of every member of a batch run (member order, then variant order), numbered from ``first``;
    ``on_result(member, results)`` sees each member's whole results first.

    The rows that ran to the end get their series' metrics from :func:`_finished_metrics` (the same bits as
    :func:`compute_metrics` on each, at a fraction of the per-call cost); the others, the monitors and every
    diagnosis are evaluated result by result."""
    outcomes, limits = [], scenario.torque_limits
    n, fault_onsets = scenario.n_joints, scenario.fault_onsets
    joint_onsets = onsets_per_joint(scenario.joint_fault_onsets, fault_onsets, n)
    first_fault = min(fault_onsets, default=np.inf)
    finished = _finished_metrics(scenario, run, joint_onsets)
    for m in range(run.members):
        results = [variant_result(scenario, run, v, m) for v in range(len(scenario.variants))]
        if on_result is not None:
            on_result(first + m, results)
        for v, result in enumerate(results):
            for one in (result, *result.monitors):
                series = finished.get(v * run.members + m) if one is result else None
                if series is None:
                    metrics = compute_metrics(one, scenario.spec.metrics, fault_onsets, joint_onsets, limits)
                else:
                    metrics = {**series, **diagnosis_metrics(one.diagnosis, joint_onsets, first_fault, n)}
                outcomes.append(MemberOutcome(first + m, one.name, one.status, one.diverged_at, metrics))
    return outcomes


def _finished_metrics(scenario: Scenario, run: BatchRun, joint_onsets: np.ndarray) -> dict[int, dict[str, np.ndarray]]:
    """Per row that ran to the end, its own result's series metrics (:func:`series_metrics`, no diagnosis).

    :data:`METRICS_ROWS` rows at a time are one call, the rows side by side: one compiled pass over their
    samples instead of one per row (a row's series are strided views of the run's, a cache line per sample)."""
    steps = len(run.times)
    finished = run.done == steps
    series, q_ref = run.series, run.reference[0]
    out: dict[int, dict[str, np.ndarray]] = {}
    for start in range(0, finished.size, METRICS_ROWS):
        rows = start + np.flatnonzero(finished[start : start + METRICS_ROWS])
        if not rows.size:
            continue
        # The rows from the group's first finished row to its last, stopped ones among them, as one slice: each
        # series is then a view of the run's (a gather of the finished rows alone cost as much as the metrics).
        # Every metric is a pass along each column alone, so a stopped row's columns (NaN, or the state it
        # stopped in) change no other column's numbers; theirs are not kept.
        first, stop = int(rows[0]), int(rows[-1]) + 1

        def block(values: np.ndarray) -> np.ndarray:
            return values[:steps, first:stop]

        if q_ref.ndim == 2:  # one reference for every row
            reference = np.broadcast_to(q_ref[:steps, None], block(series["q_true"]).shape)
        else:
            reference = q_ref[:steps, np.arange(first, stop) % run.members]
        recorded = RecordedSeries(block(series["q_true"]), reference, *(
            block(series[name]) for name in RecordedSeries._fields[2:]))
        metrics = series_metrics(run.times[:steps], recorded, scenario.spec.metrics, scenario.fault_onsets,
                                 joint_onsets, scenario.torque_limits)
        for row in rows.tolist():
            out[row] = {name: values[row - first].copy() for name, values in metrics.items()}
    return out


def variant_result(scenario: Scenario, run: BatchRun, v: int, m: int, poses: bool = False) -> VariantResult:
    """Member ``m``'s result for variant ``v`` of a batch run (views of its series, cut where it stopped)."""
    variant = scenario.variants[v]
    row = v * run.members + m
    done = int(run.done[row])
    kept = slice(0, done)

    def of_row(values: np.ndarray | None) -> np.ndarray | None:
        return None if values is None else values[kept, row]

    q_ref, qd_ref, qdd_ref = (series[kept] if series.ndim == 2 else series[kept, m] for series in run.reference)
    result = VariantResult(
        name=variant.name,
        observer=variant.observer_type.name,
        controller=variant.controller_type.name,
        t=run.times[kept],
        q_ref=q_ref,
        qd_ref=qd_ref,
        qdd_ref=qdd_ref,
        fault_active=run.fault_active[kept, row],
        body_xpos=run.body_xpos[kept, row] if poses and run.body_xpos is not None else np.zeros((0, 0, 3)),
        body_xquat=run.body_xquat[kept, row] if poses and run.body_xquat is not None else np.zeros((0, 0, 4)),
        status="ok" if done == len(run.times) else "diverged",
        diverged_at=None if done == len(run.times) else float(run.diverged_at[row]),
        extras={name: values[kept, m] for name, values in run.extras[variant.name].items()},
        qd_meas=of_row(run.qd_measured),
        **{name: values[kept, row] for name, values in run.series.items()},
    )
    in_loop = run.diagnosis.get(variant.name)
    if in_loop is None:
        diagnose_result(scenario.diagnoser, result, of_row(run.luaf_torque))
    else:  # stepped inside the loop, where its controller read it
        space = scenario.diagnoser.space
        injected = result.fault_torque if space == "torque" else result.fault_acceleration
        result.diagnosis = in_loop.of_row(m, space, result.t, np.asarray(injected, dtype=float), kept)
    monitor_extras = run.monitor_extras.get(variant.name, {})
    for name, series in run.monitor_series[variant.name].items():
        monitor = next(mon for mon in variant.monitors if mon.name == name)
        signals = {signal: values[kept, m] for signal, values in monitor_extras.get(name, {}).items()}
        view = dataclasses.replace(
            result, name=f"{variant.name}.{name}", host=variant.name, observer=monitor.observer_type.name,
            qd_hat=series["qd_hat"][kept, m], luaf_hat=series["luaf_hat"][kept, m],
            body_xpos=result.body_xpos[:0], body_xquat=result.body_xquat[:0], extras=signals, diagnosis=None,
            monitors=[],
        )
        diagnose_result(scenario.diagnoser, view, series["luaf_torque"][kept, m] if "luaf_torque" in series else None)
        result.monitors.append(view)
    return result
