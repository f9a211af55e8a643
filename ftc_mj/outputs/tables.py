"""Markdown tables from the metrics JSON of ``ftc-mj run ... --json FILE`` (the command line is
``ftc-mj report``, :mod:`ftc_mj.cli.report`).

One row per metric, one column per variant, the joints' values separated by " / " in each cell (the layout of
docs/results/reproduction.md). Undefined values (null in the JSON) print as "-".
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from ftc_mj.analysis.metrics import UNITS

#: The run's summary (``ftc-mj run``'s table unless ``--metrics all``): metric groups, each one line per
#: variant: tracking after convergence, estimation error, chattering and, with a diagnosis, its delay and false
#: alarms.
SUMMARY: tuple[tuple[str, str], ...] = (
    ("tracking (converged)", "rms_error_converged"),
    ("velocity estimation", "rms_velocity_error"),
    ("LUaF estimation", "rms_luaf_error"),
    ("chattering", "chattering"),
    ("detection delay", "detection_delay"),
    ("false alarms", "false_alarms"),
)
#: The summary's groups that need a ``diagnosis`` section.
DIAGNOSIS_GROUPS = ("detection_delay", "false_alarms")


def summary_metrics(diagnosis: bool) -> list[str]:
    """The metrics of the summary table, without the diagnosis's when there is none."""
    return [metric for _, metric in SUMMARY if diagnosis or metric not in DIAGNOSIS_GROUPS]


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
