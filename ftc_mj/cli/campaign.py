"""Campaigns: ``ftc-mj campaign run|report|replay`` (also ``python -m ftc_mj.campaign``).

    ftc-mj campaign run CAMPAIGN.yaml [--out DIR] [--runs N] [--duration S] [--set KEY=VALUE ...]
                                      [--batch-size B] [--workers N] [--scheduler ADDRESS] [--quiet]
    ftc-mj campaign report DIR
    ftc-mj campaign replay DIR RUN_ID [--variant NAME ...] [--out FILE.rrd] [--json FILE.json]

``run`` simulates every run of the campaign's population for every variant (resuming what DIR already has),
then writes ``runs.parquet``, ``campaign.json`` and the report. ``--runs``, ``--duration`` and ``--set`` (a
scenario field for every run, as the campaign's ``set``) make a smoke test of the same file; the command line
is recorded in ``campaign.json`` and the report. ``report`` writes the report again from DIR.
``replay`` simulates one run alone, as ``ftc-mj run`` would, with a recording and its metrics.

Exit status: 0 on success (diverged runs are results, not failures), 2 on bad input (one line naming the
file, the field and the problem; nothing is written), 1 when a worker process died, 130 when interrupted
(what finished is kept).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from ftc_mj.cli.command import WORK_KEPT, WORKER_DIED, Outputs, exit_status
from ftc_mj.cli.parser import ArgumentParser

if TYPE_CHECKING:
    from rich.console import Console

PROG = "ftc-mj campaign"


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    parser = ArgumentParser(prog=prog, description="Monte Carlo, sweeps and fault-diagnosis statistics over "
                            "populations of runs.")
    commands = parser.add_subparsers(dest="command", required=True, parser_class=ArgumentParser)
    run = commands.add_parser("run", help="run a campaign (resumes an interrupted one)")
    run.add_argument("campaign", type=Path)
    run.add_argument("--out", type=Path, metavar="DIR", help="results directory (default: results/<name>/)")
    run.add_argument("--runs", type=int, metavar="N", help="number of sampled points (the first N of the population)")
    run.add_argument("--duration", type=float, metavar="S", help="override the campaign's duration [s]")
    run.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="overrides",
                     help="set a scenario field in every run (joins the campaign's set), e.g. "
                          "sensors.position.noise_std=0")
    run.add_argument("--batch-size", type=int, metavar="B",
                     help="members stepped together per batch (default: the largest batches a worker's memory "
                          "allows, the same share for every worker)")
    run.add_argument("--workers", type=int, metavar="N", help="worker processes (default: all cores)")
    run.add_argument("--scheduler", metavar="ADDRESS", help="a Dask scheduler, e.g. tcp://127.0.0.1:8786")
    run.add_argument("--quiet", action="store_true", help="no progress bar and no summary")
    report = commands.add_parser("report", help="write the report of a results directory again")
    report.add_argument("directory", type=Path)
    replay = commands.add_parser("replay", help="simulate one run alone, with a recording")
    replay.add_argument("directory", type=Path)
    replay.add_argument("run_id")
    replay.add_argument("--variant", nargs="+", default=[], metavar="NAME", help="only these variants")
    replay.add_argument("--out", type=Path, metavar="FILE.rrd", help="recording (default: DIR/replay/<run_id>.rrd)")
    replay.add_argument("--json", type=Path, metavar="FILE.json", help="write the run's metrics as JSON")
    return parser


def _positive(value: int | None, option: str) -> None:
    from ftc_mj.config.errors import InputError

    if value is not None and value < 1:
        raise InputError("command line", option, f"must be at least 1, not {value}")


def assignments(items: Sequence[str], option: str = "--set") -> dict[str, object]:
    """``KEY=VALUE`` strings as field -> value, each value read as YAML (``0.5``, ``[1, 2]``, ``text``).

    Raises:
        InputError: an item without ``=`` or a value that is not YAML.
    """
    import yaml

    from ftc_mj.config.errors import InputError

    found: dict[str, object] = {}
    for item in items:
        key, equals, text = item.partition("=")
        if not equals or not key.strip():
            raise InputError("command line", option, f"{item!r} is not KEY=VALUE")
        try:
            found[key.strip()] = yaml.safe_load(text)
        except yaml.YAMLError:
            raise InputError("command line", option, f"{key.strip()}: {text!r} is not a YAML value") from None
    return found


def command_line(prog: str, argv: Sequence[str]) -> str:
    """The command as a shell would take it again."""
    import shlex

    return " ".join([prog, *(shlex.quote(a) for a in argv)])


def _run(args: argparse.Namespace, console: Console) -> int:
    from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn,
                               TimeRemainingColumn)

    from ftc_mj.campaign import execute
    from ftc_mj.campaign.summary import write_report

    for value, option in ((args.batch_size, "--batch-size"), (args.workers, "--workers")):
        _positive(value, option)
    file = str(args.campaign)
    outputs = Outputs(file)
    outputs.add("--out", args.out, directory=True)
    outputs.check([args.campaign])
    if args.scheduler is not None:
        execute.check_scheduler_address(args.scheduler, file)
    if args.duration is not None and not args.duration > 0:
        from ftc_mj.config.errors import InputError

        raise InputError("command line", "--duration", f"must be positive, not {args.duration:g}")
    campaign = execute.load(args.campaign, args.runs, duration=args.duration, assignments=assignments(args.overrides))
    campaign.command = args.command_line
    out = args.out or Path("results") / campaign.spec.name
    outputs.declared.clear()
    outputs.add("--out", out, directory=True)
    outputs.check(campaign.inputs)
    if args.scheduler is not None:
        execute.check_scheduler(args.scheduler, file)
    def note(line: str) -> None:  # said whatever --quiet: a run simulated again is not silent
        print(f"note: {line}", file=sys.stderr)

    if args.quiet:
        summary = execute.execute(campaign, out, batch_size=args.batch_size, workers=args.workers,
                                  scheduler=args.scheduler, progress=execute.Progress(note=note))
    else:
        columns = (TextColumn(f"{campaign.spec.name:<20}"), BarColumn(), MofNCompleteColumn(), TextColumn("runs"),
                   TextColumn("{task.fields[rate]}"), TimeElapsedColumn(), TextColumn("left"), TimeRemainingColumn())
        with Progress(*columns, console=console) as display:
            task = display.add_task("runs", total=len(campaign.runs), rate="")
            start, first = time.perf_counter(), [None]

            def update(done: int, total: int) -> None:
                if first[0] is None:
                    first[0] = done
                elapsed = time.perf_counter() - start
                rate = (done - first[0]) / elapsed if elapsed > 0 and done > first[0] else 0.0
                display.update(task, completed=done, rate=f"{rate:.2f} runs/s" if rate else "")

            summary = execute.execute(campaign, out, batch_size=args.batch_size, workers=args.workers,
                                      scheduler=args.scheduler, progress=execute.Progress(update, note))
    written = write_report(out)
    if not args.quiet:
        console.print(f"{summary['runs']} runs x {len(summary['variants'])} variants "
                      f"({summary['status_counts']}); {summary['simulated_runs']} simulated in "
                      f"{summary['wall_time']:.1f} s. Results in {out}/: runs.parquet, campaign.json, "
                      f"{written[0].name} and {len(written) - 1} figures.")
    return 0


@exit_status(WORK_KEPT, died=WORKER_DIED + " or a smaller --batch-size")
def main(argv: Sequence[str] | None = None, prog: str = PROG) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser(prog).parse_args(argv)
    args.command_line = command_line(prog, argv)
    from rich.console import Console

    if args.command == "run":
        return _run(args, Console(stderr=False))
    if args.command == "report":
        from ftc_mj.campaign.summary import write_report

        written = write_report(args.directory)
        print(f"wrote {written[0]} and {len(written) - 1} figures")
        return 0
    from ftc_mj.campaign.execute import replay_arguments
    from ftc_mj.cli import run

    return run.main(replay_arguments(args.directory, args.run_id, variants=args.variant, out=args.out,
                                     json_path=args.json))


if __name__ == "__main__":
    sys.exit(main())
