"""The package's layering, from its source: the static import graph between its parts (every ``import`` of
every module, ``TYPE_CHECKING`` blocks and imports inside functions included) has no cycle, the configuration
package is a leaf, nothing imports upward, and importing the figure modules has no side effect on matplotlib.

A part is a subpackage (``ftc_mj/engine/``) or a top-level module (``ftc_mj/results.py``); ``ftc_mj`` itself is
the package's ``__init__`` (the library facade ``load_scenario``, ``run_scenario``).
"""

from __future__ import annotations

import ast
import json
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "ftc_mj"

#: Every part's layer, bottom to top: a part may import its own layer's parts only when no cycle results, and
#: lower layers freely; never a higher one. A new part must be placed here.
LAYERS: dict[str, int] = {
    "config": 0, "results": 0, "fast": 0,
    "robot": 1,
    "effects": 2, "methods": 2,
    "analysis": 3, "logs": 3,
    "outputs": 4,
    "scenario": 5,
    "engine": 6,
    "ftc_mj": 7, "online": 7, "testing": 7,
    "campaign": 8,
    "tuning": 9, "ranking": 9,
    "cli": 10, "run": 10, "figures": 10, "report": 10, "tune": 10,
}


def _part(module: str) -> str | None:
    """The part a dotted module name of the package belongs to (None outside the package)."""
    names = module.split(".")
    if names[0] != "ftc_mj":
        return None
    if len(names) == 1:
        return "ftc_mj"
    return names[1]


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imported(path: Path) -> Iterator[str]:
    """Every module of the package that ``path`` imports, as a dotted name (relative imports resolved)."""
    module = _module_name(path)
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            yield from (alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target == "ftc_mj":  # from ftc_mj import run: a submodule where one exists, else the facade
                for alias in node.names:
                    exists = (PACKAGE / f"{alias.name}.py").is_file() or (PACKAGE / alias.name).is_dir()
                    yield f"ftc_mj.{alias.name}" if exists else "ftc_mj"
            else:
                yield target


def import_graph() -> dict[str, set[str]]:
    """Part -> the other parts it imports."""
    graph: dict[str, set[str]] = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        source = _part(_module_name(path))
        graph.setdefault(source, set())
        for target in filter(None, map(_part, _imported(path))):
            if target != source:
                graph[source].add(target)
    return graph


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components of ``graph``."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for target in graph.get(node, ()):
            if target not in index:
                visit(target)
                low[node] = min(low[node], low[target])
            elif target in on_stack:
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            components.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return components


def test_the_graph_is_read_from_every_module():
    graph = import_graph()
    parts = {p.name for p in PACKAGE.iterdir() if p.is_dir() and p.name != "__pycache__"}
    parts |= {p.stem for p in PACKAGE.glob("*.py") if p.name != "__init__.py"}
    assert parts | {"ftc_mj"} == set(graph)
    assert {"scenario", "config"} <= graph["engine"] and "outputs" in graph["scenario"] and "campaign" in graph["tuning"]


def test_the_cycle_check_finds_a_long_cycle():
    components = strongly_connected({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}})
    assert sorted(components) == [["a", "b", "c"], ["d"]]


def test_no_cycle_between_parts():
    cycles = [c for c in strongly_connected(import_graph()) if len(c) > 1]
    assert cycles == [], f"parts that import each other, directly or through others: {cycles}"


def test_configuration_is_a_leaf():
    graph = import_graph()
    assert graph["config"] == set(), f"ftc_mj/config imports {sorted(graph['config'])}"
    assert graph["results"] == set(), f"ftc_mj/results.py imports {sorted(graph['results'])}"


def test_nothing_imports_upward():
    graph = import_graph()
    unplaced = sorted(set(graph) - set(LAYERS))
    assert not unplaced, f"parts without a layer in LAYERS: {unplaced}"
    upward = sorted((source, target) for source, targets in graph.items() for target in targets
                    if LAYERS[target] > LAYERS[source])
    assert upward == [], f"imports of a higher layer: {upward}"


def test_the_library_does_not_import_the_command_line():
    graph = import_graph()
    commands = {part for part, layer in LAYERS.items() if layer == LAYERS["cli"]}
    for part, targets in graph.items():
        if part not in commands:
            assert not targets & commands, f"{part} imports the command line: {sorted(targets & commands)}"
    assert not graph["campaign"] & {"ftc_mj", "cli"}


#: Imports the figure modules with matplotlib.use recorded, then reports matplotlib's state.
_PROBE = """
import json, sys
import matplotlib
preset = sys.argv[1] if len(sys.argv) > 1 else None
if preset:
    matplotlib.use(preset)
calls = []
matplotlib.use = lambda *args, **kwargs: calls.append(repr(args))
import ftc_mj.outputs.figures, ftc_mj.campaign.summary, ftc_mj.tuning.outcome
from matplotlib.figure import Figure
from pathlib import Path
import tempfile
figure = Figure(figsize=(2, 1))
figure.subplots().plot([0, 1], [1, 0])
with tempfile.TemporaryDirectory() as folder:
    written = ftc_mj.outputs.figures.save(figure, Path(folder) / "probe", ["png", "svg", "pdf"], 40)
    sizes = [p.stat().st_size for p in written]
state = {"calls": calls, "pyplot": "matplotlib.pyplot" in sys.modules, "sizes": sizes,
         "backend": matplotlib.rcParams._get_backend_or_none()}
if preset:
    state["get_backend"] = matplotlib.get_backend()
print(json.dumps(state))
"""


@pytest.mark.slow  # a subprocess
@pytest.mark.parametrize("preset", [None, "svg"])
def test_importing_the_figure_modules_leaves_matplotlib_alone(preset):
    """No ``matplotlib.use`` at import, no pyplot, the backend a user chose (or none) kept; figures are still
    saved in every format."""
    env = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"}
    done = subprocess.run([sys.executable, "-c", _PROBE, *([preset] if preset else [])], capture_output=True,
                          text=True, cwd=ROOT, env={**env, "PYTHONPATH": str(ROOT)}, timeout=300)
    assert done.returncode == 0, done.stderr
    state = json.loads(done.stdout)
    assert state["calls"] == [] and not state["pyplot"], state
    assert all(size > 0 for size in state["sizes"]) and len(state["sizes"]) == 3
    if preset is None:
        assert state["backend"] is None, state  # no backend resolved: nothing chose one
    else:
        assert state["backend"] == state["get_backend"] == preset, state
