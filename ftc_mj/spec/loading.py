"""Reading a scenario file: the YAML loader (duplicate keys are errors), the ``--set`` override language, and
:func:`load_scenario`, which reads, overrides, validates (:class:`~ftc_mj.spec.scenario.ScenarioSpec`) and
compiles (:func:`~ftc_mj.spec.scenario.compile_scenario`) a scenario.

A scenario is untrusted input. It is read with a ``yaml.SafeLoader``, checked against a strict pydantic schema
(unknown keys are errors), its expressions are parsed by :mod:`ftc_mj.config.expressions` (never evaluated as
Python), and every plugin's gains are validated by the plugin's own schema. Any problem raises
:class:`~ftc_mj.config.errors.InputError` naming the file, the field path and what is wrong.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from ftc_mj.config.errors import InputError, validation_error
from ftc_mj.config.yaml import apply_override, read_yaml_mapping, set_path, unshared
from ftc_mj.spec.scenario import Scenario, ScenarioSpec, compile_scenario


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
    raw = read_yaml_mapping(path, "a scenario")
    raw = unshared(raw)
    for item in overrides:
        apply_override(raw, item, file)
    for key, value in (assignments or {}).items():
        set_path(raw, key, unshared(value), file)
    if duration is not None:
        raw["duration"] = duration
    try:
        spec = ScenarioSpec.model_validate(raw)
    except ValidationError as exc:
        raise validation_error(file, "", exc) from None
    if variants:
        unknown = [v for v in variants if v not in spec.variants]
        if unknown:
            raise InputError(file, "variants", f"unknown variant {unknown[0]!r} (known: {', '.join(spec.variants)})")
        spec.variants = {name: spec.variants[name] for name in variants}
    scenario = compile_scenario(path, spec)
    scenario.raw = raw
    return scenario
