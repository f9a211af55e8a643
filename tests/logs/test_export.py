"""The round trip: a simulated run exported as a log (``--export-log``) and replayed through the same observer
gives the closed-loop run's estimates: the log path is the same observer."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from ftc_mj import load_scenario, run_scenario
from ftc_mj.cli.run import main
from ftc_mj.logs.export import csv_log_section, variant_path
from ftc_mj.logs.trajectory import joint_names
from ftc_mj.scenario.definition import SIMULATION_ONLY

ROOT = Path(__file__).resolve().parents[2]


def _replay_scenario(tmp_path: Path, scenario, variant: str, log_file: Path) -> Path:
    """The scenario's variant ``variant`` (its observer and monitors, their initial estimates, the nominal
    model) on the exported log instead of the simulated robot."""
    raw = {key: value for key, value in scenario.written().items()
           if key not in SIMULATION_ONLY and key not in ("base", "duration", "control_dt", "figures", "diagnosis")}
    robot = dict(raw["robot"])
    robot["model"] = str(scenario.model_path)
    robot.pop("sensors", None)
    own = raw["variants"][variant]
    raw.update(name="replay", robot=robot, variants={variant: {key: own[key] for key in own
                                                               if key in ("observer", "monitors", "observer_initial")}},
               log=csv_log_section(log_file, joint_names(scenario.model), scenario.spec.control_dt,
                                   scenario.measures_velocity))
    path = tmp_path / "replay.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path


@pytest.mark.slow  # a closed-loop run of seconds
@pytest.mark.parametrize("file, variant", [
    ("scenarios/two_link_do.yaml", "a_nftsmc_do"),        # DO on the tachometers, SOSMO and ESO as monitors
    ("scenarios/puma_fault.yaml", "proposed"),            # HS-TOSMO on positions, an actuator fault acting
])
def test_replaying_an_exported_run_gives_its_estimates(tmp_path, file, variant):
    path = ROOT / file
    assert main([str(path), "--duration", "0.4", "--variant", variant, "--no-record", "--quiet",
                 "--export-log", str(tmp_path / "run.csv")]) == 0
    scenario = load_scenario(path, duration=0.4, variants=[variant])
    closed = run_scenario(scenario, record_poses=False)
    replay = load_scenario(_replay_scenario(tmp_path, scenario, variant, variant_path(tmp_path / "run.csv", variant)))
    replayed = run_scenario(replay, record_poses=False)
    assert [r.name for r in replayed] == [r.name for r in closed]
    assert replayed[0].controller == "log"
    for before, after in zip(closed, replayed):
        np.testing.assert_array_equal(after.t, before.t)
        np.testing.assert_array_equal(after.q_meas, before.q_meas)
        np.testing.assert_array_equal(after.tau, before.tau)
        np.testing.assert_array_equal(after.qd_hat, before.qd_hat)  # bit for bit
        np.testing.assert_array_equal(after.luaf_hat, before.luaf_hat)
        assert np.all(np.isnan(after.luaf_true)) and np.all(np.isnan(after.q_true))  # a log has no truth


def test_mcap_export_replays_its_readings(tmp_path):
    path = ROOT / "scenarios/two_link_do.yaml"
    assert main([str(path), "--duration", "0.1", "--variant", "smc", "--no-record", "--quiet",
                 "--export-log", str(tmp_path / "run.mcap")]) == 0
    scenario = load_scenario(path, duration=0.1, variants=["smc"])
    closed = run_scenario(scenario, record_poses=False)[0]
    section = {"file": str(tmp_path / "run.smc.mcap"), "format": "mcap", "steps": {"resample": 0.001}}
    raw = {"name": "replay", "robot": {"model": str(scenario.model_path)}, "log": section,
           "variants": {"do": {"observer": scenario.written()["variants"]["smc"]["observer"]}},
           "metrics": {"window_start": 0.0, "estimation_window_start": 0.0}}
    (tmp_path / "replay.yaml").write_text(yaml.safe_dump(raw))
    log = load_scenario(tmp_path / "replay.yaml").log
    # Stamps in whole nanoseconds: the grid instants fall a rounding off the samples, interpolated.
    np.testing.assert_allclose(log.position, closed.q_meas, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(log.velocity, closed.qd_meas, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(log.torque, closed.tau, rtol=1e-12)
