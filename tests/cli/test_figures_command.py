"""The command line ``ftc-mj figures`` (:mod:`ftc_mj.cli.figures`): one file per figure and format, bad input as one line, exit 2."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from ftc_mj.cli.figures import main

#: closed-loop runs and subprocesses of the command line
pytestmark = pytest.mark.slow

ROOT = Path(__file__).parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


def command(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", *args], capture_output=True, text=True, env=ENV, cwd=cwd, timeout=300)


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("cli")
    run = command("ftc_mj.cli", "run", str(ROOT / "scenarios" / "two_link_do.yaml"), "--duration", "0.5", "--quiet",
                  "--out", "two_link_do.rrd", cwd=folder)
    assert run.returncode == 0, run.stderr
    return folder / "two_link_do.rrd"


def test_every_figure_in_every_format(recording: Path, tmp_path: Path) -> None:
    done = command("ftc_mj.cli", "figures", str(recording), "--out", str(tmp_path / "out"), "--format", "png,pdf",
                   "--dpi", "50", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    names = ["fig2_3_luaf", "fig2_4_luaf_error", "fig2_6_tracking_error", "fig2_7_torque", "fig2_8_switching_gain"]
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == sorted(f"{n}.{e}" for n in names for e in ("png", "pdf"))
    assert done.stdout.split() == [str(tmp_path / "out" / f"{n}.{e}") for n in names for e in ("png", "pdf")]


def test_default_folder_and_only(recording: Path) -> None:
    done = command("ftc_mj.cli", "figures", str(recording), "--only", "fig2_8_switching_gain", "--dpi", "50",
                   cwd=recording.parent)
    assert done.returncode == 0, done.stderr
    assert [p.name for p in recording.with_suffix("").iterdir()] == ["fig2_8_switching_gain.png"]


@pytest.mark.parametrize(("args", "message"), [
    (["--format", "gif"], "--format: 'gif' is not one of png, svg, pdf"),
    (["--dpi", "5"], "--dpi: 5 is outside"),
    (["--only", "fig9"], "--only: no figure 'fig9'"),
])
def test_bad_options(recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture, args: list[str],
                     message: str) -> None:
    assert main([str(recording), "--out", str(tmp_path / "none"), *args]) == 2
    stderr = capsys.readouterr().err
    assert message in stderr and stderr.count("\n") == 1, stderr
    assert not (tmp_path / "none").exists()


def test_not_a_recording(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    text = tmp_path / "text.rrd"
    text.write_text("not a recording")
    for path in (tmp_path / "gone.rrd", text):
        assert main([str(path), "--out", str(tmp_path / "none")]) == 2
        stderr = capsys.readouterr().err
        assert stderr.startswith(f"error: {path}: ") and stderr.count("\n") == 1, stderr
    assert not (tmp_path / "none").exists()
