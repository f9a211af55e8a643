"""Two or more versions of ftc_mj (git worktrees) measured in one sitting, round by round, in CPU time.

    python benchmarks/versions.py single /work/wt-before /work/main [--rounds 6]
    python benchmarks/versions.py batch /work/wt-before /work/main [--rounds 4] [--members 1000] [--duration 2.0]

One worker process per version (``PYTHONPATH`` and working folder its tree; its first run, which loads the
kernels, is not a round) waits for a line, runs one round and answers; the rounds go to the versions in turn,
in alternating order, so that a drift of the machine's speed falls on every version alike. Each round times the
closed loop against bare physics measured beside it in the same worker, in the process's CPU time
(``time.process_time``, every thread's) and in wall time; the CPU-time ratio does not count the time a
process waits for a core, so on a shared machine it is the steadier comparison of two versions (the goals are
stated on wall time on a quiet machine; see ``docs/results/performance.md``). Prints every round and each
version's median and range.

* ``single``: what ``step_cost.py`` measures: one run of ``scenarios/puma_fault.yaml``, variant ``proposed``,
  10 s, poses kept, metrics and the Rerun file written, against a bare ``mj_step`` loop of as many steps
  (``sim``: the run alone; ``with_record``: with its metrics and recording).
* ``batch``: what ``batch_cost.py`` measures: ``run_batch`` of that variant for ``--members`` members on both
  cores against a bare batch of the plant's kind (one MjData per thread beyond 32 rows).

Only the library's public entry points are used, so versions of other layouts compare alike.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

SCENARIO = "scenarios/puma_fault.yaml"


def single_round() -> Callable[[], dict[str, float]]:
    """A round of the single run (the worker's current folder is the version's tree)."""
    import mujoco

    from ftc_mj import load_scenario
    from ftc_mj.analysis.metrics import compute_metrics
    from ftc_mj.engine.loop import simulate
    from ftc_mj.engine.members import single
    from ftc_mj.engine.runner import variant_result
    from ftc_mj.outputs.recording import write_recording

    scenario = load_scenario(Path(SCENARIO), duration=10.0, variants=["proposed"])
    steps = len(scenario.times)

    def bare() -> tuple[float, float]:
        data = mujoco.MjData(scenario.model)
        wall, cpu = time.perf_counter(), time.process_time()
        for _ in range(steps * scenario.substeps):
            mujoco.mj_step(scenario.model, data)
        return time.perf_counter() - wall, time.process_time() - cpu

    def closed_loop() -> tuple[float, float, float, float]:
        wall, cpu = time.perf_counter(), time.process_time()
        run = simulate(scenario, single(scenario), record_poses=True)
        sim_wall, sim_cpu = time.perf_counter() - wall, time.process_time() - cpu
        result = variant_result(scenario, run, 0, 0, poses=True)
        results = [result, *result.monitors]
        for each in results:
            compute_metrics(each, scenario.spec.metrics, scenario.fault_onsets, scenario.joint_fault_onsets)
        with tempfile.TemporaryDirectory() as folder:
            write_recording(Path(folder) / "bench.rrd", scenario=scenario.name, model=scenario.model,
                            results=results, fault_onsets=scenario.fault_onsets, seed=scenario.spec.seed)
        return sim_wall, sim_cpu, time.perf_counter() - wall, time.process_time() - cpu

    closed_loop()  # loads the kernels: not a round

    def measure() -> dict[str, float]:
        bare_wall, bare_cpu = bare()
        sim_wall, sim_cpu, whole_wall, whole_cpu = closed_loop()
        return {"bare_cpu_us": bare_cpu / steps * 1e6, "sim_cpu": sim_cpu / bare_cpu,
                "with_record_cpu": whole_cpu / bare_cpu, "sim_wall": sim_wall / bare_wall,
                "with_record_wall": whole_wall / bare_wall}

    return measure


def batch_round(members: int, duration: float) -> Callable[[], dict[str, float]]:
    """A round of the batch on both cores."""
    import mujoco
    import numpy as np
    from mujoco.batch import Batch

    from ftc_mj import load_scenario
    from ftc_mj.engine.members import replicates
    from ftc_mj.engine.runner import run_batch

    np.seterr(all="ignore")
    scenario = load_scenario(Path(SCENARIO), duration=duration, variants=["proposed"])
    periods, threads = len(scenario.times), 2
    stage = int(mujoco.mjtStage.mjSTAGE_VEL)

    def bare() -> tuple[float, float]:
        batch = Batch(scenario.model, members, nthread=threads, persistent=members <= 32)
        qpos, ctrl = batch.bind("qpos"), batch.bind("ctrl")
        wall, cpu = time.perf_counter(), time.process_time()
        for _ in range(periods):
            ctrl[:] = -10.0 * qpos
            batch.step(nstep=scenario.substeps, stage=stage)
        return time.perf_counter() - wall, time.process_time() - cpu

    run_batch(scenario, replicates(scenario, 4), nthread=threads)  # loads the kernels

    def measure() -> dict[str, float]:
        wall, cpu = time.perf_counter(), time.process_time()
        run_batch(scenario, replicates(scenario, members), nthread=threads)
        loop_wall, loop_cpu = time.perf_counter() - wall, time.process_time() - cpu
        bare_wall, bare_cpu = bare()
        return {"bare_cpu_us": bare_cpu / (periods * members) * 1e6, "batch_cpu": loop_cpu / bare_cpu,
                "batch_wall": loop_wall / bare_wall}

    return measure


def worker(kind: str, members: int, duration: float) -> None:
    measure = single_round() if kind == "single" else batch_round(members, duration)
    print("ready", flush=True)
    for _ in sys.stdin:
        print(json.dumps(measure()), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("kind", choices=["single", "batch"])
    parser.add_argument("trees", nargs="*", type=Path, help="the versions' git worktrees")
    parser.add_argument("--rounds", type=int, default=4)
    parser.add_argument("--members", type=int, default=1000)
    parser.add_argument("--duration", type=float, default=2.0)
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        worker(args.kind, args.members, args.duration)
        return
    workers = {}
    for tree in args.trees:
        tree = tree.resolve()
        process = subprocess.Popen(
            [sys.executable, str(Path(__file__).resolve()), args.kind, "--worker", "--members", str(args.members),
             "--duration", str(args.duration)],
            cwd=tree, env={**os.environ, "PYTHONPATH": str(tree)}, text=True, stdin=subprocess.PIPE,
            stdout=subprocess.PIPE)
        if process.stdout.readline().strip() != "ready":
            raise SystemExit(f"{tree}: the worker did not start")
        workers[tree] = process
    rounds: dict[Path, list[dict[str, float]]] = {tree: [] for tree in workers}
    print(f"load average at the start: {', '.join(f'{load:.1f}' for load in os.getloadavg())}")
    for number in range(args.rounds):
        for tree in (list(workers) if number % 2 == 0 else list(workers)[::-1]):
            process = workers[tree]
            process.stdin.write("go\n")
            process.stdin.flush()
            values = json.loads(process.stdout.readline())
            rounds[tree].append(values)
            print(f"round {number} {tree.name}: " + ", ".join(f"{key} {value:.2f}" for key, value in values.items()),
                  flush=True)
    for process in workers.values():
        process.stdin.close()
        process.wait()
    print(f"load average at the end: {', '.join(f'{load:.1f}' for load in os.getloadavg())}")
    for tree, values in rounds.items():
        print(f"median {tree.name}: " + ", ".join(
            f"{key} {statistics.median(v[key] for v in values):.2f} ({min(v[key] for v in values):.2f}-"
            f"{max(v[key] for v in values):.2f})" for key in values[0]))


if __name__ == "__main__":
    main()
