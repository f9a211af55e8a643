"""Suite v2's sanity gate on every robot, on a reduced protocol with the same statistics: suite v2's robots,
loops, encoders, model mismatch and diagnosis, shortened (tests/ranking/reduced_v2.py: 2.3 s runs, 0.4 s
windows, 16 calibration and 16 healthy runs, a bias of 10 residual units and a float on each fault joint, 3
draws; about 40 s of CPU). The three sanity rows and one entry, a noise observer written as a third-party
plugin, are scored by ``ftc-mj bench``.

It fails the suite unless, on every robot: oracle_fault's AUC >= 0.99 and its P_d at the common false-alarm
probability >= 0.95 on the faults that act; null's AUC is at chance (1/2 in its bootstrap interval, or the AUC
within the 95% range the Mann-Whitney statistic has under no difference); no entry's AUC interval lies above
oracle_luaf's; the third-party noise observer's AUC is at chance alike; and the paired comparison of a tuned row
with its design row calls oracle_fault apart above null and a "tuned" noise row that kept its gains not apart
from its design row (a difference of exactly 0).

What it does not cover: the quick tier's small biases (0.3 and 1 residual unit), on which the observers'
point AUCs exceed oracle_luaf's on three robots, inside its interval (docs/results/baselines.md says why: the
residual is taken about the healthy LUaF's baseline mean, not its trajectory). This reduced protocol, with
faults of 10 units and floats only, checks the pipeline, not that."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pyarrow.parquet as pq
import pytest
import yaml

from ftc_mj.cli.bench import main
from ftc_mj.methods import observers, registry
from ftc_mj.ranking.calibrated import consistent_with_chance
from reduced_v2 import reduced_suite

pytestmark = pytest.mark.slow  # a closed-loop experiment: the full suite's, not the fast tier's
ROBOTS = ("two_link", "puma560", "ur5e", "panda")


#: The useless observer as a third party ships one (examples/ftc_mj_white_noise), registered here as its entry
#: point would register it when installed.
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "examples" / "ftc_mj_white_noise"))
from ftc_mj_white_noise.observer import WhiteNoiseObserver as NoiseObserver  # noqa: E402


@pytest.fixture(scope="module")
def board(tmp_path_factory):
    with pytest.MonkeyPatch.context() as patch:
        registry._discover.cache_clear()
        patch.setitem(observers.BUILTIN, NoiseObserver.name, NoiseObserver)
        folder = tmp_path_factory.mktemp("sanity")
        (folder / "suite.yaml").write_text(yaml.safe_dump(reduced_suite(), sort_keys=False))
        noise = {"type": NoiseObserver.name, "reads": ["encoders"], "gains_from": "none: white noise",
                 "gains": {robot: {} for robot in ROBOTS}}
        # A "tuned" row that kept its design gains: the same monitor twice, for the paired comparison's pipeline.
        bench = {"suite": "suite.yaml", "diagnosis": {"noise": noise, "noise_tuned": noise}}
        (folder / "bench.yaml").write_text(yaml.safe_dump(bench, sort_keys=False))
        out = folder / "out"
        assert main([str(folder / "bench.yaml"), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    registry._discover.cache_clear()
    rows = pq.read_table(out / "leaderboard.parquet").to_pylist()
    return {(row["robot"], row["entry"], row["score"]): row for row in rows}, json.loads((out / "bench.json")
                                                                                       .read_text()), out


@pytest.mark.parametrize("robot", ROBOTS)
def test_the_sanity_gate_holds(board, robot):
    _, info, _ = board
    gate = info["gate"][robot]
    assert gate["passed"], gate["conditions"]


@pytest.mark.parametrize("robot", ROBOTS)
def test_a_third_party_noise_observer_scores_one_half(board, robot):
    rows, _, _ = board
    auc = rows[robot, "noise", "auc"]
    healthy, faulty = rows[robot, "noise", "false_alarm"]["n"], rows[robot, "noise", "pd"]["n"]
    # One claim over the four robots, at a family-wise 5%: each robot's AUC within chance's 1 - 0.05/4 range
    # (the 95% range alone fails one robot of four in 19% of draws of a perfectly useless observer).
    family = 1.0 - 0.05 / len(ROBOTS)
    assert auc["low"] <= 0.5 <= auc["high"] or consistent_with_chance(auc["value"], healthy, faulty, family), auc
    assert rows[robot, "oracle_fault", "auc"]["value"] >= 0.99


def test_the_leaderboard_shows_the_gate_and_what_each_entry_reads(board):
    _, _, out = board
    text = (out / "leaderboard.md").read_text()
    assert text.count("**Sanity gate passed:**") == len(ROBOTS)
    assert "| `noise` | encoders | 1000 |" in text and "| `oracle_luaf` (sanity) | truth |" in text
    assert "specificity" in text and "1 - false-alarm rate" not in text
    for name in ("roc", "detectability", "front"):
        assert (out / "figures" / f"{name}.png").is_file()


def test_the_false_alarms_are_said_against_chance(board):
    """Per robot and over every robot: the off rows beside the count chance predicts, Holm finding no row whose
    count the calibrated thresholds' law refuses, the pooled rate within three of a threshold's own standard
    deviations (0.055, its rows sharing their calibration runs) of the rate a threshold from 16 peaks gives on
    average (1/17 at 0.05: the higher quantile of 16 is their largest)."""
    _, info, out = board
    text = (out / "leaderboard.md").read_text()
    assert text.count("rows (sanity rows included) are \"(off)\"") == len(ROBOTS) + 1
    every = info["false_alarms"]["every robot"]
    assert every["rows"] == len(ROBOTS) * 5 and every["holm_rejected"] == []
    assert every["expected_rate"] == [pytest.approx(1 / 17)]
    assert abs(every["pooled"]["value"] - 1 / 17) < 3 * every["threshold_spread"][0], every
    assert every["expected_off_calibrated"] > every["expected_off_exact"]


@pytest.mark.parametrize("robot", ROBOTS)
def test_the_paired_comparison_scores_a_perfect_and_a_useless_entry_as_such(board, robot):
    """Through the bench: oracle_fault against null apart above on both scores at the family's strictest level
    (the check the leaderboard prints), and a tuned row that is its design row differing by exactly 0, not
    apart."""
    _, info, out = board
    pairs = info["tuned_pairs"][robot]
    check = pairs["check"]
    assert check["passed"] and check["auc"]["difference"] > 0.4 and check["pd"]["difference"] > 0.8, check
    (row,) = pairs["pairs"]
    assert (row["tuned"], row["design"], row["verdict"]) == ("noise_tuned", "noise", "not apart")
    for score in ("auc", "pd"):
        assert (row[score]["difference"], row[score]["low"], row[score]["high"], row[score]["p_holm"]) == \
            (0.0, 0.0, 0.0, 1.0)
    assert "The paired test's own check: `oracle_fault` (perfect) against `null`" in (out / "leaderboard.md") \
        .read_text()


def test_the_paired_rows_tool_checks_its_pipeline_and_scores_a_row_against_itself_as_zero(board, capsys):
    """``tools/paired_rows.py`` (the between-method comparisons of baselines.md) on the same stored runs: its own
    check (oracle_fault against null) passes on every robot, a row against the same monitor differs by exactly 0
    and the useless rows are never called apart (no ``*``)."""
    import importlib.util

    _, _, out = board
    spec = importlib.util.spec_from_file_location("paired_rows", Path(__file__).resolve().parents[2] / "tools"
                                                  / "paired_rows.py")
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    with pytest.MonkeyPatch.context() as patch:
        registry._discover.cache_clear()
        patch.setitem(observers.BUILTIN, NoiseObserver.name, NoiseObserver)
        tool.main([str(out.parent / "bench.yaml"), str(out), "noise", "noise_tuned", "null", "--tier", "quick"])
    registry._discover.cache_clear()
    printed = capsys.readouterr().out.splitlines()
    checks = [line for line in printed if line.split(" ")[0] in ROBOTS and "passed" in line]
    assert len(checks) == len(ROBOTS), printed
    rows = {tuple(line.split()[:2]): line for line in printed if line.split(" ")[0] in ROBOTS and "p " in line}
    for robot in ROBOTS:
        assert "auc +0.0000 [+0.0000, +0.0000] p 1 | pd +0.0000 [+0.0000, +0.0000] p 1" in rows[robot, "noise_tuned"]
        assert "*" not in rows[robot, "null"]
