"""Reading untrusted YAML: the loader (a ``yaml.SafeLoader`` on which duplicate keys are errors and the
document is bounded), a file that must hold a mapping, and the ``--set`` override language (dotted paths, list
indices as numbers).

The document is bounded while it is composed, before anything is constructed: at most :data:`MAX_NODES`
nodes, an alias counting as the size of what it names (so that a few lines of anchors and aliases cannot
expand to a billion values in the schema, the merge or a copy), nesting at most :data:`MAX_NESTING` deep (the
composer, the constructor and the schema recurse), and no alias inside the node it names (a structure that
contains itself). The file itself is a regular file of at most :data:`MAX_FILE_BYTES`
(:func:`~ftc_mj.config.paths.read_input_text`). Anchors, aliases and merge keys (``<<: *name``) work as
usual within these bounds.

Every problem is an :class:`~ftc_mj.config.errors.InputError` naming the file and the field (``line N`` for
a problem of the YAML itself).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from ftc_mj.config.errors import InputError
from ftc_mj.config.paths import read_input_text

#: At most this many nodes in a document, aliases expanded (every scalar, list and mapping counts one). The
#: shipped scenarios and campaigns have a few thousand.
MAX_NODES = 200_000
#: At most this many levels of lists and mappings inside one another (the shipped files have fewer than ten).
MAX_NESTING = 64
#: At most this many bytes in a YAML file (the shipped files have a few kilobytes).
MAX_FILE_BYTES = 1 << 20


class _BoundedComposer(yaml.SafeLoader):
    """A SafeLoader whose composer refuses a document beyond :data:`MAX_NODES` (aliases counted as what they
    name) or :data:`MAX_NESTING`, or with an alias inside its own anchor, before anything is constructed."""

    def __init__(self, stream: str):
        super().__init__(stream)
        self._sizes: dict[int, int] = {}  # id(node) -> its size, aliases expanded, once composed
        self._nesting = 0
        self._total = 0

    def compose_node(self, parent: yaml.Node | None, index: Any) -> yaml.Node:
        if self.check_event(yaml.AliasEvent):
            event = self.peek_event()
            node = super().compose_node(parent, index)
            size = self._sizes.get(id(node))
            if size is None:
                raise yaml.composer.ComposerError(None, None, f"alias *{event.anchor} is inside the node it names "
                                                  "(a structure that contains itself)", event.start_mark)
            self._count(size, event.start_mark)
            return node
        event = self.peek_event()
        start, collection = event.start_mark, not isinstance(event, yaml.ScalarEvent)
        self._nesting += collection
        if self._nesting > MAX_NESTING:
            raise yaml.composer.ComposerError(None, None, f"lists and mappings nested more than {MAX_NESTING} deep",
                                              start)
        before = self._total
        node = super().compose_node(parent, index)
        self._nesting -= collection
        self._count(1, start)
        self._sizes[id(node)] = self._total - before
        return node

    def _count(self, size: int, mark: yaml.Mark) -> None:
        self._total += size
        if self._total > MAX_NODES:
            raise yaml.composer.ComposerError(None, None, f"more than {MAX_NODES} values (aliases expanded): "
                                              "too large for an input file", mark)


class _UniqueKeyLoader(_BoundedComposer):
    """safe_load that rejects duplicate keys instead of silently keeping the last one, on a bounded document."""


def _construct_mapping(loader: yaml.SafeLoader, node: yaml.MappingNode, deep: bool = False) -> dict:
    seen = set()
    for key_node, _ in node.value:
        if key_node.tag == "tag:yaml.org,2002:merge":  # "<<: *anchor": merged keys may be overridden
            continue
        key = loader.construct_object(key_node, deep=deep)
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f"duplicate key {key!r}", key_node.start_mark
            )
        seen.add(key)
    return loader.construct_mapping(node, deep)


_UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)


def read_yaml_mapping(path: Path, what: str, file: str | None = None) -> dict:
    """A YAML file that must hold a mapping (duplicate keys are errors), for ``what`` ("a scenario"); errors
    name it ``file`` (default: ``path`` as given)."""
    file = str(path) if file is None else file
    raw = load_bounded(read_input_text(path, MAX_FILE_BYTES, file), file)
    if not isinstance(raw, dict):
        raise InputError(file, "", f"{what} must be a YAML mapping")
    return raw


def load_bounded(text: str, file: str, field: str = "") -> Any:
    """The YAML document ``text`` (safe, duplicate keys refused, bounded: see the module), or the one-line
    :class:`InputError` naming ``file`` and ``line N`` (after ``field``, e.g. a ``--set`` key, when given)."""
    try:
        return yaml.load(text, Loader=_UniqueKeyLoader)  # noqa: S506 - a SafeLoader subclass
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = ", ".join(p for p in (field, f"line {mark.line + 1}" if mark is not None else "") if p)
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise InputError(file, where, f"invalid YAML: {problem}") from None
    except RecursionError:  # a bound above should come first; never a traceback
        raise InputError(file, field, "invalid YAML: nested too deeply") from None


def unshared(node: Any) -> Any:
    """A copy in which no two places share an object: YAML aliases (``*name``) load as one shared dict, and an
    override of one variant must not change the others."""
    if isinstance(node, dict):
        return {key: unshared(value) for key, value in node.items()}
    if isinstance(node, list):
        return [unshared(value) for value in node]
    return node


def apply_override(raw: dict, item: str, file: str) -> None:
    key, sep, value_text = item.partition("=")
    key = key.strip()
    if not sep or not key:
        raise InputError(file, f"--set {item}", "expected key.path=value")
    try:
        value = yaml.load(value_text, Loader=_UniqueKeyLoader)  # noqa: S506 - a SafeLoader subclass, bounded
    except yaml.YAMLError as exc:
        problem = getattr(exc, "problem", None) or "not valid YAML"
        raise InputError(file, key, f"--set value {value_text[:80]!r} is not a valid YAML value: {problem}") from None
    set_path(raw, key, value, file)


def set_path(raw: dict, key: str, value: Any, file: str) -> None:
    """Set the field at the dotted path ``key`` (list indices as numbers) of a scenario's raw content."""
    parts = key.split(".")
    node: Any = raw
    for depth, part in enumerate(parts):
        last = depth == len(parts) - 1
        if isinstance(node, list):
            if not part.isdigit() or int(part) >= len(node):
                raise InputError(file, key, f"--set: {part!r} is not an index of the list at this level")
            index: Any = int(part)
        elif isinstance(node, dict):
            index = part
            if not last and index not in node:
                node[index] = {}
        else:
            raise InputError(file, key, f"--set: {'.'.join(parts[:depth])!r} is not a mapping or list")
        if last:
            node[index] = value
        else:
            node = node[index]
