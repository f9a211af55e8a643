"""Bad campaign files and command lines: one line naming the file, the field and the problem, exit 2, nothing
written."""

from __future__ import annotations

import pytest

import small_campaign
from ftc_mj.cli.campaign import main
from ftc_mj.campaign.schema import Distribution

SAMPLES = small_campaign.campaign()["samples"]


def samples_with(**fields) -> dict:
    return {"samples": {**SAMPLES, "fields": {**SAMPLES["fields"], **fields}}}


@pytest.mark.parametrize("changes, field, message", [
    ({"colour": "red"}, "colour", "unknown key"),
    ({"grid": {"terms.1.onset": [0.3, 0.3]}}, "", "terms.1.onset: a value is given twice"),
    ({"grid": {"seed": [1, 2]}}, "", "seed cannot be swept or sampled"),
    ({"grid": {"parameters.size": [1.0]}}, "", "parameters.size is both in grid and in samples"),
    (samples_with(**{"parameters.zeta": {"uniform": [5.0, 1.0]}}), "samples.fields.parameters.zeta",
     "low 5 must be below high 1"),
    (samples_with(**{"parameters.zeta": {"uniform": [1.0, 5.0], "normal": [1.0, 1.0]}}),
     "samples.fields.parameters.zeta", "exactly one of"),
    (samples_with(**{"parameters.zeta": {"log_uniform": [0.0, 5.0]}}), "samples.fields.parameters.zeta",
     "greater than 0"),
    ({"grid": {"terms.7.onset": [0.3]}}, "grid.terms.7.onset", "is not a field of the scenario"),
    ({"grid": {"variants.hs.observer.gains.Q": [1.0]}}, "grid.variants.hs.observer.gains.Q",
     "is not a field of the scenario"),
    ({"scenario": "missing.yaml"}, "scenario", "no such file"),
    ({"report": {"metrics": ["speed"]}}, "report.metrics", "unknown metric 'speed'"),
    ({"cases": [{"label": "a"}, {"label": "a"}]}, "", "two cases have the same label"),
])
def test_bad_campaign_files(tmp_path, capsys, changes, field, message):
    path = small_campaign.write(tmp_path, campaign_changes=changes)
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and err.startswith(f"error: {path}: {field}") and message in err, err
    assert not out.exists()


def test_a_drawn_value_the_scenario_refuses_names_the_run_before_anything_runs(tmp_path, capsys):
    changes = samples_with(**{"variants.hs.observer.gains.D": {"uniform": [-10.0, 30.0]}})
    path = small_campaign.write(tmp_path, campaign_changes=changes)
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "run " in err and "variants.hs.observer.gains.D=-" in err and "D" in err, err
    assert not out.exists()


def test_a_negative_rate_parameter_is_refused_with_its_run(tmp_path, capsys):
    path = small_campaign.write(tmp_path, campaign_changes=samples_with(**{"parameters.zeta": {"normal": [0.0, 1.0]}}))
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "parameters.zeta" in err and "must be positive" in err


@pytest.mark.parametrize("argv, message", [
    (["--runs", "0"], "--runs: must be at least 1"),
    (["--workers", "0"], "--workers: must be at least 1"),
    (["--batch-size", "0"], "--batch-size: must be at least 1"),
])
def test_bad_options(tmp_path, capsys, argv, message):
    path = small_campaign.write(tmp_path)
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--quiet", *argv]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_runs_needs_samples(tmp_path, capsys):
    path = small_campaign.write(tmp_path, campaign_changes={"samples": None, "grid": {"parameters.size": [1.0, 2.0]}})
    assert main(["run", str(path), "--runs", "5", "--quiet"]) == 2
    assert "the campaign samples nothing" in capsys.readouterr().err


def test_a_directory_that_holds_something_else_is_refused(tmp_path, capsys):
    path = small_campaign.write(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    assert main(["run", str(path), "--out", str(out), "--quiet"]) == 2
    assert "holds no campaign's results" in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]


def test_report_and_replay_of_a_directory_without_results(tmp_path, capsys):
    assert main(["report", str(tmp_path)]) == 2
    assert "no finished campaign here" in capsys.readouterr().err
    assert main(["replay", str(tmp_path), "abc"]) == 2
    assert "not a finished campaign's results directory" in capsys.readouterr().err


def test_distributions_map_quantiles_to_values():
    assert Distribution(uniform=(1.0, 3.0)).value(0.25) == 1.5
    assert Distribution(log_uniform=(1.0, 100.0)).value(0.5) == pytest.approx(10.0)
    assert Distribution(normal=(2.0, 0.5)).value(0.5) == 2.0
    assert Distribution(normal=(0.0, 1.0)).value(0.975) == pytest.approx(1.96, abs=1e-3)
    choice = Distribution(choice=["a", "b", "c"])
    assert [choice.value(u) for u in (0.0, 0.34, 0.99)] == ["a", "b", "c"]


def test_a_population_too_large_for_the_machine_is_refused_before_it_is_made(tmp_path, capsys):
    path = small_campaign.write(tmp_path, campaign_changes={"replicates": 10**9})
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"{path}: replicates: 8000000000 runs x 2 variants need about" in err and "half of this machine" in err
