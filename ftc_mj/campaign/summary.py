"""A campaign's report from its results directory alone (``runs.parquet`` and ``campaign.json``), without
simulating again: ``report.md`` with the tables and ``figures/*.png`` (matplotlib).

Tables: divergence per variant (Wilson interval); per metric, variant and joint the mean, median, 5th and 95th
percentiles with bootstrap intervals; paired differences against the reference variant on the same runs (mean
difference, win rate, verdict); the campaign's claims, each with how it depends on every varied field; for
diagnosis the ROC (AUC), detection and false-alarm probability at the scenario's threshold, false alarms per
hour, detection delays, detection probability against fault size at a fixed false-alarm probability, and the
isolation confusion matrix. Figures: box plots of the metrics, ROC curves, detection probability against
fault size, delay ECDFs, confusion matrices and, for a 2-D grid, a heat map.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from matplotlib.figure import Figure
from matplotlib.patches import Rectangle
import numpy as np
import pyarrow.parquet as pq

from ftc_mj.analysis.diagnosis import scale_tag
from ftc_mj.analysis.metrics import unit
from ftc_mj.campaign import statistics as st
from ftc_mj.campaign.schema import CampaignSpec
from ftc_mj.config.errors import InputError
from ftc_mj.outputs.figures import over_alike, same_roc
from ftc_mj.outputs.files import write_atomic
from ftc_mj.outputs.palette import CAMPAIGN_LINE_STYLES, assign_colours

#: Why a paired mean difference and its win rate can point different ways, said beside every paired statistic.
MEAN_AND_WIN_RATE = ("The two can disagree: the mean weighs each run by the size of its difference, the win rate "
                     "counts each run once, so a variant a little better on most runs but much worse on a few has "
                     "a win rate above 1/2 and a positive mean difference.")
#: The report metrics the summary's headline table shows (the first of the campaign's ``report.metrics``).
HEADLINE_METRICS = 3

#: Fine threshold multiples for ROC curves (the held residual peaks are continuous).
ROC_SCALES = np.concatenate(([0.0], np.geomspace(0.05, 1000.0, 400)))


@dataclass
class Results:
    """A results directory, read back: columns by name, per variant."""

    directory: Path
    summary: dict[str, Any]
    spec: CampaignSpec
    variants: list[str]
    columns: dict[str, np.ndarray]
    #: Variant -> "#rrggbb": the scenario's colours (:func:`ftc_mj.outputs.palette.declared_colours`), as in its
    #: run figures and recordings.
    colours: dict[str, str]

    def of(self, variant: str, column: str) -> np.ndarray:
        """One column's values for one variant's rows, in run order."""
        mask = self.columns["variant"] == variant
        values = self.columns.get(column)
        if values is None:
            return np.full(int(mask.sum()), np.nan)
        return values[mask]

    def joints(self) -> int:
        return max((int(name.rsplit(".", 1)[1]) for name in self.columns if name.startswith("rms_error.")), default=0)

    def has(self, column: str) -> bool:
        return column in self.columns and np.isfinite(self.columns[column].astype(float)).any()


def read(directory: Path) -> Results:
    """Raises InputError if ``directory`` holds no finished campaign."""
    runs, info = directory / "runs.parquet", directory / "campaign.json"
    if not runs.is_file() or not info.is_file():
        raise InputError(str(directory), "", "no finished campaign here (runs.parquet and campaign.json are written "
                         "when `run` ends; run it again to finish an interrupted one)")
    summary = json.loads(info.read_text())
    table = pq.read_table(runs)
    columns = {}
    for name in table.column_names:
        values = table.column(name).to_numpy(zero_copy_only=False)
        if values.dtype == object:
            try:
                values = values.astype(float)
            except (TypeError, ValueError):
                values = values.astype(str)
        columns[name] = values
    present = set(columns["variant"].tolist()) if "variant" in columns else set()
    variants = [v for v in summary["variants"] if v in present]
    variants += sorted(present - set(variants))  # monitors
    # Results written without the scenario's colours: the palette's order over the variants.
    colours = {**assign_colours(variants), **summary.get("colours", {})}
    return Results(directory, summary, CampaignSpec.model_validate(summary["resolved"]), variants, columns, colours)


# ------------------------------------------------------------------------------------------------ tables


def _table(header: list[str], rows: list[list[str]]) -> list[str]:
    return ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)] + ["| " + " | ".join(r) + " |" for r in rows]


def _divergence(results: Results) -> list[str]:
    rows = []
    for variant in results.variants:
        status = results.of(variant, "status")
        diverged = int(np.sum(status == "diverged"))
        rows.append([variant, f"{diverged} / {status.size}", st.proportion(diverged, status.size).text(".3f")])
    return ["## Divergence", "", *_table(["variant", "diverged", "rate [95% Wilson]"], rows), ""]


def _defined_columns(results: Results, metric: str) -> list[tuple[int, str]]:
    """(joint, column) of a metric's joints with any defined value."""
    return [(j, f"{metric}.{j}") for j in range(1, results.joints() + 1) if results.has(f"{metric}.{j}")]


def _metric_tables(results: Results) -> list[str]:
    lines = ["## Metrics", "", "Per variant and joint, over the runs where the metric is defined (n): mean, median, "
             "5th and 95th percentiles with 95% intervals (the mean's by bootstrap, the percentiles' between two order "
             "statistics; a side too few runs bound is inf).", ""]
    resamples = results.spec.report.bootstrap
    for metric in results.spec.report.metrics:
        rows = []
        for j, column in _defined_columns(results, metric):
            for variant in results.variants:
                s = st.summarise(results.of(variant, column), resamples)
                if s.count:
                    rows.append([variant, str(j), str(s.count), s.mean.text(), s.median.text(), s.p5.text(),
                                 s.p95.text()])
        if rows:
            lines += [f"### {metric} [{unit(metric)}]", "",
                      *_table(["variant", "joint", "n", "mean", "median", "p5", "p95"], rows), ""]
    return lines


def _paired_tables(results: Results) -> list[str]:
    reference = results.spec.report.reference or results.variants[0]
    others = [v for v in results.variants if v != reference]
    if not others:
        return []
    lines = ["## Paired differences", "",
             f"Each row compares `{reference}` with the variant named in `vs` on the same runs (the same fault, "
             f"plant and noise): mean difference = mean of `{reference}` minus `vs` (negative: `{reference}` lower, "
             f"i.e. better), 95% bootstrap interval; win rate = share of runs where `{reference}` is lower (ties "
             "half), 95% Wilson interval; verdict `holds` when both intervals favour it, `reversed` when both "
             f"favour the other. {MEAN_AND_WIN_RATE}", ""]
    resamples = results.spec.report.bootstrap
    for metric in results.spec.report.metrics:
        rows = []
        for j, column in _defined_columns(results, metric):
            for other in others:
                p = st.paired(results.of(reference, column), results.of(other, column), resamples)
                if p.count:
                    rows.append([other, str(j), str(p.count), p.mean_difference.text(), p.win_rate.text(".3f"),
                                 p.verdict])
        if rows:
            lines += [f"### {metric} [{unit(metric)}]", "",
                      *_table(["vs", "joint", "n", "mean difference", "win rate", "verdict"], rows), ""]
    return lines


def _numeric_fields(results: Results) -> list[str]:
    fields = list(results.spec.grid) + (list(results.spec.samples.fields) if results.spec.samples else [])
    fields += [name for case in results.spec.cases for name in case.values]
    out = []
    for name in dict.fromkeys(fields):
        values = results.columns.get(name)
        if values is not None and values.dtype.kind in "fi" and np.ptp(values) > 0:
            out.append(name)
    return out


def _depends(low: st.Estimate, high: st.Estimate) -> bool:
    """The claim's verdict differs between the lowest and the highest third of a field's values (holds:
    the win rate's interval above 1/2; reversed: below; open otherwise), and the two win rates differ (their
    intervals do not overlap): it holds for some values of the field and not for others."""
    def verdict(e: st.Estimate) -> str:
        return "holds" if e.low > 0.5 else "reversed" if e.high < 0.5 else "open"

    apart = low.high < high.low or high.high < low.low
    return apart and verdict(low) != verdict(high)


def _claims(results: Results) -> tuple[list[str], list[list[str]]]:
    """The claims' section, and its table's rows (claim, ordering, metric.joint, n, mean difference, win rate,
    verdict, depends on) for the summary."""
    claims = results.spec.report.claims
    if not claims:
        return [], []
    resamples = results.spec.report.bootstrap
    lines = ["## Claims", "", "Each claim compares `better` with `worse` on the same runs: mean difference = mean of "
             "`better` minus `worse` (negative: the claim's direction), win rate = share of runs where `better` is "
             f"lower; verdict as for the paired differences. {MEAN_AND_WIN_RATE} `depends on` names the varied "
             "fields on which the verdict turns: it differs between the lowest and the highest third of the field's "
             "values (holds: the win rate's interval above 1/2; reversed: below; open otherwise) and their win "
             "rates differ (the intervals do not overlap); the dependence table below lists those only.", ""]
    rows, dependence_rows = [], []
    fields = _numeric_fields(results)
    for claim in claims:
        joints = claim.joints or list(range(1, results.joints() + 1))
        for j in joints:
            column = f"{claim.metric}.{j}"
            a, b = results.of(claim.better, column), results.of(claim.worse, column)
            p = st.paired(a, b, resamples)
            depends = []
            for name in fields:
                field = results.of(claim.better, name).astype(float)
                rho, pvalue, low, high = st.dependence(a - b, field)
                if not np.isfinite(rho):
                    continue
                flips = _depends(low, high)
                if flips:
                    depends.append(f"`{name}`")
                    dependence_rows.append([claim.name, str(j), name, f"{rho:+.2f} ({pvalue:.2g})", low.text(".2f"),
                                            high.text(".2f")])
            rows.append([claim.name, f"{claim.better} < {claim.worse}", f"{claim.metric}.{j}", str(p.count),
                         p.mean_difference.text(), p.win_rate.text(".3f"), f"**{p.verdict}**",
                         ", ".join(depends) or "-"])
    lines += _table(["claim", "ordering", "metric", "n", "mean difference", "win rate", "verdict", "depends on"],
                    rows) + [""]
    lines += ["### Dependence on the varied fields", ""]
    if dependence_rows:
        lines += ["Where a claim depends on a field: Spearman's rho of the paired difference against the field "
                  "(p-value) and the win rate in the lowest and the highest third of the field's values.", "",
                  *_table(["claim", "joint", "field", "rho (p)", "win rate, lowest third", "win rate, highest third"],
                          dependence_rows), ""]
    else:
        lines += [f"No claim depends on any of the {len(fields)} varied fields.", ""]
    return lines, rows


def _claim_verdicts(claim_rows: list[list[str]]) -> list[str]:
    """The summary's claims, from :func:`_claims`'s rows: one row per claim, its joints' win rates and verdicts
    (separated by " / ") and the fields it depends on."""
    if not claim_rows:
        return []
    grouped: dict[tuple[str, str, str], list[list[str]]] = {}
    for cells in claim_rows:
        grouped.setdefault((cells[0], cells[1], cells[2].rsplit(".", 1)[0]), []).append(cells)
    rows = []
    for (claim, ordering, metric), joints in grouped.items():
        depends = dict.fromkeys(f for cells in joints for f in cells[7].split(", ") if f != "-")
        rows.append([claim, ordering, metric, " / ".join(c[2].rsplit(".", 1)[1] for c in joints),
                     " / ".join(c[5].split(" ")[0] for c in joints), " / ".join(c[6] for c in joints),
                     ", ".join(depends) or "-"])
    return _table(["claim", "ordering", "metric", "joints", "win rate", "verdict", "depends on"], rows) + [""]


# ------------------------------------------------------------------------------------------------ diagnosis


def _run_peaks(results: Results, variant: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per run: the largest held residual level on a fault-free part (any joint), the largest after the onset
    on a faulty joint (NaN for a healthy run, and for a faulty one with no armed sample after its onsets: it
    ended first, so the fault is neither detected nor missed), and whether the run has a faulty joint."""
    n = results.joints()
    healthy = np.column_stack([results.of(variant, f"residual_peak_healthy.{j}") for j in range(1, n + 1)])
    fault = np.column_stack([results.of(variant, f"residual_peak_fault.{j}") for j in range(1, n + 1)])
    faulty = np.column_stack([np.isfinite(results.of(variant, f"fault_onset.{j}")) for j in range(1, n + 1)])
    peak_healthy = np.max(np.where(np.isfinite(healthy), healthy, -np.inf), axis=1)
    peak_fault = np.max(np.where(faulty & np.isfinite(fault), fault, -np.inf), axis=1)
    peak_healthy[np.isinf(peak_healthy)] = np.nan
    peak_fault[~faulty.any(axis=1)] = np.nan
    peak_fault[np.isinf(peak_fault)] = np.nan  # faulty, never armed after the onset: undefined, not a miss
    return peak_healthy, peak_fault, faulty.any(axis=1)


def _diagnosed_variants(results: Results) -> list[str]:
    return [v for v in results.variants if np.isfinite(results.of(v, "residual_peak_healthy.1").astype(float)).any()]


def _operating_scale(p_fa: np.ndarray, target: float) -> int | None:
    """The index of the lowest threshold multiple with a false-alarm probability at most ``target``."""
    ok = np.flatnonzero(p_fa <= target)
    return int(ok[0]) if ok.size else None


def _diagnosis(results: Results, figures: Path, written: list[Path]) -> list[str]:
    variants = _diagnosed_variants(results)
    if not variants:
        return []
    target = results.spec.report.false_alarm_probability
    lines = ["## Fault diagnosis", "",
             "Per run, the diagnoser's residual over its threshold, held for its persistence (z), before and after "
             "each joint's onset, and the alarms at multiples c of the scenario's threshold (c = 1: the scenario's "
             "own). A run false-alarms at c if z > c on a fault-free part; a faulty run is detected at c if z > c "
             "after the onset on a faulty joint. False-alarm probabilities come from the healthy runs where the "
             "population has any, else from the fault-free part of every run.", ""]
    rows, curves = [], {}
    for variant in variants:
        peak_healthy, peak_fault, faulty = _run_peaks(results, variant)
        basis = peak_healthy[~faulty] if (~faulty).sum() else peak_healthy
        p_fa, p_d = st.roc(basis, peak_fault[faulty], ROC_SCALES)
        curves[variant] = (p_fa, p_d)
        fa1 = st.proportion(float(np.sum(basis > 1.0)), int(np.isfinite(basis).sum()))
        d1 = st.proportion(float(np.sum(peak_fault[faulty] > 1.0)), int(np.isfinite(peak_fault[faulty]).sum()))
        # False alarms per hour on the same runs as P_fa: joint-hours of armed fault-free operation.
        runs = ~faulty if (~faulty).sum() else np.ones_like(faulty)
        alarms = sum(np.nansum(results.of(variant, f"false_alarms_x1.{j}").astype(float)[runs])
                     for j in range(1, results.joints() + 1))
        hours = sum(np.nansum(results.of(variant, f"healthy_time.{j}").astype(float)[runs])
                    for j in range(1, results.joints() + 1)) / 3600 / max(results.joints(), 1)
        delays = _delays(results, variant, 1.0)
        op = _operating_scale(p_fa, target)
        rows.append([variant, f"{st.auc(p_fa, p_d):.3f}", fa1.text(".3f"), d1.text(".3f"),
                     f"{alarms / hours:.3g}" if hours > 0 else "-",
                     f"{np.median(delays):.3g} / {np.percentile(delays, 95):.3g}" if delays.size else "-",
                     f"{ROC_SCALES[op]:.3g}: {p_d[op]:.3f}" if op is not None else "-"])
    lines += _table(["variant", "AUC", "P_fa at c = 1", "P_d at c = 1", "false alarms per hour (c = 1)",
                     "delay median / p95 [s] (c = 1)", f"lowest c with P_fa <= {target:g}: P_d"], rows) + [""]
    written.append(_roc_figure(results, curves, figures / "roc.png"))
    lines += ["![ROC](figures/roc.png)", ""]
    delays = {v: _delays(results, v, 1.0) for v in variants}
    if any(d.size for d in delays.values()):
        written.append(_ecdf_figure(results, delays, figures / "delay_ecdf.png"))
        lines += ["![Detection delay ECDF](figures/delay_ecdf.png)", ""]
    size = results.spec.report.fault_size
    if size is not None and size in results.columns:
        path = _pd_size_figure(results, variants, curves, size, target, figures / "pd_vs_size.png")
        if path is not None:
            written.append(path)
            lines += [f"Detection probability against `{size}` at the lowest threshold multiple with a false-alarm "
                      f"probability at most {target:g} (per variant), with 95% Wilson intervals:", "",
                      "![P_d against fault size](figures/pd_vs_size.png)", ""]
    lines += _confusion(results, variants, figures / "confusion.png", written)
    return lines


def _delays(results: Results, variant: str, scale: float) -> np.ndarray:
    """Detection delays at ``scale`` over every faulty joint of every run (missed ones left out)."""
    tag = scale_tag(scale)
    values = np.concatenate([results.of(variant, f"detection_delay_{tag}.{j}").astype(float)
                             for j in range(1, results.joints() + 1)])
    return values[np.isfinite(values)]


def _joint_set(joints: tuple[int, ...]) -> str:
    """``(2,)`` -> "joint 2", ``(1, 3)`` -> "joints 1+3"."""
    return f"joint {joints[0]}" if len(joints) == 1 else "joints " + "+".join(map(str, joints))


def _confusion(results: Results, variants: list[str], path: Path, written: list[Path]) -> list[str]:
    """True faulty joint (or healthy) against the joints the diagnoser isolates at the scenario's threshold."""
    n = results.joints()
    pairs = {}
    for variant in variants:
        faulty = np.column_stack([np.isfinite(results.of(variant, f"fault_onset.{j}")) for j in range(1, n + 1)])
        isolated = np.column_stack([results.of(variant, f"isolated.{j}").astype(float) for j in range(1, n + 1)])
        # A run with no armed sample after its first onset isolates nothing: undefined, left out.
        pairs[variant] = [(tuple(np.flatnonzero(f) + 1), tuple(np.flatnonzero(i > 0.5) + 1))
                          for f, i in zip(faulty, isolated) if np.isfinite(i).all()]
    # Every single joint, then the sets of several joints that occur, each named by its joints.
    sets = [(j,) for j in range(1, n + 1)]
    sets += sorted({s for p in pairs.values() for pair in p for s in pair if len(s) > 1}, key=lambda s: (len(s), s))
    rows_of, cols_of = [(), *sets], [(), *sets]
    labels_true = ["healthy", *(_joint_set(s) for s in sets)]
    labels_pred = ["undetected", *(_joint_set(s) for s in sets)]
    matrices = {}
    for variant, found in pairs.items():
        matrix = np.zeros((len(rows_of), len(cols_of)), dtype=int)
        for true, named in found:
            matrix[rows_of.index(true), cols_of.index(named)] += 1
        matrices[variant] = matrix
    keep_rows = [r for r in range(len(rows_of)) if any(m[r].sum() for m in matrices.values())]
    keep_cols = [c for c in range(len(cols_of)) if c <= n or any(m[:, c].sum() for m in matrices.values())]
    labels_pred = [labels_pred[c] for c in keep_cols]
    matrices = {v: m[:, keep_cols] for v, m in matrices.items()}
    lines = ["### Isolation", "", "Rows: the truly faulty joint or joints; columns: the joints the diagnoser names faulty at the "
             "scenario's threshold (counts of runs).", ""]
    for variant, matrix in matrices.items():
        lines += [f"`{variant}`", "", *_table(["true \\ isolated", *labels_pred],
                  [[labels_true[r], *map(str, matrix[r])] for r in keep_rows]), ""]
    fig = Figure(figsize=(3.2 * len(matrices) + 0.6, 1.6 + 0.42 * len(keep_rows)))
    axes = fig.subplots(1, len(matrices), squeeze=False)
    for ax, (variant, matrix) in zip(axes[0], matrices.items()):
        shown = matrix[keep_rows]
        share = shown / np.maximum(shown.sum(axis=1, keepdims=True), 1)
        ax.imshow(share, cmap="Blues", vmin=0, vmax=1)
        for (r, c), count in np.ndenumerate(shown):
            ax.text(c, r, str(count), ha="center", va="center", fontsize=8,
                    color="white" if share[r, c] > 0.6 else "black")
        ax.set_xticks(range(len(labels_pred)), labels_pred, rotation=45, ha="right", fontsize=8)
        ax.set_yticks(range(len(keep_rows)), [labels_true[r] for r in keep_rows], fontsize=8)
        ax.set_title(variant, fontsize=9)
    axes[0][0].set_ylabel("true")
    fig.suptitle("Isolation at the scenario's threshold (colour: share of the row)", fontsize=10)
    fig.tight_layout()
    written.append(_save(fig, path))
    return lines + ["![Isolation confusion matrices](figures/confusion.png)", ""]


# ------------------------------------------------------------------------------------------------ figures


def _save(fig: Figure, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    return path


def _colour(results: Results, variant: str) -> str:
    """The variant's colour in the scenario's run figures and recordings."""
    return results.colours[variant]


def _style(results: Results, variant: str) -> str:
    return CAMPAIGN_LINE_STYLES[results.variants.index(variant) % len(CAMPAIGN_LINE_STYLES)]


def _box_figure(results: Results, metric: str, path: Path) -> Path | None:
    joints = [j for j, _ in _defined_columns(results, metric)]
    if not joints:
        return None
    fig = Figure(figsize=(3.3 * len(joints) + 0.5, 3.4))
    axes = fig.subplots(1, len(joints), squeeze=False)
    panels = []
    for j in joints:
        data = [results.of(v, f"{metric}.{j}").astype(float) for v in results.variants]
        panels.append([(v, d[np.isfinite(d)]) for v, d in zip(results.variants, data) if np.isfinite(d).any()])
    # One scale for every joint's panel (log where any panel spans more than two decades and all are
    # positive), so that the panels compare at a glance.
    values = np.concatenate([d for shown in panels for _, d in shown])
    log = bool(values.size and values.min() > 0 and values.max() / values.min() > 100 and any(
        np.concatenate([d for _, d in shown]).max() / np.concatenate([d for _, d in shown]).min() > 100
        for shown in panels))
    for ax, j, shown in zip(axes[0], joints, panels):
        boxes = ax.boxplot([d for _, d in shown], whis=(5, 95), showfliers=True, patch_artist=True,
                           flierprops={"markersize": 2, "alpha": 0.4}, medianprops={"color": "black"})
        for patch, (v, _) in zip(boxes["boxes"], shown):
            patch.set_facecolor(_colour(results, v))
            patch.set_alpha(0.6)
        ax.set_xticks(range(1, len(shown) + 1), [v for v, _ in shown], rotation=30, ha="right", fontsize=8)
        if log:
            ax.set_yscale("log")
        ax.set_title(f"joint {j}", fontsize=9)
        ax.grid(alpha=0.3, axis="y")
    axes[0][0].set_ylabel(f"{metric} [{unit(metric)}]")
    fig.suptitle(f"{metric} over {results.summary['runs']} runs (box: quartiles, whiskers: 5th-95th percentile)",
                 fontsize=10)
    fig.tight_layout()
    return _save(fig, path)


def _roc_figure(results: Results, curves: dict[str, tuple[np.ndarray, np.ndarray]], path: Path) -> Path:
    fig = Figure(figsize=(4.6, 4.2))
    ax = fig.subplots()
    one = int(np.argmin(np.abs(ROC_SCALES - 1.0)))
    drawn: list[np.ndarray] = []
    for variant, (p_fa, p_d) in curves.items():
        colour = _colour(results, variant)
        over = same_roc(p_fa, p_d, drawn)  # the same line as one drawn already: dashed, so that both show
        ax.plot(np.concatenate(([1.0], p_fa, [0.0])), np.concatenate(([1.0], p_d, [0.0])), color=colour,
                linestyle=over_alike(over) if over else _style(results, variant), linewidth=1.6,
                label=f"{variant} (AUC {st.auc(p_fa, p_d):.3f})" + (" = the curve beneath" if over else ""))
        ax.plot(p_fa[one], p_d[one], "o", color=colour, markersize=5)
    ax.plot([0, 1], [0, 1], ":", color="grey", linewidth=0.8)
    ax.set_xlabel("false-alarm probability")
    ax.set_ylabel("detection probability")
    ax.set_xlim(-0.02, 1.02)
    ax.set_ylim(-0.02, 1.02)
    ax.set_title("ROC (dots: the scenario's threshold)", fontsize=10)
    ax.legend(fontsize=8, loc="lower right")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return _save(fig, path)


def _ecdf_figure(results: Results, delays: dict[str, np.ndarray], path: Path) -> Path:
    fig = Figure(figsize=(5.0, 3.6))
    ax = fig.subplots()
    for variant, d in delays.items():
        if d.size:
            x = np.sort(d)
            ax.step(x, np.arange(1, x.size + 1) / x.size, where="post", color=_colour(results, variant),
                    linestyle=_style(results, variant), label=f"{variant} (n = {x.size})")
    ax.set_xscale("log")
    ax.set_xlabel("detection delay [s]")
    ax.set_ylabel("share of detected faults")
    ax.set_title("Detection delay at the scenario's threshold (ECDF)", fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return _save(fig, path)


def _pd_size_figure(results: Results, variants: list[str], curves: dict, size: str, target: float,
                    path: Path) -> Path | None:
    """P_d against the fault's size at the operating threshold, one panel per fault kind if the campaign names
    a kind column, each variant one colour."""
    kind_column = results.spec.report.fault_kind
    kinds = [None]
    if kind_column is not None and kind_column in results.columns:
        kinds = [k for k in dict.fromkeys(results.of(variants[0], kind_column).tolist())]
    operating = {v: _operating_scale(curves[v][0], target) for v in variants}
    panels = []
    for kind in kinds:
        lines = []
        for variant in variants:
            op = operating[variant]
            if op is None:
                continue
            _, peak_fault, faulty = _run_peaks(results, variant)
            faulty = faulty & np.isfinite(peak_fault)
            if kind is not None:
                faulty = faulty & (results.of(variant, kind_column) == kind)
            if not faulty.any():
                continue
            sizes = results.of(variant, size).astype(float)[faulty]
            detected = peak_fault[faulty] > ROC_SCALES[op]
            values = np.unique(sizes)
            if values.size > 8:  # continuous: eight bins of equal count
                edges = np.unique(np.percentile(sizes, np.linspace(0, 100, 9)))
                which = np.clip(np.searchsorted(edges, sizes, side="right") - 1, 0, len(edges) - 2)
                centres = [float(np.median(sizes[which == b])) for b in range(len(edges) - 1)]
                groups = [which == b for b in range(len(edges) - 1)]
            else:
                centres, groups = list(values), [sizes == v for v in values]
            lines.append((variant, centres, [st.proportion(float(detected[g].sum()), int(g.sum())) for g in groups]))
        if lines:
            panels.append((kind, lines))
    if not panels:
        return None
    columns = min(3, len(panels))
    rows = math.ceil(len(panels) / columns)
    fig = Figure(figsize=(3.6 * columns + 1.6, 3.0 * rows + 0.8))
    axes = fig.subplots(rows, columns, squeeze=False, sharey=True)
    for ax in axes.flat[len(panels):]:
        ax.set_visible(False)
    for ax, (kind, lines) in zip(axes.flat, panels):
        for variant, centres, estimates in lines:
            y = np.array([e.value for e in estimates])
            err = np.array([[e.value - e.low for e in estimates], [e.high - e.value for e in estimates]])
            ax.errorbar(centres, y, yerr=err, marker="o", markersize=4, capsize=3, color=_colour(results, variant),
                        linestyle=_style(results, variant), label=f"{variant} (c = {ROC_SCALES[operating[variant]]:.3g})")
        ax.set_xlabel(size)
        ax.set_ylim(-0.03, 1.03)
        ax.grid(alpha=0.3)
        if kind is not None:
            ax.set_title(str(kind), fontsize=9)
    for row in axes:
        row[0].set_ylabel("detection probability")
    axes.flat[len(panels) - 1].legend(fontsize=7, loc="lower right")
    fig.suptitle(f"P_d at P_fa <= {target:g} (c: the threshold multiple; 95% Wilson intervals)", fontsize=10)
    fig.tight_layout()
    return _save(fig, path)


def _heatmap(results: Results, figures: Path, written: list[Path]) -> list[str]:
    axes_fields = [p for p in results.spec.grid if results.columns.get(p) is not None
                   and results.columns[p].dtype.kind in "fi"]
    if len(axes_fields) != 2:
        return []
    metric, joint = results.spec.report.heatmap.metric, results.spec.report.heatmap.joint
    column = f"{metric}.{joint}"
    xs, ys = (sorted(set(results.columns[p].tolist())) for p in axes_fields)
    variants = results.variants
    fig = Figure(figsize=(4.6 * len(variants) + 1.2, 3.8))
    axes = fig.subplots(1, len(variants), squeeze=False)
    grids = []
    for variant in variants:
        x, y = results.of(variant, axes_fields[0]), results.of(variant, axes_fields[1])
        v = results.of(variant, column).astype(float)
        grid = np.full((len(ys), len(xs)), np.nan)
        for i, yv in enumerate(ys):
            for k, xv in enumerate(xs):
                cell = v[(x == xv) & (y == yv)]
                cell = cell[np.isfinite(cell)]
                if cell.size:
                    grid[i, k] = np.mean(cell)
        grids.append(grid)
    finite = np.concatenate([g[np.isfinite(g)] for g in grids]) if grids else np.array([])
    log = finite.size and finite.min() > 0 and finite.max() / finite.min() > 10
    from matplotlib.colors import LogNorm, Normalize

    norm = LogNorm(finite.min(), finite.max()) if log else Normalize(finite.min(), finite.max()) if finite.size else None
    for ax, variant, grid in zip(axes[0], variants, grids):
        image = ax.imshow(grid, origin="lower", cmap="viridis", norm=norm, aspect="auto")
        ax.set_xticks(range(len(xs)), [f"{v:g}" for v in xs], fontsize=8)
        ax.set_yticks(range(len(ys)), [f"{v:g}" for v in ys], fontsize=8)
        ax.set_xlabel(axes_fields[0].rsplit(".", 1)[-1])
        ax.set_title(variant, fontsize=9)
        for (i, k), value in np.ndenumerate(grid):
            if np.isfinite(value):  # dark text on the bright end of viridis
                ax.text(k, i, f"{value:.2e}", ha="center", va="center", fontsize=7,
                        color="black" if norm(value) > 0.6 else "white")
        best = np.unravel_index(np.nanargmin(grid), grid.shape) if np.isfinite(grid).any() else None
        if best is not None:  # a frame around the lowest cell
            ax.add_patch(Rectangle((best[1] - 0.5, best[0] - 0.5), 1, 1, fill=False, edgecolor="white",
                                       linewidth=2.5))
    axes[0][0].set_ylabel(axes_fields[1].rsplit(".", 1)[-1])
    fig.colorbar(image, ax=axes[0].tolist(), label=f"mean {column} [{unit(metric)}]")
    fig.suptitle(f"mean {column} [{unit(metric)}] (framed: the lowest)", fontsize=10)
    written.append(_save(fig, figures / "heatmap.png"))
    return ["## Grid", "", f"Mean `{column}` over `{axes_fields[0]}` (x) and `{axes_fields[1]}` (y); the framed cell is "
            "the lowest.", "", "![Heat map](figures/heatmap.png)", ""]


# ------------------------------------------------------------------------------------------------ the report


def _headline(results: Results) -> list[str]:
    """Per variant: divergence and the mean of the first :data:`HEADLINE_METRICS` report metrics, the joints'
    values separated by " / "."""
    metrics = results.spec.report.metrics[:HEADLINE_METRICS]
    rows = []
    for variant in results.variants:
        status = results.of(variant, "status")
        cells = [variant, f"{int(np.sum(status == 'diverged'))} / {status.size}"]
        for metric in metrics:
            means = []
            for j in range(1, results.joints() + 1):
                values = results.of(variant, f"{metric}.{j}").astype(float)
                values = values[np.isfinite(values)]
                means.append(f"{values.mean():.3g}" if values.size else "-")
            cells.append(" / ".join(means))
        rows.append(cells)
    header = ["variant", "diverged", *(f"{m} [{unit(m)}], mean per joint" for m in metrics)]
    return _table(header, rows) + [""]


def write_report(directory: Path) -> list[Path]:
    """Write ``report.md`` and ``figures/*.png`` into ``directory``; the files written. The report opens with a
    one-screen summary (the claims' verdicts, the headline table, links to the figures); the details follow."""
    results = read(directory)
    summary = results.summary
    figures = directory / "figures"
    written: list[Path] = []
    counts = ", ".join(f"{k}: {v}" for k, v in summary["status_counts"].items())
    per_period = summary["wall_time"] / summary["control_steps"] * 1e6 if summary.get("control_steps") else math.nan
    head = [f"# Campaign `{summary['name']}`", "", results.spec.description.strip(), "",
            f"- base scenario: `{Path(summary['scenario']).name}`; variants: {', '.join(summary['variants'])}",
            f"- runs: {summary['runs']} ({summary['groups']} structure group{'s' if summary['groups'] != 1 else ''}), rows: {summary['rows']} ({counts})",
            f"- last `run`: {summary['simulated_runs']} runs simulated in {summary['wall_time']:.1f} s "
            f"({summary['runs_per_second'] or 0:.3g} runs/s, {per_period:.3g} us per member and control period "
            f"with {summary['physics_substeps']} physics steps; {summary['scheduler']}, {summary['workers']} "
            "worker(s))"]
    if summary.get("command"):
        head.append(f"- command: `{summary['command']}`")
    head.append("")
    details = ["# Details", ""]
    details += _divergence(results)
    claims, claim_rows = _claims(results)
    details += claims
    details += _metric_tables(results)
    for metric in results.spec.report.metrics:
        path = _box_figure(results, metric, figures / f"box_{metric}.png")
        if path is not None:
            written.append(path)
            details += [f"![{metric}](figures/{path.name})", ""]
    details += _paired_tables(results)
    details += _diagnosis(results, figures, written)
    details += _heatmap(results, figures, written)
    overview = ["## Summary", ""]
    verdicts = _claim_verdicts(claim_rows)
    if verdicts:
        overview += ["Claims (details and dependence below):", "", *verdicts]
    overview += _headline(results)
    if written:
        overview += ["Figures: " + ", ".join(f"[{p.stem}](figures/{p.name})" for p in written), ""]
    report = directory / "report.md"
    write_atomic(report, ("\n".join(head + overview + details) + "\n").encode())
    return [report, *written]
