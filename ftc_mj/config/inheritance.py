"""Scenario inheritance: a file that names ``base: PATH`` is its base file with the file's own fields merged
over it, resolved before validation.

The merge rules: mappings merge key by key, lists and scalars replace, and an explicit ``null`` removes the
key (a file without ``base`` is read as written, its nulls included). ``PATH`` is relative to the file that
writes it, and a base may have its own ``base``, up to :data:`MAX_DEPTH` files. A path field that is
relative to its file (the schema says which: ``robot.model``) keeps naming what it named in the base: it is
rewritten relative to the file that was asked for.

Files are untrusted: a cycle, a missing base file, a chain longer than :data:`MAX_DEPTH` and a ``base`` that
is not a path are each one :class:`~ftc_mj.config.errors.InputError` naming the file that wrote ``base``.
The merge keeps a :class:`Provenance`, the file that wrote each value, so that a value the schema refuses
is reported against that file rather than against the file that inherited it.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path, PurePath
from typing import Any

from ftc_mj.config.errors import InputError
from ftc_mj.config.paths import input_file_problem
from ftc_mj.config.yaml import read_yaml_mapping, unshared

#: The key that names a file's base.
BASE = "base"
#: At most this many files in one chain (the file asked for and its bases).
MAX_DEPTH = 16


@dataclass
class Provenance:
    """The file that wrote each value of a merged scenario, by field path.

    Values are recorded as leaves: scalars and whole lists (a list is replaced, never merged, so one file
    wrote all of it). A field path is looked up by its longest recorded prefix; a path with none (e.g. a
    required field nobody wrote) belongs to ``default``, the file that was asked for.
    """

    default: str
    files: dict[tuple[str, ...], str] = field(default_factory=dict)

    def file_of(self, loc: Sequence[Any]) -> str:
        """The file that wrote the value at ``loc`` (keys and list indices, as pydantic's error locations)."""
        parts = tuple(str(part) for part in loc)
        for end in range(len(parts), 0, -1):
            found = self.files.get(parts[:end])
            if found is not None:
                return found
        return self.default

    def record(self, path: tuple[str, ...], value: Any, file: str) -> None:
        """``file`` wrote ``value`` at ``path``: it replaces whatever was recorded there or below."""
        self.forget(path)
        self._leaves(path, value, file)

    def claim(self, path: tuple[str, ...], file: str) -> None:
        """``file`` wrote everything at ``path`` and below (e.g. a ``--set`` override of the file asked for)."""
        self.forget(path)
        self.files[path] = file

    def forget(self, path: tuple[str, ...]) -> None:
        """Drop what is recorded at ``path`` and below it (the key was removed or replaced)."""
        n = len(path)
        for key in [key for key in self.files if key[:n] == path]:
            del self.files[key]

    def _leaves(self, path: tuple[str, ...], value: Any, file: str) -> None:
        if isinstance(value, dict) and value:
            for key, item in value.items():
                self._leaves(path + (str(key),), item, file)
        else:
            self.files[path] = file


@dataclass
class Resolved:
    """A scenario file with its bases merged in: ``raw`` is what the schema validates."""

    raw: dict
    provenance: Provenance
    #: Every file read: the file asked for, then its base, its base's base... (resolved paths).
    files: list[Path] = field(default_factory=list)


def resolve_bases(path: str | Path, relative_fields: Sequence[str] = (), what: str = "a scenario") -> Resolved:
    """Read ``path`` and the chain of its bases, and merge each file over its base.

    Args:
        path: the file asked for; errors name it as given.
        relative_fields: dotted paths of the fields that hold a path relative to their file
            (``robot.model``); in a base in another folder they are rewritten to stay right.
        what: what the file must be, for the error when it is not a mapping.

    Raises:
        InputError: a file that cannot be read, a ``base`` that is not a path, names a missing file or makes
            a cycle, or a chain of more than :data:`MAX_DEPTH` files.
    """
    path = Path(path)
    provenance = Provenance(str(path))
    files: list[Path] = []
    raw = _resolve(path, path.parent.resolve(), [], relative_fields, what, provenance, files)
    return Resolved(raw=raw, provenance=provenance, files=files)


def _resolve(path: Path, folder: Path, chain: list[Path], relative_fields: Sequence[str], what: str,
             provenance: Provenance, files: list[Path]) -> dict:
    """The merged content of ``path``; ``folder`` is the first file's folder (resolved), ``chain`` the
    resolved files that inherit from ``path``; every file read is appended to ``files``."""
    file = provenance.default if not chain else os.path.normpath(path)
    raw = unshared(read_yaml_mapping(path, what, file=file))
    files.append(path.resolve())
    if chain and path.parent.resolve() != folder:
        _rebase_paths(raw, path.parent, folder, relative_fields)
    if BASE not in raw:
        provenance.record((), raw, file)
        return raw
    base = raw.pop(BASE)
    if not isinstance(base, str) or not base.strip():
        raise InputError(file, BASE, "must be the path of a file (relative to this one)")
    chain = chain + [path.resolve()]
    if len(chain) >= MAX_DEPTH:
        raise InputError(file, BASE, f"more than {MAX_DEPTH} files in a chain of bases")
    base_path = path.parent / base
    if base_path.resolve() in chain:
        raise InputError(file, BASE, f"{base!r} makes a cycle: {base_path.resolve()} is this file or inherits "
                         "from it")
    problem = input_file_problem(base_path)
    if problem is not None:
        raise InputError(file, BASE, f"base file {base_path.resolve()} {problem}")
    merged = _resolve(base_path, folder, chain, relative_fields, what, provenance, files)
    return merge(merged, raw, file, provenance)


def merge(base: dict, override: dict, file: str, provenance: Provenance | None = None,
          prefix: tuple[str, ...] = ()) -> dict:
    """``override`` (written by ``file``) merged over ``base``: mappings key by key, lists and scalars
    replace, ``None`` removes the key. ``base`` is updated in place and returned."""
    for key, value in override.items():
        path = prefix + (str(key),)
        if value is None:
            base.pop(key, None)
            if provenance is not None:
                provenance.forget(path)
        elif isinstance(value, dict):
            below = base.get(key)
            if not isinstance(below, dict):
                below = {}
                if provenance is not None:
                    provenance.forget(path)
            base[key] = merge(below, value, file, provenance, path)
            if not base[key] and provenance is not None:  # an empty mapping is a value of its own
                provenance.record(path, base[key], file)
        else:
            base[key] = value
            if provenance is not None:
                provenance.record(path, value, file)
    return base


def _rebase_paths(raw: dict, own: Path, folder: Path, relative_fields: Sequence[str]) -> None:
    """Rewrite the path fields of a base's content, relative to its folder ``own``, to name the same files
    relative to ``folder`` (the first file's, resolved). The file a relative name means is the one
    :meth:`pathlib.Path.resolve` finds (symbolic links followed before ``..``), so the new name is made from
    resolved paths and means the same file from ``folder``."""
    for dotted in relative_fields:
        *parents, last = dotted.split(".")
        node: Any = raw
        for part in parents:
            node = node.get(part) if isinstance(node, dict) else None
        value = node.get(last) if isinstance(node, dict) else None
        if not isinstance(value, str) or not value or "://" in value or PurePath(value).is_absolute():
            continue
        target = (own / value).resolve()
        try:
            node[last] = os.path.relpath(target, folder)
        except ValueError:  # another drive: no relative name
            node[last] = str(target)
