"""The metrics registry (ftc_mj.analysis.registry): a metric added as one NumPy function appears at once in a
run's table and ``--json``, in a campaign's rows and in its report's statistics; a name is registered once."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from ftc_mj.analysis.registry import METRICS, REGISTRY, UNITS, metric, unregister

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "campaign"))
import small_campaign  # noqa: E402


@pytest.fixture
def peak_torque():
    """A metric of this test's own, registered for the test only."""

    @metric("peak_torque", unit="N m", window="the whole run")
    def peak_torque(run):
        """The largest |commanded torque|."""
        return np.max(np.abs(run.tau), axis=0)

    yield peak_torque
    unregister("peak_torque")


def test_a_registered_metric_is_in_the_names_units_and_docs(peak_torque):
    assert "peak_torque" in METRICS and METRICS[-1] != "peak_torque"  # the series metrics come first
    assert list(METRICS).index("peak_torque") < list(METRICS).index("detection_delay")
    assert UNITS["peak_torque"] == "N m" and REGISTRY["peak_torque"].doc == "The largest |commanded torque|."
    with pytest.raises(ValueError, match="registered already"):
        metric("peak_torque", "N m", "the whole run")(lambda run: None)


@pytest.mark.slow
def test_a_registered_metric_is_in_the_runs_table_and_json(peak_torque, tmp_path, capsys, monkeypatch):
    from ftc_mj.run import main

    scenario = small_campaign.write(tmp_path).parent / "scenario.yaml"
    monkeypatch.chdir(tmp_path)
    assert main([str(scenario), "--set", "duration=0.2", "--json", "out.json", "--out", "rec.rrd",
                 "--metrics", "all"]) == 0
    assert "peak_torque" in capsys.readouterr().out
    values = json.loads((tmp_path / "out.json").read_text())["variants"]["hs"]["metrics"]["peak_torque"]
    assert len(values) == 3 and all(v > 0 for v in values)


@pytest.mark.slow
def test_a_registered_metric_is_in_a_campaigns_rows_and_statistics(peak_torque, tmp_path):
    import pyarrow.parquet as pq

    from ftc_mj.campaign import execute
    from ftc_mj.campaign.summary import write_report

    path = small_campaign.write(tmp_path, {"duration": 0.35}, {"report": {"metrics": ["peak_torque"],
                                                                         "bootstrap": 100}})
    out = tmp_path / "results"
    execute.execute(execute.load(path), out, workers=1)
    rows = pq.read_table(out / "runs.parquet").to_pylist()
    assert all(row["peak_torque.1"] > 0 for row in rows if row["status"] == "ok")
    write_report(out)
    assert "### peak_torque [N m]" in (out / "report.md").read_text()
