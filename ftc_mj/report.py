"""Markdown tables from the metrics JSON of ``python -m ftc_mj.run ... --json FILE``.

    python -m ftc_mj.report FILE [--metrics NAME ...] [--variants NAME ...]

The command line of :func:`ftc_mj.outputs.report.markdown_table`: one row per metric, one column per variant,
the joints' values separated by " / " in each cell (the layout of REPRODUCTION.md). Undefined values (null in
the JSON) print as "-". Exit status 2 when the file is not a metrics JSON.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

from ftc_mj.outputs.report import markdown_table


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m ftc_mj.report", description=__doc__.split("\n\n")[0])
    parser.add_argument("json", type=Path, help="metrics JSON written by python -m ftc_mj.run --json")
    parser.add_argument("--metrics", nargs="+", default=[], metavar="NAME", help="only these rows")
    parser.add_argument("--variants", nargs="+", default=[], metavar="NAME", help="only these columns")
    args = parser.parse_args(argv)
    try:
        document = json.loads(args.json.read_text(encoding="utf-8"))
        print(markdown_table(document, args.metrics, args.variants))
    except (OSError, ValueError, KeyError, TypeError) as error:
        print(f"error: {args.json}: not a metrics JSON of ftc_mj.run ({error})", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
