"""The documentation site builds in strict mode: a broken link, anchor, cross-reference or missing page of
``mkdocs.yml``'s nav fails the build, and so does a generated reference page that no longer matches the code
(a metric without a definition)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

pytest.importorskip("mkdocs")
pytest.importorskip("material")
pytest.importorskip("mkdocstrings_handlers.python")


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1", "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--quiet", "--site-dir", str(out)],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    return out


def test_every_nav_page_is_built(site: Path) -> None:
    for page in ("index.html", "getting-started/index.html", "tutorials/plugin/index.html",
                 "reference/scenario/index.html", "reference/commands/index.html", "reference/api/index.html",
                 "explanation/batching/index.html", "results/reproduction/index.html"):
        assert (site / page).is_file(), page


def test_generated_reference_follows_the_code(site: Path) -> None:
    from ftc_mj.analysis.metrics import METRICS
    from ftc_mj.cli.main import COMMANDS
    from ftc_mj.methods.controllers import BUILTIN as CONTROLLERS
    from ftc_mj.methods.observers import BUILTIN as OBSERVERS
    from ftc_mj.scenario.definition import ScenarioSpec

    scenario = (site / "reference/scenario/index.html").read_text()
    for field in ScenarioSpec.model_fields:
        assert f"<code>{field}</code>" in scenario, field
    commands = (site / "reference/commands/index.html").read_text()
    for name in COMMANDS:
        assert f"ftc-mj {name}" in commands, name
    assert "--duration" in commands and "--scheduler" in commands
    methods = (site / "reference/methods/index.html").read_text()
    for name in [*OBSERVERS, *CONTROLLERS]:
        assert f'id="{name}"' in methods, name
    metrics = (site / "reference/metrics/index.html").read_text()
    for name in METRICS:
        assert f"<code>{name}</code>" in metrics, name
    api = (site / "reference/api/index.html").read_text()
    assert "run_batch" in api and "command_acceleration" in api


def test_no_page_names_a_machine_an_outside_path_or_a_tracker_number() -> None:
    forbidden = re.compile(r"this (2-core |idle |busy )?machine|/work/|/tmp/\w|\.\./shared|issue \d|#\d{2,}\b"
                           r"|\b20\d\d-\d\d-\d\d\b")
    for page in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]:
        for number, line in enumerate(page.read_text().splitlines(), 1):
            assert not forbidden.search(line), f"{page.relative_to(ROOT)}:{number}: {line.strip()}"


def _slug(heading: str) -> str:
    """A heading's anchor as GitHub and MkDocs' toc make it (lower case, punctuation dropped, spaces to -)."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def test_the_readme_links_resolve() -> None:
    """The README is read on the repository's page, outside the site: its links must hold there."""
    readme = (ROOT / "README.md").read_text()
    links = re.findall(r"\]\(([^)\s]+)\)", readme)
    assert len(links) > 30
    for link in links:
        if link.startswith(("http://", "https://")):
            continue
        path, _, anchor = link.partition("#")
        target = ROOT / path
        assert target.exists(), link
        if anchor:
            headings = re.findall(r"^#+ (.+)$", target.read_text(), re.MULTILINE)
            assert anchor in {_slug(heading) for heading in headings}, link
