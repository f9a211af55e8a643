"""The documentation site builds as the README says (``mkdocs build``, strict mode, nothing hidden): any warning
fails the test (a broken link, anchor or cross-reference, a page missing from ``mkdocs.yml``'s nav, a generated
reference page that no longer matches the code), and every relative link of every built page resolves on the
built site, not only in the source tree.

``--quiet`` is not passed: with mkdocs 1.6 it keeps warnings from reaching strict mode's count, so a site with
warnings would build; the log is read here as well, so that a warning fails the test whatever mkdocs counts."""

from __future__ import annotations

import os
import re
from html.parser import HTMLParser
import subprocess
import sys
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest

#: the documentation site built, and the tutorials' commands run
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]

pytest.importorskip("mkdocs")
pytest.importorskip("material")
pytest.importorskip("mkdocstrings_handlers.python")


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1", "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    log = done.stdout + done.stderr
    assert done.returncode == 0, log
    warnings = [line for line in log.splitlines() if line.startswith(("WARNING", "ERROR"))]
    assert not warnings, "\n".join(warnings)
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
    assert len(links) > 15
    for link in links:
        if link.startswith(("http://", "https://")):
            continue
        path, _, anchor = link.partition("#")
        target = ROOT / path if path else ROOT / "README.md"
        assert target.exists(), link
        if anchor:
            headings = re.findall(r"^#+ (.+)$", target.read_text(), re.MULTILINE)
            assert anchor in {_slug(heading) for heading in headings}, link


class _Links(HTMLParser):
    """The ``href``/``src`` targets and the element ids of one HTML page, and Markdown link syntax left as
    text outside code (a link that did not render, such as ``[text]](page.md)``)."""

    def __init__(self) -> None:
        super().__init__()
        self.targets: list[str] = []
        self.ids: set[str] = set()
        self.unrendered: list[str] = []
        self._code = 0

    def handle_endtag(self, tag: str) -> None:
        if tag in ("code", "pre", "script", "style", "textarea"):
            self._code = max(0, self._code - 1)

    def handle_data(self, data: str) -> None:
        if not self._code and re.search(r"\]\(\S+\)", data):
            self.unrendered.append(data.strip()[:80])

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag in ("code", "pre", "script", "style", "textarea"):
            self._code += 1
        for name, value in attrs:
            if name in ("href", "src") and value:
                self.targets.append(value)
            elif name in ("id", "name") and value:
                self.ids.add(value)


def _parse(page: Path) -> _Links:
    links = _Links()
    links.feed(page.read_text(encoding="utf-8"))
    return links


def _resolve(site: Path, page: Path, target: str) -> tuple[Path | None, str]:
    """The built file a relative link of ``page`` names (a folder means its index.html), and its anchor;
    (None, "") for a link that leaves the site (a scheme, a protocol-relative or an absolute path)."""
    parts = urlsplit(target)
    if parts.scheme or parts.netloc or target.startswith(("/", "mailto:", "javascript:")):
        return None, ""
    if not parts.path:
        return page, unquote(parts.fragment)
    path = (page.parent / unquote(parts.path)).resolve()
    if path.is_dir() or parts.path.endswith("/"):
        path = path / "index.html"
    return path, unquote(parts.fragment)


def test_every_relative_link_resolves_on_the_built_site(site: Path) -> None:
    pages = sorted(site.rglob("*.html"))
    assert len(pages) > 30
    parsed = {page: _parse(page) for page in pages}
    broken, checked = [], 0
    for page, links in parsed.items():
        for target in links.targets:
            path, anchor = _resolve(site, page, target)
            if path is None:
                continue
            checked += 1
            where = f"{page.relative_to(site)}: {target}"
            if not path.is_relative_to(site.resolve()) or not path.is_file():
                broken.append(where)
            elif anchor and path.suffix == ".html":
                ids = parsed[path].ids if path in parsed else _parse(path).ids
                if anchor not in ids:
                    broken.append(where + " (no such anchor)")
    assert checked > 500
    assert not broken, "\n".join(broken[:40])
    unrendered = [f"{page.relative_to(site)}: {text}" for page, links in parsed.items() for text in links.unrendered]
    assert not unrendered, "\n".join(unrendered)


def test_the_link_check_finds_a_dead_link(tmp_path: Path) -> None:
    """The check above on a two-page site: a folder link with no index page and a missing anchor are dead."""
    (tmp_path / "a").mkdir()
    (tmp_path / "results").mkdir()
    page = tmp_path / "a" / "index.html"
    page.write_text('<h1 id="top">a</h1><a href="../results/">x</a><a href="#top">y</a><a href="#nope">z</a>')
    links = _parse(page)
    resolved = [_resolve(tmp_path, page.resolve(), t) for t in links.targets]
    assert not resolved[0][0].is_file()
    assert resolved[1] == (page.resolve(), "top") and "top" in links.ids
    assert resolved[2][1] not in links.ids
    broken = _Links()
    broken.feed('<p>see [the logs]](../results/real-logs.md)</p><pre><code>x = [a](b)</code></pre>')
    assert broken.unrendered == ["see [the logs]](../results/real-logs.md)"]


def test_the_equations_are_rendered(site: Path) -> None:
    """The methods reference and the scenario tutorial show MathML, and no page shows TeX left as text."""
    for page in ("reference/methods/index.html", "tutorials/scenario/index.html"):
        assert (site / page).read_text().count("<math") >= 5, page
    for page in site.rglob("*.html"):
        text = page.read_text()
        assert 'class="arithmatex"' not in text and ":math:`" not in text, page.relative_to(site)
