"""Tables of a run's metrics: Markdown tables from the metrics JSON of ``ftc-mj run ... --json FILE`` (the
command line is ``ftc-mj report``, :mod:`ftc_mj.cli.report`), and the labels and rows of the table
``ftc-mj run`` prints (:func:`joint_labels`, :func:`table_rows`), which fits 80 columns.

Markdown: one row per metric, one column per variant, the joints' values separated by " / " in each cell (the
layout of docs/results/reproduction.md). Undefined values (null in the JSON) print as "-".
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence

import numpy as np

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


#: The widest joint heading the printed table keeps; longer names become j1, j2, ... with a legend.
JOINT_LABEL_WIDTH = 8


def joint_labels(names: Sequence[str]) -> tuple[list[str], str | None]:
    """Headings of the joint columns and the legend that goes with them (None when the names are the
    headings): the names with the suffix they share dropped (``shoulder_pan_joint`` -> ``shoulder_pan``) when
    they all stay unique and fit :data:`JOINT_LABEL_WIDTH`, else ``j1``, ``j2``, ... and a legend ``j1
    shoulder_pan, j2 shoulder_lift, ...``; an unnamed joint is ``j<k>``."""
    names = [name or f"j{k + 1}" for k, name in enumerate(names)]
    suffix = os.path.commonprefix([name[::-1] for name in names])[::-1] if len(names) > 1 else ""
    suffix = suffix[suffix.find("_"):] if "_" in suffix else ""  # whole words only: "_joint", not "t"
    short = [name.removesuffix(suffix) if suffix and name != suffix else name for name in names]
    if len(set(short)) == len(short) and max(map(len, short)) <= JOINT_LABEL_WIDTH:
        return short, None
    return [f"j{k + 1}" for k in range(len(names))], ", ".join(f"j{k + 1} {name}" for k, name in enumerate(short))


def table_rows(metric_values: dict[str, np.ndarray], hosts: dict[str, str | None],
               shared_plant: bool = False) -> list[tuple[str, np.ndarray]]:
    """The rows of one metric in the printed table, (label, values per joint), in the results' order, each
    value printed once:

    * a monitor's row (``hosts[name]`` its variant) is left out where it equals its variant's (the tracking
      metrics: a monitor observes its variant's closed loop, so they are the same numbers); a monitor's
      label is ``.monitor`` under its variant;
    * with ``shared_plant`` (a log replay: every variant reads the same log and commands nothing), where
      every variant's row is the same and there are two or more (the chattering of the logged torque, which
      no observer changes), one row labelled ``all``. Simulated variants are closed loops of their own: a
      row they share by chance (no false alarms) is printed for each.

    Rows are equal when every value is, NaN equal to NaN."""
    def same(a: np.ndarray, b: np.ndarray) -> bool:
        return bool(np.array_equal(np.asarray(a, float), np.asarray(b, float), equal_nan=True))

    names = list(metric_values)
    variants = [name for name in names if hosts.get(name) is None]
    alike = len(variants) >= 2 and all(same(metric_values[v], metric_values[variants[0]]) for v in variants)
    if shared_plant and alike and all(same(metric_values[m], metric_values[hosts[m]])
                                      for m in names if hosts.get(m) is not None):
        return [("all", metric_values[variants[0]])]
    rows = []
    for name in names:
        host = hosts.get(name)
        if host is None:
            rows.append((name, metric_values[name]))
        elif not same(metric_values[name], metric_values[host]):
            rows.append(("." + name.removeprefix(host + "."), metric_values[name]))
    return rows
