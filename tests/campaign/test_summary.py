"""The report (ftc_mj.campaign.summary), from a results directory alone."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import small_campaign
from ftc_mj.campaign import execute
from ftc_mj.cli.campaign import main

#: a campaign of closed-loop runs, reported
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    folder = tmp_path_factory.mktemp("report")
    path = small_campaign.write(folder)
    out = folder / "out"
    assert main(["run", str(path), "--out", str(out), "--quiet", "--workers", "1"]) == 0
    return out


def test_the_report_has_every_section_and_its_figures(results):
    text = (results / "report.md").read_text()
    for heading in ("## Divergence", "## Claims", "## Metrics", "### rms_error_converged [rad]", "## Paired differences",
                    "## Fault diagnosis", "### Isolation"):
        assert heading in text, heading
    for figure in ("box_rms_error_converged.png", "roc.png", "delay_ecdf.png", "pd_vs_size.png", "confusion.png"):
        path = results / "figures" / figure
        assert path.stat().st_size > 5000, figure
        assert f"figures/{figure}" in text
    assert "| hs faster | hs < tosmo | observer_convergence_time.1 |" in text
    # The healthy runs: the confusion table's first row counts them (4 samples).
    assert "| healthy | 4 |" in text or "| healthy | 3 |" in text


def test_report_again_gives_the_same_text(results):
    before = (results / "report.md").read_text()
    assert main(["report", str(results)]) == 0
    assert (results / "report.md").read_text() == before  # fixed bootstrap seed: the same numbers


def test_a_grid_of_two_numbers_gets_a_heat_map(tmp_path):
    path = small_campaign.write(tmp_path, campaign_changes={
        "cases": [], "samples": None,
        "grid": {"variants.hs.controller.gains.mu": [0.25, 1.0], "variants.hs.controller.gains.beta4": [2.0, 5.0]},
        "report": {"metrics": ["rms_error_converged"], "heatmap": {"metric": "rms_error_converged", "joint": 2}},
    })
    out = tmp_path / "out"
    execute.execute(execute.load(path), out, workers=1)
    from ftc_mj.campaign.summary import write_report

    written = write_report(out)
    assert out / "figures" / "heatmap.png" in written
    assert "## Grid" in (out / "report.md").read_text()


def test_the_report_opens_with_a_summary(results):
    text = (results / "report.md").read_text()
    head, _, details = text.partition("# Details")
    assert "## Summary" in head and "## Claims" in details
    assert "| claim | ordering | metric | joints | win rate | verdict | depends on |" in head
    assert "figures/roc.png" in head  # links to the figures
    assert len(head.splitlines()) <= 40
    assert "can disagree" in details.split("## Paired differences")[1]  # why mean and win rate differ
    assert "several" not in text  # the isolation table names joints


def test_smoke_options_shrink_the_run_and_are_recorded(tmp_path):
    import json

    path = small_campaign.write(tmp_path)
    out = tmp_path / "out"
    argv = ["run", str(path), "--out", str(out), "--quiet", "--workers", "1", "--runs", "2", "--duration", "0.4",
            "--set", "sensors.position.noise_std=0"]
    assert main(argv) == 0
    summary = json.loads((out / "campaign.json").read_text())
    assert summary["command"] == "ftc-mj campaign " + " ".join(argv)
    assert summary["resolved"]["duration"] == 0.4 and summary["resolved"]["samples"]["runs"] == 2
    assert summary["resolved"]["set"]["sensors.position.noise_std"] == 0
    assert summary["command"] in (out / "report.md").read_text()


def test_a_bad_set_is_one_line(tmp_path, capsys):
    path = small_campaign.write(tmp_path)
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--set", "duration"]) == 2
    assert capsys.readouterr().err.strip() == "error: command line: --set: 'duration' is not KEY=VALUE"


def test_a_fault_after_the_runs_end_is_no_miss_in_the_detection_statistics() -> None:
    """A faulty run with no armed sample after its onset (it ended first) has no fault peak: it is left out of
    the detection probability instead of counting as a missed fault (peak 0)."""
    from ftc_mj.campaign.summary import Results, _run_peaks

    columns = {"variant": np.array(["a", "a", "a"]), "rms_error.1": np.zeros(3),
               "residual_peak_healthy.1": np.array([0.5, 0.4, 0.3]),
               "residual_peak_fault.1": np.array([np.nan, 5.0, np.nan]),
               "fault_onset.1": np.array([np.nan, 0.3, 10.0])}
    results = Results(directory=Path("."), summary={}, spec=None, variants=["a"], columns=columns, colours={})
    peak_healthy, peak_fault, faulty = _run_peaks(results, "a")
    np.testing.assert_array_equal(faulty, [False, True, True])
    np.testing.assert_array_equal(peak_fault, [np.nan, 5.0, np.nan])
    np.testing.assert_array_equal(peak_healthy, [0.5, 0.4, 0.3])
