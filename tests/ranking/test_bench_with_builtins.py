"""``ftc-mj bench FILE --with-builtins``: the file's entries beside every built-in entry of its suite, on the tasks
the file scores; a name the file shares with a built-in entry refused (one line, exit 2, nothing written); the
built-in runs already in the output directory reused (only the file's new entries planned)."""

from __future__ import annotations

import pytest
import yaml

import tiny_suite
from ftc_mj.cli.bench import main
from ftc_mj.ranking import execute
from ftc_mj.ranking.entries import DEFAULT_ENTRIES, load_bench

BUILTIN = yaml.safe_load(DEFAULT_ENTRIES.read_text())


def _mine(bandwidth: float = 40.0, name: str = "mine") -> dict:
    return {"suite": "suite.yaml", "diagnosis": {name: {
        "type": "eso", "gains_from": "assumption", "gains": {"puma560": {"bandwidth": bandwidth}}}}}


def test_the_files_entries_come_with_every_builtin_entry_of_its_tasks_on_its_robots(tmp_path):
    bench = load_bench(tiny_suite.write(tmp_path, _mine()), with_builtins=True)
    assert [e.name for e in bench.of("diagnosis")] == ["mine", *BUILTIN["diagnosis"]]
    assert bench.of("tracking") == []  # the file scores diagnosis only
    builtin = {e.name: e for e in load_bench().entries}
    for entry in bench.of("diagnosis")[1:]:  # the same runs as the built-in bench's on the robot: the same identity
        assert list(entry.sections) == ["puma560"]
        assert entry.identity("puma560") == builtin[entry.name].identity("puma560")
    assert [e.name for e in load_bench(tiny_suite.write(tmp_path, _mine()), with_builtins=False).entries] == ["mine"]


def test_a_name_of_a_builtin_entry_is_one_line_exit_2_nothing_written(tmp_path, capsys):
    path = tiny_suite.write(tmp_path, _mine(name="momentum"))
    out = tmp_path / "out"
    assert main([str(path), "--with-builtins", "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err and not out.exists()
    assert f"{path}: diagnosis.momentum: is also a built-in entry's name" in err
    assert main(["--with-builtins", "--out", str(out), "--quiet"]) == 2
    assert "--with-builtins: needs a bench file" in capsys.readouterr().err


@pytest.mark.slow
def test_the_builtin_runs_in_the_directory_are_reused(tmp_path):
    """After one bench with the built-ins, a file with one more entry plans that entry alone."""
    out = tmp_path / "out"
    first = load_bench(tiny_suite.write(tmp_path, _mine()), with_builtins=True)
    execute.run(first, "quick", out, workers=1)
    more = _mine()
    more["diagnosis"]["mine_fast"] = {**more["diagnosis"]["mine"], "gains": {"puma560": {"bandwidth": 80.0}}}
    second = load_bench(tiny_suite.write(tmp_path, more, "more.yaml"), with_builtins=True)
    done, chunks = execute.plan(second, "quick", out)
    assert {entry.name for chunk in chunks for entry in chunk.entries} == {"mine_fast"}
    assert {name for (task, _, _, name) in done} >= set(BUILTIN["diagnosis"]) | {"mine"}


def test_a_tracking_file_gets_the_builtin_pairs_their_tunings_found_from_the_builtin_file(tmp_path):
    """The built-in pairs come with a tracking entry, the tuned ones' tuning files (relative to the built-in
    file) found and checked against the file's suite."""
    mine = tiny_suite.entries()
    del mine["diagnosis"]
    mine["tracking"] = {"mine": mine["tracking"].pop("proposed")}
    bench = load_bench(tiny_suite.write(tmp_path, mine), with_builtins=True)
    assert [e.name for e in bench.of("tracking")] == ["mine", *BUILTIN["tracking"]] and bench.of("diagnosis") == []
