"""The reference pages generated from the code at build time, so that they cannot drift from it.

Used as a MkDocs hook (``mkdocs.yml``: ``hooks``): :func:`on_files` adds one generated Markdown page per
entry of :data:`PAGES` to the site. Every schema page is read from the pydantic models themselves (field,
type, default) and their ``#:`` comments (meaning); the command pages from each command's ``build_parser``;
the methods page from the registry of built-in observers and controllers and their gain ``Config`` models;
the metrics page from the metrics registry (``ftc_mj.analysis.registry``: names, units, windows and the
definitions' docstrings).
"""

from __future__ import annotations

import argparse
import enum
import inspect
import re
import sys
import textwrap
import types
import typing
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import annotated_types
import yaml
from pydantic import BaseModel
from pydantic_core import PydanticUndefined

HERE = Path(__file__).resolve().parent

# ----------------------------------------------------------------------------------------------- schemas


def _comments(cls: type) -> dict[str, str]:
    """Field name -> the ``#:`` comment lines just above its annotation in the class body."""
    try:
        lines, _ = inspect.getsourcelines(cls)
    except (OSError, TypeError):
        return {}
    found: dict[str, str] = {}
    pending: list[str] = []
    body_indent = None
    for line in lines[1:]:
        stripped = line.strip()
        indent = len(line) - len(line.lstrip())
        if not stripped:
            pending = []
            continue
        if body_indent is None:
            body_indent = indent
        if indent != body_indent:
            continue
        if stripped.startswith("#:"):
            pending.append(stripped[2:].strip())
            continue
        match = re.match(r"([A-Za-z_][A-Za-z0-9_]*)\s*:", stripped)
        if match and pending:
            found[match.group(1)] = " ".join(pending)
        pending = []
    return found


def _inherited_comments(model: type) -> dict[str, str]:
    """The ``#:`` comments of a model's fields, its bases' included (a subclass's own comment wins)."""
    comments: dict[str, str] = {}
    for base in reversed(model.__mro__):
        if isinstance(base, type) and issubclass(base, BaseModel) and base is not BaseModel:
            comments.update(_comments(base))
    return comments


def _doc(obj: object) -> str:
    doc = inspect.getdoc(obj) or ""
    if doc.startswith(("Usage docs:", "!!! abstract")) or obj.__doc__ is None:
        return ""
    return doc


def _rst_to_md(text: str) -> str:
    """Sphinx roles and double backquotes of the docstrings as Markdown code, and their mathematics (the
    ``:math:`TEX``` role and the ``.. math::`` directive) as the site's (``\\( \\)``, ``\\[ \\]``: MathML
    when built)."""
    text = _math_directives(text)
    text = re.sub(r":math:`([^`]+)`", lambda m: "\\(" + m.group(1) + "\\)", text)
    text = re.sub(r":(?:class|func|meth|mod|data|attr|exc|obj):`~?([^`]+)`", r"`\1`", text)
    return text.replace("``", "`")


def _math_directives(text: str) -> str:
    """Each ``.. math::`` directive (its indented lines, one equation per paragraph) as display equations, at the
    directive's indentation (one inside a list item stays in it)."""
    lines, out, k = text.splitlines(), [], 0
    while k < len(lines):
        match = re.match(r"^(\s*)\.\. math::\s*$", lines[k])
        if match is None:
            out.append(lines[k])
            k += 1
            continue
        indent, body, k = len(match.group(1)), [], k + 1
        while k < len(lines) and (not lines[k].strip() or len(lines[k]) - len(lines[k].lstrip()) > indent):
            body.append(lines[k].strip())
            k += 1
        for equation in "\n".join(body).strip().split("\n\n"):  # at the directive's indentation: in its list item
            out += ["", " " * indent + "\\[" + " ".join(equation.split("\n")) + "\\]", ""]
    return "\n".join(out)


def _cell(text: str) -> str:
    """A table cell: Markdown, one line, its pipes escaped; a pipe inside mathematics (an absolute value) as
    ``\\vert``, which the table's escape would otherwise turn into the norm ``\\|``."""
    text = _rst_to_md(text)
    text = re.sub(r"\\\((.*?)\\\)", lambda m: "\\(" + m.group(1).replace("|", "\\vert ") + "\\)", text)
    return text.replace("|", "\\|").replace("\n", " ")


try:
    from griffe import Extension as _GriffeExtension
except ImportError:  # pragma: no cover - griffe comes with the docs extra (mkdocstrings)
    _GriffeExtension = object


class DocstringMath(_GriffeExtension):
    """A Griffe extension (``mkdocs.yml``: the python handler's ``extensions``): the docstrings the API
    reference renders through mkdocstrings pass through :func:`_rst_to_md` too, so that their ``:math:`` and
    ``.. math::`` render there as on the methods page (mkdocstrings reads Markdown, not Sphinx roles)."""

    def on_instance(self, *, obj, **kwargs) -> None:
        if obj.docstring is not None:
            obj.docstring.value = _rst_to_md(obj.docstring.value)


_CONSTRAINTS = {annotated_types.Gt: ("gt", "> {}"), annotated_types.Ge: ("ge", ">= {}"),
                annotated_types.Lt: ("lt", "< {}"), annotated_types.Le: ("le", "<= {}"),
                annotated_types.MinLen: ("min_length", "at least {} long"),
                annotated_types.MaxLen: ("max_length", "at most {} long")}


def _constraints(metadata: Iterable[object]) -> list[str]:
    said = []
    for item in metadata:
        for kind, (attribute, form) in _CONSTRAINTS.items():
            if isinstance(item, kind):
                said.append(form.format(getattr(item, attribute)))
        pattern = getattr(item, "pattern", None)
        if isinstance(pattern, str):
            said.append(f"matches `{pattern}`")
    return said


class _Types:
    """Renders annotations as short text and collects the models they name (documented after)."""

    def __init__(self) -> None:
        self.models: list[type[BaseModel]] = []

    def name(self, annotation: Any) -> str:
        origin = typing.get_origin(annotation)
        args = typing.get_args(annotation)
        if origin is typing.Annotated:
            base, *metadata = args
            said = _constraints(metadata)
            text = self.name(base)
            return f"{text} ({', '.join(said)})" if said else text
        if origin in (typing.Union, types.UnionType):
            return " or ".join(self.name(arg) for arg in args)
        if origin is typing.Literal:
            return " or ".join(f"`{arg!r}`" if not isinstance(arg, str) else f'`"{arg}"`' for arg in args)
        if origin in (list, tuple, set, frozenset):
            inner = ", ".join(self.name(arg) for arg in args if arg is not Ellipsis)
            return f"list of {inner}" if inner else "list"
        if origin is dict:
            key, value = args
            return f"mapping {self.name(key)} -> {self.name(value)}"
        if annotation is type(None):
            return "null"
        if isinstance(annotation, type) and issubclass(annotation, BaseModel):
            if annotation not in self.models:
                self.models.append(annotation)
            return f"[{annotation.__name__}](#{annotation.__name__.lower()})"
        if isinstance(annotation, type) and issubclass(annotation, enum.Enum):
            return " or ".join(f'`"{member.value}"`' for member in annotation)
        if isinstance(annotation, type):
            return {"str": "text", "float": "number", "int": "integer", "bool": "true/false",
                    "Any": "any"}.get(annotation.__name__, annotation.__name__)
        if annotation is Any:
            return "any"
        return str(annotation).replace("typing.", "")


def _default(info: Any) -> str:
    if info.is_required():
        return "required"
    if info.default_factory is not None:
        value = info.default_factory()
    else:
        value = info.default
    if value is PydanticUndefined:
        return "required"
    if value is None:
        return "none"
    if isinstance(value, BaseModel):
        return "its defaults"
    if isinstance(value, enum.Enum):
        value = value.value
    text = yaml.safe_dump(value, default_flow_style=True, width=10_000).strip()
    text = text.removesuffix("...").strip()
    return f"`{text}`"


def schema_page(title: str, intro: str, root: type[BaseModel]) -> str:
    """One table per model, the root first, then every model its fields name, in order of first mention."""
    kinds = _Types()
    kinds.models.append(root)
    out = [f"# {title}", "", intro, ""]
    index = 0
    while index < len(kinds.models):
        model = kinds.models[index]
        index += 1
        comments = _inherited_comments(model)
        out += [f"## {model.__name__}", ""]
        doc = _doc(model)
        if doc:
            out += [_rst_to_md(doc), ""]
        out += [f"`{model.__module__}.{model.__name__}`", "",
                "| field | type | default | meaning |", "|---|---|---|---|"]
        for name, info in model.model_fields.items():
            key = info.alias or name
            meaning = comments.get(name) or info.description or ""
            tag = typing.get_origin(info.annotation) is typing.Literal and len(typing.get_args(info.annotation)) == 1
            if not meaning and tag:
                meaning = "The tag that selects this form."
            type_text = kinds.name(info.annotation)
            said = _constraints(info.metadata)
            if said:
                type_text += f" ({', '.join(said)})"
            out.append(f"| `{key}` | {_cell(type_text)} | {_cell(_default(info))} | {_cell(meaning)} |")
        out.append("")
    return "\n".join(out)


# ---------------------------------------------------------------------------------------------- commands


def _parser_section(parser: argparse.ArgumentParser, level: int) -> list[str]:
    out = ["```text", parser.format_usage().strip(), "```", ""]
    if parser.description:
        out += [parser.description.strip(), ""]
    rows = []
    subparsers = None
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            subparsers = action
            continue
        if isinstance(action, argparse._HelpAction):
            continue
        name = ", ".join(f"`{option}`" for option in action.option_strings) or f"`{action.metavar or action.dest}`"
        if action.option_strings and action.nargs != 0:
            metavar = action.metavar or action.dest.upper()
            if isinstance(metavar, tuple):
                metavar = " ".join(metavar)
            name += f" `{metavar}`"
        default = ""
        if action.default not in (None, argparse.SUPPRESS, False) and action.nargs != 0:
            default = f"`{action.default}`"
        help_text = (action.help or "").replace("%(default)s", str(action.default)).replace("%%", "%")
        if action.choices and not isinstance(action, argparse._SubParsersAction):
            help_text += f" (one of {', '.join(map(str, action.choices))})"
        rows.append(f"| {name} | {_cell(help_text)} | {default} |")
    if rows:
        out += ["| argument | meaning | default |", "|---|---|---|", *rows, ""]
    if parser.epilog:
        out += [parser.epilog.strip(), ""]
    if subparsers is not None:
        for name, sub in subparsers.choices.items():
            out += [f"{'#' * level} {sub.prog}", ""]
            out += _parser_section(sub, level + 1)
    return out


def commands_page() -> str:
    import importlib

    from ftc_mj.cli.main import COMMANDS

    out = ["# Commands", "",
           "Every command is `ftc-mj COMMAND` (installed with the package; `python -m ftc_mj.cli COMMAND` "
           "without installing). Generated from each command's parser: `ftc-mj COMMAND --help` prints the same. "
           "Every command refuses a bad option or bad input with one line and exit status 2, writing nothing "
           "([bad input](bad-input.md)).", "",
           "| command | does |", "|---|---|"]
    out += [f"| [`ftc-mj {name}`](#ftc-mj-{name}) | {_cell(summary)} |" for name, summary in COMMANDS.items()]
    out.append("")
    for name in COMMANDS:
        module = importlib.import_module(f"ftc_mj.cli.{name}")
        parser = module.build_parser(prog=f"ftc-mj {name}")
        out += [f"## ftc-mj {name}", ""]
        out += _parser_section(parser, 3)
    return "\n".join(out)


# ----------------------------------------------------------------------------------------------- methods


def _gains_table(config: type[BaseModel]) -> list[str]:
    kinds = _Types()
    comments = _inherited_comments(config)
    rows = ["| gain | type | default | meaning |", "|---|---|---|---|"]
    for name, info in config.model_fields.items():
        rows.append(f"| `{name}` | {_cell(kinds.name(info.annotation))} | {_cell(_default(info))} | "
                    f"{_cell(comments.get(name) or info.description or '')} |")
    for model in kinds.models:  # a section inside the gains (a supervisor's controllers): its own table
        rows += ["", f"#### {model.__name__}", "", _rst_to_md(_doc(model)), ""] + _gains_table(model)
    return rows


def methods_page() -> str:
    from ftc_mj.methods.controllers import BUILTIN as CONTROLLERS
    from ftc_mj.methods.observers import BUILTIN as OBSERVERS

    out = ["# Methods", "",
           "Every built-in observer and controller, generated from the registry "
           "(`ftc_mj.methods.observers.BUILTIN`, `ftc_mj.methods.controllers.BUILTIN`): the name a scenario's "
           "`type` takes, the class and its docstring (the equations it implements), the sensors it needs and "
           "its gains from its `Config` (a per-joint gain is one number or a list of one per joint). "
           "The readings of misprinted equations are in [the assumptions](../explanation/assumptions.md); "
           "a method of your own is [a package of its own](../tutorials/plugin.md).", ""]
    for title, registry in (("Observers", OBSERVERS), ("Controllers", CONTROLLERS)):
        out += [f"## {title}", "", "| name | class | needs |", "|---|---|---|"]
        for name, cls in registry.items():
            out.append(f"| [`{name}`](#{name}) | `{cls.__module__}.{cls.__name__}` | "
                       f"{', '.join(sorted(cls.requires))} |")
        out.append("")
        first_of_module: dict[str, str] = {}
        for name, cls in registry.items():
            out += [f"### {name}", "", f"`{cls.__module__}.{cls.__name__}`", "", _rst_to_md(_doc(cls)), ""]
            module = sys.modules[cls.__module__]
            if cls.__module__ in first_of_module:
                first = first_of_module[cls.__module__]
                out += [f"The equations: as [`{first}`](#{first}) (the same module).", ""]
            elif module.__doc__:
                first_of_module[cls.__module__] = name
                equations = re.sub(r"::$", ":", _rst_to_md(inspect.getdoc(module)), flags=re.MULTILINE)
                out += [f"**The equations** (`{cls.__module__}`):", "", equations, ""]
            config_doc = _doc(cls.Config)
            if config_doc:
                out += [_rst_to_md(config_doc), ""]
            if cls.signal_names:
                out += ["Signals it records (figures `extras.NAME`): "
                        + ", ".join(f"`{s}`" for s in sorted(cls.signal_names)) + ".", ""]
            out += _gains_table(cls.Config) + [""]
    return "\n".join(out)


# ----------------------------------------------------------------------------------------------- metrics


def metrics_page() -> str:
    """The metrics page from the registry (:mod:`ftc_mj.analysis.registry`): name, unit, window and the
    definition's docstring of every registered metric."""
    from ftc_mj.analysis.metrics import MetricsSpec
    from ftc_mj.analysis.registry import of_kind

    out = ["# Metrics", "",
           "Per variant and per joint, SI units, each a NumPy function registered in `ftc_mj.analysis.registry` "
           "(series metrics in `ftc_mj.analysis.metrics`, diagnosis metrics in `ftc_mj.analysis.diagnosis`); this "
           "page is generated from that registry. e = q - q_d on the true position. The windows and tolerances are "
           "the scenario's [`metrics` section](scenario.md#metricsspec). A metric of your own is one function "
           "decorated with `@metric(name, unit, window)`: it is then in every run's table and `--json`, a "
           "campaign's rows and statistics, and here.", "",
           "| metric | unit | window | definition |", "|---|---|---|---|"]
    for entry in of_kind("series"):
        out.append(f"| `{entry.name}` | {entry.unit} | {entry.window} | {_cell(entry.doc)} |")
    out += ["", "## Diagnosis metrics", "",
            "All undefined (`-` in the table, `null` in `--json`) without a `diagnosis` section.", "",
            "| metric | unit | window | definition |", "|---|---|---|---|"]
    for entry in of_kind("diagnosis"):
        out.append(f"| `{entry.name}` | {entry.unit} | {entry.window} | {_cell(entry.doc)} |")
    out += ["", "## The `metrics` section", "", *_gains_table(MetricsSpec), ""]
    return "\n".join(out)


# ------------------------------------------------------------------------------------------------- pages


def _scenario() -> str:
    from ftc_mj.scenario.definition import ScenarioSpec
    return schema_page("Scenario file", "A scenario file (`scenarios/*.yaml`) is one `ScenarioSpec`; unknown "
                       "keys are errors. Generated from the pydantic models; how to write one: "
                       "[write a scenario](../tutorials/scenario.md).", ScenarioSpec)


def _campaign() -> str:
    from ftc_mj.campaign.schema import CampaignSpec
    return schema_page("Campaign file", "A campaign file (`campaigns/*.yaml`) is one `CampaignSpec`. Generated "
                       "from the pydantic models; how to use one: [campaigns and tuning]"
                       "(../tutorials/campaigns.md).", CampaignSpec)


def _tuning() -> str:
    from ftc_mj.tuning.schema import TuningSpec
    return schema_page("Tuning file", "A tuning file (`tuning/*.yaml`) is one `TuningSpec`. Generated from "
                       "the pydantic models; how to use one: [campaigns and tuning](../tutorials/campaigns.md).",
                       TuningSpec)


def _bench() -> str:
    from ftc_mj.ranking.entries import BenchSpec
    return schema_page("Benchmark entries file", "The file of entries `ftc-mj bench` takes is one `BenchSpec`. "
                       "Generated from the pydantic models; how to use it: [the benchmark]"
                       "(../tutorials/benchmark.md).", BenchSpec)


#: Generated page (relative to docs/) -> the function that writes it.
PAGES: dict[str, Callable[[], str]] = {
    "reference/scenario.md": _scenario,
    "reference/campaign.md": _campaign,
    "reference/tuning.md": _tuning,
    "reference/bench.md": _bench,
    "reference/commands.md": commands_page,
    "reference/methods.md": methods_page,
    "reference/metrics.md": metrics_page,
}


def on_files(files, config):  # the MkDocs hook
    from mkdocs.structure.files import File

    for path, write in PAGES.items():
        files.append(File.generated(config, path, content=write()))
    return files


# ----------------------------------------------------------------------------------------------- the package tree

#: Where the architecture page takes the tree of the package, generated when the site is built.
TREE_MARK = "<!-- the package tree, generated -->"
PACKAGE = HERE.parents[1] / "ftc_mj"


def _summary(path: Path) -> str:
    """A module's (or package's) docstring up to its first full stop or colon, roles and markup dropped."""
    import ast

    doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
    doc = re.sub(r":\w+:`~?([^`]+)`", lambda m: m.group(1).rsplit(".", 1)[-1], " ".join(doc.split()))
    doc = doc.replace("``", "`")
    # The first full stop, colon or semicolon that ends a phrase, not an abbreviation's ("eq. (5.6)", "Fig. 2").
    not_after = r"(?<!\beq\.)(?<!\beqs\.)(?<!\bFig\.)(?<!\be\.g\.)(?<!\bi\.e\.)(?<!\.\.\.)"
    first = re.split(not_after + r"(?<=[.:;])\s", doc, maxsplit=1)[0]
    first = first.rstrip(".:;")
    return first if len(first) <= 90 else first[:87].rsplit(" ", 1)[0] + " ..."


def package_modules(root: Path = PACKAGE) -> list[str]:
    """Every subpackage (``name/``) and module (``name.py``) of the package, as paths relative to it, in tree
    order (a package's modules, then its subpackages); ``__init__.py`` and ``__main__.py`` stand for their
    package."""
    out: list[str] = []

    def walk(folder: Path, prefix: str) -> None:
        for module in sorted(folder.glob("*.py")):
            if not module.name.startswith("__"):
                out.append(prefix + module.name)
        for package in sorted(p for p in folder.iterdir() if (p / "__init__.py").is_file()):
            out.append(prefix + package.name + "/")
            walk(package, prefix + package.name + "/")

    walk(root, "")
    return out


def package_tree(root: Path = PACKAGE) -> str:
    """The package as an indented tree, each entry with the first phrase of its docstring."""
    lines = [f"{root.name}/"]
    for entry in package_modules(root):
        depth = entry.rstrip("/").count("/") + 1
        name = entry.rstrip("/").rsplit("/", 1)[-1] + ("/" if entry.endswith("/") else "")
        source = root / entry / "__init__.py" if entry.endswith("/") else root / entry
        label = "  " * depth + name
        lines.append(f"{label:<34} {_summary(source)}".rstrip())
    return "```text\n" + "\n".join(lines) + "\n```"


_MATH = re.compile(r'<(span|div) class="arithmatex">\\[(\[](.*?)\\[)\]]</\1>', re.DOTALL)


#: ``\\lvert \\rvert \\lVert \\rVert``, which latex2mathml writes as one bare ``<mo>`` for both sides: a browser then
#: spaces them as binary operators (``| s |  =``). Each is carried through the conversion as a private-use
#: character and written back as an opening or closing fence (``|s| =``).
_FENCES = {"\\lvert": ("\ue000", "prefix", "&#x0007C;"), "\\rvert": ("\ue001", "postfix", "&#x0007C;"),
           "\\lVert": ("\ue002", "prefix", "&#x02016;"), "\\rVert": ("\ue003", "postfix", "&#x02016;")}


def mathml(html: str) -> str:
    """The pages' mathematics (``pymdownx.arithmatex``'s generic output, ``\\(x\\)`` and ``\\[x\\]``) as MathML
    (``latex2mathml``), which browsers render without a script: the site needs no network, no JavaScript."""
    import html as entities

    from latex2mathml.converter import convert

    def render(match: re.Match) -> str:
        tex = entities.unescape(match.group(2))
        for command, (mark, _, _) in _FENCES.items():
            tex = re.sub(r"(?<!\\left)(?<!\\right)" + re.escape(command) + r"(?![A-Za-z])", mark, tex)
        out = convert(tex, display="block" if match.group(1) == "div" else "inline")
        for mark, form, glyph in _FENCES.values():
            out = out.replace(f"<mi>{mark}</mi>", f'<mo fence="true" form="{form}" stretchy="false">{glyph}</mo>')
        return out

    return _MATH.sub(render, html)


def on_page_content(html, page, config, files):  # the MkDocs hook
    return mathml(html)


def on_page_markdown(markdown, page, config, files):  # the MkDocs hook
    if TREE_MARK in markdown:
        markdown = markdown.replace(TREE_MARK, package_tree())
    return markdown
