"""Every ``bash`` and ``python`` block of the tutorials (docs/tutorials/*.md) runs, in page order, from the root
of a copy of the repository's files (so that what they write stays out of the work tree; the package itself is
imported from the work tree): a tutorial whose code no longer works fails here. Blocks that must not run (a blocking viewer, an hour-long benchmark) are written as
``console`` or ``text``.

The example plugin package (examples/ftc_mj_pole_eso) is made importable with its entry point, as
``pip install`` would: its folder on the path and its ``.dist-info`` (metadata and ``entry_points.txt``)
beside it."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

#: the documentation site built, and the tutorials' commands run
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
TUTORIALS = sorted((ROOT / "docs" / "tutorials").glob("*.md"))
BLOCK = re.compile(r"^```(bash|python)\n(.*?)^```$", re.MULTILINE | re.DOTALL)
EXAMPLE = ROOT / "examples" / "ftc_mj_pole_eso"


def blocks(page: Path) -> list[tuple[str, str]]:
    return [(match.group(1), match.group(2)) for match in BLOCK.finditer(page.read_text())]


def _installed(example: Path, site: Path) -> None:
    """The entry point of ``example``'s pyproject.toml, as an installed distribution in ``site``."""
    project = tomllib.loads((example / "pyproject.toml").read_text())["project"]
    info = site / f"{project['name']}-{project['version']}.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {project['name']}\nVersion: {project['version']}\n")
    lines = []
    for group, entries in project["entry-points"].items():
        lines.append(f"[{group}]")
        lines += [f"{name} = {target}" for name, target in entries.items()]
    (info / "entry_points.txt").write_text("\n".join(lines) + "\n")


@pytest.fixture(scope="module")
def workspace(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, str]]:
    copy = tmp_path_factory.mktemp("tutorials") / "repo"

    def skipped(folder: str, names: list[str]) -> set[str]:
        # The package itself is imported from the work tree (with its compiled kernels' cache), not copied.
        top = {"ftc_mj", "tests", "site"} if Path(folder) == ROOT else set()
        return top | {name for name in names if name in {".git", "__pycache__", "results", ".pytest_cache",
                                                          "figures"} or name.endswith(".rrd")}

    shutil.copytree(ROOT, copy, ignore=skipped)
    site = copy.parent / "site-packages"
    _installed(EXAMPLE, site)
    env = {**os.environ, "MPLBACKEND": "Agg",
           "PYTHONPATH": os.pathsep.join([str(site), str(copy / "examples" / "ftc_mj_pole_eso"), str(ROOT)])}
    return copy, env


def test_the_tutorials_have_code() -> None:
    assert TUTORIALS, "no tutorial found"
    assert sum(len(blocks(page)) for page in TUTORIALS) >= 6


@pytest.mark.parametrize("page", TUTORIALS, ids=[page.stem for page in TUTORIALS])
def test_every_code_block_runs(page: Path, workspace: tuple[Path, dict[str, str]]) -> None:
    copy, env = workspace
    for number, (language, code) in enumerate(blocks(page), 1):
        command = ["bash", "-euo", "pipefail", "-c", code] if language == "bash" else [sys.executable, "-c", code]
        done = subprocess.run(command, cwd=copy, env=env, capture_output=True, text=True, timeout=240)
        assert done.returncode == 0, (f"{page.relative_to(ROOT)}, block {number} ({language}) exited "
                                      f"{done.returncode}:\n{code}\n--- stdout\n{done.stdout[-3000:]}\n"
                                      f"--- stderr\n{done.stderr[-3000:]}")
