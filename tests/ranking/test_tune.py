"""Tuning a bench's diagnosis entries on the suite's tune population (ftc_mj/ranking/tune.py, ``ftc-mj tune`` on
a bench tuning file): the runs it picks, its record's seeds refused by a bench when they are scored ones, the
leaderboard's better-only-when-apart rule at its boundary, bad input as one line, and (slow) that it mends a
deliberately bad gain on a reduced protocol."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from ftc_mj.cli.bench import main as bench_main
from ftc_mj.cli.tune import main as tune_main
from ftc_mj.config.errors import InputError
from ftc_mj.ranking import calibrated as cal
from ftc_mj.ranking.entries import TUNING_RECORD, load_bench
from ftc_mj.ranking.score import Score
from ftc_mj.ranking.tune import chosen_runs
from ftc_mj.ranking.windowed import RobotBoard, compare_tuned, tuned_pairs
from reduced_v2 import reduced_suite
from test_paired_differences import _pair


def _score(low: float, high: float) -> Score:
    return Score((low + high) / 2, low, high, 10)


@pytest.mark.parametrize("tuned, design, verdict", [
    ((0.80, 0.90), (0.70, 0.80), "not apart"),      # touching: not apart
    ((0.8001, 0.90), (0.70, 0.80), "better"),       # just above
    ((0.60, 0.70), (0.70, 0.80), "not apart"),
    ((0.60, 0.6999), (0.70, 0.80), "worse"),
    ((0.60, 0.95), (0.70, 0.80), "not apart"),      # one interval inside the other
    ((np.nan, np.nan), (0.70, 0.80), "not apart"),
])
def test_a_tuned_row_is_better_only_when_its_interval_is_apart(tuned, design, verdict):
    assert cal.apart(_score(*tuned), _score(*design)) == verdict


def test_the_verdict_of_both_scores():
    assert cal.tuned_verdict(["better", "not apart"]) == "better"
    assert cal.tuned_verdict(["not apart", "not apart"]) == "not apart"
    assert cal.tuned_verdict(["better", "worse"]) == "mixed"
    assert cal.tuned_verdict(["worse", "not apart"]) == "worse"


def test_the_leaderboard_pairs_each_tuned_row_with_its_design_row():
    """Each ``<name>_tuned`` row beside its ``<name>`` row, compared paired (tests/ranking/test_windowed.py has
    the verdicts); a row without its design row, or a design row alone, makes no pair."""
    rng = np.random.default_rng(8)
    useless, better = _pair(rng, faulty_gain=3.0)
    perfect, _ = _pair(rng, faulty_gain=0.0)
    perfect.fault_z[:] = 100.0
    windows = {"oracle_fault": perfect, "null": useless, "momentum": useless, "momentum_tuned": better,
               "ndob": useless, "ndob_tuned": useless, "kalman": useless, "eso_tuned": better}
    board = RobotBoard("arm", [], windows=windows, scores={name: cal.scores(w, 100) for name, w in windows.items()})
    board.scores.pop("eso_tuned")
    board.windows.pop("eso_tuned")
    compare_tuned({"arm": board}, resamples=200)
    lines = tuned_pairs(board)
    rows = {line.split(" | ")[0].strip("| `"): line for line in lines if line.startswith("| `")}
    assert set(rows) == {"momentum_tuned", "ndob_tuned"}
    assert "| **better** |" in rows["momentum_tuned"] and "| **not apart** |" in rows["ndob_tuned"]
    alone = RobotBoard("arm", [], windows={"kalman": useless}, scores={"kalman": board.scores["kalman"]})
    compare_tuned({"arm": alone})
    assert alone.pairs == [] and tuned_pairs(alone) == []


def test_each_draw_is_run_healthy_and_under_one_fault_case():
    cases = 3
    runs = list(range(5 * (cases + 1)))  # draw s, case c (0: healthy) at s (C + 1) + c
    assert chosen_runs(runs, 5, cases) == [0, 1, 4, 6, 8, 11, 12, 13, 16, 18]


def _write(folder, record: dict | None, tuned_with: str = "tuned.yaml") -> str:
    suite = reduced_suite()
    (folder / "suite.yaml").write_text(yaml.safe_dump(suite, sort_keys=False))
    if record is not None:
        (folder / "tuned.yaml").write_text(yaml.safe_dump(record, sort_keys=False))
    bench = {"suite": "suite.yaml", "diagnosis": {"momentum_tuned": {
        "type": "momentum", "gains_from": "tuned", "tuned_with": tuned_with,
        "gains": {robot: {"K": 100.0} for robot in suite["robots"]}}}}
    (folder / "bench.yaml").write_text(yaml.safe_dump(bench, sort_keys=False))
    return str(folder / "bench.yaml")


def _refused(capsys, bench: str, out) -> str:
    assert bench_main([bench, "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err and not out.exists()
    return err


def test_a_tuning_record_with_scoring_seeds_is_refused(tmp_path, capsys):
    tune_seed = reduced_suite()["populations"]["tune"]["seed"]
    scored = reduced_suite()["populations"]["calibrate"]["seed"]
    record = {"kind": TUNING_RECORD, "population": "tune", "seeds": [tune_seed, scored + 3]}
    err = _refused(capsys, _write(tmp_path, record), tmp_path / "out")
    assert "bench.yaml: diagnosis.momentum_tuned.tuned_with: " in err and f"seed {scored + 3}" in err \
        and "calibrate seeds" in err
    record["seeds"] = [tune_seed, tune_seed + 1]
    assert load_bench(_write(tmp_path, record)).of("diagnosis")[0].name == "momentum_tuned"
    del record["seeds"]
    err = _refused(capsys, _write(tmp_path, record), tmp_path / "out")
    assert "diagnosis.momentum_tuned.tuned_with: " in err and "lists no seeds" in err


def test_tuned_with_may_list_several_tunings_each_checked(tmp_path):
    suite = reduced_suite()
    (tmp_path / "a.yaml").write_text(yaml.safe_dump({"kind": TUNING_RECORD, "seeds": [suite["populations"]["tune"]
                                                                                     ["seed"]]}))
    (tmp_path / "b.yaml").write_text(yaml.safe_dump({"kind": TUNING_RECORD, "seeds": [suite["populations"]["faults"]
                                                                                     ["seed"]]}))
    path = _write(tmp_path, None)
    bench = yaml.safe_load(open(path))
    bench["diagnosis"]["momentum_tuned"]["tuned_with"] = ["a.yaml", "b.yaml"]
    (tmp_path / "bench.yaml").write_text(yaml.safe_dump(bench))
    with pytest.raises(InputError) as refused:
        load_bench(path)
    assert refused.value.field == "diagnosis.momentum_tuned.tuned_with.1" and "faults seeds" in refused.value.problem


def _tuning(folder, bad_k: float = 100.0, **optimizer) -> str:
    suite = reduced_suite()
    suite["robots"] = {"two_link": suite["robots"]["two_link"]}
    suite["tiers"]["quick"]["tune_runs"] = 4
    suite["faults"]["bias"] = [1.0, 10.0]
    (folder / "suite.yaml").write_text(yaml.safe_dump(suite, sort_keys=False))
    bench = {"suite": "suite.yaml", "diagnosis": {"momentum": {"gains_from": "design rule",
                                                               "gains": {"two_link": {"K": bad_k}}}}}
    (folder / "bench.yaml").write_text(yaml.safe_dump(bench, sort_keys=False))
    tuning = {"name": "t", "bench": "bench.yaml", "entries": {"momentum": {"gains": {"K": {"factor": 100.0}}}},
              "optimizer": {"population": 4, "generations": 3, "sigma": 0.3, "seed": 0, **optimizer}}
    (folder / "tuning.yaml").write_text(yaml.safe_dump(tuning, sort_keys=False))
    return str(folder / "tuning.yaml")


@pytest.mark.parametrize("argv, field", [
    (["--conditions", "3"], "--conditions"),
    (["--set", "duration=1"], "--set"),
    (["--population", "1"], "--population"),
])
def test_bad_input_to_a_bench_tuning_is_one_line(tmp_path, capsys, argv, field):
    tuning = _tuning(tmp_path)
    out = tmp_path / "out"
    assert tune_main([tuning, "--out", str(out), "--quiet", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err and f": {field}: " in err and not out.exists()


def test_a_bench_tuning_of_an_unknown_entry_is_refused(tmp_path, capsys):
    tuning = _tuning(tmp_path)
    raw = yaml.safe_load(open(tuning))
    raw["entries"]["kalman"] = raw["entries"].pop("momentum")
    (tmp_path / "tuning.yaml").write_text(yaml.safe_dump(raw))
    assert tune_main([tuning, "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: {tuning}: entries.kalman: not a diagnosis entry") and "\n" not in err


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")  # the bad gain's residual
def test_the_tuner_mends_a_deliberately_bad_gain(tmp_path):
    """The momentum observer with K = 2500 1/s: K dt = 2.5, its discrete residual diverges and detects nothing
    (P_d 0 on the tune population). Three generations of four candidates, on 4 draws of a reduced protocol with
    biases of 1 and 10 residual units and a float, must find a K that detects, below the bad one; the record
    lists only the tune population's seeds, which a bench accepts."""
    tuning = _tuning(tmp_path, bad_k=2500.0)
    out = tmp_path / "out"
    assert tune_main([tuning, "--out", str(out), "--workers", "1", "--quiet"]) == 0
    record = yaml.safe_load((out / "tuned.yaml").read_text())
    objective = record["entries"]["momentum"]["objective"]["two_link"]
    assert objective["design"]["pd"] < 0.2
    assert objective["tuned"]["pd"] >= objective["design"]["pd"] + 0.5
    assert record["entries"]["momentum"]["tuned"]["two_link"]["K"] < 2000.0
    suite = reduced_suite()
    first = suite["populations"]["tune"]["seed"]
    assert record["seeds"] == list(range(first, first + 4)) and record["population"] == "tune"
    assert record["budget"]["candidates"] == 4 and record["budget"]["generations"] == 3 and record["budget"]["runs"] == 8


@pytest.mark.parametrize("record_name", ["v2-tuned.yaml", "v2-tuned-others.yaml"])
def test_the_shipped_tuned_rows_carry_their_records_gains(record_name):
    """v2-entries.yaml's ``*_tuned`` rows are the gains their record (v2-tuned.yaml, v2-tuned-others.yaml) holds,
    tuned on the tune seeds only, with the same budget."""
    from ftc_mj.ranking.entries import DEFAULT_ENTRIES
    from ftc_mj.ranking.suite import seed_ranges

    bench = load_bench()
    record = yaml.safe_load((DEFAULT_ENTRIES.parent / record_name).read_text())
    first = yaml.safe_load((DEFAULT_ENTRIES.parent / "v2-tuned.yaml").read_text())
    entries = {e.name: e for e in bench.of("diagnosis")}
    raw = yaml.safe_load(DEFAULT_ENTRIES.read_text())["diagnosis"]
    for name, tuned in record["entries"].items():
        assert raw[f"{name}_tuned"]["tuned_with"] == record_name
        assert raw[f"{name}_tuned"]["gains_from"].startswith("tuned: ")
        for robot in bench.suite.spec.robots:
            assert entries[f"{name}_tuned"].sections[robot] == {"type": tuned["type"], "gains": tuned["tuned"][robot]}
            assert entries[name].sections[robot]["gains"] == tuned["design"][robot]
    assert set(record["seeds"]) <= set(seed_ranges(bench.suite.spec)["tune"])
    assert (record["budget"], record["seeds"], record["tier"]) == (first["budget"], first["seeds"], first["tier"])


def test_every_shipped_observer_has_a_tuned_row():
    """One tuning effort for all: each built-in diagnosis entry (but the tuned rows) has its ``<name>_tuned`` row."""
    names = {e.name for e in load_bench().of("diagnosis")}
    design = {name for name in names if not name.endswith("_tuned")}
    assert {f"{name}_tuned" for name in design} <= names and len(design) == 11


@pytest.mark.parametrize("tuned, design, verdict", [
    ((0.10, 0.20), (0.20, 0.30), "not apart"),      # touching
    ((0.10, 0.1999), (0.20, 0.30), "better"),       # lower is better: wholly below
    ((0.3001, 0.40), (0.20, 0.30), "worse"),
])
def test_where_lower_is_better_a_tuned_row_is_better_only_wholly_below(tuned, design, verdict):
    assert cal.apart(_score(*tuned), _score(*design), higher_is_better=False) == verdict
