"""Chapter 5 end to end: scenarios/puma_fault.yaml, the full 30 s, through the command line.

Bounds are set from measured values (in the comments) with a margin of about 3x, tight enough that a broken
compensation (which gives the uncompensated law's ~6e-5 rad) or a broken observer fails them. The tracking-error bounds leave room for the 1 ms physics step (6.7e-6 rad).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from ftc_mj.engine.runner import simulate_variant
from ftc_mj.outputs.recording import read_series
from ftc_mj.run import main
from ftc_mj.spec.loading import load_scenario

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "puma_fault.yaml"


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, Path]:
    out = tmp_path_factory.mktemp("puma_fault")
    status = main([str(SCENARIO), "--quiet", "--out", str(out / "rec.rrd"), "--json", str(out / "metrics.json")])
    assert status == 0
    document = json.loads((out / "metrics.json").read_text())
    return document, out / "rec.rrd"


@pytest.fixture(scope="module")
def metrics(run: tuple[dict, Path]) -> dict[str, dict[str, np.ndarray]]:
    return {
        name: {metric: np.array(values, dtype=float) for metric, values in variant["metrics"].items()}
        for name, variant in run[0]["variants"].items()
    }


def test_all_variants_ok(run: tuple[dict, Path]) -> None:
    variants = run[0]["variants"]
    assert list(variants) == ["proposed", "nftsmc_tosmo", "nftsmc_sosmo", "nftsmc"]
    assert all(v["status"] == "ok" and v["diverged_at"] is None for v in variants.values())


def test_proposed_tracking_after_convergence(metrics: dict) -> None:
    proposed = metrics["proposed"]
    # Measured: rms 3.4e-6 / 3.8e-6 / 8.9e-7 rad, max 7.4e-6 / 8.2e-6 / 3.4e-6 rad (fault at 10 s included).
    assert np.all(proposed["rms_error_converged"] < 1.2e-5)
    assert np.all(proposed["max_error_converged"] < 2.5e-5)
    # Measured: 0.66 s on every joint from an initial error of 0.5 rad.
    assert np.all(proposed["convergence_time"] < 1.0)


def test_proposed_estimates_after_convergence(metrics: dict) -> None:
    proposed = metrics["proposed"]
    # Measured: velocity 3.1e-4 / 3.3e-4 / 1.3e-4 rad/s; LUaF 0.060 / 0.069 / 0.054 rad/s^2.
    assert np.all(proposed["rms_velocity_error"] < 1e-3)
    assert np.all(proposed["rms_luaf_error"] < 0.2)


def test_tosmo_compensation_beats_uncompensated(metrics: dict) -> None:
    # Fig. 5.6/5.7: measured rms error 3.4e-6 vs 6.3e-5 rad; chattering 9.0e3 vs 1.25e5 N m/s (joint 1).
    uncompensated = metrics["nftsmc"]
    for name in ("proposed", "nftsmc_tosmo"):
        assert np.all(metrics[name]["rms_error_converged"] < 0.3 * uncompensated["rms_error_converged"]), name
        assert np.all(metrics[name]["chattering"] < 0.2 * uncompensated["chattering"]), name
        assert np.all(metrics[name]["rms_torque"] < uncompensated["rms_torque"]), name


def test_high_speed_tosmo_converges_faster(metrics: dict) -> None:
    # Fig. 5.3: measured 0.25 / 0.21 / 0.38 s against 0.35 / 0.33 / 0.61 s for the TOSMO.
    fast, slow = metrics["proposed"]["observer_convergence_time"], metrics["nftsmc_tosmo"]["observer_convergence_time"]
    assert np.all(fast < 0.8 * slow)


def test_third_order_estimates_luaf_better_than_sosmo(metrics: dict) -> None:
    # Fig. 5.5: measured LUaF error 0.06 (TOSMOs) against 1.35 rad/s^2 (SOSMO, 10 ms filter).
    for name in ("proposed", "nftsmc_tosmo"):
        assert np.all(metrics[name]["rms_luaf_error"] < 0.2 * metrics["nftsmc_sosmo"]["rms_luaf_error"]), name


def test_recording_holds_what_the_runner_computed(run: tuple[dict, Path]) -> None:
    path = run[1]
    scenario = load_scenario(SCENARIO, variants=["proposed"])
    result = simulate_variant(scenario, scenario.variants[0])
    times, estimate = read_series(path, "/luaf/estimate/proposed")
    np.testing.assert_array_equal(estimate, result.luaf_hat.astype(np.float32))  # stored as float32
    np.testing.assert_allclose(times, result.t, atol=1e-9)
    for entity in ("/q/nftsmc", "/tracking_error/nftsmc_sosmo", "/velocity/true/nftsmc_tosmo", "/torque/proposed",
                   "/sliding/proposed", "/fault/proposed", "/luaf/true/proposed"):
        assert read_series(path, entity)[1].shape == (30000, 3), entity
