"""The leaderboard: every entry's scores per task and robot (:mod:`ftc_mj.ranking.score`) from its campaigns'
rows, as ``leaderboard.md`` (one table per task and robot, ranked), ``leaderboard.csv`` and
``leaderboard.parquet`` (one row per task, robot, entry and score, with its interval), figures (the ROC per
robot, the ranked scores with their intervals) and ``bench.json`` (the suite's version, the tier, the
package versions, the entries and where their gains come from)."""

from __future__ import annotations

import csv
import io
import json
from functools import lru_cache
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from matplotlib.figure import Figure
from matplotlib.ticker import FormatStrFormatter, LogLocator, NullFormatter

from ftc_mj.outputs.figures import over_alike, same_roc
from ftc_mj.ranking import score as sc
from ftc_mj.ranking.calibrated import design_row
from ftc_mj.ranking import windowed
from ftc_mj.ranking.execute import Found, damaged
from ftc_mj.ranking.entries import Bench
from ftc_mj.outputs.files import parquet_bytes, write_atomic
from ftc_mj.outputs.palette import CAMPAIGN_LINE_STYLES, ORDER, assign_colours

PACKAGES = ("ftc_mj", "mujoco", "numpy")
SCORES = {"diagnosis": sc.DIAGNOSIS_SCORES, "tracking": sc.TRACKING_SCORES}
#: Per robot and tracking entry: the median faulty RMS per fault kind.
KindMedians = dict[str, dict[str, dict[str, float]]]


@lru_cache(maxsize=64)
def _table(path: Path) -> dict[str, np.ndarray]:
    try:
        table = pq.read_table(path)
    except (OSError, pa.ArrowException) as error:  # damaged after find_done read its footer
        raise damaged(path, error) from None
    return {name: table.column(name).to_numpy(zero_copy_only=False) for name in table.column_names}


def entry_rows(found: Found) -> dict[str, np.ndarray]:
    """One entry's rows of a finished campaign, by column, in run order."""
    table = _table(found.results / "runs.parquet")
    mask = table["variant"] == found.variant
    return {name: values[mask] for name, values in table.items()}


def _per_joint(rows: dict[str, np.ndarray], metric: str) -> np.ndarray:
    """``(runs, joints)`` of a per-joint column (NaN where absent)."""
    joints = sorted(int(name.rsplit(".", 1)[1]) for name in rows if name.startswith(metric + ".")
                    and name.rsplit(".", 1)[1].isdigit())
    count = rows["variant"].size
    if not joints:
        return np.full((count, 0), np.nan)
    return np.column_stack([np.asarray(rows[f"{metric}.{j}"], dtype=float) for j in joints])


def _diverged(rows: dict[str, np.ndarray]) -> np.ndarray:
    return rows["status"] != "ok"


def diagnosis_runs(healthy: dict[str, np.ndarray], faults: dict[str, np.ndarray]) -> sc.DiagnosisRuns:
    """The per-run inputs of the diagnosis scores from an entry's healthy and faulty rows."""
    peaks = _per_joint(healthy, "residual_peak_healthy")
    healthy_peak = np.max(np.where(np.isfinite(peaks), peaks, 0.0), axis=1, initial=0.0)
    healthy_peak[_diverged(healthy)] = np.inf
    alarms = np.nansum(_per_joint(healthy, "false_alarms_x1"), axis=1)
    seconds = np.nanmean(_per_joint(healthy, "healthy_time"), axis=1) if healthy["variant"].size else np.zeros(0)
    faulty = np.isfinite(_per_joint(faults, "fault_onset"))
    fault_levels = np.where(faulty, _per_joint(faults, "residual_peak_fault"), np.nan)
    fault_peak = np.max(np.where(np.isfinite(fault_levels), fault_levels, 0.0), axis=1, initial=0.0)
    delays = np.where(faulty, _per_joint(faults, "detection_delay_x1"), np.nan)
    fault_delay = np.where(np.isfinite(delays).any(axis=1), np.nanmin(np.where(np.isfinite(delays), delays, np.inf),
                                                                       axis=1), np.nan)
    isolated = _per_joint(faults, "isolated") > 0.5
    isolated_right = (isolated == faulty).all(axis=1)
    diverged = _diverged(faults)
    fault_peak[diverged], fault_delay[diverged], isolated_right[diverged] = 0.0, np.nan, False
    return sc.DiagnosisRuns(healthy_peak, alarms, np.nan_to_num(seconds), fault_peak, fault_delay, isolated_right)


def tracking_runs(healthy: dict[str, np.ndarray], faults: dict[str, np.ndarray]) -> sc.TrackingRuns:
    """The per-run inputs of the tracking scores from a pair's healthy and faulty rows."""
    def ok(rows: dict[str, np.ndarray], values: np.ndarray) -> np.ndarray:
        return np.where(_diverged(rows), np.nan, values)

    peaks = _per_joint(faults, "fault_peak_error")
    fault_peak = np.max(np.where(np.isfinite(peaks), peaks, -np.inf), axis=1, initial=-np.inf)
    fault_peak[np.isinf(fault_peak)] = np.nan
    return sc.TrackingRuns(
        healthy_rms=ok(healthy, sc.arm_rms(_per_joint(healthy, "rms_error_converged"))),
        faulty_rms=ok(faults, sc.arm_rms(_per_joint(faults, "rms_error_converged"))),
        fault_peak=ok(faults, fault_peak),
        chattering=ok(healthy, np.mean(_per_joint(healthy, "chattering"), axis=1)),
        diverged=np.concatenate([_diverged(healthy), _diverged(faults)]),
        faulty_kind=np.asarray(faults["kind"]).astype(str) if "kind" in faults else None)


def scores(bench: Bench, done: dict[tuple[str, str, str, str], Found], resamples: int = sc.BOOTSTRAP
           ) -> tuple[list[dict[str, Any]], dict[str, dict[str, sc.DiagnosisRuns]], KindMedians]:
    """One row per task, robot, entry and score; the diagnosis runs per robot and entry (for the ROC); the
    tracking entries' median faulty RMS per fault kind."""
    out, roc_runs, medians = [], {}, {}
    for entry in bench.entries:
        if entry.task == "diagnosis" and bench.suite.calibrated:
            continue  # suite v2: windowed.py
        for robot in bench.suite.spec.robots:
            healthy = entry_rows(done[entry.task, robot, "healthy", entry.name])
            faults = entry_rows(done[entry.task, robot, "faults", entry.name])
            if entry.task == "diagnosis":
                runs = diagnosis_runs(healthy, faults)
                roc_runs.setdefault(robot, {})[entry.name] = runs
                values = sc.diagnosis_scores(runs, resamples)
            else:
                pair = tracking_runs(healthy, faults)
                values = sc.tracking_scores(pair, resamples)
                medians.setdefault(robot, {})[entry.name] = sc.kind_medians(pair)
            for name, s in values.items():
                label, unit, higher = SCORES[entry.task][name]
                out.append({"task": entry.task, "robot": robot, "entry": entry.name, "method": entry.label,
                            "score": name, "label": label, "unit": unit, "higher_is_better": higher,
                            "value": s.value, "low": s.low, "high": s.high, "n": s.count,
                            "gains_from": entry.gains_from})
    return out, roc_runs, medians


def _text(value: float, low: float, high: float) -> str:
    if not np.isfinite(value):
        return "-"
    return f"{value:.3g} [{low:.3g}, {high:.3g}]"


def ranked(rows: list[dict[str, Any]], task: str, robot: str) -> list[str]:
    """The entries of a task on a robot, best first by the task's ranking score (missing last)."""
    key = sc.RANKED_BY[task]
    higher = SCORES[task][key][2]
    values = {r["entry"]: r["value"] for r in rows if r["task"] == task and r["robot"] == robot and r["score"] == key}
    return sorted(values, key=lambda e: (not np.isfinite(values[e]), -values[e] if higher else values[e]))


def markdown(bench: Bench, tier: str, rows: list[dict[str, Any]], info: dict[str, Any],
             boards: dict[str, "windowed.RobotBoard"] | None = None, medians: KindMedians | None = None) -> str:
    suite = bench.suite
    lines = [f"# Benchmark {suite.version} ({tier} tier)", ""]
    if suite.spec.superseded_by:
        lines += [f"**Superseded by suite {suite.spec.superseded_by}** (CHANGELOG.md says why): its diagnosis "
                  "scores are properties of its protocol, not of the methods.", ""]
    lines += [suite.spec.description.strip(), "",
              f"- suite {suite.version}; " + ", ".join(f"{k} {v}" for k, v in info["versions"].items()),
              f"- {info['simulated_runs']} runs simulated this time ({info['simulated_members']} members) in "
              f"{info['wall_time']:.0f} s on {info['workers']} worker(s); the rest reused", "",
              "Scores with 95% intervals (Wilson for proportions, bootstrap otherwise), ranked by the AUC for "
              "diagnosis and by the faulty runs' RMS error for tracking. Definitions: `ftc_mj/ranking/score.py`"
              + (" and `ftc_mj/ranking/calibrated.py`." if suite.calibrated else "."), ""]
    for task in ("diagnosis", "tracking"):
        entries = {e.name: e for e in bench.of(task)}
        if not entries:
            continue
        if task == "diagnosis" and boards is not None:
            lines += windowed.markdown(bench, boards)
            lines += [f"### {task.capitalize()} entries: where the gains come from", ""]
            lines += [f"- `{name}` ({entry.label}): {entry.gains_from}" for name, entry in entries.items()] + [""]
            continue
        names = list(SCORES[task])
        header = ["entry", "method"] + [SCORES[task][n][0] + (f" [{SCORES[task][n][1]}]" if SCORES[task][n][1] else "")
                                        for n in names]
        for robot in suite.spec.robots:
            lines += [f"## {task.capitalize()}: {robot}", ""]
            limit = suite.spec.robots[robot].torque_limit
            if task == "tracking" and limit:
                lines += [f"Every pair's command is clipped by the plant at {' / '.join(f'{v:g}' for v in limit)} "
                          "N m (the robot's torque limits; an actuator fault acts on what the limited motor "
                          "gives).", ""]
            lines += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
            for name in ranked(rows, task, robot):
                by_score = {r["score"]: r for r in rows if r["task"] == task and r["robot"] == robot
                            and r["entry"] == name}
                cells = [f"`{name}`", entries[name].label] + [_text(by_score[n]["value"], by_score[n]["low"],
                                                                    by_score[n]["high"]) for n in names]
                lines.append("| " + " | ".join(cells) + " |")
            lines.append("")
            if task == "tracking":
                lines += _tuned_pairs(rows, task, robot, names)
                lines += _kind_table((medians or {}).get(robot, {}))
        lines += [f"### {task.capitalize()} entries: where the gains come from", ""]
        lines += [f"- `{name}` ({entry.label}): {entry.gains_from}" for name, entry in entries.items()] + [""]
    if bench.of("diagnosis") and boards is None:
        lines += ["![ROC per robot](figures/roc.png)", ""]
    lines += ["![Ranked scores](figures/ranked.png)", ""]
    return "\n".join(lines) + "\n"


def _tuned_pairs(rows: list[dict[str, Any]], task: str, robot: str, names: list[str]) -> list[str]:
    """Each ``<name>_tuned`` row against its ``<name>`` row: per score, whether the intervals are apart
    (:func:`~ftc_mj.ranking.calibrated.apart`; better only when the tuned row's lies wholly on the better side)."""
    from ftc_mj.ranking.calibrated import apart

    scores: dict[str, dict[str, sc.Score]] = {}
    for r in rows:
        if r["task"] == task and r["robot"] == robot:
            scores.setdefault(r["entry"], {})[r["score"]] = sc.Score(r["value"], r["low"], r["high"], r["n"])
    pairs = [(name, design) for name in scores if (design := design_row(name, scores))]
    if not pairs:
        return []
    lines = ["Tuned rows against their design rows, per score: better only where the tuned row's interval lies "
             "wholly on the better side of the design row's, worse where wholly on the other side:", "",
             "| tuned | design | " + " | ".join(SCORES[task][n][0] for n in names) + " |",
             "|" + "---|" * (len(names) + 2)]
    for tuned, design in sorted(pairs):
        cells = [apart(scores[tuned][n], scores[design][n], SCORES[task][n][2]) for n in names]
        lines.append(f"| `{tuned}` | `{design}` | " + " | ".join(cells) + " |")
    return lines + [""]


def _kind_table(medians: dict[str, dict[str, float]]) -> list[str]:
    """Per fault kind, each pair's median faulty RMS error, the winner marked, and each pair's wins."""
    kinds = sorted({kind for by_kind in medians.values() for kind in by_kind})
    if not kinds:
        return []
    winners = {}
    for kind in kinds:  # a kind is won by the one pair with the lowest median; a tie is nobody's
        values = {e: medians[e].get(kind, np.inf) for e in medians}
        best = min(values.values())
        leaders = [e for e, v in values.items() if v == best]
        winners[kind] = leaders[0] if len(leaders) == 1 else None
    lines = [f"Median RMS error [rad] of the faulty runs per fault kind (a diverged run at {sc.DIVERGED_RMS:g} rad; "
             "**bold**: the lowest, none where pairs tie), and the kinds each pair wins:", "",
             "| entry | " + " | ".join(kinds) + " | wins |", "|" + "---|" * (len(kinds) + 2)]
    for name, by_kind in medians.items():
        cells = [f"**{by_kind[k]:.3g}**" if winners[k] == name else f"{by_kind.get(k, np.nan):.3g}" for k in kinds]
        wins = sum(winners[k] == name for k in kinds)
        lines.append(f"| `{name}` | " + " | ".join(cells) + f" | {wins} |")
    return lines + [""]


def _colours(entries: list[str]) -> dict[str, tuple[str, str]]:
    """Each entry's colour (the palette's rule over the bench file's order) and a line style that changes once
    the colours are used up, so overlapping curves stay apart."""
    colours = assign_colours(entries)
    return {name: (colours[name], CAMPAIGN_LINE_STYLES[(i // len(ORDER)) % len(CAMPAIGN_LINE_STYLES)])
            for i, name in enumerate(entries)}


def roc_figure(bench: Bench, roc_runs: dict[str, dict[str, sc.DiagnosisRuns]]) -> Figure:
    robots = [r for r in bench.suite.spec.robots if r in roc_runs]
    styles = _colours([e.name for e in bench.of("diagnosis")])
    fig = Figure(figsize=(4.2 * max(len(robots), 1), 4.4))
    axes = fig.subplots(1, max(len(robots), 1), squeeze=False)[0]
    for ax, robot in zip(axes, robots):
        drawn: list[np.ndarray] = []
        for name, runs in roc_runs[robot].items():
            p_fa, p_d = sc.roc_curve(runs.healthy_peak, runs.fault_peak)
            colour, style = styles[name]
            over = same_roc(p_fa, p_d, drawn)
            if over:
                style = over_alike(over)  # the same line as an entry's drawn before: dashed, so that both show
            ax.plot(np.concatenate(([1.0], p_fa, [0.0])), np.concatenate(([1.0], p_d, [0.0])), color=colour,
                    linestyle=style, linewidth=1.4, label=f"{name} ({sc.auc(runs.healthy_peak, runs.fault_peak):.3f})")
        ax.plot([0, 1], [0, 1], ":", color="grey", linewidth=0.8)
        ax.axvline(sc.FALSE_ALARM_PROBABILITY, color="grey", linewidth=0.6)
        ax.set_xlim(-0.02, 1.02)
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlabel("false-alarm probability")
        ax.set_title(robot, fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower right", title="AUC", title_fontsize=7)
    axes[0].set_ylabel("detection probability")
    fig.suptitle(f"Benchmark {bench.suite.version}: ROC of each observer's diagnosis\n(healthy against faulty "
                 "runs)", fontsize=10)  # two lines: one robot's panel is narrower than the title
    fig.tight_layout()
    return fig


def ranked_figure(bench: Bench, rows: list[dict[str, Any]]) -> Figure:
    """Per task (row) and robot (column), the ranking score of every entry with its interval, best on top."""
    tasks = [t for t in ("diagnosis", "tracking") if bench.of(t)]
    robots = list(bench.suite.spec.robots)
    fig = Figure(figsize=(3.6 * len(robots) + 1.0, 0.4 + sum(0.3 * len(bench.of(t)) + 1.2 for t in tasks)))
    axes = fig.subplots(len(tasks), len(robots), squeeze=False)
    for t, task in enumerate(tasks):
        key = sc.RANKED_BY[task]
        label, unit, _ = SCORES[task][key]
        # The other figures' colours: a tuned row its design row's, drawn hollow.
        names = [e.name for e in bench.of(task)]
        styles = windowed.line_styles(names)
        for r, robot in enumerate(robots):
            ax = axes[t][r]
            order = [name for name in ranked(rows, task, robot) if name in styles]  # the sanity rows too: the scale
            by_entry = {row["entry"]: row for row in rows if row["task"] == task and row["robot"] == robot
                        and row["score"] == key}
            for y, name in enumerate(reversed(order)):
                row, colour = by_entry[name], styles[name][0]
                if np.isfinite(row["value"]):
                    ax.errorbar(row["value"], y, xerr=[[row["value"] - row["low"]], [row["high"] - row["value"]]],
                                fmt="o", color=colour, capsize=3, markersize=4,
                                markerfacecolor="white" if design_row(name, names) else colour)
            ax.set_yticks(range(len(order)), list(reversed(order)), fontsize=7)
            ax.set_xlabel(f"{label}" + (f" [{unit}]" if unit else ""), fontsize=8)
            if task == "tracking":  # plain numbers at 1, 2 and 5 per decade: the default's minor labels collided
                ax.set_xscale("log")
                ax.xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
                ax.xaxis.set_major_formatter(FormatStrFormatter("%g"))
                ax.xaxis.set_minor_formatter(NullFormatter())
                ax.tick_params(axis="x", labelsize=7)
            ax.set_title(f"{task}: {robot}", fontsize=9)
            ax.grid(alpha=0.3, axis="x")
    fig.suptitle(f"Benchmark {bench.suite.version}: ranked scores with 95% intervals (best on top)", fontsize=10)
    fig.tight_layout()
    return fig


def _csv(rows: list[dict[str, Any]]) -> bytes:
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=list(rows[0]), lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return buffer.getvalue().encode()


def versions() -> dict[str, str]:
    out = {}
    for name in PACKAGES:
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = "unknown"
    return out


def _save(fig: Figure, path: Path) -> Path:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110)
    write_atomic(path, buffer.getvalue())
    return path


def write(bench: Bench, tier: str, out: Path, done: dict[tuple[str, str, str, str], Found],
          info: dict[str, Any], resamples: int = sc.BOOTSTRAP) -> list[Path]:
    """Every output of the leaderboard into ``out``; the files written."""
    rows, roc_runs, medians = scores(bench, done, resamples)
    boards = None
    if bench.suite.calibrated and bench.of("diagnosis"):
        boards = {robot: windowed.robot_board(bench, robot, done) for robot in bench.suite.spec.robots}
        windowed.compare_tuned(boards)
        rows = windowed.rows(bench, boards) + rows
    info = {**info, "versions": versions()}
    written = [out / "leaderboard.md", out / "leaderboard.csv", out / "leaderboard.parquet", out / "bench.json"]
    write_atomic(written[0], markdown(bench, tier, rows, info, boards, medians).encode())
    write_atomic(written[1], _csv(rows))
    write_atomic(written[2], parquet_bytes(pa.Table.from_pylist(rows)))
    meta = {"suite": bench.suite.version, "suite_file": str(bench.suite.path), "bench_file": str(bench.path),
            "tier": tier, "versions": info["versions"], "wall_time": info["wall_time"],
            "simulated_runs": info["simulated_runs"], "workers": info["workers"],
            "entries": [{"task": e.task, "name": e.name, "method": e.label, "gains_from": e.gains_from,
                         "sections": e.sections} for e in bench.entries]}
    write_atomic(written[3], (json.dumps(meta, indent=2) + "\n").encode())
    if roc_runs:
        written.append(_save(roc_figure(bench, roc_runs), out / "figures" / "roc.png"))
    if boards:
        alpha = bench.suite.spec.calibration.false_alarm
        written.append(_save(windowed.roc_figure(boards), out / "figures" / "roc.png"))
        written.append(_save(windowed.detectability_figure(boards, alpha), out / "figures" / "detectability.png"))
        written.append(_save(windowed.front_figure(boards), out / "figures" / "front.png"))
    if boards is not None:
        meta["gate"] = {robot: {"passed": b.gate.passed, "conditions": b.gate.conditions()} for robot, b in boards.items()}
        alpha = bench.suite.spec.calibration.false_alarm
        meta["false_alarms"] = {**{robot: windowed.false_alarms({robot: b}, alpha) for robot, b in boards.items()},
                                "every robot": windowed.false_alarms(boards, alpha)}
        meta["tuned_pairs"] = {robot: {"pairs": b.pairs, "check": b.paired_check} for robot, b in boards.items()}
        write_atomic(written[3], (json.dumps(meta, indent=2) + "\n").encode())
    written.append(_save(ranked_figure(bench, rows), out / "figures" / "ranked.png"))
    return written
