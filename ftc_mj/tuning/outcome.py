"""What a tuning leaves for its user: ``best.yaml`` (the tuned gains, ready to paste into a scenario),
``report.json`` (with the held-out check), ``report.md`` and ``convergence.png``."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from matplotlib.figure import Figure
import numpy as np
import yaml

from ftc_mj.analysis.metrics import unit
from ftc_mj.campaign import statistics as st
from ftc_mj.outputs.files import write_atomic
from ftc_mj.outputs.palette import COLOURS
from ftc_mj.tuning.optimise import Tuning, aggregate, condition_costs, violations


def _nested(gains: dict[str, float]) -> dict:
    """Dotted paths as the nested mapping a scenario file holds."""
    root: dict = {}
    for path, value in gains.items():
        node = root
        *parents, leaf = path.split(".")
        for part in parents:
            node = node.setdefault(part, {})
        node[leaf] = float(f"{value:.6g}")
    return root


def _clean(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_clean(v) for v in value]
    return value


def write(tuning: Tuning, out: Path, result: dict[str, Any], command: str = "") -> dict[str, Any]:
    """Write the four files; returns the report.json document. ``command``: the command line that ran the
    tuning (default: ``ftc-mj tune`` and the file), recorded in each."""
    command = command or f"ftc-mj tune {tuning.path}"
    spec = tuning.spec
    held = result["held"]
    costs = condition_costs(tuning, held, held)  # relative to the scenario's gains on each held-out condition
    violated = violations(tuning, held)
    paired = st.paired(costs[1], costs[0])
    aggregated = aggregate(tuning, costs)

    def side(i: int) -> dict:
        return {"cost": float(aggregated[i]), "mean_condition_cost": float(costs[i].mean()),
                "metrics": {m: float(np.nanmean(v[i])) if np.isfinite(v[i]).any() else None
                            for m, v in held.metrics.items()},
                "diverged": int(held.diverged[i].sum())}

    document = {
        "name": spec.name,
        "command": command,
        "variant": spec.variant,
        "gains": {"baseline": tuning.baseline, "tuned": result["best_gains"]},
        "training": {"conditions": spec.conditions, "generations": spec.optimizer.generations,
                     "population": int(max(r["candidate"] for r in result["history"]) + 1),
                     "best": {k: result["best_row"][k] for k in ("generation", "candidate", "cost", "penalised",
                                                                  "violations")},
                     "evaluations": result["evaluations"], "seconds": result["tuning_seconds"],
                     "evaluations_per_second": result["evaluations"] / result["tuning_seconds"]
                     if result["tuning_seconds"] > 0 else None},
        "held_out": {
            "runs": spec.held_out,
            "baseline": side(0),
            "tuned": side(1),
            "paired_difference": {"mean": paired.mean_difference.value,
                                  "ci95": [paired.mean_difference.low, paired.mean_difference.high],
                                  "win_rate": paired.win_rate.value},
            "constraint_violations": {"baseline": int(violated[0].sum()), "tuned": int(violated[1].sum())},
            "seconds": result["held_seconds"],
        },
        "workers": result["workers"], "scheduler": result["scheduler"],
    }
    document = _clean(document)
    write_atomic(out / "report.json", (json.dumps(document, indent=2) + "\n").encode())
    write_atomic(out / "best.yaml", best_yaml(result["best_gains"], command, spec.variant).encode())
    _convergence_figure(tuning, result["history"], out / "convergence.png")
    write_atomic(out / "report.md", _markdown(tuning, document, paired).encode())
    return document


def best_yaml(gains: dict[str, float], command: str, variant: str) -> str:
    """The tuned gains as a partial scenario (the nested mapping a scenario file holds: a ``base:`` of one, or
    pasted into one), the provenance and the equivalent ``--set`` options in comments."""
    nested = _nested(gains)
    sets = " ".join(f"--set {path}={value:.6g}" for path, value in gains.items())
    return "\n".join([f"# tuned gains of variant {variant}, by: {command}",
                      f"# as options of ftc-mj run: {sets}",
                      yaml.safe_dump(nested, sort_keys=False).rstrip(), ""])


def _convergence_figure(tuning: Tuning, history: list[dict], path: Path) -> None:
    generations = sorted({r["generation"] for r in history})
    best_so_far, median, best_of = [], [], []
    running = math.inf
    for g in generations:
        values = [r["penalised"] for r in history if r["generation"] == g]
        running = min(running, min(values))
        best_so_far.append(running)
        best_of.append(min(values))
        median.append(float(np.median(values)))
    x = np.array(generations) + 1
    # The tuned variant's colour (its colour in the scenario's run figures) for its best and its scenario gains;
    # the generations' statistics in grey.
    colour = tuning.campaign.scenario.colours.get(tuning.spec.variant,
                                                                                  COLOURS["blue"])
    fig = Figure(figsize=(5.4, 3.6))
    ax = fig.subplots()
    ax.plot(x, median, "o-", color=COLOURS["grey"], markersize=3, linewidth=0.8, label="generation median")
    ax.plot(x, best_of, "s:", color=COLOURS["grey"], markersize=3, linewidth=0.8, label="generation best")
    ax.plot(x, best_so_far, "-", color=colour, linewidth=2, label=f"best so far ({tuning.spec.variant})")
    baseline = aggregate(tuning, np.full((1, tuning.spec.conditions), sum(tuning.spec.cost.weights.values())))[0]
    ax.axhline(baseline, color=colour, linestyle="--", label="the scenario's gains")
    ax.set_yscale("log")
    ax.set_xlabel("generation")
    ax.set_ylabel("cost (penalised)")
    ax.set_title(f"CMA-ES on {tuning.spec.conditions} conditions ({tuning.spec.variant})", fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)


def _markdown(tuning: Tuning, doc: dict, paired: st.Paired) -> str:
    spec, held = tuning.spec, doc["held_out"]
    weights = " + ".join(f"{w:g} x {m}" for m, w in spec.cost.weights.items())
    lines = [f"# Tuning `{spec.name}`", "", spec.description.strip(), "",
             f"Variant `{spec.variant}` of `{tuning.campaign.scenario_path.name}`, on the population of "
             f"`{Path(spec.campaign).name}`: {spec.conditions} training conditions, {spec.held_out} held-out ones "
             "(other seeds and draws). Cost of a condition: " + weights + ", each metric (mean over the joints) "
             "relative to the scenario's gains on the same condition (so the scenario's gains cost "
             f"{sum(spec.cost.weights.values()):g}); aggregated as {spec.cost.aggregate}"
             + (f" (CVaR of the worst {spec.cost.fraction:g})" if spec.cost.aggregate == "mean_cvar" else "")
             + f"; plus {spec.optimizer.penalty:g} x the share of conditions violating a constraint.", "",
             f"Command: `{doc['command']}`", "",
             "## Gains", "", "| gain | bounds | scenario | tuned |", "|---|---|---|---|"]
    for path in tuning.paths:
        b = spec.gains[path]
        lines.append(f"| `{path}` | [{b.low:g}, {b.high:g}]{' log' if b.log else ''} | {doc['gains']['baseline'][path]:.4g} "
                     f"| {doc['gains']['tuned'][path]:.4g} |")
    training = doc["training"]
    lines += ["", "## Training", "",
              f"{training['generations']} generations of {training['population']} candidates x "
              f"{spec.conditions} conditions: {training['evaluations']} runs in {training['seconds']:.0f} s "
              f"({training['evaluations_per_second']:.3g} runs/s). Best: generation {training['best']['generation'] + 1}, "
              f"cost {training['best']['cost']:.4g}, {training['best']['violations']} violating conditions.", "",
              "![convergence](convergence.png)", "",
              "## Held-out check", "",
              f"{held['runs']} conditions not used in training; cost relative to the scenario's gains on each; "
              "paired difference tuned - scenario (negative: the tuning helped) with its 95% bootstrap interval.", "",
              "| | scenario's gains | tuned |", "|---|---|---|",
              f"| cost ({spec.cost.aggregate}) | {held['baseline']['cost']:.4g} | {held['tuned']['cost']:.4g} |",
              f"| mean condition cost | {held['baseline']['mean_condition_cost']:.4g} | {held['tuned']['mean_condition_cost']:.4g} |"]
    for metric in held["baseline"]["metrics"]:
        a, b = held["baseline"]["metrics"][metric], held["tuned"]["metrics"][metric]
        lines.append(f"| mean {metric} [{unit(metric)}] | {_fmt(a)} | {_fmt(b)} |")
    lines += [f"| diverged runs | {held['baseline']['diverged']} | {held['tuned']['diverged']} |",
              f"| conditions violating a constraint | {held['constraint_violations']['baseline']} | "
              f"{held['constraint_violations']['tuned']} |", "",
              f"Paired difference of the condition cost: {paired.mean_difference.text('.4g')}; the tuned gains are "
              f"better on {paired.win_rate.text('.3f')} of the conditions.", ""]
    return "\n".join(lines) + "\n"


def _fmt(value: float | None) -> str:
    return "-" if value is None else f"{value:.4g}"
