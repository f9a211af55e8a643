"""Cost of one closed-loop control step against a bare ``mj_step`` loop of the same model, in one process.

    python benchmarks/step_cost.py [--scenario scenarios/puma_fault.yaml] [--variant proposed] [--duration 10] [--rounds 3]

The closed loop is the scenario's variant with recording on: body poses kept for the 3-D view, ground truth
computed, metrics evaluated, and the Rerun file written (to a temporary directory). The bare loop is
``mujoco.mj_step`` on the same model with nothing else, as many steps. Prints microseconds per control step of
each (the fastest round of each) and their ratio; then each round's own ratio, its closed loop against the bare
loop measured just before it, and their median: the machine's speed drifts from minute to minute, and a round's
two measurements, a second apart, drift least. Last, the cost of the causal diagnoser stepped inside the loop
(``simulate(..., diagnose_in_loop=True)``, as for a controller that reads the diagnosis) against the same run
diagnosed after it (its accelerator), alternated rounds, the fastest of each: microseconds per control step.

The same rounds are also timed in the process's CPU time (``time.process_time``: every thread's, the Rerun
writer's too): on a shared machine the wall ratio moves with what else runs, while CPU time does not count
the time the process waits for a core, so its ratio is the steadier comparison of two versions there. It adds
the recording's background threads to the loop's, where a quiet machine's wall clock runs them beside it.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import mujoco

from ftc_mj import load_scenario, run_scenario
from ftc_mj.analysis.metrics import compute_metrics
from ftc_mj.engine.loop import simulate
from ftc_mj.engine.members import single
from ftc_mj.engine.runner import variant_result
from ftc_mj.outputs.recording import write_recording
from ftc_mj.scenario.definition import Scenario

ROOT = Path(__file__).resolve().parents[1]


def bare_loop_seconds(model: mujoco.MjModel, steps: int, clock: Callable[[], float] = time.perf_counter) -> float:
    """Seconds by ``clock`` of ``steps`` bare ``mj_step`` calls."""
    data = mujoco.MjData(model)
    start = clock()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    return clock() - start


def bare_loop_times(model: mujoco.MjModel, steps: int) -> tuple[float, float]:
    """Wall and CPU seconds of ``steps`` bare ``mj_step`` calls."""
    data = mujoco.MjData(model)
    start, cpu = time.perf_counter(), time.process_time()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    return time.perf_counter() - start, time.process_time() - cpu


def single_run(description: str, rounds_help: str, clock: bool = False) -> tuple[argparse.Namespace, Scenario]:
    """The command line of a single-run benchmark (scenario, variant, duration, rounds; with ``clock`` the
    choice of clock) and its scenario of that one variant."""
    parser = argparse.ArgumentParser(description=description)
    if clock:
        parser.add_argument("--clock", choices=["wall", "cpu"], default="wall",
                            help="wall time, or this thread's CPU time (steadier on a shared machine; each "
                                 "reading costs about a microsecond more, added to the phases)")
    parser.add_argument("--scenario", type=Path, default=ROOT / "scenarios" / "puma_fault.yaml")
    parser.add_argument("--variant", default="proposed")
    parser.add_argument("--duration", type=float, default=10.0)
    parser.add_argument("--rounds", type=int, default=3, help=rounds_help)
    args = parser.parse_args()
    return args, load_scenario(args.scenario, duration=args.duration, variants=[args.variant])


def main() -> None:
    args, scenario = single_run(__doc__.split("\n\n")[0], "alternated measurements of each; the fastest counts")
    steps = int(round(args.duration / scenario.spec.control_dt))
    physics_steps = steps * scenario.substeps

    run_scenario(scenario, record_poses=True)  # the first run in a process loads the kernels: not a round
    # Alternated rounds, the fastest of each: this machine's speed drifts by a fifth from minute to minute.
    bare = simulated = recorded = bare_cpu = simulated_cpu = recorded_cpu = float("inf")
    paired, paired_cpu = [], []
    for _ in range(args.rounds):
        round_bare, round_bare_cpu = bare_loop_times(scenario.model, physics_steps)
        bare, bare_cpu = min(bare, round_bare), min(bare_cpu, round_bare_cpu)
        start, cpu = time.perf_counter(), time.process_time()
        results = run_scenario(scenario, record_poses=True)
        loop_done, loop_done_cpu = time.perf_counter(), time.process_time()
        for result in results:
            compute_metrics(result, scenario.spec.metrics, scenario.fault_onsets, scenario.joint_fault_onsets)
        with tempfile.TemporaryDirectory() as folder:
            write_recording(Path(folder) / "bench.rrd", scenario=scenario.name, model=scenario.model,
                            results=results, fault_onsets=scenario.fault_onsets, seed=scenario.spec.seed)
        end, end_cpu = time.perf_counter(), time.process_time()
        simulated, recorded = min(simulated, loop_done - start), min(recorded, end - start)
        simulated_cpu, recorded_cpu = min(simulated_cpu, loop_done_cpu - cpu), min(recorded_cpu, end_cpu - cpu)
        paired.append((end - start) / round_bare)
        paired_cpu.append((end_cpu - cpu) / round_bare_cpu)

    per_step = lambda seconds: seconds / steps * 1e6  # noqa: E731
    print(f"scenario {scenario.name}, variant {args.variant}, {steps} control steps "
          f"({scenario.substeps} physics step(s) each)")
    print(f"bare mj_step loop:           {per_step(bare):8.2f} us per control step")
    print(f"closed loop (sim only):      {per_step(simulated):8.2f} us per control step")
    print(f"closed loop (with record):   {per_step(recorded):8.2f} us per control step")
    print(f"ratio closed loop / bare:    {recorded / bare:8.1f}")
    print("each round against its own bare loop: " + ", ".join(f"{ratio:.2f}" for ratio in paired)
          + f"; median {statistics.median(paired):.2f}")
    print(f"CPU time: bare {per_step(bare_cpu):.2f}, closed loop (sim only) {per_step(simulated_cpu):.2f}, with "
          f"record {per_step(recorded_cpu):.2f} us per control step; ratios sim only {simulated_cpu / bare_cpu:.2f}, "
          f"with record {recorded_cpu / bare_cpu:.2f}")
    print("CPU time, each round against its own bare loop: " + ", ".join(f"{ratio:.2f}" for ratio in paired_cpu)
          + f"; median {statistics.median(paired_cpu):.2f}")
    if scenario.diagnoser is not None:
        after, inside = diagnosis_in_loop_seconds(scenario, args.rounds)
        print(f"diagnosis after the run:     {per_step(after):8.2f} us per control step (simulate + diagnose)")
        print(f"diagnosis inside the loop:   {per_step(inside):8.2f} us per control step; "
              f"the causal diagnoser per period: {per_step(inside - after):+.2f} us")


def diagnosis_in_loop_seconds(scenario: Scenario, rounds: int) -> tuple[float, float]:
    """The fastest of ``rounds`` alternated runs (simulated and every variant's result made, so diagnosed) with
    the diagnosis after the run and inside the loop."""
    def one(in_loop: bool) -> float:
        start = time.perf_counter()
        run = simulate(scenario, single(scenario), diagnose_in_loop=in_loop)
        for v in range(len(scenario.variants)):
            variant_result(scenario, run, v, 0)
        return time.perf_counter() - start

    one(True)  # the component's first use: not a round
    after = inside = float("inf")
    for _ in range(rounds):
        after, inside = min(after, one(False)), min(inside, one(True))
    return after, inside


if __name__ == "__main__":
    main()
