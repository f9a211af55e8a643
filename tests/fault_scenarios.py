"""Helpers shared by the tests of faults, sensors, diagnosis and randomness: the fault scenarios
(scenarios/faults/) as plain data, written to tmp_path, loaded and run."""

from __future__ import annotations

import functools
import json
from pathlib import Path

import mujoco
import numpy as np
import pytest
import yaml

from ftc_mj.engine.runner import simulate_variant
from ftc_mj.results import VariantResult
from ftc_mj.config.errors import InputError
from ftc_mj.config.inheritance import resolve_bases
from ftc_mj.scenario.loading import load_scenario
from ftc_mj.scenario.definition import Scenario

ROOT = Path(__file__).resolve().parents[1]
FAULTS = ROOT / "scenarios" / "faults"
PUMA_MODEL = ROOT / "models" / "puma560.xml"


@functools.cache
def puma_model() -> mujoco.MjModel:
    """The PUMA 560 (three joints, ``joint1`` .. ``joint3``), loaded once: what the compile functions of
    ftc_mj.effects take to resolve joint selections."""
    return mujoco.MjModel.from_xml_path(str(PUMA_MODEL))


def scenario_data(name: str = "puma_loss_of_effectiveness", variants: tuple[str, ...] = ("proposed",)) -> dict:
    """A scenario of scenarios/faults/ as plain data (its bases merged in, aliases unshared), with an absolute
    model path and only the given variants."""
    data = json.loads(json.dumps(resolve_bases(FAULTS / f"{name}.yaml").raw))
    data["robot"]["model"] = str(PUMA_MODEL)
    data["variants"] = {key: data["variants"][key] for key in variants}
    data.pop("output", None)
    return data


def write(tmp_path: Path, data: dict, name: str = "scenario.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return path


def load(tmp_path: Path, data: dict, name: str = "scenario.yaml", **kwargs) -> Scenario:
    return load_scenario(write(tmp_path, data, name), **kwargs)


def run(tmp_path: Path, data: dict, name: str = "scenario.yaml", **kwargs) -> tuple[Scenario, VariantResult]:
    """Load and run the first variant."""
    scenario = load(tmp_path, data, name, **kwargs)
    return scenario, simulate_variant(scenario, scenario.variants[0])


def assert_input_error(tmp_path: Path, data: dict, field: str, fragment: str) -> None:
    """Loading ``data`` fails with one line naming the file, exactly ``field``, and a problem containing
    ``fragment``."""
    path = write(tmp_path, data)
    with pytest.raises(InputError) as info:
        load_scenario(path)
    assert (info.value.file, info.value.field) == (str(path), field), str(info.value)
    assert fragment in info.value.problem
    assert "\n" not in str(info.value)


def array_fields(result: VariantResult) -> dict[str, np.ndarray]:
    """Every array of a result, the diagnosis' included (prefixed ``diagnosis.``)."""
    arrays = {name: value for name, value in vars(result).items() if isinstance(value, np.ndarray)}
    if result.diagnosis is not None:
        arrays.update({f"diagnosis.{name}": value for name, value in vars(result.diagnosis).items()
                       if isinstance(value, np.ndarray)})
    return arrays
