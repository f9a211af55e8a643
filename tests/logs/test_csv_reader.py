"""The CSV reader (ftc_mj.logs.readers.read_csv) on small tables written here: leading blank lines, a single
row, columns left unused (text among them), and each bad table as its exact one line; and the CSV export's
exact text (ftc_mj.logs.export.csv_bytes: 17 significant digits, lower-case exponents, every signal's header)."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from ftc_mj.config.errors import InputError
from ftc_mj.logs import readers
from ftc_mj.logs.export import csv_bytes
from ftc_mj.logs.readers import read_csv
from ftc_mj.logs.schema import ColumnsSpec

COLUMNS = ColumnsSpec(time="t", position=["q1", "q2"], torque=["i1", "i2"])
HEADER = "t,q1,q2,i1,i2"


def _file(tmp_path: Path, text: str | bytes, name: str = "log.csv") -> Path:
    path = tmp_path / name
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    return path


def _error(path: Path, columns: ColumnsSpec = COLUMNS) -> str:
    with pytest.raises(InputError) as raised:
        read_csv(path, columns, ",")
    return str(raised.value)


def test_leading_blank_lines_and_a_single_row(tmp_path):
    recording = read_csv(_file(tmp_path, f"\n  \n{HEADER}\n0.5,1,2,3,4\n"), COLUMNS, ",")
    np.testing.assert_array_equal(recording.times, [0.5])
    np.testing.assert_array_equal(recording.position, [[1.0, 2.0]])
    np.testing.assert_array_equal(recording.torque, [[3.0, 4.0]])
    assert recording.velocity is None and recording.first == 2 and recording.sample == "row"


def test_unused_columns_are_not_read(tmp_path):
    """A text column and a number column between the used ones: neither is parsed nor taken."""
    text = "t,note,q1,x,q2,i1,i2\n0,start,1,9,2,3,4\n0.1,moving,5,9,6,7,8\n"
    recording = read_csv(_file(tmp_path, text), COLUMNS, ",")
    np.testing.assert_array_equal(recording.position, [[1.0, 2.0], [5.0, 6.0]])
    np.testing.assert_array_equal(recording.torque, [[3.0, 4.0], [7.0, 8.0]])


def test_bad_tables_are_one_line(tmp_path):
    cases = [
        ("", "log.file: is empty"),
        ("\n", "log.file: is empty"),
        (HEADER + "\n", "log.file: has no rows of numbers"),
        (b"t,q1,q2,i1,i2\n0,1,2,\xff,4\n", "log.file: is not UTF-8 text (byte 20)"),
        ("tt,q1,q2,i1,i2\n0,1,2,3,4\n", "log.columns.time: no column 't' in the header (tt, q1, q2, i1, i2)"),
    ]
    for k, (text, problem) in enumerate(cases):
        path = _file(tmp_path, text, f"{k}.csv")
        assert _error(path) == f"{path}: {problem}"
    # '#' starts no comment: a row of it is not numbers.
    path = _file(tmp_path, f"{HEADER}\n0,1,2,3,4\n# paused\n", "hash.csv")
    assert _error(path).startswith(f"{path}: log.file: is not a ','-separated table of numbers: ")


def test_more_rows_or_bytes_than_a_log_may_have(tmp_path, monkeypatch):
    monkeypatch.setattr(readers, "MAX_SAMPLES", 4)
    rows = "".join(f"{k},1,2,3,4\n" for k in range(5))
    assert len(read_csv(_file(tmp_path, HEADER + "\n" + rows[: -len("4,1,2,3,4\n")]), COLUMNS, ",").times) == 4
    path = _file(tmp_path, HEADER + "\n" + rows, "five.csv")
    assert _error(path) == f"{path}: log.file: has 5 rows, more than the 4 a log may have"
    monkeypatch.setattr(readers, "MAX_LOG_BYTES", 2**20)
    path = _file(tmp_path, HEADER + "\n" + "0,1,2,3,4\n" * 200_000, "big.csv")  # 1.9 MiB
    assert _error(path) == f"{path}: log.file: is 2 MiB, more than the 1 MiB a log may have"


def test_csv_export_text():
    """17 significant digits (the doubles back exactly), exponents in lower case, a column per joint and
    signal, the delivered torque last."""
    q = np.array([[0.1, 1e-20], [-2.5, 3.0]])
    run = SimpleNamespace(t=np.array([0.0, 0.25]), q_meas=q, qd_meas=None, tau=10 * q, tau_delivered=5 * q)
    assert csv_bytes(run, ["a", "b"]).decode() == (
        "t,q_a,q_b,tau_a,tau_b,tau_delivered_a,tau_delivered_b\n"
        "0,0.10000000000000001,9.9999999999999995e-21,1,9.9999999999999998e-20,0.5,4.9999999999999999e-20\n"
        "0.25,-2.5,3,-25,30,-12.5,15\n")


@pytest.mark.slow  # a subprocess
def test_a_utf8_log_reads_alike_under_an_ascii_locale(tmp_path):
    """The log is read as UTF-8, not in the locale's encoding: a header naming a column with a non-ASCII name
    reads under the C locale with Python's UTF-8 mode off (this package's copy, run from the repository root)."""
    import os
    import subprocess
    import sys

    path = _file(tmp_path, "t,q\u00e91,q2,i1,i2\n0,1,2,3,4\n0.1,5,6,7,8\n")
    code = ("import sys; from pathlib import Path; from ftc_mj.logs.readers import read_csv; "
            "from ftc_mj.logs.schema import ColumnsSpec; "
            "columns = ColumnsSpec(time='t', position=['q\\u00e91', 'q2'], torque=['i1', 'i2']); "
            "print(read_csv(Path(sys.argv[1]), columns, ',').position.tolist())")
    env = {**os.environ, "LC_ALL": "C", "PYTHONCOERCECLOCALE": "0", "PYTHONIOENCODING": "ascii"}
    env.pop("PYTHONUTF8", None)
    root = Path(__file__).resolve().parents[2]
    out = subprocess.run([sys.executable, "-X", "utf8=0", "-c", code, str(path)], cwd=root, env=env,
                         capture_output=True, text=True, check=True)
    here = read_csv(path, ColumnsSpec(time="t", position=["q\u00e91", "q2"], torque=["i1", "i2"]), ",")
    assert out.stdout.strip() == str(here.position.tolist()) == "[[1.0, 2.0], [5.0, 6.0]]"


def test_columns_past_the_last_by_index_or_by_name(tmp_path):
    """Index 5 of a five-column file is past it; a name needs a header; a header of more than 12 names shows 12."""
    path = _file(tmp_path, "0,1,2,3,4\n0.1,5,6,7,8\n")
    by_index = ColumnsSpec(time=0, position=[1, 5], torque=[3, 4])
    assert _error(path, by_index) == (f"{path}: log.columns.position.1: column 5 is not in the file (it has 5 "
                                      "columns, 0 to 4)")
    assert _error(path) == f"{path}: log.columns.time: names the column 't', but the file has no header row"
    names = [f"c{k}" for k in range(13)]
    for shown, header in ((", ".join(names[:12]) + ", ...", names), (", ".join(names[:12]), names[:12])):
        path = _file(tmp_path, ",".join(header) + "\n" + ",".join("0" * len(header)) + "\n", f"{len(header)}.csv")
        assert _error(path) == f"{path}: log.columns.time: no column 't' in the header ({shown})"


def test_a_log_of_exactly_the_largest_size_is_read(tmp_path, monkeypatch):
    path = _file(tmp_path, f"{HEADER}\n0,1,2,3,4\n0.1,5,6,7,8\n")
    monkeypatch.setattr(readers, "MAX_LOG_BYTES", path.stat().st_size)
    assert len(read_csv(path, COLUMNS, ",").times) == 2


def _compile(path: Path, columns: dict):
    from ftc_mj.logs.schema import LogSpec
    from ftc_mj.logs.trajectory import compile_log

    spec = LogSpec.model_validate({"file": str(path), "format": "csv", "columns": columns,
                                   "steps": {"resample": 0.1}})
    return compile_log(spec, path.parent / "replay.yaml", ["joint1", "joint2"], None, "replay.yaml")


def test_values_checked_after_reading_are_exact_lines(tmp_path):
    """ftc_mj.logs.trajectory: one row is too few (two are enough); a time that repeats or goes back names both
    times; a bad torque is found past a signal the log lacks (no velocity columns)."""
    columns = {"time": "t", "position": ["q1", "q2"], "torque": ["i1", "i2"]}
    rows = ["0,1,2,3,4", "0.1,5,6,7,8", "0.2,1,2,3,4", "0.15,1,2,3,4"]
    cases = [
        (rows[:1], "log.columns.time: the log has 1 sample: at least two are needed"),
        (rows[:2] + ["0.1,1,2,3,4"], "log.columns.time: row 4: the time does not increase (0.1 after 0.1)"),
        (rows, "log.columns.time: row 5: the time does not increase (0.15 after 0.2)"),
        (rows[:2] + ["0.2,1,2,3,nan"], "log.columns.torque.1: row 4: nan is not a finite number"),
        (rows[:2] + ["0.2,1,2,3,nan"], "log.columns.torque.1: row 3: nan is not a finite number"),  # no header
    ]
    by_index = {"time": 0, "position": [1, 2], "torque": [3, 4]}
    for k, (body, problem) in enumerate(cases):
        headed = k < len(cases) - 1
        path = _file(tmp_path, "\n".join([HEADER, *body] if headed else body) + "\n", f"{k}.csv")
        with pytest.raises(InputError) as raised:
            _compile(path, columns if headed else by_index)
        assert str(raised.value) == f"{path}: {problem}"
    log = _compile(_file(tmp_path, "\n".join([HEADER, *rows[:2]]) + "\n", "two.csv"), columns)
    np.testing.assert_array_equal(log.position, [[1.0, 2.0], [5.0, 6.0]])


def test_a_column_name_the_header_repeats_is_refused_and_an_index_still_reads_it(tmp_path):
    """Two columns ``q1``: which one is the joint's? (The first would be replayed silently.)"""
    path = _file(tmp_path, "t,q1,q2,i1,i2,q1\n0,9,0.5,1,2,0.25\n0.01,9,0.5,1,2,0.5\n")
    assert _error(path) == (f"{path}: log.columns.position.0: the header names 2 columns 'q1' (columns 1, 5): name "
                            "each column once, or give the column by its index")
    by_index = read_csv(path, ColumnsSpec(time="t", position=[5, "q2"], torque=["i1", "i2"]), ",")
    assert by_index.position[:, 0].tolist() == [0.25, 0.5]
