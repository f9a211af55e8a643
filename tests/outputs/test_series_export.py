"""``ftc-mj run ... --export FILE.mat|.parquet|.csv`` (ftc_mj.outputs.series_export): every series of every
variant and monitor, at the run's float64, read back by ``scipy.io.loadmat``, pyarrow and a CSV reader to the same bits,
with units; a name that is no MATLAB identifier made one; an unknown extension refused in one line."""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
import yaml
from scipy.io import loadmat

from ftc_mj.cli.run import main
from ftc_mj.engine.runner import run_scenario
from ftc_mj.outputs.series_export import SERIES, _identifier
from ftc_mj.scenario.loading import load_scenario

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "campaign"))
import small_campaign  # noqa: E402


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """A short run of two variants (one with a monitor, one named as MATLAB cannot) exported in the three forms,
    and the same run's results in memory."""
    folder = tmp_path_factory.mktemp("export")
    data = small_campaign.scenario()
    data["duration"] = 0.35
    data["variants"]["hs-2"] = data["variants"].pop("hs")
    data["variants"]["tosmo"]["monitors"] = {"eso": {"type": "eso", "gains": {"bandwidth": 20.0}}}
    (folder / "s.yaml").write_text(yaml.safe_dump(data))
    for form in ("mat", "parquet", "csv"):
        assert main([str(folder / "s.yaml"), "--quiet", "--no-record", "--export", str(folder / f"run.{form}")]) == 0
    results = run_scenario(load_scenario(folder / "s.yaml"))
    return folder, results


def _every(results):
    return list({one.name: one for result in results for one in (result, *result.monitors)}.values())


def test_loadmat_reads_every_series_of_every_variant_at_float64(exported):
    folder, results = exported
    mat = loadmat(folder / "run.mat", simplify_cells=True)
    assert sorted(mat["variant_names"]) == ["hs-2", "tosmo", "tosmo.eso"]
    assert list(mat["variant_names"]) == [one.name for one in _every(results)]
    assert list(mat["joints"]) == ["joint1", "joint2", "joint3"]
    np.testing.assert_array_equal(mat["t"], results[0].t)
    fields = {"tosmo": "tosmo", "tosmo.eso": "tosmo_eso", "hs-2": "hs_2"}
    for one in _every(results):
        variant = mat["variants"][fields[one.name]]
        for name, (attribute, _) in SERIES.items():
            values = getattr(one, attribute)
            if values is None:
                assert name not in variant
                continue
            assert variant[name].dtype == np.float64
            np.testing.assert_array_equal(variant[name], np.asarray(values, dtype=float))  # the same bits
        for name in ("residual", "threshold", "alarm", "fault_estimate"):
            np.testing.assert_array_equal(variant[f"diagnosis_{name}"], getattr(one.diagnosis, name))
        for name, values in one.extras.items():
            np.testing.assert_array_equal(variant[f"extras_{name}"], values)
        assert variant["status"] == one.status and np.isnan(variant["diverged_at"])
    # The monitor has its own estimates on its host's trajectory.
    monitor, host = mat["variants"]["tosmo_eso"], mat["variants"]["tosmo"]
    np.testing.assert_array_equal(monitor["q_true"], host["q_true"])
    assert not np.array_equal(monitor["luaf_hat"], host["luaf_hat"])
    assert mat["units"]["q_true"] == "rad" and mat["units"]["tau"] == "N m" and mat["units"]["luaf_hat"] == "rad/s^2"
    assert mat["units"]["diagnosis_residual"] == "N m"  # the diagnosis' torque space


def test_parquet_and_csv_hold_the_same_doubles_with_units(exported):
    folder, results = exported
    table = pq.read_table(folder / "run.parquet")
    assert table.schema.field("q_true.joint2").metadata[b"unit"] == b"rad"
    rows = {name: np.asarray(table.column("variant").to_pylist()) == name for name in ("tosmo", "tosmo.eso", "hs-2")}
    with open(folder / "run.csv", newline="") as handle:
        reader = csv.reader(handle)
        header = next(reader)
        body = list(reader)
    assert header[:3] == ["variant", "t [s]", "q_ref.joint1 [rad]"]
    for one in _every(results):
        mask = rows[one.name]
        for j in range(3):
            np.testing.assert_array_equal(table.column(f"luaf_hat.joint{j + 1}").to_numpy()[mask], one.luaf_hat[:, j])
        column = header.index("tau.joint3 [N m]")
        from_csv = np.array([float(row[column]) for row in body if row[0] == one.name])
        np.testing.assert_array_equal(from_csv, one.tau[:, 2])  # 17 digits: the same doubles


def test_names_made_matlab_identifiers_stay_unique():
    taken: set[str] = set()
    assert [_identifier(n, taken) for n in ("a.b", "a_b", "2x", "a" * 70, "a" * 70)] == [
        "a_b", "a_b_2", "v_2x", "a" * 63, "a" * 61 + "_2"]


def test_an_unknown_extension_is_one_line_and_nothing_is_run(tmp_path, capsys):
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(small_campaign.scenario()))
    assert main([str(tmp_path / "s.yaml"), "--quiet", "--no-record", "--export", str(tmp_path / "run.xlsx")]) == 2
    assert capsys.readouterr().err == (f"error: {tmp_path / 's.yaml'}: --export: '{tmp_path / 'run.xlsx'}': the "
                                       "extension must be one of .mat, .parquet, .csv\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.yaml"]
