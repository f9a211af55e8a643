"""ftc_mj.outputs.tables and ftc-mj report: the Markdown tables of docs/results/reproduction.md from a run's --json document."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
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


# ------------------------------------------------------------------------------------ the printed table

UR10E = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
         "wrist_3_joint"]


def test_joint_labels_keep_short_names_and_number_long_ones_with_a_legend():
    from ftc_mj.outputs.tables import JOINT_LABEL_WIDTH, joint_labels

    assert joint_labels(["joint1", "joint2", "joint3"]) == (["joint1", "joint2", "joint3"], None)
    assert joint_labels(["shoulder", "elbow"]) == (["shoulder", "elbow"], None)
    assert joint_labels(["base_joint", "elbow_joint"]) == (["base", "elbow"], None)  # the shared suffix dropped
    labels, legend = joint_labels(UR10E)
    assert labels == ["j1", "j2", "j3", "j4", "j5", "j6"]
    assert legend == "j1 shoulder_pan, j2 shoulder_lift, j3 elbow, j4 wrist_1, j5 wrist_2, j6 wrist_3"
    assert joint_labels(["", "b"]) == (["j1", "b"], None)
    labels, _ = joint_labels(["a" * (JOINT_LABEL_WIDTH + 1), "b"])
    assert labels == ["j1", "j2"]


def test_table_rows_print_each_value_once():
    from ftc_mj.outputs.tables import table_rows

    nan = float("nan")
    host, other = np.array([1.0, nan]), np.array([2.0, 3.0])
    hosts = {"v": None, "v.mo": "v", "v.kf": "v", "w": None}
    # A monitor equal to its variant (a tracking metric) is left out; one that differs is kept, as ".name".
    rows = table_rows({"v": host, "v.mo": host.copy(), "v.kf": other, "w": other}, hosts)
    assert [label for label, _ in rows] == ["v", ".kf", "w"]
    # A log replay with every row the same (NaN equal to NaN): one row, "all"; simulated variants each.
    alike = {"v": host, "v.mo": host.copy(), "v.kf": host.copy(), "w": host.copy()}
    assert [label for label, _ in table_rows(alike, hosts, shared_plant=True)] == ["all"]
    assert [label for label, _ in table_rows(alike, hosts)] == ["v", "w"]
    # Variants alike but a monitor not: each row as it is.
    rows = table_rows({"v": host, "v.mo": other, "v.kf": host.copy(), "w": host.copy()}, hosts, shared_plant=True)
    assert [label for label, _ in rows] == ["v", ".mo", "w"]
    # One variant alone is never "all".
    assert [label for label, _ in table_rows({"v": host}, {"v": None}, shared_plant=True)] == ["v"]


def test_the_printed_table_of_a_six_joint_arm_fits_80_columns():
    """The UR10e's six joints, a monitor and the metrics with the longest names, on a console of 80 columns:
    no line wider, no name cut (rich marks a cut with an ellipsis)."""
    from types import SimpleNamespace

    from rich.console import Console

    from ftc_mj.cli.run import metrics_table

    model = SimpleNamespace(joint=lambda j: SimpleNamespace(name=UR10E[j]))
    scenario = SimpleNamespace(n_joints=6, model=model, name="ur10e", diagnoser=None, log=None)
    results = [SimpleNamespace(name=name, host=host, status="ok", diverged_at=None)
               for name, host in (("momentum", None), ("momentum.momentum_levant", "momentum"), ("tosmo", None))]
    shown = ["rms_error_converged", "rms_luaf_error_fault", "chattering"]
    values = {"momentum": np.full(6, -3.42e-6), "momentum.momentum_levant": np.full(6, 1.5e5),
              "tosmo": np.full(6, 0.667)}
    metrics = {name: {metric: v for metric in shown} for name, v in values.items()}
    console = Console(width=80, record=True, file=open("/dev/null", "w"))
    console.print(metrics_table(scenario, results, metrics, shown))
    text = console.export_text()
    assert max(map(len, text.splitlines())) <= 80, text
    assert "…" not in text and "rms_luaf_error_fault [rad/s^2]" in text and ".momentum_levant" in text, text
    assert "j1 shoulder_pan" in text and "-3.42e-06" in text, text
    # The columns line up from metric to metric: each value ends where its joint's heading does.
    lines = text.splitlines()
    heading = next(line for line in lines if " j6" in line)
    assert all(line.rstrip().endswith("-3.42e-06") and len(line.rstrip()) == len(heading.rstrip())
               for line in lines if line.lstrip().startswith("momentum ")), text
