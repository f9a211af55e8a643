"""The bench file's bad inputs: each is one line ``FILE: FIELD: PROBLEM``, exit status 2, and nothing is
written."""

from __future__ import annotations

import copy

import pytest

from ftc_mj.ranking.entries import load_bench
from ftc_mj.cli.bench import main
import tiny_suite

#: campaigns, calibrations, tunings and benchmarks of closed-loop runs
pytestmark = pytest.mark.slow


def _with(change) -> dict:
    bench = copy.deepcopy(tiny_suite.entries())
    change(bench)
    return bench


BAD = {
    "unknown field": (lambda b: b.update(colour="red"), "colour"),
    "unknown entry field": (lambda b: b["diagnosis"]["tosmo"].update(colour="red"), "diagnosis.tosmo.colour"),
    "unknown observer": (lambda b: b["diagnosis"].update(nonexistent={"gains_from": "x", "gains": {"puma560": {}}}),
                         "diagnosis.nonexistent.type: unknown observer 'nonexistent'"),
    "unknown controller": (lambda b: b["tracking"]["proposed"].update(controller="nonexistent"),
                           "tracking.proposed.controller: unknown controller 'nonexistent'"),
    "no gains for a robot": (lambda b: b["diagnosis"]["tosmo"].update(gains={}),
                             "diagnosis.tosmo.gains: no gains for robot 'puma560'"),
    "gains for another robot": (lambda b: b["diagnosis"]["tosmo"]["gains"].update(ur5e={"D": 1.0}),
                                "diagnosis.tosmo.gains.ur5e: not a robot of the suite"),
    "gains the method refuses": (lambda b: b["diagnosis"]["tosmo"]["gains"].update(puma560={"D": -1.0}),
                                 "diagnosis.tosmo.gains.puma560.D"),
    "a pair without gains for a robot": (lambda b: b["tracking"]["proposed"].update(gains={}),
                                         "tracking.proposed.gains: no gains for robot 'puma560'"),
    "no gains source": (lambda b: b["diagnosis"]["tosmo"].pop("gains_from"), "diagnosis.tosmo.gains_from"),
    "unknown suite": (lambda b: b.update(suite="v9"), "suite: no suite 'v9'"),
    "no entries": (lambda b: (b.pop("diagnosis"), b.pop("tracking")), "no entries"),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_bench_file_is_one_line_exit_2_nothing_written(tmp_path, capsys, case):
    change, expected = BAD[case]
    path = tiny_suite.write(tmp_path, _with(change))
    out = tmp_path / "out"
    assert main([str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"error: {path}") and expected in err, err
    assert not out.exists()


def test_a_tier_the_suite_lacks_is_refused(tmp_path, capsys):
    path = tiny_suite.write(tmp_path)
    assert main([str(path), "--tier", "full", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "tiers: the suite has no tier 'full'" in err
    assert not (tmp_path / "out").exists()


def test_an_output_directory_of_something_else_is_refused(tmp_path, capsys):
    path = tiny_suite.write(tmp_path)
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    assert main([str(path), "--out", str(other)]) == 2
    assert "holds no bench's results" in capsys.readouterr().err
    assert sorted(p.name for p in other.iterdir()) == ["notes.txt"]


def test_the_shipped_entries_cover_every_robot_of_suite_v2():
    bench = load_bench()
    assert bench.suite.version == "v2"
    assert set(bench.suite.spec.robots) == {"two_link", "puma560", "ur5e", "panda"}
    names = {e.name for e in bench.of("diagnosis")}
    assert {"tosmo", "hs_tosmo", "sosmo", "eso", "do", "levant", "ndob", "ndob_levant", "kalman"} <= names
    assert all(set(e.sections) == set(bench.suite.spec.robots) for e in bench.entries)
    assert all(e.gains_from for e in bench.entries)
    # Where the gains come from, led by its kind, so that a reader sees which baselines were given a rule.
    kinds = ("dissertation", "design rule", "tuned", "assumption")
    assert all(e.gains_from.startswith(kinds) for e in bench.entries), [e.name for e in bench.entries]
    baselines = {"levant", "ndob", "ndob_levant", "kalman", "momentum", "momentum_levant", "ctc_hs_tosmo",
                 "super_twisting_hs_tosmo", "pid"}
    assert all(not e.gains_from.startswith("dissertation") for e in bench.entries if e.name in baselines)


def test_an_entrys_identity_is_its_method_and_gains_not_its_name():
    bench = load_bench(None)
    entry = bench.of("diagnosis")[0]
    renamed = type(entry)(entry.task, "another_name", entry.label, "elsewhere", entry.sections)
    assert renamed.identity("puma560") == entry.identity("puma560")
    assert entry.identity("puma560") != entry.identity("ur5e")
