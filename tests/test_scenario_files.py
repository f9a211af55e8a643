"""Every shipped scenario file loads and every one of its variants runs (a short run)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ftc_mj.engine.runner import simulate_variant
from ftc_mj.spec.loading import load_scenario

SCENARIOS = sorted((Path(__file__).resolve().parents[1] / "scenarios").glob("*.yaml"))


def test_the_five_experiments_are_shipped() -> None:
    names = {path.stem for path in SCENARIOS}
    assert {"two_link_do", "two_link_tosmo_simple", "two_link_tosmo_complex", "puma_disturbance",
            "puma_fault"} <= names


@pytest.mark.parametrize("path", SCENARIOS, ids=[path.stem for path in SCENARIOS])
def test_every_variant_runs(path: Path) -> None:
    scenario = load_scenario(path, duration=0.3)
    assert scenario.name == path.stem
    assert scenario.output_path == Path(f"recordings/{path.stem}.rrd")
    for variant in scenario.variants:
        result = simulate_variant(scenario, variant)
        assert result.status == "ok", variant.name
        assert np.isfinite(result.tau).all() and np.isfinite(result.luaf_hat).all(), variant.name
