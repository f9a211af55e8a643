"""Paired differences between one diagnosis row and others of a stored benchmark tier (reads, never simulates):
the between-method comparisons of docs/results/baselines.md, which the leaderboard makes only for tuned rows
against their design rows.

    python tools/paired_rows.py BENCH.yaml OUT_DIR REFERENCE [OTHER ...] [--tier full] [--robots R ...]

Every row of a robot is a monitor of runs with the same seeds, mass scales and fault cases, so two rows are scored
on the same windows (checked: :func:`ftc_mj.ranking.calibrated.paired_differences` refuses otherwise). Each OTHER
row (default: every diagnosis row of the bench but REFERENCE) less REFERENCE, AUC and P_d, with the paired
clustered bootstrap interval; the p-values adjusted by Holm over every robot, row and score printed (one family).
A row may be a sanity row too (``oracle_fault``, ``oracle_luaf``, ``null``).

The test's own check comes first, per robot, as the leaderboard makes it: ``oracle_fault`` (perfect) against
``null`` (useless) on the same windows must be apart above on both scores at the family's strictest level
(alpha / tests); where it is not, that robot's verdicts (``*``) are withheld.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ftc_mj.config.errors import InputError
from ftc_mj.ranking import calibrated as cal
from ftc_mj.ranking import execute, windows as stored
from ftc_mj.ranking.entries import load_bench
from ftc_mj.ranking.windowed import FAMILY_ALPHA, PAIRED_SCORES, entry_windows


def windows(bench, done, robot: str, name: str) -> cal.Windows:
    """One row's calibrated windows on one robot, as the leaderboard makes them (no bootstrap of its own)."""
    return entry_windows(bench, robot, done, name)[0]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("bench")
    parser.add_argument("out", help="the tier's output directory (its runs/ are read)")
    parser.add_argument("reference")
    parser.add_argument("others", nargs="*")
    parser.add_argument("--tier", default="full")
    parser.add_argument("--robots", nargs="*")
    args = parser.parse_args(argv)
    bench = load_bench(args.bench)
    names = [e.name for e in bench.of("diagnosis")] + list(stored.SANITY)
    for field, name in [("reference", args.reference)] + [(f"others.{i}", n) for i, n in enumerate(args.others)]:
        if name not in names:
            raise InputError(args.bench, field, f"{name!r} is not a diagnosis row (its rows: {', '.join(names)})")
    robots = args.robots or list(bench.suite.spec.robots)
    for i, robot in enumerate(robots):
        if robot not in bench.suite.spec.robots:
            raise InputError("command line", f"--robots.{i}", f"{robot!r} is not a robot of the suite")
    done, missing = execute.plan(bench, args.tier, Path(args.out))
    if missing:
        raise InputError(args.out, "runs", f"{len(missing)} campaigns are not simulated; run ftc-mj bench first")
    others = args.others or [n for n in names if n != args.reference and n not in stored.SANITY]
    tests = len(robots) * len(others) * len(PAIRED_SCORES)
    resamples = cal.paired_resamples(tests, FAMILY_ALPHA)
    found, passed = [], {}
    print(f"the test's own check, oracle_fault - null at the family's strictest level ({FAMILY_ALPHA} / {tests}):")
    for robot in robots:
        check = cal.paired_differences(windows(bench, done, robot, "oracle_fault"),
                                       windows(bench, done, robot, "null"), PAIRED_SCORES, resamples)
        passed[robot] = all(check[score].low > 0 and check[score].p_value * tests <= FAMILY_ALPHA
                            for score in PAIRED_SCORES)
        print(f"{robot:9s} " + " | ".join(f"{score} {check[score].value:+.4f} [{check[score].low:+.4f}, "
                                          f"{check[score].high:+.4f}]" for score in PAIRED_SCORES)
              + ("  passed" if passed[robot] else "  FAILED: this robot's verdicts are withheld"))
    for robot in robots:
        reference = windows(bench, done, robot, args.reference)
        for name in others:
            found.append((robot, name, cal.paired_differences(windows(bench, done, robot, name), reference,
                                                              PAIRED_SCORES, resamples)))
    adjusted = iter(cal.holm([d[score].p_value for _, _, d in found for score in PAIRED_SCORES]))
    print(f"row - {args.reference}, paired; Holm over {tests} tests ({resamples} resamples)")
    for robot, name, difference in found:
        cells = []
        for score in PAIRED_SCORES:
            d, p = difference[score], float(next(adjusted))
            cells.append(f"{score} {d.value:+.4f} [{d.low:+.4f}, {d.high:+.4f}] p {p:.3g}"
                         + (" *" if passed[robot] and p <= FAMILY_ALPHA and (d.low > 0 or d.high < 0) else ""))
        print(f"{robot:9s} {name:22s} " + " | ".join(cells))


if __name__ == "__main__":
    try:
        main()
    except InputError as error:  # bad input: one line, exit 2
        print(f"error: {error}", file=sys.stderr)
        sys.exit(2)
