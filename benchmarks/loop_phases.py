"""Where a campaign batch's time goes, phase by phase, against its own physics: the floor of the campaign's cost.

The first batch of a campaign (default ``campaigns/ch5_monte_carlo.yaml``), cut as ``python -m ftc_mj.campaign
run`` cuts it (its default batch size on this machine's workers), is run on one core the way a worker runs it,
with a timer around each phase of the loop (:mod:`ftc_mj.engine.loop`):

* physics: the plant's substeps (``MuJoCoPlant.step``), the campaign's only share of bare physics;
* nominal model: Psi at every estimate and M at every measured position (:func:`nominal_batch`,
  :mod:`ftc_mj.engine.mass`);
* methods: observers' and controllers' laws (``update``, ``compute``, ``advance``), the recorded series;
* plant terms: friction, disturbance and fault terms on the true state, the truths' bookkeeping;
* readings: sensor effects and the divergence check;
* set-up and truths: buffers, plugins, the truths solved after the run;
* metrics: every member's results, diagnosis, metrics and detection statistics, as a worker computes them.

Beside the phases, the analysis' accelerators (``ftc_mj/fast/analysis_*.py``) against their NumPy definitions
(``FTC_MJ_FAST=0`` for one of each): the series metrics of every row, the post-run diagnosis of each variant's
rows at once, and the causal diagnoser stepped each period over every row on the batch's recorded estimates,
as the loop steps it for a controller that reads the diagnosis.

Each phase is printed per row (variant x member) and control period, and as a share of the physics. The
campaign's goal is at most 1.3 times the bare physics, so everything but the physics must stay
within 0.3 of it; the printed cumulative ratios say how far each phase brings it. The bare physics of the
same rows on one core (``benchmarks/batch_cost.py``'s batch, the plant's kind) is measured before and after as
a check that the physics phase is the bare physics' cost, and so is a bare batch with one MjData per row, the
faster kind on some machines (the whole batch's ratio against it is printed too).

    python benchmarks/loop_phases.py [--campaign campaigns/ch5_monte_carlo.yaml] [--duration SECONDS] [--members B]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from batch_cost import bare  # the same bare physics as the batch benchmark (this folder is on sys.path)
from ftc_mj import fast
from ftc_mj.analysis.causal import RecordedDiagnoser
from ftc_mj.campaign import execute
from ftc_mj.engine import loop
from ftc_mj.engine.members import members_from_overrides
from ftc_mj.analysis.metrics import onsets_per_joint
from ftc_mj.engine.runner import _finished_metrics, member_outcomes
from ftc_mj.engine.series import BatchRun

ROOT = Path(__file__).resolve().parents[1]
PHASES = ("physics", "nominal model", "methods", "plant terms", "readings", "set-up and truths", "metrics")


def timed_periods(run: loop._Run, seconds: dict[str, float], clock: Callable[[], float] = time.perf_counter
                  ) -> BatchRun:
    """Every control period of ``run`` as the loop steps it, each phase's seconds by ``clock`` added to
    ``seconds`` (the keys of :data:`PHASES` but the metrics); the truths after the run under "set-up and
    truths". The run."""
    with np.errstate(all="ignore"):
        for k in range(run.steps):
            t = run.times[k]
            a = clock()
            run.stop(run.plant.check(), k)
            run.sense(k)
            b = clock()
            run.evaluate_nominal(k)
            c = clock()
            run.control(k, t)
            d = clock()
            run.actuate(k, t)
            e = clock()
            run.integrate_observers()  # advance(), split: the observers (methods), then the plant (physics)
            f = clock()
            run.step_plant(k)
            g = clock()
            seconds["readings"] += b - a
            seconds["nominal model"] += c - b
            seconds["methods"] += d - c + f - e
            seconds["plant terms"] += e - d
            seconds["physics"] += g - f
        a = clock()
        run.finish_truth()
        batch_run = run.result()
        seconds["set-up and truths"] += clock() - a
    return batch_run


def phase_seconds(campaign: execute.Campaign, task: execute.Task) -> tuple[dict[str, float], int, int]:
    """Seconds per phase of one batch on one core; the batch's rows and control periods."""
    scenario = execute.compiled_scenario(task.scenario, task.variants, task.duration, execute.frozen(task.structure))
    members = members_from_overrides(scenario, [member for _, _, member in task.runs])
    seconds = dict.fromkeys(PHASES, 0.0)
    clock = time.perf_counter
    start = clock()
    run = loop._Run.set_up(scenario, members, record_poses=False, nthread=1)
    seconds["set-up and truths"] += clock() - start
    batch_run = timed_periods(run, seconds)
    a = clock()
    _, keep_detection = execute.detection_keeper(scenario, task.scales)
    member_outcomes(scenario, batch_run, 0, keep_detection)
    seconds["metrics"] += clock() - a
    for accelerated in (True, False):
        fast.set_enabled(accelerated)
        try:
            tag = "" if accelerated else ", NumPy definitions"
            joint_onsets = onsets_per_joint(scenario.joint_fault_onsets, scenario.fault_onsets, scenario.n_joints)
            a = clock()
            _finished_metrics(scenario, batch_run, joint_onsets)
            seconds["series metrics" + tag] = clock() - a
            seconds["post-run diagnosis" + tag] = post_run_seconds(scenario, batch_run)
            seconds["causal diagnoser in the loop" + tag] = diagnoser_seconds(scenario, batch_run)
        finally:
            fast.set_enabled(True)
    return seconds, run.rows, run.steps


def post_run_seconds(scenario, batch_run: BatchRun) -> float:
    """Seconds to diagnose every variant's rows after the run, all rows of a variant at once (0 without a
    diagnosis)."""
    if scenario.diagnoser is None:
        return 0.0
    members, series = batch_run.members, batch_run.series
    estimate = batch_run.luaf_torque if scenario.diagnoser.space == "torque" else series["luaf_hat"]
    start = time.perf_counter()
    for v in range(len(batch_run.variants)):
        rows = slice(v * members, (v + 1) * members)
        scenario.diagnoser.diagnose_rows(batch_run.times, estimate[:, rows], series["q_meas"][:, rows],
                                         series["qd_hat"][:, rows])
    return time.perf_counter() - start


def diagnoser_seconds(scenario, batch_run: BatchRun) -> float:
    """Seconds to step every variant's causal diagnoser over its members' recorded estimates, period by
    period, as the loop does for a controller that reads the diagnosis (0 without a diagnosis)."""
    if scenario.diagnoser is None:
        return 0.0
    members, series = batch_run.members, batch_run.series
    estimate = batch_run.luaf_torque if scenario.diagnoser.space == "torque" else series["luaf_hat"]
    total = 0.0
    with np.errstate(all="ignore"):
        for v in range(len(batch_run.variants)):
            rows = slice(v * members, (v + 1) * members)
            diagnoser = RecordedDiagnoser(scenario.diagnoser, members, len(batch_run.times))
            values = [np.ascontiguousarray(s[:, rows]) for s in (estimate, series["q_meas"], series["qd_hat"])]
            start = time.perf_counter()
            for k, t in enumerate(batch_run.times.tolist()):
                diagnoser.step(k, t, values[0][k], values[1][k], values[2][k])
            total += time.perf_counter() - start
    return total


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--campaign", type=Path, default=ROOT / "campaigns" / "ch5_monte_carlo.yaml")
    parser.add_argument("--duration", type=float, default=None, help="simulated seconds (default: the campaign's)")
    parser.add_argument("--members", type=int, default=None, help="members of the batch (default: the campaign's)")
    args = parser.parse_args()
    campaign = execute.load(args.campaign)
    task = execute.tasks_for(campaign, campaign.runs, args.members, execute.default_workers())[0]
    if args.duration is not None:
        task = execute.Task(**{**task.__dict__, "duration": args.duration})
    periods = len(execute.compiled_scenario(task.scenario, task.variants, task.duration,
                                            execute.frozen(task.structure)).times)
    rows = len(task.runs) * len(task.variants)

    def physics(persistent: bool | None = None) -> float:
        return bare(campaign.scenario.model, rows, campaign.scenario.substeps, min(periods, 4000), 1, persistent)

    before, persistent_before = physics(), physics(True)
    seconds, rows, steps = phase_seconds(campaign, task)
    after, persistent_after = physics(), physics(True)
    per = {name: value / (rows * steps) for name, value in seconds.items()}
    print(f"{args.campaign.name}: one batch of {len(task.runs)} members x {len(task.variants)} variants = {rows} rows, "
          f"{steps} control periods of {campaign.scenario.substeps} physics steps, on one core")
    print(f"{'phase':20s} {'us per row-period':>18s} {'/ physics':>10s} {'cumulative':>11s}")
    physics_cost, cumulative = per["physics"], 0.0
    for name in PHASES:
        cumulative += per[name]
        print(f"{name:20s} {per[name] * 1e6:18.2f} {per[name] / physics_cost:10.2f} {cumulative / physics_cost:11.2f}")
    print(f"bare physics, same rows, one core: {before * 1e6:.2f} before, {after * 1e6:.2f} after "
          f"(the physics phase: {physics_cost * 1e6:.2f})")
    print(f"bare physics with one MjData per row (the faster kind on some machines): {persistent_before * 1e6:.2f} "
          f"before, {persistent_after * 1e6:.2f} after; ratio whole batch / it: "
          f"{cumulative / ((persistent_before + persistent_after) / 2):.2f}")
    print(f"ratio whole batch / its physics: {cumulative / physics_cost:.2f}")
    print(f"ratio physics + nominal model / physics (the floor with the methods free): "
          f"{(per['physics'] + per['nominal model']) / physics_cost:.2f}")
    for name in ("series metrics", "post-run diagnosis", "causal diagnoser in the loop"):
        fast_cost, numpy_cost = per[name], per[name + ", NumPy definitions"]
        print(f"{name}: {fast_cost * 1e6:.2f} us per row-period accelerated, {numpy_cost * 1e6:.2f} on the NumPy "
              f"definitions ({fast_cost / physics_cost:.3f} and {numpy_cost / physics_cost:.3f} of the physics)")


if __name__ == "__main__":
    main()
