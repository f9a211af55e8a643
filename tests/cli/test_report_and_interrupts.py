"""``ftc-mj report`` writes undefined numbers as the run's table does, and every command's interruption is one
line, exit 130, nothing written (:mod:`ftc_mj.cli.command`): ``calibrate`` stopped by SIGINT in its runs."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import yaml

from ftc_mj.cli import report

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "campaign"))
import small_campaign  # noqa: E402


def test_report_prints_nan_infinity_and_1e400_as_undefined(tmp_path, capsys):
    text = ('{"variants": {"a": {"metrics": {"rms_error": [NaN, Infinity, 1e400, -Infinity, 0.5, null]}}, '
            '"b": {"metrics": {"rms_error": [1, 2, 3, 4, 5, 6]}}}}')
    (tmp_path / "m.json").write_text(text)
    assert report.main([str(tmp_path / "m.json")]) == 0
    rows = capsys.readouterr().out.splitlines()
    assert rows[2] == "| rms_error | rad | - / - / - / - / 0.5 / - | 1 / 2 / 3 / 4 / 5 / 6 |"
    assert report.read_metrics(tmp_path / "m.json")["variants"]["a"]["metrics"]["rms_error"] == [
        None, None, None, None, 0.5, None]  # as run --json writes them


@pytest.mark.slow  # a subprocess
def test_calibrate_interrupted_exits_130_with_one_line_and_writes_nothing(tmp_path):
    data = small_campaign.scenario()
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(data))
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    process = subprocess.Popen([sys.executable, "-m", "ftc_mj.cli", "calibrate", "s.yaml", "--false-alarm-rate",
                                "0.1", "--runs", "2000", "--out", "c.yaml"], cwd=tmp_path, env=env,
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                               # Python takes Ctrl-C only where SIGINT is not ignored (as in background jobs)
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    time.sleep(12)  # imports, loading, and into the healthy runs
    assert process.poll() is None, process.stderr.read()
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=60)
    lines = [line for line in stderr.splitlines() if not line.startswith("compiling ")]
    assert process.returncode == 130, stderr
    assert lines == ["interrupted: nothing written"], stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.yaml"]
    assert yaml.safe_load((tmp_path / "s.yaml").read_text()) == data
