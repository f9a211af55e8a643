"""The report (ftc_mj.campaign.summary), from a results directory alone."""

from __future__ import annotations

import pytest

import small_campaign
from ftc_mj.campaign import execute
from ftc_mj.cli.campaign import main


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
