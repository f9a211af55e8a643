"""Draw a run's figures from its recording: ``ftc-mj figures RECORDING.rrd [...] [options]`` (also
``python -m ftc_mj.figures``).

One file per figure of the recording's layout (the scenario's ``figures`` section, or the default figures),
named ``<figure>.<format>`` in ``--out`` (default: a folder named after the recording, beside it). The
recording holds every series at the full control rate and the layout it was written with, so figures are
redrawn without running the scenario again. Exit status: 0 on success, 2 on bad input (one line on stderr), 130 when interrupted (the figures drawn
so far removed).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from ftc_mj.cli.command import Outputs, exit_status
from ftc_mj.cli.parser import ArgumentParser
from ftc_mj.outputs.figures import FORMATS

PROG = "ftc-mj figures"


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    parser = ArgumentParser(prog=prog, description=__doc__.split("\n\n")[1])
    parser.add_argument("recordings", type=Path, nargs="+", metavar="RECORDING", help="recordings (.rrd) of runs")
    parser.add_argument("--out", type=Path, metavar="DIR",
                        help="output folder (default: beside each recording, named after it); with several "
                             "recordings, one subfolder per recording")
    parser.add_argument("--format", default="png", metavar="LIST",
                        help=f"comma-separated formats among {', '.join(FORMATS)} (default: png)")
    parser.add_argument("--dpi", type=int, default=150, help="resolution of PNG files (default: 150)")
    parser.add_argument("--size", choices=("page", "column"), default="page",
                        help="page: 8 in wide (default); column: 3.5 in, one column of a two-column paper")
    parser.add_argument("--only", nargs="+", default=[], metavar="NAME", help="draw only these figures")
    parser.add_argument("--scenario-title", action="store_true",
                        help="end each figure's title with the scenario's name")
    return parser


@exit_status()
def main(argv: Sequence[str] | None = None, prog: str = PROG) -> int:
    args = build_parser(prog).parse_args(argv)
    formats = [f.strip().lower() for f in args.format.split(",") if f.strip()]
    unknown = [f for f in formats if f not in FORMATS]
    if unknown or not formats:
        print(f"error: --format: {unknown[0] if unknown else args.format!r} is not one of {', '.join(FORMATS)}",
              file=sys.stderr)
        return 2
    if not 20 <= args.dpi <= 1200:
        print(f"error: --dpi: {args.dpi} is outside 20-1200", file=sys.stderr)
        return 2

    from ftc_mj.config.paths import input_file_problem
    from ftc_mj.outputs import figures
    from ftc_mj.outputs.files import output_problem
    from ftc_mj.outputs.recording import read_entities, read_layout

    jobs = []
    for recording in args.recordings:  # check every input before drawing anything
        if args.out is None:
            folder = recording.with_suffix("")
        else:
            folder = args.out / recording.stem if len(args.recordings) > 1 else args.out
        problem = input_file_problem(recording)
        if problem is None:
            problem = output_problem(folder, directory=True, inputs=args.recordings)
            problem = problem and f"--out: {problem}"
        if problem is not None:
            print(f"error: {recording}: {problem}", file=sys.stderr)
            return 2
        try:
            layout = read_layout(recording)
        except Exception as error:  # noqa: BLE001 - any unreadable file is bad input: one line, exit 2
            print(f"error: {recording}: {_reason(error)}", file=sys.stderr)
            return 2
        chosen = [f for f in layout.figures if not args.only or f.name in args.only]
        missing = set(args.only) - {f.name for f in layout.figures}
        if missing and len(args.recordings) == 1:
            print(f"error: {recording}: --only: no figure {sorted(missing)[0]!r} (figures: "
                  f"{', '.join(f.name for f in layout.figures)})", file=sys.stderr)
            return 2
        for target in [folder / f"{f.name}.{fmt}" for f in chosen for fmt in formats]:  # before drawing anything
            problem = output_problem(target, inputs=args.recordings)
            if problem is not None:
                print(f"error: {recording}: --out: {problem}", file=sys.stderr)
                return 2
        jobs.append((recording, layout, chosen, folder))

    outputs = Outputs(str(args.recordings[0]))  # the files drawn, removed if the command is interrupted
    for recording, layout, chosen, folder in jobs:
        series = read_entities(recording, {e for f in chosen for e in figures.entities_of(f, layout)})
        folder.mkdir(parents=True, exist_ok=True)
        for figure in chosen:
            # The run's variants the figure's section does not list: one line on stderr (stdout lists files).
            skipped = [s.name for s in layout.variants if s.name not in figure.variants]
            if skipped:
                print(f"{figure.name}: not shown (not in its variants): {', '.join(skipped)}", file=sys.stderr)
            drawing = figures.draw(figure, layout, series, args.scenario_title, args.size)
            with outputs.writing("--out", folder / figure.name):
                for path in figures.save(drawing, folder / figure.name, formats, args.dpi):
                    outputs.written.append(path)
                    print(path)
    return 0


def _reason(error: Exception) -> str:
    if isinstance(error, OSError):
        return error.strerror or str(error)
    return str(error).strip("'\"")


if __name__ == "__main__":
    sys.exit(main())
