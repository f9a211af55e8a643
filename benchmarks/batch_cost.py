"""Cost of the batched closed loop against the bare physics batch, on the same machine in the same process.

The Chapter 5 ``proposed`` variant (high-speed TOSMO + NFTSMC, PUMA560) with B members stepped together
(:func:`ftc_mj.engine.runner.run_batch`, metrics computed, series dropped per chunk), against a bare
``mujoco.batch.Batch`` of the same model, substeps, B and thread count that only writes ``ctrl`` between
steps (the plant's kind of batch, and one with an MjData per member: the faster kind depends on the machine's
caches). Prints the cost per member and control period of each, the peak memory, the ratio against the bare
batch with an MjData per member, and as its last line the ratio against the plant's kind (goal <= 1.3).

Each is timed twice: wall time (the goal's measure, on a quiet machine) and the process's CPU time (every
thread's, ``time.process_time``). On a shared machine the wall ratio moves with what else runs, since the
loop and its physics get the cores in different shares; the CPU ratio does not count the time the process
waits for a core, so it is the steadier comparison of two versions there. It counts the physics' two threads
and the loop's one thread alike, so it is not the wall ratio of a quiet machine (where the physics' threads run
side by side): compare CPU ratios with CPU ratios.

    python benchmarks/batch_cost.py [--members 1000] [--duration 2.0] [--threads 0] [--rounds 3]
"""

from __future__ import annotations

import argparse
import os
import resource
import time
from pathlib import Path

import mujoco
import numpy as np
from mujoco.batch import Batch

from ftc_mj.engine.members import replicates
from ftc_mj.fast.crossovers import PERSISTENT_ROWS
from ftc_mj.engine.runner import run_batch
from ftc_mj.scenario.loading import load_scenario

SCENARIO = Path(__file__).resolve().parents[1] / "scenarios" / "puma_fault.yaml"


def bare(model: mujoco.MjModel, members: int, substeps: int, periods: int, threads: int,
         persistent: bool | None = None) -> float:
    """Wall seconds per member and period of :func:`bare_seconds`'s batch."""
    return bare_seconds(model, members, substeps, periods, threads, persistent)[0]


def bare_seconds(model: mujoco.MjModel, members: int, substeps: int, periods: int, threads: int,
                 persistent: bool | None = None) -> tuple[float, float]:
    """Wall and CPU seconds per member and period of a Batch that only writes ``ctrl`` (a PD law) between steps:
    by default the plant's kind of batch for as many rows (:data:`~ftc_mj.fast.crossovers.PERSISTENT_ROWS`);
    ``persistent`` True or False: one MjData per row, or one per thread."""
    if persistent is None:
        persistent = members <= PERSISTENT_ROWS
    batch = Batch(model, members, nthread=threads, persistent=persistent)
    qpos, ctrl = batch.bind("qpos"), batch.bind("ctrl")
    stage = int(mujoco.mjtStage.mjSTAGE_VEL)
    start, cpu = time.perf_counter(), time.process_time()
    for _ in range(periods):
        ctrl[:] = -10.0 * qpos
        batch.step(nstep=substeps, stage=stage)
    return (time.perf_counter() - start) / (periods * members), (time.process_time() - cpu) / (periods * members)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--members", type=int, default=1000)
    parser.add_argument("--duration", type=float, default=2.0, help="simulated seconds per member")
    parser.add_argument("--threads", type=int, default=0, help="0: all cores")
    parser.add_argument("--rounds", type=int, default=3, help="alternated measurements of each; the fastest counts")
    args = parser.parse_args()
    threads = args.threads or os.cpu_count() or 1

    scenario = load_scenario(SCENARIO, duration=args.duration, variants=["proposed"])
    periods = len(scenario.times)
    members = replicates(scenario, args.members)
    # Alternated rounds, the fastest of each: this machine's speed drifts by a fifth from minute to minute.
    closed = physics = persistent = closed_cpu = physics_cpu = persistent_cpu = np.inf
    cpu_ratios = []
    for _ in range(args.rounds):
        start, cpu = time.perf_counter(), time.process_time()
        outcomes = run_batch(scenario, members, nthread=threads)
        closed = min(closed, (time.perf_counter() - start) / (periods * args.members))
        round_cpu = (time.process_time() - cpu) / (periods * args.members)
        closed_cpu = min(closed_cpu, round_cpu)
        assert len(outcomes) == args.members and all(o.status == "ok" for o in outcomes)
        wall, cpu = bare_seconds(scenario.model, args.members, scenario.substeps, periods, threads)
        physics, physics_cpu = min(physics, wall), min(physics_cpu, cpu)
        cpu_ratios.append(round_cpu / cpu)
        wall, cpu = bare_seconds(scenario.model, args.members, scenario.substeps, periods, threads, True)
        persistent, persistent_cpu = min(persistent, wall), min(persistent_cpu, cpu)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # KiB on Linux
    print(f"members {args.members}, {periods} control periods of {scenario.substeps} physics steps, {threads} threads")
    print(f"batched closed loop: {closed * 1e6:.2f} us per member and control period")
    print(f"bare batch:          {physics * 1e6:.2f} us per member and control period")
    print(f"bare batch, one MjData per member (the faster kind on some machines): {persistent * 1e6:.2f} us")
    print(f"peak memory: {peak:.0f} MiB")
    print(f"CPU time (every thread): closed loop {closed_cpu * 1e6:.2f}, bare batch {physics_cpu * 1e6:.2f}, one MjData "
          f"per member {persistent_cpu * 1e6:.2f} us per member and control period")
    print(f"CPU-time ratio batched closed loop / bare batch: {closed_cpu / physics_cpu:.2f} (each round against the "
          f"bare batch after it: {', '.join(f'{ratio:.2f}' for ratio in cpu_ratios)}); against one MjData per "
          f"member: {closed_cpu / persistent_cpu:.2f}")
    print(f"ratio batched closed loop / bare batch with one MjData per member: {closed / persistent:.2f}")
    print(f"ratio batched closed loop / bare batch: {closed / physics:.2f}")


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
