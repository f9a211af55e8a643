"""Per fault case, when reconfiguring on the diagnosis pays and what a false alarm costs: the runs of
``campaigns/ftc_reconfiguration.yaml`` (its runs.parquet) as the tables of docs/results/reconfiguration.md.

    python -m ftc_mj.campaign run campaigns/ftc_reconfiguration.yaml
    python studies/ftc_reconfiguration.py results/ftc_reconfiguration/runs.parquet

Per case and variant: tracking after convergence (``rms_error_converged``, on the faulty joint where the case
has one, else the mean over joints), the peak error after the onset (``fault_peak_error``, faulty joint) and
chattering (mean over joints), each as a mean with its 95% bootstrap interval, and the paired difference with
the passive loop on the same seeds (the variant minus passive: positive where the variant's value is higher,
i.e. worse for all three). The false-alarm cost: per variant, the over-sensitive healthy case minus the healthy case on the same
seeds.
"""

from __future__ import annotations

import sys

import numpy as np
import pyarrow.parquet as pq

from ftc_mj.campaign.statistics import paired, summarise

VARIANTS = ["passive", "uncompensated", "active", "supervisor", "accommodation", "pid"]
#: The joint each case's fault acts on (1-based), None for the healthy cases.
FAULTY = {"healthy": None, "false_alarms": None, "loe_0.5": 2, "bias_5": 3, "saturation_40": 2}


def column(table: dict, metric: str, joint: int | None) -> np.ndarray:
    if joint is not None:
        return np.asarray(table[f"{metric}.{joint}"], dtype=float)
    return np.mean([np.asarray(table[f"{metric}.{j}"], dtype=float) for j in (1, 2, 3)], axis=0)


def rows(table: dict, case: str, variant: str) -> np.ndarray:
    return (np.asarray(table["case"]) == case) & (np.asarray(table["variant"]) == variant)


def by_seed(table: dict, mask: np.ndarray, values: np.ndarray) -> np.ndarray:
    order = np.argsort(np.asarray(table["seed"])[mask])
    return values[mask][order]


def main(path: str) -> None:
    table = pq.read_table(path).to_pydict()
    cases = list(dict.fromkeys(table["case"]))
    metrics = [("rms_error_converged", "rad", True), ("fault_peak_error", "rad", True), ("chattering", "N m/s", False)]
    for case in cases:
        joint = FAULTY.get(case)
        where = f"joint {joint}" if joint else "mean over joints"
        print(f"\n### {case}\n")
        print("| variant | " + " | ".join(f"{m} [{u}] ({where if faulty else 'mean over joints'})"
                                        for m, u, faulty in metrics) + " | runs with a false alarm |")
        print("|---|" + "---|" * (len(metrics) + 1))
        for variant in VARIANTS:
            mask = rows(table, case, variant)
            cells = []
            for metric, _, faulty in metrics:
                values = column(table, metric, joint if faulty else None)[mask]
                summary = summarise(values)
                text = summary.mean.text() if summary.count else "-"
                if variant != "passive" and summary.count:
                    reference = by_seed(table, rows(table, case, "passive"), column(table, metric, joint if faulty else None))
                    difference = paired(by_seed(table, mask, column(table, metric, joint if faulty else None)), reference)
                    text += f"; vs passive {difference.mean_difference.text()}"
                cells.append(text)
            alarms = sum(np.asarray(table[f"false_alarms.{j}"], dtype=float)[mask] for j in (1, 2, 3))
            cells.append(f"{int(np.sum(np.nan_to_num(alarms) > 0))} / {int(mask.sum())}")
            print(f"| {variant} | " + " | ".join(cells) + " |")
    if {"healthy", "false_alarms"} <= set(cases):
        print("\n### The cost of a false alarm (over-sensitive diagnosis minus healthy, same seeds)\n")
        print("| variant | rms_error_converged [rad] | chattering [N m/s] |")
        print("|---|---|---|")
        for variant in VARIANTS:
            cells = []
            for metric in ("rms_error_converged", "chattering"):
                values = column(table, metric, None)
                difference = paired(by_seed(table, rows(table, "false_alarms", variant), values),
                                    by_seed(table, rows(table, "healthy", variant), values))
                cells.append(difference.mean_difference.text())
            print(f"| {variant} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "results/ftc_reconfiguration/runs.parquet")
