"""``robot.builtin``: a shipped robot named without a path, so a scenario copied anywhere runs; a relative model
path that fails names where it was looked for."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from ftc_mj import load_scenario
from ftc_mj.config.errors import InputError

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "puma_fault.yaml"


def _copy(folder: Path, robot: dict) -> Path:
    raw = yaml.safe_load(SCENARIO.read_text())
    raw["robot"] = {**{k: v for k, v in raw["robot"].items() if k != "model"}, **robot}
    path = folder / "copied.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path


def test_a_copied_scenario_runs_anywhere_with_a_builtin_robot(tmp_path):
    copied = load_scenario(_copy(tmp_path, {"builtin": "puma560"}), duration=0.01)
    original = load_scenario(SCENARIO, duration=0.01)
    assert copied.model.nv == original.model.nv == 3
    assert (copied.model.body_mass == original.model.body_mass).all()


@pytest.mark.parametrize("robot, message", [
    ({"builtin": "puma"}, "robot.builtin: no shipped robot 'puma' (shipped: "),
    ({"builtin": "../models/puma560.xml"}, "robot.builtin: no shipped robot"),
    ({"builtin": "puma560", "model": "x.xml"}, "robot.builtin: give one of robot.builtin, robot.model"),
    ({"model": "../models/puma560.xml"}, "robot.model: model file '../models/puma560.xml' not found: looked for"),
])
def test_bad_robot_names_say_what_and_where(tmp_path, robot, message):
    with pytest.raises(InputError) as error:
        load_scenario(_copy(tmp_path, robot), duration=0.01)
    assert message in str(error.value)
    if "looked for" in message:
        assert str(tmp_path.parent / "models" / "puma560.xml") in str(error.value)
