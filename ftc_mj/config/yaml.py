"""Reading untrusted YAML: the loader (a ``yaml.SafeLoader`` on which duplicate keys are errors), a file that
must hold a mapping, and the ``--set`` override language (dotted paths, list indices as numbers).

Every problem is an :class:`~ftc_mj.config.errors.InputError` naming the file and the field.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from ftc_mj.config.errors import InputError


class _UniqueKeyLoader(yaml.SafeLoader):
    """safe_load that rejects duplicate keys instead of silently keeping the last one."""


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
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = "not UTF-8 text" if isinstance(exc, UnicodeDecodeError) else exc.strerror or str(exc)
        raise InputError(file, "", f"cannot read the file: {reason}") from None
    try:
        raw = yaml.load(text, Loader=_UniqueKeyLoader)  # noqa: S506 - a SafeLoader subclass
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise InputError(file, where, f"invalid YAML: {problem}") from None
    if not isinstance(raw, dict):
        raise InputError(file, "", f"{what} must be a YAML mapping")
    return raw


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
        value = yaml.safe_load(value_text)
    except yaml.YAMLError:
        raise InputError(file, key, f"--set value {value_text!r} is not a valid YAML scalar") from None
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
