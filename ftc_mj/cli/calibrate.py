"""Diagnosis thresholds calibrated per arm: ``ftc-mj calibrate SCENARIO --false-alarm-rate P [options]``.

Runs N healthy members of the scenario (its faults removed, seeds differing), takes each joint's residual
after the diagnoser is armed, and writes per-joint fixed thresholds at the quantile that gives the per-run
false-alarm rate P on each joint (:mod:`ftc_mj.campaign.calibrate`), as a scenario file that inherits the
scenario (``base:``) and sets ``diagnosis.threshold``: run it as it is, or copy its values into ``--set``;
with ``--thresholds-only``, the thresholds alone, for a scenario that names the file as its own ``base:``.
On a scenario that replays a log (a ``log`` section), the log is the one healthy run: each joint's threshold
is ``--margin`` times the largest residual it holds (at least ``diagnosis.threshold.floor``).

Exit status: 0 on success, 2 on bad input (one line naming the file, the field and the problem; nothing
written), 130 when interrupted (nothing written).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from ftc_mj.cli.command import Outputs, exit_status
from ftc_mj.cli.parser import ArgumentParser
from ftc_mj.config.errors import InputError

PROG = "ftc-mj calibrate"


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    parser = ArgumentParser(prog=prog, description=__doc__.split("\n\n")[1])
    parser.add_argument("scenario", type=Path, help="scenario YAML file (with a diagnosis section)")
    parser.add_argument("--false-alarm-rate", type=float, metavar="P",
                        help="per-run false-alarm probability per joint, in (0, 1) (simulated scenarios)")
    parser.add_argument("--margin", type=float, default=1.1, metavar="M",
                        help="on a log: the threshold is M times the log's largest residual (default 1.1)")
    parser.add_argument("--runs", type=int, default=40, metavar="N", help="healthy runs (default 40)")
    parser.add_argument("--first-seed", type=int, metavar="S",
                        help="seed of the first healthy run (default: the scenario's seed + 1000)")
    parser.add_argument("--variant", nargs="+", default=[], metavar="NAME", help="calibrate on these variants only")
    parser.add_argument("--duration", type=float, metavar="S", help="override the scenario's duration [s]")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="overrides",
                        help="override a scenario field before calibrating")
    parser.add_argument("--out", type=Path, metavar="PATH",
                        help="the calibrated scenario file (default: <scenario>_calibrated.yaml beside it)")
    parser.add_argument("--thresholds-only", action="store_true",
                        help="write the thresholds alone (no base:), a fragment for a scenario's own base:")
    return parser


@exit_status()
def main(argv: Sequence[str] | None = None, prog: str = PROG) -> int:
    args = build_parser(prog).parse_args(argv)
    from ftc_mj.campaign.calibrate import MAX_RUNS, calibrate, calibrate_log, scenario_fragment
    from ftc_mj.scenario.loading import load_scenario

    file = str(args.scenario)
    if not 2 <= args.runs <= MAX_RUNS:  # before anything is loaded: a billion runs is a typo, not a plan
        raise InputError(file, "--runs", f"must be 2 to {MAX_RUNS}, not {args.runs}")
    out = args.out or args.scenario.with_name(f"{args.scenario.stem}_calibrated.yaml")
    outputs = Outputs(file)
    outputs.add("--out", out)
    outputs.check([args.scenario])  # before loading: the scenario is an input whatever it inherits
    scenario = load_scenario(args.scenario, overrides=args.overrides, variants=args.variant)
    outputs.check(scenario.inputs)  # its bases, its model and meshes, its log
    if scenario.log is not None:
        calibration = calibrate_log(args.scenario, margin=args.margin, overrides=args.overrides,
                                    variants=args.variant)
    else:
        if args.false_alarm_rate is None:
            raise InputError(file, "--false-alarm-rate", "is required for a simulated scenario")
        calibration = calibrate(args.scenario, runs=args.runs, false_alarm_rate=args.false_alarm_rate,
                                overrides=args.overrides, first_seed=args.first_seed, variants=args.variant,
                                duration=args.duration)
    text = scenario_fragment(calibration, out, base=not args.thresholds_only)
    outputs.write("--out", out, text.encode("utf-8"))
    empirical = calibration.empirical_rate()
    for j, joint in enumerate(calibration.joints):
        if calibration.margin is not None:
            parts = ", ".join(f"{name} {calibration.per_variant[name][j]:.4g}" for name in calibration.per_variant)
            print(f"{joint}: threshold {calibration.thresholds[j]:.4g}; per variant: {parts}")
            continue
        parts = ", ".join(f"{name} {calibration.per_variant[name][j]:.4g} ({empirical[name][j]:.2g})"
                          for name in calibration.per_variant)
        print(f"{joint}: threshold {calibration.thresholds[j]:.4g}; per variant (calibration-run exceedance): {parts}")
    diverged = {name: count for name, count in calibration.diverged.items() if count}
    if diverged:
        print(f"diverged runs left out: {diverged}")
    for joint in calibration.bound_above_target:
        print(f"note: {joint}: the scenario's threshold bound alone raises false alarms less often than "
              f"{calibration.false_alarm_rate:g} per run; its fixed part is 0 (a lower bound would detect sooner)")
    print(f"calibrated scenario: {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
