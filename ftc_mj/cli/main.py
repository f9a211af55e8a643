"""The ``ftc-mj`` command: ``ftc-mj run|figures|report|campaign|tune|bench|robot|calibrate|identify|monitor ...`` (``python -m
ftc_mj.cli`` too).

Dispatches to the command's module in this package, which reads the rest of the arguments; each command's
``--help`` tells its options.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from ftc_mj.cli.parser import ArgumentParser

#: Command -> what it does (its module is ``ftc_mj.cli.<command>``).
COMMANDS = {
    "run": "run a scenario: metrics table, Rerun recording, --json metrics",
    "figures": "draw a run's figures (PNG, SVG, PDF) from its recording",
    "report": "Markdown tables from a run's --json metrics",
    "campaign": "Monte Carlo, sweeps and fault-diagnosis statistics: run, report, replay",
    "tune": "robust gain tuning (CMA-ES): a variant on a campaign, or bench entries on P_d",
    "bench": "benchmark: score methods on a versioned suite",
    "robot": "check a robot before its first run: per-joint numbers, warnings",
    "calibrate": "per-joint diagnosis thresholds: for a false-alarm rate, or from a healthy log",
    "identify": "identify joint friction (and inertial parameters) from logs: a scenario base file",
    "monitor": "a scenario's observer and diagnosis on a stream: a log row by row, or a ROS 2 topic (--ros)",
}


def build_parser() -> argparse.ArgumentParser:
    from importlib.metadata import PackageNotFoundError, version

    try:
        installed = version("ftc_mj")
    except PackageNotFoundError:  # run from a source tree without installing
        installed = "unknown"
    parser = ArgumentParser(
        prog="ftc-mj", description="Fault diagnosis and fault-tolerant control of robot manipulators on MuJoCo.",
        epilog="Run 'ftc-mj COMMAND --help' for a command's options.",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"ftc-mj {installed}")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND", parser_class=ArgumentParser)
    for name, summary in COMMANDS.items():
        commands.add_parser(name, help=summary, add_help=False)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] in COMMANDS:
        command = importlib.import_module(f"ftc_mj.cli.{argv[0]}")
        return command.main(argv[1:], prog=f"ftc-mj {argv[0]}")
    build_parser().parse_args(argv)  # --help, --version, or a one-line error (exit 2)
    return 2


if __name__ == "__main__":
    sys.exit(main())
