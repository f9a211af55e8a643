"""Markdown tables from the metrics JSON of ``ftc-mj run ... --json FILE``: ``ftc-mj report FILE [options]``
(also ``python -m ftc_mj.report``).

    ftc-mj report FILE [--metrics NAME ...] [--variants NAME ...]

The command line of :func:`ftc_mj.outputs.tables.markdown_table`: one row per metric, one column per variant,
the joints' values separated by " / " in each cell (the layout of docs/results/reproduction.md). Undefined values (null in
the JSON) print as "-", as do NaN, Infinity and numbers beyond a double (``1e400``), which ``run --json``
never writes. Exit status 2 when the file is not a metrics JSON.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

from ftc_mj.cli.command import exit_status
from ftc_mj.cli.parser import ArgumentParser
from ftc_mj.config.errors import InputError

PROG = "ftc-mj report"


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    parser = ArgumentParser(prog=prog, description=__doc__.split("\n\n")[0])
    parser.add_argument("json", type=Path, help="metrics JSON written by ftc-mj run --json")
    parser.add_argument("--metrics", nargs="+", default=[], metavar="NAME", help="only these rows")
    parser.add_argument("--variants", nargs="+", default=[], metavar="NAME", help="only these columns")
    return parser


#: The largest metrics JSON read [bytes] (a run of 50 variants of 7 joints writes about 100 KiB).
MAX_JSON_BYTES = 16 * 2**20


def read_metrics(path: Path) -> dict:
    """A ``--json`` document, its numbers as ``run --json`` writes them: NaN, Infinity and numbers beyond a
    double (``1e400``) are undefined (None, printed "-"), as the run's table prints them.

    Raises:
        InputError: not a readable JSON document.
    """
    import math

    from ftc_mj.config.paths import read_input_text

    file = str(path)
    text = read_input_text(path, MAX_JSON_BYTES, file)

    def number(literal: str) -> float | None:
        value = float(literal)
        return value if math.isfinite(value) else None

    try:
        return json.loads(text, parse_constant=lambda name: None, parse_float=number)
    except ValueError as error:
        raise InputError(file, "", f"not a metrics JSON of ftc-mj run ({error})") from None


@exit_status()
def main(argv: Sequence[str] | None = None, prog: str = PROG) -> int:
    args = build_parser(prog).parse_args(argv)
    from ftc_mj.outputs.tables import markdown_table

    document = read_metrics(args.json)
    try:
        table = markdown_table(document, args.metrics, args.variants)
    except (ValueError, KeyError, TypeError, AttributeError, IndexError, StopIteration) as error:
        raise InputError(str(args.json), "", f"not a metrics JSON of ftc-mj run ({type(error).__name__}: "
                         f"{error})") from None
    print(table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
