"""Reading a scenario file: :func:`load_scenario`, which reads a scenario and its bases
(:mod:`ftc_mj.config.inheritance`), applies the overrides, validates
(:class:`~ftc_mj.scenario.definition.ScenarioSpec`) and compiles (:func:`~ftc_mj.scenario.definition.compile_scenario`).

A scenario is untrusted input. It is read with a ``yaml.SafeLoader``, checked against a strict pydantic schema
(unknown keys are errors), its expressions are parsed by :mod:`ftc_mj.config.expressions` (never evaluated as
Python), and every plugin's gains are validated by the plugin's own schema. Any problem raises
:class:`~ftc_mj.config.errors.InputError` naming the file, the field path and what is wrong; the file is the
one that wrote the value (the scenario or one of its bases).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from ftc_mj.config.errors import InputError, validate
from ftc_mj.config.inheritance import resolve_bases
from ftc_mj.config.yaml import apply_override, set_path, unshared
from ftc_mj.robot.model import model_files
from ftc_mj.scenario.definition import Scenario, ScenarioSpec, compile_scenario

#: The scenario fields that hold a path relative to the scenario file (:func:`ftc_mj.robot.model.load_robot`):
#: written in a base in another folder, they are rewritten to keep naming the same file.
FILE_RELATIVE_FIELDS = ("robot.model", "log.file")


def _method_of_type(key: str) -> tuple[str, ...] | None:
    """The path of the method whose ``type`` ``key`` sets (a variant's observer or controller, or a monitor),
    else None."""
    parts = tuple(key.split("."))
    if len(parts) < 4 or parts[0] != "variants" or parts[-1] != "type":
        return None
    method = parts[:-1]
    return method if method[-1] in ("observer", "controller") or method[-2] == "monitors" else None


def _lookup(raw: Any, path: Sequence[str]) -> Any:
    for part in path:
        raw = raw.get(part) if isinstance(raw, dict) else None
    return raw


def _drop_replaced_gains(raw: dict[str, Any], keys: Sequence[str], types_before: Mapping[tuple[str, ...], Any]) -> None:
    """A method whose ``type`` an override changes keeps only the gains the overrides set (the file's are those
    of the method it replaces): the new method starts from its own defaults, and the gains it has none for
    are named in one line (:func:`ftc_mj.methods.registry.compile_method`)."""
    for method, before in types_before.items():
        node = _lookup(raw, method)
        prefix = ".".join(method) + ".gains"
        if not isinstance(node, dict) or node.get("type") == before or prefix in keys:
            continue
        gains = node.get("gains") if isinstance(node.get("gains"), dict) else {}
        chosen = {key[len(prefix) + 1:].split(".")[0] for key in keys if key.startswith(prefix + ".")}
        node["gains"] = {name: value for name, value in gains.items() if name in chosen}


class UnknownVariant(InputError):
    """A variant to keep that the scenario does not have; ``name`` and the scenario's ``known`` variants let a
    caller that chose it (a campaign's ``variants``) name its own file and field."""

    def __init__(self, file: str, name: str, known: list[str]):
        self.name, self.known = name, known
        super().__init__(file, "variants", f"unknown variant {name!r} (known: {', '.join(known)})")


def load_scenario(
    path: str | Path, overrides: list[str] = (), duration: float | None = None, variants: list[str] = (),
    assignments: Mapping[str, Any] | None = None,
) -> Scenario:
    """Read, validate and compile a scenario file.

    Args:
        path: the YAML file.
        overrides: ``key.path=value`` strings (the command line's ``--set``), applied before validation.
        assignments: values by dotted path (any YAML value, e.g. a whole fault), applied after ``overrides``:
            what a campaign sets.
        duration: overrides ``duration``.
        variants: keep only these variants (all when empty).

    Raises:
        InputError: on any problem, naming the file and the field.
    """
    path = Path(path)
    file = str(path)
    resolved = resolve_bases(path, FILE_RELATIVE_FIELDS)
    raw, provenance = resolved.raw, resolved.provenance
    keys = [item.partition("=")[0].strip() for item in overrides]
    types_before = {m: _lookup(raw, (*m, "type")) for m in map(_method_of_type, keys) if m is not None}
    for item in overrides:
        apply_override(raw, item, file)
        provenance.claim(tuple(item.partition("=")[0].strip().split(".")), file)
    _drop_replaced_gains(raw, keys, types_before)
    for key, value in (assignments or {}).items():
        set_path(raw, key, unshared(value), file)
        provenance.claim(tuple(key.split(".")), file)
    if duration is not None:
        raw["duration"] = duration
        provenance.claim(("duration",), file)
    spec = validate(ScenarioSpec, raw, file, file_of=provenance.file_of)
    if variants:
        unknown = [v for v in variants if v not in spec.variants]
        if unknown:
            raise UnknownVariant(file, unknown[0], list(spec.variants))
        spec.variants = {name: spec.variants[name] for name in variants}
    try:
        scenario = compile_scenario(path, spec, raw)
    except InputError as exc:
        # The compiler names the scenario file; a value it refuses may have been written by a base.
        writer = provenance.file_of(exc.field.split(".")) if exc.file == file and exc.field else file
        if writer == file:
            raise
        raise InputError(writer, exc.field, exc.problem) from None
    log = () if scenario.log is None else (scenario.log.file,)
    scenario.inputs = (*resolved.files, *model_files(scenario.model_path, file), *log)
    return scenario
