"""Running a campaign: results do not depend on the batch size or the workers, an interrupted campaign resumes
to the same table, a changed campaign is refused, and a replayed run equals its row."""

from __future__ import annotations

import json
import math
import shutil

import pyarrow.parquet as pq
import pytest

import small_campaign
from ftc_mj.campaign import execute
from ftc_mj.cli import run
from ftc_mj.config.errors import InputError

#: campaigns, calibrations, tunings and benchmarks of closed-loop runs
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def campaign_file(tmp_path_factory):
    return small_campaign.write(tmp_path_factory.mktemp("campaign"))


@pytest.fixture(scope="module")
def reference_dir(campaign_file, tmp_path_factory):
    """The campaign run in this process, one member per batch."""
    out = tmp_path_factory.mktemp("results") / "one"
    execute.execute(execute.load(campaign_file), out, batch_size=1, workers=1)
    return out


def rows(directory) -> list[dict]:
    return pq.read_table(directory / "runs.parquet").to_pylist()


def same_rows(a: list[dict], b: list[dict]) -> None:
    assert [(r["run_id"], r["variant"]) for r in a] == [(r["run_id"], r["variant"]) for r in b]
    for x, y in zip(a, b):
        assert x.keys() == y.keys()
        for key in x:
            both_nan = isinstance(x[key], float) and math.isnan(x[key]) and math.isnan(y[key])
            assert both_nan or x[key] == y[key], (x["run_id"], x["variant"], key)


def test_every_run_and_variant_has_a_row_with_its_columns(campaign_file, reference_dir):
    table = rows(reference_dir)
    assert len(table) == 8 * 2  # 4 samples x 2 cases, 2 variants
    first = table[0]
    for column in ("run", "run_id", "variant", "status", "diverged_at", "seed", "case", "fault_joint",
                   "parameters.size", "variants.hs.controller.gains.mu", "rms_error_converged.2",
                   "detection_delay.2", "residual_peak_healthy.1", "false_alarms_x0p5.3", "detection_delay_x2.2",
                   "isolated.2", "fault_onset.2"):
        assert column in first
    assert [r["run"] for r in table] == sorted(r["run"] for r in table)
    healthy = [r for r in table if r["case"] == "healthy"]
    assert all(math.isnan(r["fault_onset.2"]) for r in healthy)
    assert all(r["fault_onset.2"] == 0.3 for r in table if r["case"] == "joint2")
    summary = json.loads((reference_dir / "campaign.json").read_text())
    assert summary["runs"] == 8 and summary["status_counts"] == {"ok": 16}
    assert summary["control_steps"] == 8 * 2 * 600 and summary["physics_substeps"] == 2


def test_the_scenario_threshold_columns_equal_the_diagnosis_metrics(reference_dir):
    for row in rows(reference_dir):
        for j in (1, 2, 3):
            a, b = row[f"detection_delay_x1.{j}"], row[f"detection_delay.{j}"]
            assert (math.isnan(a) and math.isnan(b)) or a == b
            assert row[f"false_alarms_x1.{j}"] == row[f"false_alarms.{j}"]
        # A larger threshold raises no more alarms and detects no sooner.
        assert row["false_alarms_x2.2"] <= row["false_alarms_x1.2"] <= row["false_alarms_x0p5.2"]
        if not math.isnan(row["detection_delay_x2.2"]):
            assert row["detection_delay_x2.2"] >= row["detection_delay_x1.2"] >= row["detection_delay_x0p5.2"]
        # The held residual peak decides detection at every multiple.
        if row["case"] == "joint2":
            for c, tag in ((0.5, "x0p5"), (1.0, "x1"), (2.0, "x2")):
                assert (row["residual_peak_fault.2"] > c) == (not math.isnan(row[f"detection_delay_{tag}.2"]))


def test_results_do_not_depend_on_batch_size_or_workers(campaign_file, reference_dir, tmp_path):
    out = tmp_path / "pool"
    execute.execute(execute.load(campaign_file), out, batch_size=3, workers=2)
    same_rows(rows(reference_dir), rows(out))


def test_an_interrupted_campaign_resumes_to_the_same_table(campaign_file, reference_dir, tmp_path):
    out = tmp_path / "resumed"
    shutil.copytree(reference_dir, out)
    parts = sorted((out / "parts").glob("*.parquet"))
    for part in parts[::2]:  # as if killed before these batches finished
        part.unlink()
    (out / "runs.parquet").unlink()
    (out / "parts" / ".half.parquet.123.tmp").write_bytes(b"half")  # a temporary left by a killed writer
    campaign = execute.load(campaign_file)
    done = execute.prepare_directory(campaign, out)
    assert len(done) == len(campaign.runs) - len(parts[::2])
    summary = execute.execute(campaign, out, batch_size=2, workers=1)
    assert summary["simulated_runs"] == len(parts[::2])
    same_rows(rows(reference_dir), rows(out))


def test_more_runs_keep_the_first_ones(campaign_file, reference_dir):
    fewer = execute.load(campaign_file, runs=2)
    more = execute.load(campaign_file, runs=9)
    everything = execute.load(campaign_file)
    assert [r.run_id for r in fewer.runs] == [r.run_id for r in everything.runs[:4]]
    assert [r.run_id for r in more.runs[:8]] == [r.run_id for r in everything.runs]


def test_a_changed_campaign_is_refused(campaign_file, reference_dir, tmp_path):
    changed = small_campaign.write(tmp_path / "changed", campaign_changes={"replicates": 2})
    with pytest.raises(InputError, match="holds the results of another campaign"):
        execute.prepare_directory(execute.load(changed), reference_dir)


def test_a_replayed_run_equals_its_row(reference_dir, tmp_path, capsys):
    table = rows(reference_dir)
    row = next(r for r in table if r["case"] == "joint2" and r["variant"] == "hs")
    document = tmp_path / "replay.json"
    code = run.main(execute.replay_arguments(reference_dir, row["run_id"], out=tmp_path / "replay.rrd",
                                             json_path=document))
    assert code == 0 and (tmp_path / "replay.rrd").is_file()
    replayed = json.loads(document.read_text())["variants"]
    for r in (r for r in table if r["run_id"] == row["run_id"]):
        for metric, values in replayed[r["variant"]]["metrics"].items():
            for j, value in enumerate(values, start=1):
                stored = r[f"{metric}.{j}"]
                if value is None:
                    assert math.isnan(stored)
                else:
                    assert stored == pytest.approx(value, rel=1e-9, abs=0)


def test_a_dask_cluster_gives_the_same_results(campaign_file, reference_dir, tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        out = tmp_path / "dask"
        summary = execute.execute(execute.load(campaign_file), out, batch_size=4, scheduler=cluster.scheduler_address)
    assert summary["scheduler"] == cluster.scheduler_address
    same_rows(rows(reference_dir), rows(out))
