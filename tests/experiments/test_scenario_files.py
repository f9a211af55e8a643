"""Every shipped scenario file loads and every one of its variants (and monitors) runs (a short run); the
fragments of scenarios/bases/ are not scenarios, and each is some scenario's base."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ftc_mj import load_scenario, run_scenario
from ftc_mj.config.yaml import read_yaml_mapping
from ftc_mj.robot.packages import resolve_package_uri

#: whole-scenario closed-loop experiments
pytestmark = pytest.mark.slow

FOLDER = Path(__file__).resolve().parents[2] / "scenarios"
SCENARIOS = sorted(FOLDER.glob("*.yaml"))
#: Shared fragments that scenarios name as their ``base``.
FRAGMENTS = FOLDER / "bases"
#: Every scenario file, in every folder but the fragments'.
ALL = sorted(path for path in FOLDER.rglob("*.yaml") if FRAGMENTS not in path.parents)


def test_the_five_experiments_are_shipped() -> None:
    names = {path.stem for path in SCENARIOS}
    assert {"two_link_do", "two_link_tosmo_simple", "two_link_tosmo_complex", "puma_disturbance",
            "puma_fault"} <= names


@pytest.mark.parametrize("path", SCENARIOS, ids=[path.stem for path in SCENARIOS])
def test_every_variant_runs(path: Path) -> None:
    scenario = load_scenario(path, duration=0.3)
    assert scenario.name == path.stem
    assert scenario.output_path == Path(f"recordings/{path.stem}.rrd")
    results = run_scenario(scenario, record_poses=False)
    assert [r.name for r in results if "." not in r.name] == [variant.name for variant in scenario.variants]
    for result in results:
        assert result.status == "ok", result.name
        assert np.isfinite(result.tau).all() and np.isfinite(result.luaf_hat).all(), result.name


@pytest.mark.parametrize("path", ALL, ids=[str(path.relative_to(FOLDER)) for path in ALL])
def test_every_scenario_file_loads_under_its_own_name(path: Path) -> None:
    model = read_yaml_mapping(path, "a scenario").get("robot", {}).get("model", "")
    if model.startswith("package://") and resolve_package_uri(model) is None:
        pytest.skip(f"{model} is not installed (the robots extra: pip install -e \".[robots]\")")
    scenario = load_scenario(path, duration=0.1)
    assert scenario.name == path.stem
    assert scenario.output_path == Path(f"recordings/{path.stem}.rrd")
    assert "base" not in scenario.written()


def test_every_fragment_is_the_base_of_a_scenario() -> None:
    named = set()
    for path in ALL + sorted(FRAGMENTS.glob("*.yaml")):
        base = read_yaml_mapping(path, "a scenario").get("base")
        if base is not None:
            named.add((path.parent / base).resolve())
    fragments = {path.resolve() for path in FRAGMENTS.glob("*.yaml")}
    assert fragments and fragments <= named
