"""Suite v2's diagnosis leaderboard: every entry's window scores at calibrated thresholds
(:mod:`ftc_mj.ranking.calibrated`) beside the three sanity rows and their gate, per robot; the per-stratum
table, the tuned rows against their design rows (paired differences, Holm over every robot's pairs), P_d per
fault kind, the runs whose reference loop diverged (apart, never scored), and the figures: the
pooled ROC, the detectability curves (P_d at the common false-alarm probability against the bias size in
residual units) and the delay-against-false-alarm front."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import FixedLocator, FormatStrFormatter, NullFormatter

from ftc_mj.ranking import calibrated as cal
from ftc_mj.ranking.entries import Bench, Entry
from ftc_mj.ranking.execute import WINDOWS, Found
from ftc_mj.ranking.sizing import ACTS
from ftc_mj.ranking.windows import SANITY, load

#: What each sanity row is, for the leaderboard.
SANITY_ROWS = {"oracle_fault": "the true fault torque + 1% white noise (a perfect fault detector)",
               "oracle_luaf": "the true LUaF in torque space (a perfect LUaF estimator)",
               "null": "white noise (a useless detector)"}


@lru_cache(maxsize=64)
def _population(path: Path) -> cal.Population:
    return cal.Population.of(load(path))


def _entry_population(found: Found, name: str) -> cal.Population:
    """The population of ``found``'s chunk with the entry's envelope under ``name``: an entry whose runs are
    another's (the same method and gains on this robot, e.g. a tuning that kept the design gains) was
    simulated under that entry's name."""
    population = _population(found.results / WINDOWS)
    if found.variant == name or found.variant not in population.envelopes:
        return population
    return replace(population, envelopes={**population.envelopes, name: population.envelopes[found.variant]})


@dataclass
class RobotBoard:
    """One robot's v2 diagnosis results."""

    robot: str
    layers: list[cal.Stratum]
    #: Entry (sanity rows first) -> its windows and scores.
    windows: dict[str, cal.Windows] = field(default_factory=dict)
    scores: dict[str, dict[str, Any]] = field(default_factory=dict)
    fronts: dict[str, list[tuple[float, float, float, float]]] = field(default_factory=dict)
    gate: cal.Gate | None = None
    diverged: dict[str, int] = field(default_factory=dict)
    diverged_cases: dict[str, int] = field(default_factory=dict)
    rate: float = 1000.0
    #: Calibration runs whose peaks set the thresholds (the diverged ones left out).
    calibration_runs: int = 0
    #: The tuned rows against their design rows, paired (:func:`compare_tuned`; None until compared), and the
    #: paired test's own check on the sanity rows (oracle_fault against null).
    pairs: list[dict[str, Any]] | None = None
    paired_check: dict[str, Any] = field(default_factory=dict)


def _protocol(bench: Bench, robot: str) -> tuple[Any, float]:
    """The robot's window strata and the bias below which a fault counts as not acting (residual units)."""
    suite = bench.suite
    spec = suite.spec.robots[robot]
    layers = cal.strata(suite.spec.protocol.onsets, spec.fault_joints, suite.spec.calibration.windows)
    return layers, ACTS * min(spec.residual_unit or spec.torque_scale)


def entry_windows(bench: Bench, robot: str, done: dict[tuple[str, str, str, str], Found], name: str
                  ) -> tuple[cal.Windows, list[Any]]:
    """One row's calibrated windows on one robot (an entry or a sanity row), and its three populations
    (calibration, healthy, faults) as stored."""
    layers, acts = _protocol(bench, robot)
    populations = [_entry_population(done["diagnosis", robot, population, name], name)
                   for population in ("calibrate", "healthy", "faults")]
    w, _ = cal.windows(name, *populations, layers, bench.suite.spec.calibration.false_alarm, acts)
    return w, populations


def robot_board(bench: Bench, robot: str, done: dict[tuple[str, str, str, str], Found],
                resamples: int = cal.RESAMPLES) -> RobotBoard:
    layers, acts = _protocol(bench, robot)
    board = RobotBoard(robot, layers, rate=1.0 / float(bench.suite.resolved[robot].get("control_dt", 0.001)))
    names = list(SANITY) + [e.name for e in bench.of("diagnosis")]
    for name in names:
        w, populations = entry_windows(bench, robot, done, name)
        board.windows[name] = w
        board.scores[name] = cal.scores(w, resamples)
        board.fronts[name] = cal.front(name, *populations, layers, acts)
        if name == SANITY[0]:
            board.diverged = {population: pop.diverged for population, pop in
                              zip(("calibrate", "healthy", "faults"), populations)}
            board.diverged_cases = populations[2].diverged_cases
            board.calibration_runs = int(populations[0].draw.size)
    board.gate = cal.gate(board.scores, board.windows)
    return board


def rows(bench: Bench, boards: dict[str, RobotBoard]) -> list[dict[str, Any]]:
    """The leaderboard's rows (as the v1 leaderboard's: one per robot, entry and score)."""
    out = []
    labels = {e.name: e for e in bench.of("diagnosis")}
    for robot, board in boards.items():
        for name, by_score in board.scores.items():
            entry = labels.get(name)
            for score, s in by_score.items():
                label, unit, higher = cal.SCORES[score]
                out.append({"task": "diagnosis", "robot": robot, "entry": name,
                            "method": entry.label if entry else "sanity row", "score": score, "label": label,
                            "unit": unit, "higher_is_better": higher, "value": s.value, "low": s.low,
                            "high": s.high, "n": s.count,
                            "gains_from": entry.gains_from if entry else SANITY_ROWS[name]})
    return out


def _text(s: Any) -> str:
    if not np.isfinite(s.value):
        return "-"
    return f"{s.value:.3g} [{s.low:.3g}, {s.high:.3g}]"


def _fa_cell(s: Any, alpha: float) -> str:
    """The realised false-alarm rate, and whether it is within two binomial standard errors of the nominal."""
    if not np.isfinite(s.value):
        return "-"
    se = np.sqrt(alpha * (1 - alpha) / max(s.count, 1))
    mark = "" if abs(s.value - alpha) <= 2 * se else " (off)"
    return f"{s.value:.3g}{mark}"


def reads(entry: Entry | None) -> str:
    return "truth" if entry is None else ", ".join(entry.reads)


def markdown(bench: Bench, boards: dict[str, RobotBoard]) -> list[str]:
    """The v2 diagnosis sections of ``leaderboard.md``."""
    suite = bench.suite
    alpha = suite.spec.calibration.false_alarm
    entries = {e.name: e for e in bench.of("diagnosis")}
    compare_tuned(boards)
    lines = [
        f"Diagnosis is scored on windows ({', '.join(f'{L:g} s' for L in suite.spec.calibration.windows)} from each "
        "onset, the same statistic for healthy and faulty runs) at each entry's thresholds, calibrated on "
        f"healthy runs that are never scored at {alpha:g} false alarms per window and joint. Intervals: 95% "
        "bootstrap clustered by draw. `specificity` is 1 - the realised false-alarm rate per window; "
        "\"(off)\" marks a realised rate more than two binomial standard errors from the nominal one. "
        "\"alarm on at onset\": detected windows whose alarm was already on before the fault (a false alarm "
        "still on, left out of the delays). \"latched\": healthy windows alarmed from end to end. The first "
        "three rows are the benchmark's sanity rows (they read the engine's truth; no plugin can).", ""]
    names = list(cal.SCORES)
    header = ["entry", "reads", "rate [Hz]"] + [cal.SCORES[n][0] + (f" [{cal.SCORES[n][1]}]" if cal.SCORES[n][1]
                                                                     else "") for n in names]
    for robot, board in boards.items():
        gate = board.gate
        verdict = "passed" if gate.passed else "FAILED"
        lines += [f"## Diagnosis: {robot}", "",
                  f"Declared healthy uncertainty: {suite.spec.robots[robot].uncertainty or 'not declared'}.", "",
                  f"**Sanity gate {verdict}:** " + "; ".join(f"{text} ({'yes' if ok else 'NO'})"
                                                           for text, ok in gate.conditions()), ""]
        lines += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
        order = list(SANITY) + sorted((n for n in board.scores if n not in SANITY),
                                      key=lambda n: -np.nan_to_num(board.scores[n]["auc"].value, nan=-1.0))
        for name in order:
            s = board.scores[name]
            cells = [f"`{name}`" + (" (sanity)" if name in SANITY else ""), reads(entries.get(name)),
                     f"{board.rate:g}"]
            for score in names:
                cells.append(_fa_cell(s[score], alpha) if score == "false_alarm" else _text(s[score]))
            lines.append("| " + " | ".join(cells) + " |")
        lines += ["", f"Per stratum (joint, onset, window length): AUC / P_d / realised FA.", "",
                  "| entry | " + " | ".join(layer.label for layer in board.layers) + " |",
                  "|" + "---|" * (len(board.layers) + 1)]
        for name in order:
            cells = [f"{p['auc']:.3g} / {p['pd']:.3g} / {p['false_alarm']:.3g}"
                     for p in cal.per_stratum(board.windows[name], len(board.layers))]
            lines.append(f"| `{name}` | " + " | ".join(cells) + " |")
        lines += tuned_pairs(board)
        kinds = sorted(np.unique(board.windows[SANITY[0]].fault_kind).tolist())
        lines += ["", "P_d at the common false-alarm probability per fault kind (every size):", "",
                  "| entry | " + " | ".join(kinds) + " |", "|" + "---|" * (len(kinds) + 1)]
        for name in order:
            by_kind = cal.per_kind(board.windows[name])
            lines.append(f"| `{name}` | " + " | ".join(f"{by_kind.get(k, np.nan):.3g}" for k in kinds) + " |")
        lines += ["", _fa_summary(f"On {robot}", {robot: board}, alpha)]
        apart = ", ".join(f"{case}: {count}" for case, count in sorted(board.diverged_cases.items())) or "none"
        lines += ["", f"Runs whose reference loop diverged (apart, not scored): calibration "
                  f"{board.diverged.get('calibrate', 0)}, healthy {board.diverged.get('healthy', 0)}, faulty "
                  f"{board.diverged.get('faults', 0)} ({apart}).", ""]
    if len(boards) > 1:
        lines += ["## Diagnosis: realised false alarms, every robot", "",
                  _fa_summary("Over every robot", boards, alpha), ""]
    lines += ["![ROC per robot, pooled windows](figures/roc.png)", "",
              "![Detectability: P_d at the common false-alarm probability against the bias size](figures/"
              "detectability.png)", "",
              "![Median delay against the false-alarm probability](figures/front.png)", ""]
    return lines


def false_alarms(boards: dict[str, RobotBoard], alpha: float) -> dict[str, Any]:
    """The realised false-alarm rates of every row of ``boards`` against chance
    (:func:`~ftc_mj.ranking.calibrated.false_alarm_check`) and pooled over the rows, as plain data (bench.json)."""
    rows, windows, clusters = {}, [], []
    for robot, board in boards.items():
        for name, w in board.windows.items():
            per_stratum = [int((w.healthy_stratum == s).sum()) for s in range(len(board.layers))]
            rows[f"{robot}/{name}"] = (int((w.healthy_z > 1.0).sum()), per_stratum, board.calibration_runs)
            windows.append(w)
            clusters.append(robot)
    check = cal.false_alarm_check(rows, alpha)
    pooled = cal.pooled_false_alarm(windows, clusters)
    peaks = sorted({board.calibration_runs for board in boards.values()})
    return {"nominal": alpha, "rows": check.rows, "off": check.off, "expected_off_exact": check.expected_exact,
            "expected_off_calibrated": check.expected_calibrated, "p_value": check.p_value,
            "holm_rejected": list(check.holm_rejected), "calibration_peaks": peaks,
            "expected_rate": [cal.expected_false_alarm(n, alpha) for n in peaks],
            "threshold_spread": [cal.threshold_spread(n, alpha) for n in peaks],
            "pooled": {"value": pooled.value, "low": pooled.low, "high": pooled.high, "windows": pooled.count}}


def _fa_summary(where: str, boards: dict[str, RobotBoard], alpha: float) -> str:
    """How many rows' realised false-alarm rates lie beyond two binomial standard errors of the nominal, against
    how many chance predicts, the rows' counts tested against the law calibrated thresholds give (Holm), and the
    rate pooled over every row (:func:`false_alarms`)."""
    f = false_alarms(boards, alpha)
    expected = ", ".join(f"{rate:.3g} (sd {spread:.2g})" for rate, spread in zip(f["expected_rate"],
                                                                                f["threshold_spread"]))
    differ = ", ".join(f"`{name}`" for name in f["holm_rejected"]) or "none"
    pooled = f["pooled"]
    return (f"{where}: {f['off']} of {f['rows']} rows (sanity rows included) are \"(off)\", beyond two binomial "
            f"standard errors of {alpha:g}; chance predicts {f['expected_off_exact']:.1f} with exact thresholds, "
            f"{f['expected_off_calibrated']:.1f} with thresholds from {'/'.join(map(str, f['calibration_peaks']))} "
            f"calibration peaks ({expected} false alarms on average, the sd from one calibration to another; "
            "each row's count beta-binomial), "
            f"P({f['off']} or more) = {f['p_value']:.2g} (rows taken as independent; they share runs). Rows off that "
            f"law at 5% family-wise (Holm): {differ}. Pooled over the rows: {pooled['value']:.3g} "
            f"[{pooled['low']:.3g}, {pooled['high']:.3g}] ({pooled['windows']} windows; interval resampling the "
            "scored healthy runs, the thresholds held).")


#: The scores a tuned row is compared on with its design row, and the family-wise level of the verdicts.
PAIRED_SCORES = ("auc", "pd")
FAMILY_ALPHA = 0.05


def _tuned_rows(board: RobotBoard) -> list[tuple[str, str]]:
    """(tuned, design) for each ``<name>_tuned`` row of the board beside its ``<name>`` row."""
    return sorted((name, design) for name in board.scores if (design := cal.design_row(name, board.scores)))


def compare_tuned(boards: dict[str, RobotBoard], resamples: int | None = None) -> None:
    """Each board's tuned rows against their design rows (``board.pairs``), paired: the difference tuned - design
    of each of :data:`PAIRED_SCORES` on the same windows with its clustered paired interval and p-value
    (:func:`~ftc_mj.ranking.calibrated.paired_differences`), the p-values adjusted by Holm over every test of
    ``boards`` at once (every robot's pairs and both scores: the leaderboard's claims about the tuned rows are
    made over them together), with enough resamples for that family
    (:func:`~ftc_mj.ranking.calibrated.paired_resamples`). Holm rather than Bonferroni: the same family-wise
    guarantee under any dependence (the pairs share runs), never less power. Beside each, the marginal
    intervals' overlap (:func:`~ftc_mj.ranking.calibrated.apart`). Boards already compared are kept.

    The test's own check (``board.paired_check``, outside the family): oracle_fault against null on the same
    windows, which must be apart above on both scores at the family's strictest level (Holm's first threshold,
    alpha / tests); where it is not, the board's paired verdicts are withheld."""
    if all(board.pairs is not None for board in boards.values()):
        return
    found = [(robot, tuned, design) for robot, board in boards.items() for tuned, design in _tuned_rows(board)]
    tests = len(found) * len(PAIRED_SCORES)
    resamples = resamples or cal.paired_resamples(tests, FAMILY_ALPHA)
    for board in boards.values():
        if found and all(name in board.windows for name in ("oracle_fault", "null")):
            check = cal.paired_differences(board.windows["oracle_fault"], board.windows["null"], PAIRED_SCORES,
                                           resamples)
            strictest = {score: min(1.0, check[score].p_value * tests) for score in PAIRED_SCORES}
            board.paired_check = {
                "first": "oracle_fault", "second": "null",
                **{score: {**check[score].as_dict(), "p_strictest": strictest[score],
                           "verdict": cal.paired_verdict(check[score], strictest[score], True, FAMILY_ALPHA)}
                   for score in PAIRED_SCORES}}
            board.paired_check["passed"] = all(board.paired_check[score]["verdict"] == "better"
                                               for score in PAIRED_SCORES)
    differences = [cal.paired_differences(boards[robot].windows[tuned], boards[robot].windows[design],
                                          PAIRED_SCORES, resamples) for robot, tuned, design in found]
    adjusted = iter(cal.holm([d[score].p_value for d in differences for score in PAIRED_SCORES]))
    for board in boards.values():
        board.pairs = []
    for (robot, tuned, design), difference in zip(found, differences):
        board = boards[robot]
        row: dict[str, Any] = {"tuned": tuned, "design": design, "tests": tests, "family_alpha": FAMILY_ALPHA}
        paired, marginal = [], []
        for score in PAIRED_SCORES:
            higher, p_holm = cal.SCORES[score][2], float(next(adjusted))
            paired.append(cal.paired_verdict(difference[score], p_holm, higher, FAMILY_ALPHA))
            marginal.append(cal.apart(board.scores[tuned][score], board.scores[design][score], higher))
            row[score] = {**difference[score].as_dict(), "p_holm": p_holm, "verdict": paired[-1],
                          "marginal": marginal[-1]}
        row["verdict"], row["marginal_verdict"] = cal.tuned_verdict(paired), cal.tuned_verdict(marginal)
        board.pairs.append(row)


def _difference_text(d: dict[str, Any]) -> str:
    if not np.isfinite(d["difference"]):
        return "-"
    return f"{d['difference']:+.3g} [{d['low']:+.3g}, {d['high']:+.3g}]"


def tuned_pairs(board: RobotBoard) -> list[str]:
    """The tuned rows against their design-rule rows (``<name>_tuned`` beside ``<name>``), as compared by
    :func:`compare_tuned` (which must have run): each row's AUC and P_d with their marginal intervals, the paired
    difference with its interval and Holm-adjusted p-value, the paired verdict (better only when a difference is
    apart above and none below), and the marginal intervals' overlap verdict beside it."""
    if not board.pairs:
        return []
    first, check = board.pairs[0], board.paired_check
    withheld = not check.get("passed", False)
    lines = ["", "Tuned rows against their design-rule rows, paired: both rows are scored on the same windows of "
             "the same runs, so the difference (tuned - design) is resampled with the same runs and draws for both "
             "(95% interval). Its p-value is adjusted by Holm over the "
             f"{first['tests']} tests of this leaderboard (every robot's tuned pairs, AUC and P_d; "
             f"{first['auc']['resamples']} resamples); a tuned row is better or worse where an adjusted p-value is "
             f"at most {first['family_alpha']:g}. \"Marginal\": the verdict of the two rows' own intervals "
             "(apart only where they do not overlap), which ignores the pairing.", "",
             "| tuned | design | AUC tuned | AUC design | AUC difference | p (Holm) | P_d tuned | P_d design | "
             "P_d difference | p (Holm) | paired verdict | marginal |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for row in board.pairs:
        cells = [f"`{row['tuned']}`", f"`{row['design']}`"]
        for score in PAIRED_SCORES:
            cells += [_text(board.scores[row['tuned']][score]), _text(board.scores[row['design']][score]),
                      _difference_text(row[score]), f"{row[score]['p_holm']:.2g}"]
        cells += ["withheld (the check below failed)" if withheld else f"**{row['verdict']}**",
                  row["marginal_verdict"]]
        lines.append("| " + " | ".join(cells) + " |")
    if check:
        lines += ["", f"The paired test's own check: `oracle_fault` (perfect) against `null` (useless) on the same "
                  "windows, apart above on both scores at the family's strictest level "
                  f"({first['family_alpha']:g} / {first['tests']}): AUC {_difference_text(check['auc'])}, P_d "
                  f"{_difference_text(check['pd'])} ({'yes' if check['passed'] else 'NO'})."]
    return lines


def line_styles(names: list[str]) -> dict[str, tuple[str, str, str | None]]:
    """Colour, line style and marker per row: the sanity rows grey and black, entries the palette's order with
    a marker each, so that identical curves stay apart; a tuned row its design row's colour and marker, dashed
    (a wrapped palette's second round dash-dotted), so that each pair reads as one method."""
    from ftc_mj.ranking.leaderboard import _colours

    entries = [n for n in names if n not in SANITY and cal.design_row(n, names) is None]
    base = _colours(entries)
    markers = ("o", "s", "^", "v", "D", "x", "+", "<", ">", "P", "*", "h")
    out: dict[str, tuple[str, str, str | None]] = {
        "oracle_fault": ("#000000", ":", None), "oracle_luaf": ("#7f7f7f", "--", None), "null": ("#bbbbbb", ":", None)}
    for i, name in enumerate(entries):
        out[name] = (base[name][0], "-." if base[name][1] != "-" else "-", markers[i % len(markers)])
    for name in names:
        if (design := cal.design_row(name, names)) is not None:
            out[name] = (out[design][0], "--", out[design][2])
    return out


def _panels(boards: dict[str, RobotBoard], title: str, xlabel: str, ylabel: str
            ) -> tuple[Figure, list[tuple[Any, RobotBoard, dict[str, tuple[str, str, str | None]]]]]:
    """A figure of one panel per robot (two columns, a double-column figure's width) with its title and axis
    labels; each panel with its robot's board and line styles."""
    columns = min(2, len(boards))
    rows = -(-len(boards) // columns)
    fig = Figure(figsize=(7.0, 2.9 * rows + 0.9))
    axes = fig.subplots(rows, columns, squeeze=False).ravel()
    for ax in axes[len(boards):]:
        ax.set_visible(False)
    panels = []
    for ax, (robot, board) in zip(axes, boards.items()):
        ax.set_title(robot, fontsize=9)
        ax.set_xlabel(xlabel, fontsize=8)
        ax.set_ylabel(ylabel, fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3, which="both")
        panels.append((ax, board, line_styles(list(board.windows))))
    fig.suptitle(title, fontsize=9)
    return fig, panels


def _legend(fig: Figure, panels: list) -> Figure:
    """One legend for every panel, below them (the entries are the same on every robot)."""
    handles, labels = panels[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=5, fontsize=6.5, frameon=False)
    fig.tight_layout(rect=(0, 0.03 + 0.022 * (-(-len(labels) // 5)), 1, 1))
    return fig


def roc_figure(boards: dict[str, RobotBoard]) -> Figure:
    fig, panels = _panels(boards, "ROC of the pooled windows (z = peak / calibrated threshold); each row's AUC in "
                          "the tables", "false-alarm probability per window", "detection probability")
    for ax, board, styles in panels:
        for name, w in board.windows.items():
            if not (w.healthy_z.size and w.fault_z.size):
                continue
            thresholds = np.unique(np.concatenate([w.healthy_z, w.fault_z, [np.inf]]))
            p_fa = np.array([np.mean(w.healthy_z > c) for c in thresholds])
            p_d = np.array([np.mean(w.fault_z > c) for c in thresholds])
            colour, style, marker = styles[name]
            ax.plot(np.concatenate(([1.0], p_fa)), np.concatenate(([1.0], p_d)), color=colour, linestyle=style,
                    marker=marker, markevery=0.2, markersize=3, linewidth=1.0, label=name)
        ax.plot([0, 1], [0, 1], color="#dddddd", linewidth=0.6)
    return _legend(fig, panels)  # below the panels: inside one, some twenty rows hid the curves


def detectability_figure(boards: dict[str, RobotBoard], alpha: float) -> Figure:
    fig, panels = _panels(boards, "Detectability: P_d at the common false-alarm probability against the bias",
                          "bias [residual units]",
                          f"P_d at {alpha:g} false alarms per window")
    for ax, board, styles in panels:
        names = list(board.windows)
        for i, name in enumerate(names):
            curve = cal.detectability(board.windows[name])
            if not curve:
                continue
            size, pd = np.array([c[0] for c in curve]), np.array([c[1] for c in curve])
            # Entries a little apart along x (a few percent) so that identical curves stay visible.
            shift = 1.0 + 0.06 * (i - len(names) / 2) / max(len(names), 1)
            colour, style, marker = styles[name]
            ax.plot(size * shift, pd, color=colour, linestyle=style, marker=marker, markersize=3.5, linewidth=1.0,
                    label=name)
        ax.axhline(alpha, color="#999999", linewidth=0.6)
        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(FormatStrFormatter("%g"))
        ax.set_ylim(-0.03, 1.03)
    return _legend(fig, panels)


def front_figure(boards: dict[str, RobotBoard]) -> Figure:
    fig, panels = _panels(boards, "Median delay against false alarms (thresholds at 0.5-30% per window)",
                          "realised false-alarm probability per window", "median detection delay [ms]")
    for ax, board, styles in panels:
        for name, points in board.fronts.items():
            if name == "null":  # its "detections" are its false alarms: no delay to speak of
                continue
            fa = np.array([p[1] for p in points])
            delay = np.array([p[3] for p in points])
            keep = np.isfinite(fa) & np.isfinite(delay) & (fa > 0)
            colour, style, marker = styles[name]
            ax.plot(fa[keep], delay[keep] * 1000.0, color=colour, linestyle=style, marker=marker, markersize=3.5,
                    linewidth=1.0, label=name)
        ax.set_xscale("log")
        ax.set_yscale("log")
        # Plain tick labels at round values (a log axis spanning less than a decade labels its minor ticks in
        # overlapping powers of ten).
        for axis, ticks in ((ax.xaxis, (0.01, 0.02, 0.05, 0.1, 0.2, 0.5)), (ax.yaxis, (10, 20, 50, 100, 200, 500))):
            axis.set_major_locator(FixedLocator(ticks))
            axis.set_major_formatter(FormatStrFormatter("%g"))
            axis.set_minor_formatter(NullFormatter())
    return _legend(fig, panels)
