"""The architecture page cannot go stale: its tree of the package is generated from the package's files when
the site is built (``docs/_gen/reference.py``: ``package_tree``), and every module, function or class its text
names (``engine.loop.simulate``, ``scenario.definition.compile_scenario``) exists."""

from __future__ import annotations

import importlib
import pkgutil
import re
import sys
from pathlib import Path

import pytest

import ftc_mj

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "explanation" / "architecture.md"
sys.path.insert(0, str(ROOT / "docs" / "_gen"))
reference = pytest.importorskip("reference")  # the site's hook module (needs pydantic, yaml: core dependencies)


def _package_names() -> set[str]:
    """Every subpackage and module of ftc_mj by pkgutil (the import system's view, not a walk of files)."""
    names = set()
    for info in pkgutil.walk_packages(ftc_mj.__path__, "ftc_mj."):
        if info.name.rsplit(".", 1)[-1].startswith("__"):
            continue
        names.add(info.name.removeprefix("ftc_mj.").replace(".", "/") + ("/" if info.ispkg else ".py"))
    return names


def test_the_tree_lists_every_subpackage_and_module_and_nothing_else():
    listed = reference.package_modules()
    assert len(listed) == len(set(listed))
    assert set(listed) == _package_names()
    tree = reference.package_tree()
    for entry in listed:
        name = entry.rstrip("/").rsplit("/", 1)[-1] + ("/" if entry.endswith("/") else "")
        depth = entry.rstrip("/").count("/") + 1
        assert re.search(rf"^{'  ' * depth}{re.escape(name)}(\s|$)", tree, re.MULTILINE), entry


def test_a_module_added_appears_in_the_tree(tmp_path: Path):
    package = tmp_path / "pkg"
    (package / "online").mkdir(parents=True)
    (package / "__init__.py").write_text('"""The package."""\n')
    (package / "online" / "__init__.py").write_text('"""Diagnosis inside the loop: one sample at a time."""\n')
    (package / "online" / "monitor.py").write_text('"""A monitor, eq. (5.6). It raises alarms."""\n')
    (package / "online" / "notes.txt").write_text("not a module")
    assert reference.package_modules(package) == ["online/", "online/monitor.py"]
    tree = reference.package_tree(package)
    assert "  online/" in tree and "Diagnosis inside the loop" in tree
    assert "    monitor.py" in tree and "A monitor, eq. (5.6)" in tree and "It raises" not in tree


def test_the_page_asks_for_the_generated_tree():
    assert reference.TREE_MARK in PAGE.read_text()


#: Dotted names in prose: ``engine.loop.simulate``, ``config.yaml`` (and scenario fields, attributes).
DOTTED = re.compile(r"(?<![\w./])[a-z_]+(?:\.[A-Za-z_]\w*)+")
#: Subpackages the package had once: a name under one of them is stale.
FORMER = {"spec", "bench"}


def _resolves(dotted: str) -> bool:
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module("ftc_mj." + ".".join(parts[:cut]))
        except ImportError:
            continue
        for attribute in parts[cut:]:
            if not hasattr(obj, attribute):
                return False
            obj = getattr(obj, attribute)
        return True
    return False


def test_every_name_the_page_gives_exists():
    """A dotted name that starts with a subpackage's name, present or former, names a module, class or
    function that exists: a renamed module (``spec.loading`` after the rename) fails."""
    subpackages = {name.split("/")[0] for name in _package_names() if name.endswith("/")} | FORMER
    named = sorted({name for name in DOTTED.findall(PAGE.read_text()) if name.split(".")[0] in subpackages})
    assert len(named) > 10
    missing = [name for name in named if not _resolves(name)]
    assert not missing, missing


def test_a_stale_name_is_found():
    assert not _resolves("spec.loading") and not _resolves("engine.loop.no_such_function")
    assert _resolves("engine.loop.simulate") and _resolves("config.yaml")
