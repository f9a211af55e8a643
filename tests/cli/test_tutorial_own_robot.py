"""docs/tutorials/own-robot.md: every command of its ```bash blocks runs from the repository root and exits 0
(``ftc-mj`` as ``python -m ftc_mj.cli``, so that this checkout's package runs). Outputs go under results/,
which the test removes."""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from ftc_mj.robot.packages import resolve_package_uri

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "tutorials" / "own-robot.md"
OUTPUT = ROOT / "results" / "own-robot"


def commands() -> list[str]:
    blocks = re.findall(r"```bash\n(.*?)```", PAGE.read_text(encoding="utf-8"), flags=re.DOTALL)
    return [line.strip() for block in blocks for line in block.splitlines() if line.strip()]


def test_the_page_has_commands_for_every_step():
    found = " ".join(commands())
    for command in ("ftc-mj robot check", "ftc-mj run", "ftc-mj calibrate", "--thresholds-only", "ftc-mj tune"):
        assert command in found


@pytest.mark.parametrize("command", commands())
def test_command_runs(command, tmp_path):
    if "ur5_urdf" in command and resolve_package_uri(
            "package://example-robot-data/robots/ur_description/urdf/ur5_robot.urdf") is None:
        pytest.skip("example-robot-data is not installed")
    words = shlex.split(command)
    env = dict(os.environ, FTC_MJ_CACHE_DIR=str(tmp_path / "cache"))
    if words[0].startswith("PYTHONPATH="):
        env["PYTHONPATH"] = str(ROOT)
        words = words[1:]
    if words[0] == "python":
        words[0] = sys.executable
    elif words[0] == "ftc-mj":
        words = [sys.executable, "-m", "ftc_mj.cli", *words[1:]]
    process = subprocess.run(words, cwd=ROOT, env=env, capture_output=True, text=True, timeout=900, check=False)
    assert process.returncode == 0, process.stderr[-2000:]
    assert "Traceback" not in process.stderr


@pytest.fixture(scope="module", autouse=True)
def _clean_results():
    yield
    shutil.rmtree(OUTPUT, ignore_errors=True)
