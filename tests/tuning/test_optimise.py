"""Tuning: the files a user gets, resuming gives the uninterrupted tuning, constraints are penalties, and bad
tuning files are refused."""

from __future__ import annotations

import json
import warnings
import sys
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "campaign"))
import small_campaign  # noqa: E402
from ftc_mj.cli.tune import main  # noqa: E402
from ftc_mj.tuning import optimise  # noqa: E402

#: campaigns, calibrations, tunings and benchmarks of closed-loop runs
pytestmark = pytest.mark.slow

TUNING = {
    "name": "small", "campaign": "campaign.yaml", "variant": "hs", "conditions": 2, "held_out": 3,
    "gains": {"variants.hs.controller.gains.mu": {"low": 0.05, "high": 5.0, "log": True},
              "variants.hs.observer.gains.gamma": {"low": 1.0, "high": 20.0}},
    "cost": {"weights": {"rms_error_converged": 1.0, "chattering": 0.2}, "aggregate": "mean_cvar", "fraction": 0.5},
    "constraints": {"divergence": True, "false_alarms": 0},
    "optimizer": {"population": 4, "generations": 2, "sigma": 0.3, "seed": 1},
}


def write(folder: Path, **changes) -> Path:
    small_campaign.write(folder, campaign_changes={"cases": [], "samples": {
        "runs": 6, "fields": {"parameters.size": {"uniform": [5.0, 20.0]}}}})
    path = folder / "tuning.yaml"
    path.write_text(yaml.safe_dump({**TUNING, **changes}))
    return path


@pytest.fixture(scope="module")
def tuned(tmp_path_factory):
    folder = tmp_path_factory.mktemp("tuning")
    path = write(folder)
    assert main([str(path), "--out", str(folder / "out"), "--workers", "1", "--quiet"]) == 0
    return path, folder / "out"


def test_the_files_a_user_gets(tuned):
    _, out = tuned
    report = json.loads((out / "report.json").read_text())
    held = report["held_out"]
    assert held["runs"] == 3
    assert set(held) >= {"baseline", "tuned", "paired_difference", "constraint_violations"}
    assert set(held["baseline"]) >= {"cost", "metrics"} and len(held["paired_difference"]["ci95"]) == 2
    # The scenario's gains cost the sum of the weights on every condition: the cost is relative to them.
    assert held["baseline"]["mean_condition_cost"] == pytest.approx(1.2)
    text = (out / "best.yaml").read_text()
    best = yaml.safe_load(text)
    assert list(best) == ["variants"]  # the provenance is a comment, not a key
    assert text.startswith("# tuned gains of variant hs, by: ftc-mj tune ") and "--workers 1" in text.splitlines()[0]
    tuned_gains = report["gains"]["tuned"]
    assert best["variants"]["hs"]["controller"]["gains"]["mu"] == pytest.approx(
        tuned_gains["variants.hs.controller.gains.mu"], rel=1e-5)
    history = pq.read_table(out / "history.parquet").to_pylist()
    assert len(history) == 2 * 4
    assert {"generation", "candidate", "cost", "penalised", "violations", "variants.hs.controller.gains.mu",
            "mean.chattering"} <= set(history[0])
    for row in history:  # an explicit penalty, never a dropped candidate
        assert row["penalised"] == pytest.approx(row["cost"] + 10.0 * row["violations"] / 2)
        assert 0.05 <= row["variants.hs.controller.gains.mu"] <= 5.0
    assert (out / "convergence.png").stat().st_size > 5000
    assert "## Held-out check" in (out / "report.md").read_text()


def test_best_yaml_below_a_base_line_is_the_tuned_scenario(tuned):
    from ftc_mj import load_scenario

    path, out = tuned
    report = json.loads((out / "report.json").read_text())
    tuned_file = path.parent / "tuned_scenario.yaml"
    tuned_file.write_text("base: scenario.yaml\n" + (out / "best.yaml").read_text())
    scenario = load_scenario(tuned_file)
    assert scenario.written()["variants"]["hs"]["controller"]["gains"]["mu"] == pytest.approx(
        report["gains"]["tuned"]["variants.hs.controller.gains.mu"], rel=1e-5)


def test_size_options_make_a_smoke_test_and_are_recorded(tmp_path):
    path = write(tmp_path)
    out = tmp_path / "smoke"
    argv = [str(path), "--out", str(out), "--workers", "1", "--quiet", "--conditions", "1", "--held-out", "1",
            "--population", "2", "--generations", "1", "--duration", "0.5", "--set", "sensors.position.noise_std=0"]
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # two candidates: no division by a zero learning rate shown
        assert main(argv) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["training"]["conditions"] == 1 and report["held_out"]["runs"] == 1
    assert report["training"]["generations"] == 1 and report["training"]["population"] == 2
    assert report["command"] == "ftc-mj tune " + " ".join(argv)
    assert report["command"] in (out / "report.md").read_text()


@pytest.mark.parametrize("option, value", [("--conditions", "0"), ("--population", "-1"), ("--duration", "nan"),
                                           ("--set", "nokey")])
def test_bad_size_options(tmp_path, capsys, option, value):
    path = write(tmp_path)
    assert main([str(path), "--out", str(tmp_path / "x"), option, value]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: command line: {option}: ")


def test_resuming_gives_the_uninterrupted_tuning(tuned, tmp_path):
    path, out = tuned
    interrupted = tmp_path / "out"
    assert main([str(path), "--out", str(interrupted), "--workers", "1", "--quiet", "--generations", "1"]) == 0
    assert main([str(path), "--out", str(interrupted), "--workers", "1", "--quiet"]) == 0
    a = pq.read_table(out / "history.parquet").to_pylist()
    b = pq.read_table(interrupted / "history.parquet").to_pylist()
    assert a == b
    assert json.loads((out / "report.json").read_text())["gains"] == json.loads(
        (interrupted / "report.json").read_text())["gains"]


def test_costs_and_constraints():
    class Stub:
        spec = type("S", (), {"cost": type("C", (), {"weights": {"rms_error_converged": 1.0}, "aggregate": "mean_cvar",
                                                     "fraction": 0.5})(),
                              "constraints": type("K", (), {"divergence": True, "false_alarms": 0,
                                                            "detection_delay": 0.5})()})()

    evaluation = optimise.Evaluation(
        metrics={"rms_error_converged": np.array([[2.0, 1.0], [np.nan, 3.0]])},
        diverged=np.array([[False, False], [True, False]]),
        false_alarms=np.array([[0.0, 1.0], [0.0, 0.0]]),
        worst_delay=np.array([[0.1, np.inf], [np.nan, 0.7]]))
    base = optimise.Evaluation({"rms_error_converged": np.array([[1.0, 2.0]])}, np.zeros((1, 2), bool),
                               np.zeros((1, 2)), np.zeros((1, 2)))
    costs = optimise.condition_costs(Stub, evaluation, base)
    np.testing.assert_allclose(costs, [[2.0, 0.5], [optimise.DIVERGED_COST, 1.5]])
    np.testing.assert_allclose(optimise.aggregate(Stub, costs), [1.25 + 2.0, 5.75 + 10.0])
    np.testing.assert_array_equal(optimise.violations(Stub, evaluation), [[False, True], [True, True]])


@pytest.mark.parametrize("changes, field, message", [
    ({"gains": {"seed": {"low": 0, "high": 1}}}, "", "is not a gain of variant hs"),
    ({"gains": {"variants.hs.observer_initial.qd_hat.0": {"low": 0, "high": 1}}}, "", "is not a gain of variant hs"),
    ({"gains": {"variants.tosmo.controller.gains.mu": {"low": 0.1, "high": 1}}}, "", "is not a gain of variant hs"),
    ({"gains": {"variants.hs.controller.gains.mu": {"low": 1.0, "high": 5.0}}}, "gains.variants.hs.controller.gains.mu",
     "the scenario's value 0.5 is outside [1, 5]"),
    ({"gains": {"variants.hs.controller.gains.mu": {"low": -1.0, "high": 5.0}}}, "gains",
     "the lower bounds are not valid gains"),
    ({"gains": {"variants.hs.controller.gains.mu": {"low": 0.0, "high": 5.0, "log": True}}},
     "gains.variants.hs.controller.gains.mu", "needs low > 0"),
    ({"cost": {"weights": {"speed": 1.0}}}, "cost.weights", "unknown metric 'speed'"),
    ({"campaign": "nothing.yaml"}, "campaign", "no such file"),
])
def test_bad_tuning_files(tmp_path, capsys, changes, field, message):
    path = write(tmp_path, **changes)
    assert main([str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and err.startswith(f"error: {path}: {field}") and message in err, err
    assert not (tmp_path / "out").exists()
