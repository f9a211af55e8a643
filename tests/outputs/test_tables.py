"""ftc_mj.outputs.tables and ftc-mj report: the Markdown tables of docs/results/reproduction.md from a run's --json document."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from ftc_mj.cli.report import main
from ftc_mj.outputs.tables import markdown_table

DOCUMENT = {
    "scenario": "demo",
    "seed": 0,
    "variants": {
        "a": {"status": "ok", "diverged_at": None,
              "metrics": {"rms_error": [1.23456e-6, 0.5], "convergence_time": [0.25, None]}},
        "b": {"status": "ok", "diverged_at": None,
              "metrics": {"rms_error": [2.0, 3.0], "convergence_time": [None, 1.0]}},
    },
}


def test_table_has_a_row_per_metric_and_a_column_per_variant() -> None:
    lines = markdown_table(DOCUMENT).splitlines()
    assert lines[0] == "| metric (joints 1 / 2) | unit | a | b |"
    assert lines[2] == "| rms_error | rad | 1.23e-06 / 0.5 | 2 / 3 |"
    assert lines[3] == "| convergence_time | s | 0.25 / - | - / 1 |"
    assert all(line.count("|") == 5 for line in lines)


def test_selection_of_rows_and_columns() -> None:
    lines = markdown_table(DOCUMENT, metrics=["convergence_time"], variants=["b"]).splitlines()
    assert lines == ["| metric (joints 1 / 2) | unit | b |", "|---|---|---|", "| convergence_time | s | - / 1 |"]


def test_command_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "m.json"
    path.write_text(json.dumps(DOCUMENT), encoding="utf-8")
    assert main([str(path)]) == 0
    assert "| rms_error | rad |" in capsys.readouterr().out
    path.write_text("{}", encoding="utf-8")
    assert main([str(path)]) == 2
    error = capsys.readouterr().err
    assert error.startswith(f"error: {path}:") and error.count("\n") == 1
