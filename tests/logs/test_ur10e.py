"""The real UR10e's logs (data/ur10) through the shipped scenarios (models/ur10e, its friction identified by
the logs' source): the command's outputs without the metrics that need ground truth, the residuals' level in
free motion (what the identified friction leaves, and what it is without it, and with a sign error in the
torque scale), and the pushed arm's alarms scored against the labelled pushes (log.events)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from ftc_mj import load_scenario, run_scenario
from ftc_mj.campaign.calibrate import calibrate_log
from ftc_mj.cli.run import main
from ftc_mj.logs.events import event_metrics

ROOT = Path(__file__).resolve().parents[2]
FREE, PUSHED = ROOT / "scenarios/real/ur10e_free_motion.yaml", ROOT / "scenarios/real/ur10e_pushed.yaml"
CONSTANTS = [10.0, 10.6956, 8.4566, 9.0029, 9.48, 10.1232]
pytestmark = pytest.mark.slow  # real robot logs replayed through the observers

NO_FRICTION = ["nominal.friction.viscous=0", "nominal.friction.coulomb=0", "nominal.friction.offset=0"]


def _residual_rms(results, name: str) -> np.ndarray:
    found = next(r for r in results if r.name == name).diagnosis
    return np.sqrt(np.mean(found.signal[found.armed] ** 2, axis=0))


def test_free_motion_command_writes_table_json_recording(tmp_path, capsys):
    assert main([str(FREE), "--json", str(tmp_path / "m.json"), "--out", str(tmp_path / "r.rrd")]) == 0
    table = capsys.readouterr().out
    assert "ur10e_free_motion: summary" in table
    # No ground truth, no controller of ours: those metrics are left out of the table, not rows of "-".
    for metric in ("rms_error_converged", "rms_luaf_error", "detection_delay", "chattering"):
        assert metric not in table
    document = json.loads((tmp_path / "m.json").read_text())
    assert set(document["variants"]) == {"tosmo", "hs_tosmo", "sosmo", "eso", "do", "momentum"}
    assert document["variants"]["do"]["metrics"]["rms_luaf_error"] == [None] * 6  # the JSON keeps them, null
    # Thresholds set on this log on the momentum observer: no false alarm of it here.
    assert document["variants"]["momentum"]["diagnosis"]["alarms"] == [[]] * 6
    assert (tmp_path / "r.rrd").stat().st_size > 0


def test_free_motion_residual_is_what_the_identified_friction_leaves():
    """The momentum observer's residual RMS on joints 1-3 at most 8 / 8 / 4 N m with the UR10e's identified
    friction (measured 6.4 / 7.4 / 2.2); the rigid body alone leaves the friction, 27 / 25 / 8; a sign error
    in the torque scale twice the gravity torque."""
    results = run_scenario(load_scenario(FREE, variants=["momentum", "do"]), record_poses=False)
    rms = _residual_rms(results, "momentum")
    assert np.all(rms[:3] <= [8.0, 8.0, 4.0]), rms
    assert np.all(rms[3:] < 1.0), rms  # the wrists: 0.4-0.6
    assert np.all(_residual_rms(results, "do")[:3] <= [10.0, 10.0, 4.0])  # 6.7 / 8.1 / 2.9
    rigid = run_scenario(load_scenario(FREE, variants=["momentum"], overrides=NO_FRICTION), record_poses=False)
    rigid_rms = _residual_rms(rigid, "momentum")
    assert rigid_rms[0] > 20 and rigid_rms[1] > 20 and rigid_rms[2] > 6, rigid_rms
    flipped = load_scenario(FREE, overrides=[f"log.scale.torque={[-c for c in CONSTANTS]}"], variants=["momentum"])
    rms = _residual_rms(run_scenario(flipped, record_poses=False), "momentum")
    assert rms[1] > 100 and rms[2] > 30, rms


@pytest.fixture(scope="module")
def pushed():
    scenario = load_scenario(PUSHED, variants=["momentum", "eso"])
    return scenario, {r.name: r for r in run_scenario(scenario, record_poses=False)}


def test_the_shoulder_pushes_alarm_on_their_own_joints_and_nothing_outside_the_pushes(pushed):
    """Thresholds set on the free motion alone: the momentum observer alarms on the shoulder pan in its push
    (11.6-16.4 s) and on the shoulder lift in its (25.3-31.5 s), and nowhere outside the labelled pushes."""
    scenario, results = pushed
    found = results["momentum"].diagnosis
    t, alarm = found.t, found.alarm
    assert alarm[(t >= 11.6) & (t <= 16.4), 0].any()
    assert alarm[(t >= 25.3) & (t <= 31.5), 1].any()
    metrics = event_metrics(found, scenario.log.events, 6)
    np.testing.assert_array_equal(metrics["alarms_outside_events"], 0.0)
    np.testing.assert_array_equal(metrics["alarms_on_other_joints"], 0.0)
    assert metrics["events_detected"][0] == 1.0 and metrics["events_detected"][2] == 1.0
    # The rigid body alone: thresholds set the same way on its free-motion residual (friction-sized) miss both
    # shoulder pushes.
    rigid = calibrate_log(FREE, margin=1.1, overrides=NO_FRICTION, variants=["momentum"]).thresholds
    assert rigid[0] > 30 and rigid[1] > 30, rigid
    overrides = [*NO_FRICTION, f"diagnosis.threshold.fixed={rigid.tolist()}"]
    worse = run_scenario(load_scenario(PUSHED, variants=["momentum"], overrides=overrides), record_poses=False)
    missed = event_metrics(worse[0].diagnosis, scenario.log.events, 6)
    assert missed["events_detected"][0] < 1.0 and missed["events_detected"][1] < metrics["events_detected"][1]


def test_pushed_command_scores_the_events(tmp_path, capsys):
    assert main([str(PUSHED), "--variant", "momentum", "--no-record", "--json", str(tmp_path / "m.json")]) == 0
    table = capsys.readouterr().out
    assert "events_detected" in table and "alarms_outside_events" in table
    assert "false_alarms" not in table  # counted against no fault, it would count the pushes themselves
    document = json.loads((tmp_path / "m.json").read_text())
    assert document["variants"]["momentum"]["metrics"]["alarms_outside_events"] == [0.0] * 6
