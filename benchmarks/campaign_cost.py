"""Cost of a campaign against the bare batched physics of the same member steps, and against running the same
runs one by one with ``python -m ftc_mj.run``, measured in one run on the same machine.

The first ``--runs`` runs of a campaign (default ``campaigns/ch5_monte_carlo.yaml``) are run with
:func:`ftc_mj.campaign.execute.execute` into a temporary directory (all workers); the bare physics is a
``mujoco.batch.Batch`` of the base model with the campaign's substeps that only writes ``ctrl`` between steps,
as many rows as a worker steps together, on all cores, for up to 4000 control periods; one by one is
``python -m ftc_mj.run`` as a new process per run (``--no-record --quiet``, every field of the run given with
``--set``, as ``replay`` does) for ``--single`` runs, extrapolated.

The machine's speed drifts over a long campaign, so the bare physics is measured ``--bare-rounds`` times just
before and just after the campaign, and once between its ``--slices`` (the campaign run as that many growing
slices of its runs, each resuming the last); the ratio is against the mean of those, the campaign's time is the
sum of its slices'. Prints the three costs per member and control period and, as its last lines, the ratios
(goal: campaign / bare physics <= 1.3). The bare physics is the plant's kind of batch; a bare batch with one
MjData per row, the faster kind on some machines, is measured once before and once after, and the campaign's
ratio against it printed as well.

    python benchmarks/campaign_cost.py [--campaign campaigns/ch5_monte_carlo.yaml] [--runs 64] [--single 3] [--bare-rounds 3] [--slices 1]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from batch_cost import bare  # the same bare physics as the batch benchmark (this folder is on sys.path)
from ftc_mj.campaign import execute

ROOT = Path(__file__).resolve().parents[1]


def one_by_one(campaign: execute.Campaign, count: int) -> float:
    """Seconds per member and period of ``python -m ftc_mj.run`` per run, all variants, a process each."""
    start = time.perf_counter()
    for run in campaign.runs[:count]:
        argv = [sys.executable, "-m", "ftc_mj.run", str(campaign.scenario_path), "--no-record", "--quiet",
                "--variant", *campaign.variants]
        for path, value in run.assignments().items():
            argv += ["--set", f"{path}={json.dumps(value)}"]
        if campaign.spec.duration is not None:
            argv += ["--duration", repr(campaign.spec.duration)]
        subprocess.run(argv, check=False, stdout=subprocess.DEVNULL)
    return (time.perf_counter() - start) / (count * len(campaign.variants) * campaign.control_periods)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--campaign", type=Path, default=ROOT / "campaigns" / "ch5_monte_carlo.yaml")
    parser.add_argument("--runs", type=int, default=64, help="sampled runs of the campaign to run")
    parser.add_argument("--single", type=int, default=3, help="runs timed one by one with python -m ftc_mj.run")
    parser.add_argument("--bare-rounds", type=int, default=3, help="bare physics measurements before and after")
    parser.add_argument("--slices", type=int, default=1,
                        help="run the campaign in this many growing slices (resumed), the bare physics between them")
    parser.add_argument("--keep", type=Path, default=None,
                        help="write the campaign's results here (a new folder; then `python -m ftc_mj.campaign report "
                             "DIR`) instead of a temporary one")
    args = parser.parse_args()
    if args.keep is not None and args.keep.exists():
        parser.error(f"--keep: {args.keep} already exists")
    campaign = execute.load(args.campaign, runs=args.runs)
    periods, variants = campaign.control_periods, len(campaign.variants)
    member_periods = len(campaign.runs) * variants * periods
    # The bare physics with the rows one worker steps at once (its chunk of members, every variant), on all cores,
    # measured before the campaign, between its slices and after it (the machine's speed drifts from minute to
    # minute): the ratio is against their mean.
    threads = execute.default_workers()
    rows = max(len(task.runs) for task in execute.tasks_for(campaign, campaign.runs, None, threads)) * variants

    def physics_rounds(count: int, persistent: bool | None = None) -> list[float]:
        """``count`` bare rounds: the plant's kind of batch, or ``persistent`` True: one MjData per row."""
        return [bare(campaign.scenario.model, rows, campaign.scenario.substeps, min(periods, 4000), threads,
                     persistent) for _ in range(count)]

    persistent_times = physics_rounds(1, True)  # the faster kind of bare batch on some machines
    physics_times = [physics_rounds(args.bare_rounds)]
    wall = 0.0
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "out" if args.keep is None else args.keep
        for slice_ in range(1, args.slices + 1):  # the first k/S of the runs; each slice runs what is missing
            runs = len(campaign.runs) * slice_ // args.slices
            part = campaign if slice_ == args.slices else execute.load(args.campaign, runs=runs)
            summary = execute.execute(part, out)
            wall += summary["wall_time"]
            physics_times.append(physics_rounds(args.bare_rounds if slice_ == args.slices else 1))
    persistent_times += physics_rounds(1, True)
    summary["wall_time"], summary["runs_per_second"] = wall, len(campaign.runs) / wall
    batched = wall / member_periods
    physics = float(np.mean([x for times in physics_times for x in times]))
    single = one_by_one(campaign, args.single)
    print(f"{args.campaign.name}: {len(campaign.runs)} runs x {variants} variants x {periods} control periods of "
          f"{campaign.scenario.substeps} physics steps ({summary['groups']} groups, {summary['workers']} workers, "
          f"{args.slices} slice{'s' if args.slices > 1 else ''})")
    print(f"campaign:       {summary['wall_time']:.1f} s, {summary['runs_per_second']:.3g} runs/s, "
          f"{batched * 1e6:.2f} us per member and control period")
    print(f"bare physics:   {physics * 1e6:.2f} us per member and control period ({rows} rows, {threads} threads; "
          "mean of " + " | ".join(", ".join(f"{x * 1e6:.2f}" for x in times) for times in physics_times) +
          f", measured before, {'between the slices and ' if args.slices > 1 else ''}after the campaign)")
    print(f"one by one:     {single * 1e6:.2f} us per member and control period ({args.single} runs of "
          "python -m ftc_mj.run)")
    print(f"for 1000 runs:  campaign {1000 * variants * periods * batched / 60:.1f} min, one by one "
          f"{1000 * variants * periods * single / 60:.1f} min")
    persistent = float(np.mean(persistent_times))
    print(f"bare physics with one MjData per row (the faster kind on some machines): {persistent * 1e6:.2f} us per "
          "member and control period (mean of " + ", ".join(f"{x * 1e6:.2f}" for x in persistent_times) +
          f", before and after); ratio campaign / it: {batched / persistent:.2f}")
    print(f"ratio campaign / bare physics: {batched / physics:.2f}")
    print(f"ratio one by one / campaign: {single / batched:.2f}")


if __name__ == "__main__":
    np.seterr(all="ignore")
    os.environ.setdefault("PYTHONWARNINGS", "ignore")
    main()
