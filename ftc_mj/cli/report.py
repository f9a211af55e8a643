"""Markdown tables from the metrics JSON of ``ftc-mj run ... --json FILE``: ``ftc-mj report FILE [options]``
(also ``python -m ftc_mj.report``).

    ftc-mj report FILE [--metrics NAME ...] [--variants NAME ...]

The command line of :func:`ftc_mj.outputs.tables.markdown_table`: one row per metric, one column per variant,
the joints' values separated by " / " in each cell (the layout of docs/results/reproduction.md). Undefined values (null in
the JSON) print as "-". Exit status 2 when the file is not a metrics JSON.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

from ftc_mj.cli.parser import ArgumentParser

PROG = "ftc-mj report"


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    parser = ArgumentParser(prog=prog, description=__doc__.split("\n\n")[0])
    parser.add_argument("json", type=Path, help="metrics JSON written by ftc-mj run --json")
    parser.add_argument("--metrics", nargs="+", default=[], metavar="NAME", help="only these rows")
    parser.add_argument("--variants", nargs="+", default=[], metavar="NAME", help="only these columns")
    return parser


def main(argv: Sequence[str] | None = None, prog: str = PROG) -> int:
    args = build_parser(prog).parse_args(argv)
    from ftc_mj.outputs.tables import markdown_table

    try:
        document = json.loads(args.json.read_text(encoding="utf-8"))
        print(markdown_table(document, args.metrics, args.variants))
    except (OSError, ValueError, KeyError, TypeError) as error:
        print(f"error: {args.json}: not a metrics JSON of ftc-mj run ({error})", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
