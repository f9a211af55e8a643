"""Every shipped scenario file loads and every one of its variants (and monitors) runs (a short run)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ftc_mj import load_scenario, run_scenario

SCENARIOS = sorted((Path(__file__).resolve().parents[2] / "scenarios").glob("*.yaml"))


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
