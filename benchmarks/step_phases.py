"""Where a single run's time goes, phase by phase, against a bare ``mj_step`` loop: the floor of its cost.

One run of a scenario's variant (default ``scenarios/puma_fault.yaml``, ``proposed``): one row on one MjData, as
``python -m ftc_mj.run`` steps it, with a timer around each phase of the loop as ``loop_phases.py`` times a
campaign batch (physics, nominal model, methods, plant terms, readings, set-up and truths), then what the run
does after the loop: the metrics and the Rerun file (poses kept, written to a temporary directory). Each round
measures a bare ``mj_step`` loop of as many physics steps just before the run, and prints each phase in
microseconds per control period and as a multiple of that bare loop; the last line is the physics phase against
the bare loop: what the loop's other work between two steps costs MuJoCo's own (likely through the caches).

    python benchmarks/step_phases.py [--scenario scenarios/puma_fault.yaml] [--variant proposed] [--duration 10] [--rounds 3] [--clock cpu]

``--clock cpu`` times everything (the bare loop too) in the thread's CPU time, which does not count the time the
process waits for a core on a shared machine; the recording's background threads are then not counted.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from loop_phases import timed_periods  # this folder is on sys.path
from step_cost import bare_loop_seconds, single_run
from ftc_mj.analysis.metrics import compute_metrics
from ftc_mj.engine import loop
from ftc_mj.engine.members import single
from ftc_mj.engine.runner import variant_result
from ftc_mj.outputs.recording import write_recording
from ftc_mj.scenario.definition import Scenario

PHASES = ("physics", "nominal model", "methods", "plant terms", "readings", "set-up and truths", "metrics",
          "recording")


def round_seconds(scenario: Scenario, clock: Callable[[], float] = time.perf_counter) -> dict[str, float]:
    """Seconds per phase of one run of ``scenario`` (one variant), its metrics and its recording, by ``clock``."""
    seconds = dict.fromkeys(PHASES, 0.0)
    with loop.quiet_warnings():
        start = clock()
        run = loop._Run.set_up(scenario, single(scenario), record_poses=True, nthread=1)
        seconds["set-up and truths"] += clock() - start
        batch_run = timed_periods(run, seconds, clock)
    start = clock()
    result = variant_result(scenario, batch_run, 0, 0, poses=True)
    results = [result, *result.monitors]  # what run_scenario gives
    for each in results:
        compute_metrics(each, scenario.spec.metrics, scenario.fault_onsets, scenario.joint_fault_onsets)
    seconds["metrics"] += clock() - start
    start = clock()
    with tempfile.TemporaryDirectory() as folder:
        write_recording(Path(folder) / "bench.rrd", scenario=scenario.name, model=scenario.model, results=results,
                        fault_onsets=scenario.fault_onsets, seed=scenario.spec.seed)
    seconds["recording"] += clock() - start
    return seconds


def main() -> None:
    args, scenario = single_run(__doc__.split("\n\n")[0], "rounds of bare loop then run; each is printed", clock=True)
    clock = time.thread_time if args.clock == "cpu" else time.perf_counter
    periods = len(scenario.times)
    round_seconds(scenario)  # the first run in a process loads the kernels
    print(f"{args.scenario.name}, variant {args.variant}: one row, {periods} control periods of {scenario.substeps} "
          f"physics steps; bare: mj_step on the same model, as many steps, just before each round")
    print(f"{'phase':20s} " + " ".join(f"{'us':>7s} {'/ bare':>6s}" for _ in range(args.rounds)))
    rounds = []
    for _ in range(args.rounds):
        bare = bare_loop_seconds(scenario.model, periods * scenario.substeps, clock) / periods
        rounds.append((bare, {name: value / periods for name, value in round_seconds(scenario, clock).items()}))
    for name in PHASES:
        print(f"{name:20s} " + " ".join(f"{per[name] * 1e6:7.2f} {per[name] / bare:6.2f}" for bare, per in rounds))
    print(f"{'whole run':20s} " + " ".join(f"{sum(per.values()) * 1e6:7.2f} {sum(per.values()) / bare:6.2f}"
                                           for bare, per in rounds))
    print(f"{'bare mj_step':20s} " + " ".join(f"{bare * 1e6:7.2f} {1.0:6.2f}" for bare, _ in rounds))
    print("physics phase / bare mj_step: " + ", ".join(f"{per['physics'] / bare:.2f}" for bare, per in rounds))


if __name__ == "__main__":
    main()
