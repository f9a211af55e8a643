"""Resuming a bench from results that cannot be read (ftc_mj.ranking.execute.find_done): a damaged
``entries.json`` or a finished campaign's damaged ``runs.parquet`` is one line naming the file and the folder
to remove, before anything is simulated."""

from __future__ import annotations

import json

import pytest

from ftc_mj.config.errors import InputError
from ftc_mj.ranking.execute import find_done


def _campaign(out, manifest: str | bytes, table: bytes = b"PAR1 not a table") -> None:
    folder = out / "runs" / "diagnosis" / "arm" / "healthy" / "abc"
    (folder / "results").mkdir(parents=True)
    (folder / "entries.json").write_bytes(manifest if isinstance(manifest, bytes) else manifest.encode())
    (folder / "results" / "campaign.json").write_text("{}")
    (folder / "results" / "runs.parquet").write_bytes(table)


@pytest.mark.parametrize("manifest", ['{"protocol": "p", "entr', b"\xff\xfe", "[]", '{"protocol": "p"}'])
def test_a_damaged_entries_file_is_one_line(tmp_path, manifest):
    _campaign(tmp_path, manifest)
    with pytest.raises(InputError) as raised:
        find_done(tmp_path, "diagnosis", "arm", "healthy", "p")
    folder = tmp_path / "runs" / "diagnosis" / "arm" / "healthy" / "abc"
    assert str(raised.value).startswith(f"{folder / 'entries.json'}: cannot be read (truncated or damaged: ")
    assert str(raised.value).endswith(f"remove {folder} and run the same command again (its runs are simulated "
                                      "again)")


def test_a_damaged_table_of_a_finished_campaign_is_one_line(tmp_path):
    _campaign(tmp_path, json.dumps({"protocol": "p", "entries": {"id": "mine"}}))
    with pytest.raises(InputError) as raised:
        find_done(tmp_path, "diagnosis", "arm", "healthy", "p")
    assert str(raised.value).startswith(f"{tmp_path / 'runs/diagnosis/arm/healthy/abc/results/runs.parquet'}: "
                                        "cannot be read")
    assert find_done(tmp_path, "diagnosis", "arm", "healthy", "another protocol") == {}


def test_the_bench_command_reads_stored_results_before_it_simulates(tmp_path, monkeypatch, capsys):
    """``ftc-mj bench`` refuses a damaged ``entries.json`` before its first simulation (the check that every
    fault case acts runs a healthy loop per robot: seconds, minutes with the fast paths off)."""
    import ftc_mj.ranking.sizing as sizing
    from ftc_mj.cli import bench

    def simulates(*args, **kwargs):
        raise AssertionError("a loop was simulated before the stored results were read")

    monkeypatch.setattr(sizing, "check_faults_act", simulates)
    out = tmp_path / "results"
    manifest = out / "runs" / "diagnosis" / "two_link" / "healthy" / "abc" / "entries.json"  # a suite v2 robot
    manifest.parent.mkdir(parents=True)
    manifest.write_text('{"protocol": "p", "entr')
    assert bench.main(["--out", str(out), "--quiet", "--workers", "1"]) == 2
    error = capsys.readouterr().err.strip()
    assert error.count("\n") == 0 and "entries.json: cannot be read (truncated or damaged" in error
