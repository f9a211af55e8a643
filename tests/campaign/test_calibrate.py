"""Thresholds calibrated per arm (ftc_mj.campaign.calibrate, ``ftc-mj calibrate``).

On scenarios/faults/puma_bias.yaml (Chapter 5's method on the PUMA560 with noisy, quantised encoders), 8 s
healthy runs: thresholds calibrated on 24 seeds for a per-run false-alarm rate of 0.2 per joint hold that
rate on 40 fresh seeds (pooled over the three joints, 120 joint-runs: measured 0.217 (26 of 120); the bound
[0.08, 0.35] is the binomial +-3 sd, 0.037, plus the fit's error on 24 runs); the statistic S predicts exactly
the alarms the scenario's own diagnoser raises with the calibrated file; and the bias fault is still detected.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from ftc_mj.campaign.calibrate import calibrate, exceedance_statistics, gumbel_quantile, healthy_scenario
from ftc_mj.cli.main import main
from ftc_mj.engine.members import members_from_overrides
from ftc_mj.engine.runner import run_batch, run_scenario
from ftc_mj.analysis.metrics import compute_metrics
from ftc_mj.scenario.loading import load_scenario

#: campaigns, calibrations, tunings and benchmarks of closed-loop runs
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
BIAS = ROOT / "scenarios" / "faults" / "puma_bias.yaml"
RATE = 0.2
HELD_OUT = list(range(7000, 7040))


@pytest.fixture(scope="module")
def calibration():
    return calibrate(BIAS, runs=24, false_alarm_rate=RATE, duration=8.0)


def test_gumbel_quantile_of_gumbel_samples():
    rng = np.random.default_rng(0)
    samples = rng.gumbel(2.0, 0.5, size=(20000, 2))
    expected = 2.0 - 0.5 * np.log(-np.log(1 - 0.01))
    np.testing.assert_allclose(gumbel_quantile(samples, 0.01), expected, rtol=0.02)


def test_healthy_scenario_has_no_faults_and_the_bound_alone():
    healthy = healthy_scenario(BIAS, duration=8.0)
    assert healthy.actuator_faults == [] and healthy.fault_onsets == []
    assert not any(term.kind == "fault" for term in healthy.terms)
    assert healthy.diagnoser.k == 0 and not healthy.diagnoser.fixed.any() and healthy.diagnoser.bound is not None


def test_calibrated_thresholds_hold_the_rate_on_fresh_seeds(calibration):
    assert calibration.seeds == list(range(1001, 1025)) and calibration.diverged == {"proposed": 0}
    healthy = healthy_scenario(BIAS, duration=8.0)
    held, diverged = exceedance_statistics(healthy, HELD_OUT)
    assert diverged == {"proposed": 0}
    alarms = held["proposed"] > calibration.thresholds  # (40 runs, 3 joints)
    pooled = alarms.mean()
    assert 0.08 <= pooled <= 0.35, pooled
    assert (alarms.mean(axis=0) <= 0.5).all(), alarms.mean(axis=0)


def test_statistic_predicts_the_diagnosers_alarms(calibration, tmp_path):
    fragment = tmp_path / "calibrated.yaml"
    assert main(["calibrate", str(BIAS), "--false-alarm-rate", str(RATE), "--runs", "24", "--duration", "8",
                 "--out", str(fragment)]) == 0
    document = yaml.safe_load(fragment.read_text(encoding="utf-8"))
    np.testing.assert_allclose(document["diagnosis"]["threshold"]["fixed"], calibration.thresholds, rtol=1e-5)
    seeds = HELD_OUT[:8]
    scenario = load_scenario(fragment, duration=8.0, assignments={"actuator_faults": []})
    outcomes = run_batch(scenario, members_from_overrides(scenario, [{"seed": s} for s in seeds]))
    raised = np.array([np.asarray(o.metrics["false_alarms"]) > 0 for o in outcomes])
    healthy = healthy_scenario(BIAS, duration=8.0)
    held, _ = exceedance_statistics(healthy, seeds)
    thresholds = np.array(document["diagnosis"]["threshold"]["fixed"])
    np.testing.assert_array_equal(raised, held["proposed"] > thresholds)


def test_the_fault_is_still_detected(calibration, tmp_path):
    overrides = [f"diagnosis.threshold.fixed=[{', '.join(repr(float(t)) for t in calibration.thresholds)}]",
                 "diagnosis.threshold.k=0"]
    scenario = load_scenario(BIAS, overrides=overrides)
    result = run_scenario(scenario, record_poses=False)[0]
    metrics = compute_metrics(result, scenario.spec.metrics, scenario.fault_onsets, scenario.joint_fault_onsets)
    assert metrics["missed_detection"][2] == 0
    assert 0 <= metrics["detection_delay"][2] < 0.5


def test_thresholds_only_is_a_base_for_the_scenario(calibration, tmp_path):
    fragment = tmp_path / "thresholds.yaml"
    assert main(["calibrate", str(BIAS), "--false-alarm-rate", str(RATE), "--runs", "24", "--duration", "8",
                 "--thresholds-only", "--out", str(fragment)]) == 0
    document = yaml.safe_load(fragment.read_text(encoding="utf-8"))
    assert set(document) == {"diagnosis"}  # no base: a scenario names it as its own
    np.testing.assert_allclose(document["diagnosis"]["threshold"]["fixed"], calibration.thresholds, rtol=1e-5)
    for arm in ("ur5e", "panda"):  # the shipped arms take their thresholds from such a file
        shipped = yaml.safe_load((ROOT / "scenarios" / "bases" / f"{arm}_thresholds.yaml")
                                 .read_text(encoding="utf-8"))
        scenario = load_scenario(ROOT / "scenarios" / "robots" / f"{arm}_fault.yaml", duration=0.1)
        np.testing.assert_array_equal(scenario.diagnoser.fixed, shipped["diagnosis"]["threshold"]["fixed"])
        assert scenario.diagnoser.k == 0 and shipped["diagnosis"]["threshold"]["fixed"] != [10.0] * 6


def test_bad_options_are_one_line(capsys):
    assert main(["calibrate", str(BIAS), "--false-alarm-rate", "1.5", "--runs", "4"]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and "--false-alarm-rate" in err
    assert main(["calibrate", str(ROOT / "scenarios" / "two_link_do.yaml"), "--false-alarm-rate", "0.1"]) == 2
    assert "diagnosis" in capsys.readouterr().err


def test_on_a_log_the_threshold_is_the_margin_times_its_largest_residual_at_least_the_floor():
    """One healthy run, the log: per joint margin x S of the momentum observer, at least the floor (3 N m on
    the UR10e's wrists); a margin below 1 is refused."""
    from ftc_mj.campaign.calibrate import calibrate_log
    from ftc_mj.config.errors import InputError

    free = ROOT / "scenarios" / "real" / "ur10e_free_motion.yaml"
    calibration = calibrate_log(free, margin=1.1, variants=["momentum"])
    statistic, _ = exceedance_statistics(healthy_scenario(free, variants=["momentum"]), [0])
    expected = np.maximum(1.1 * statistic["momentum"][0], [0, 0, 0, 3, 3, 3])
    np.testing.assert_allclose(calibration.thresholds, expected)
    assert np.all(calibration.thresholds[3:] == 3.0) and calibration.thresholds[1] > 10
    with pytest.raises(InputError, match="--margin"):
        calibrate_log(free, margin=0.9)
