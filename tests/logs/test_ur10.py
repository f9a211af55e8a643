"""The real UR10's logs (data/ur10) through the shipped scenarios: the command's outputs, the residuals' level in
free motion within a band a broken reader leaves (a sign error in the torque scale), and the alarms on the pushed
arm in the windows its data shows."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from ftc_mj import load_scenario, run_scenario
from ftc_mj.cli.run import main
from ftc_mj.robot.packages import resolve_package_uri

ROOT = Path(__file__).resolve().parents[2]
FREE, PUSHED = ROOT / "scenarios/real/ur10_free_motion.yaml", ROOT / "scenarios/real/ur10_pushed.yaml"
CONSTANTS = [10.0, 10.6956, 8.4566, 9.0029, 9.48, 10.1232]

pytestmark = [pytest.mark.slow, pytest.mark.skipif(  # real robot logs replayed through the observers
    resolve_package_uri("package://example-robot-data/robots/ur_description/urdf/ur10_robot.urdf") is None,
    reason="example-robot-data is not installed (the robots extra)")]


def _residual_rms(results, name: str) -> np.ndarray:
    found = next(r for r in results if r.name == name).diagnosis
    return np.sqrt(np.mean(found.residual[found.armed] ** 2, axis=0))


def test_free_motion_command_writes_table_json_recording(tmp_path, capsys):
    assert main([str(FREE), "--json", str(tmp_path / "m.json"), "--out", str(tmp_path / "r.rrd")]) == 0
    assert "ur10_free_motion: summary" in capsys.readouterr().out
    document = json.loads((tmp_path / "m.json").read_text())
    assert set(document["variants"]) == {"tosmo", "hs_tosmo", "sosmo", "eso", "do", "momentum"}
    do = document["variants"]["do"]
    assert do["metrics"]["rms_luaf_error"] == [None] * 6  # no truth: not reported
    assert do["diagnosis"]["alarms"] == [[]] * 6  # calibrated on this log: no false alarm of the DO
    assert document["variants"]["momentum"]["diagnosis"]["alarms"] == [[]] * 6  # nor of the momentum observer
    assert (tmp_path / "r.rrd").stat().st_size > 0


def test_free_motion_residuals_are_the_friction_level_and_a_sign_error_leaves_it():
    results = run_scenario(load_scenario(FREE), record_poses=False)
    for name in ("do", "eso", "momentum"):
        rms = _residual_rms(results, name)
        # Joints 2 and 3 carry gravity and inertia: a correct torque leaves 25 / 10 N m (friction, model errors).
        assert 20 < rms[1] < 35 and 6 < rms[2] < 14, rms
        assert np.all(rms[3:] < 4.0), rms  # the wrists: their friction, about 3 N m
    flipped = load_scenario(FREE, overrides=[f"log.scale.torque={[-c for c in CONSTANTS]}"], variants=["do"])
    rms = _residual_rms(run_scenario(flipped, record_poses=False), "do")
    assert rms[1] > 100 and rms[2] > 30, rms  # twice the gravity torque


def _windows(alarm: np.ndarray, t: np.ndarray) -> list[tuple[float, float]]:
    edges = np.flatnonzero(np.diff(np.r_[0, alarm.astype(int), 0]))
    return [(t[start], t[stop - 1]) for start, stop in zip(edges[::2], edges[1::2])]


def test_pushed_arm_alarms_where_the_torques_move():
    results = run_scenario(load_scenario(PUSHED, variants=["do", "eso"]), record_poses=False)
    for result in results:
        found = result.diagnosis
        windows = _windows(found.alarm[:, 2], found.t)  # the elbow
        assert any(s < 13 and e > 15.5 for s, e in windows), windows  # the push at 12-16 s
        assert any(s < 26.5 and e > 30.5 for s, e in windows), windows  # and at 25.5-31 s
        assert not found.alarm[:, [0, 1, 3, 4, 5]].any()  # below the free-motion thresholds
