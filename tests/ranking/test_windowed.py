"""The v2 leaderboard's boards: an entry whose runs on a robot are another entry's (the same method and gains,
e.g. a tuning that kept its design gains) is scored from those runs, found under the name they were made
under."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ftc_mj.ranking import calibrated as cal
from ftc_mj.ranking import windowed
from ftc_mj.ranking.execute import Found


def _population() -> cal.Population:
    empty = np.zeros(2)
    return cal.Population(envelopes={"momentum": np.ones((2, 3, 1))}, draw=empty, kind=empty, size=empty,
                          joint=empty, onset=empty, fault_effect=np.zeros((2, 1)), diverged=0, block_seconds=0.005)


def test_an_entry_simulated_under_another_name_is_scored_from_its_runs(monkeypatch):
    population = _population()
    monkeypatch.setattr(windowed, "_population", lambda path: population)
    shared = windowed._entry_population(Found(Path("chunk"), "momentum"), "momentum_tuned")
    assert shared.envelopes["momentum_tuned"] is population.envelopes["momentum"]
    assert shared.envelopes["momentum"] is population.envelopes["momentum"]
    assert windowed._entry_population(Found(Path("chunk"), "momentum"), "momentum") is population


def _board(robot: str, windows: dict[str, cal.Windows]) -> windowed.RobotBoard:
    return windowed.RobotBoard(robot, [], windows=dict(windows),
                               scores={name: cal.scores(w, 100) for name, w in windows.items()})


def _rows(board: windowed.RobotBoard) -> dict[str, dict]:
    return {row["tuned"]: row for row in board.pairs}


def test_tuned_rows_are_compared_paired_with_holm_over_every_robot():
    """A tuned row whose faulty windows stand clearly higher than its design row's on the same windows is
    better, though the two rows' marginal intervals overlap; a tuned row that is its design row differs by 0.
    Holm's family is every robot's pairs and both scores (8 tests here), and the resamples resolve it."""
    from test_paired_differences import _pair

    rng = np.random.default_rng(9)
    design, tuned = _pair(rng, faulty_gain=0.25, own=0.1)  # entries that share most of their residual
    perfect, _ = _pair(rng)
    perfect.fault_z[:] = 100.0
    sanity = {"oracle_fault": perfect, "null": design}
    boards = {robot: _board(robot, {**sanity, "momentum": design, "momentum_tuned": tuned, "ndob": design,
                                    "ndob_tuned": design}) for robot in ("arm", "other")}
    windowed.compare_tuned(boards)
    for board in boards.values():
        rows = _rows(board)
        assert rows["momentum_tuned"]["tests"] == 8
        assert rows["momentum_tuned"]["auc"]["resamples"] == cal.paired_resamples(8)
        assert rows["momentum_tuned"]["verdict"] == "better" and rows["momentum_tuned"]["marginal_verdict"] == \
            "not apart", rows["momentum_tuned"]
        assert rows["ndob_tuned"]["verdict"] == "not apart" and rows["ndob_tuned"]["auc"]["difference"] == 0.0
        assert board.paired_check["passed"]
        holm = cal.holm([rows["momentum_tuned"]["auc"]["p_value"]] * 2 + [rows["momentum_tuned"]["pd"]["p_value"]]
                        * 2 + [1.0] * 4)
        assert rows["momentum_tuned"]["auc"]["p_holm"] == holm[0]
    # Compared once: a second call keeps the verdicts.
    first = boards["arm"].pairs
    windowed.compare_tuned(boards)
    assert boards["arm"].pairs is first


def test_the_verdicts_are_withheld_where_the_paired_check_fails():
    """Where oracle_fault is not apart from null (a broken pipeline: here oracle_fault is useless too), the
    board's paired verdicts are not published."""
    from test_paired_differences import _pair

    rng = np.random.default_rng(10)
    design, tuned = _pair(rng, faulty_gain=3.0)
    board = _board("arm", {"oracle_fault": design, "null": design, "momentum": design, "momentum_tuned": tuned})
    windowed.compare_tuned({"arm": board}, resamples=200)
    assert not board.paired_check["passed"]
    lines = windowed.tuned_pairs(board)
    assert "withheld (the check below failed)" in next(line for line in lines if line.startswith("| `momentum"))
    assert lines[-1].endswith("(NO).")
