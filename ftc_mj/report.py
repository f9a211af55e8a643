"""Markdown tables from the metrics JSON of ``python -m ftc_mj.run ... --json FILE``.

    python -m ftc_mj.report FILE [--metrics NAME ...] [--variants NAME ...]

One row per metric, one column per variant, the joints' values separated by " / " in each cell (the layout of
REPRODUCTION.md). Undefined values (null in the JSON) print as "-".
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path

from ftc_mj.analysis.metrics import UNITS


def _cell(values: Sequence[float | None]) -> str:
    return " / ".join("-" if v is None or not math.isfinite(v) else f"{v:.3g}" for v in values)


def markdown_table(document: dict, metrics: Sequence[str] = (), variants: Sequence[str] = ()) -> str:
    """The metrics of a ``--json`` document as a Markdown table."""
    names = list(variants) or list(document["variants"])
    rows = list(metrics) or list(document["variants"][names[0]]["metrics"])
    lines = [
        f"| metric (joints {' / '.join(str(j + 1) for j in range(_joints(document, names[0])))}) | unit | "
        + " | ".join(names) + " |",
        "|---|---|" + "---|" * len(names),
    ]
    for metric in rows:
        cells = [_cell(document["variants"][name]["metrics"][metric]) for name in names]
        unit = UNITS.get(metric, "").replace("|", "\\|")  # a bar would end the cell
        lines.append(f"| {metric} | {unit} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _joints(document: dict, variant: str) -> int:
    return len(next(iter(document["variants"][variant]["metrics"].values())))


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
