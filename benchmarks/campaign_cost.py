"""Cost of a campaign against the bare batched physics of the same member steps, and against running the same
runs one by one with ``python -m ftc_mj.run``, measured in one run on the same machine.

The first ``--runs`` runs of a campaign (default ``campaigns/ch5_monte_carlo.yaml``) are run with
:func:`ftc_mj.campaign.execute.execute` into a temporary directory (all workers); the bare physics is a
``mujoco.batch.Batch`` of the base model with the campaign's substeps that only writes ``ctrl`` between steps,
as many rows as the campaign steps together, on all cores, for as many member-periods; one by one is
``python -m ftc_mj.run`` as a new process per run (``--no-record --quiet``, every field of the run given with
``--set``, as ``replay`` does) for ``--single`` runs, extrapolated. The bare physics is measured
``--bare-rounds`` times just before and just after the campaign; the ratio is against the mean of those. Prints the three costs per member and
control period and, as its last lines, the ratios (goal: campaign / bare physics <= 1.5).

    python benchmarks/campaign_cost.py [--campaign campaigns/ch5_monte_carlo.yaml] [--runs 64] [--single 3] [--bare-rounds 3]
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
    args = parser.parse_args()
    campaign = execute.load(args.campaign, runs=args.runs)
    periods, variants = campaign.control_periods, len(campaign.variants)
    member_periods = len(campaign.runs) * variants * periods
    # The bare physics with the rows one worker steps at once (its chunk of members, every variant), on all cores,
    # measured just before and just after the campaign (the machine's speed drifts from minute to minute): the
    # ratio is against their mean.
    rows = min(len(campaign.runs), max(1, execute.WORKER_MEMORY // campaign.member_bytes)) * variants
    threads = execute.default_workers()

    def physics_rounds() -> list[float]:
        return [bare(campaign.scenario.model, rows, campaign.scenario.substeps, min(periods, 4000), threads)
                for _ in range(args.bare_rounds)]

    before = physics_rounds()
    with tempfile.TemporaryDirectory() as folder:
        summary = execute.execute(campaign, Path(folder) / "out")
    batched = summary["wall_time"] / member_periods
    after = physics_rounds()
    physics = float(np.mean(before + after))
    single = one_by_one(campaign, args.single)
    print(f"{args.campaign.name}: {len(campaign.runs)} runs x {variants} variants x {periods} control periods of "
          f"{campaign.scenario.substeps} physics steps ({summary['groups']} groups, {summary['workers']} workers)")
    print(f"campaign:       {summary['wall_time']:.1f} s, {summary['runs_per_second']:.3g} runs/s, "
          f"{batched * 1e6:.2f} us per member and control period")
    print(f"bare physics:   {physics * 1e6:.2f} us per member and control period ({rows} rows, {threads} threads; "
          f"before the campaign {', '.join(f'{x * 1e6:.2f}' for x in before)}, after it "
          f"{', '.join(f'{x * 1e6:.2f}' for x in after)})")
    print(f"one by one:     {single * 1e6:.2f} us per member and control period ({args.single} runs of "
          "python -m ftc_mj.run)")
    print(f"for 1000 runs:  campaign {1000 * variants * periods * batched / 60:.1f} min, one by one "
          f"{1000 * variants * periods * single / 60:.1f} min")
    print(f"ratio campaign / bare physics: {batched / physics:.2f}")
    print(f"ratio one by one / campaign: {single / batched:.2f}")


if __name__ == "__main__":
    np.seterr(all="ignore")
    os.environ.setdefault("PYTHONWARNINGS", "ignore")
    main()
