"""The streaming monitor (ftc_mj.online.Monitor): the shipped real UR10 logs streamed row by row from their CSV
(raw units, the log's own irregular times) give the replay's estimate, residual, threshold and alarms bit for
bit, variant by variant; the map from a source's joint names; what a monitor refuses."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ftc_mj import load_scenario, run_scenario
from ftc_mj.config.errors import InputError
from ftc_mj.logs.readers import read_csv
from ftc_mj.online import InputMap, Monitor, SampleError

ROOT = Path(__file__).resolve().parents[2]
FREE, PUSHED = ROOT / "scenarios/real/ur10e_free_motion.yaml", ROOT / "scenarios/real/ur10e_pushed.yaml"


def stream_log(scenario, variant: str) -> dict[str, np.ndarray]:
    """Every period of ``variant``'s monitor on the scenario's log, pushed row by row as the CSV holds it."""
    spec = scenario.spec.log
    recording = read_csv(scenario.log.file, spec.columns, spec.delimiter)
    inputs = InputMap.of(scenario)
    order = inputs.source_order
    monitor = Monitor(scenario, variant)
    periods = []
    for i in range(len(recording.times)):
        periods += monitor.push(recording.times[i] * inputs.time_scale,
                                inputs.to_robot("position", recording.position[i], order),
                                inputs.to_robot("velocity", recording.velocity[i], order),
                                inputs.to_robot("torque", recording.torque[i], order))
    assert [p.index for p in periods] == list(range(len(periods)))
    return {name: np.array([getattr(p, name) for p in periods])
            for name in ("time", "estimate", "residual", "threshold", "alarm", "isolated", "armed")}


@pytest.mark.slow  # both logs replayed and streamed, every variant
@pytest.mark.parametrize("path", [FREE, PUSHED], ids=["free_motion", "pushed"])
def test_the_logs_streamed_give_the_replay_bit_for_bit(path):
    scenario = load_scenario(path)
    for result in run_scenario(scenario, record_poses=False):
        streamed = stream_log(scenario, result.name)
        replay = result.diagnosis
        count = len(streamed["time"])
        # The stream completes an instant when a sample at or after it arrives: every one but possibly the last.
        assert len(replay.t) - 1 <= count <= len(replay.t)
        np.testing.assert_array_equal(streamed["time"], replay.t[:count])
        np.testing.assert_array_equal(streamed["residual"], replay.residual[:count])
        np.testing.assert_array_equal(streamed["threshold"], replay.threshold[:count])
        np.testing.assert_array_equal(streamed["alarm"], replay.alarm[:count])
        np.testing.assert_array_equal(streamed["armed"], replay.armed[:count])
        np.testing.assert_array_equal(streamed["isolated"], np.logical_or.accumulate(replay.alarm[:count]))
        if path == PUSHED and result.name == "do":
            assert streamed["alarm"].any()  # a test that alarms, not only silence compared with silence


def test_joint_names_map_in_any_order_and_unknown_missing_or_repeated_names_are_refused():
    inputs = InputMap.of(load_scenario(FREE, variants=["do"]))
    names = list(reversed(inputs.robot_joints))
    order = inputs.order(names)
    values = np.arange(6.0)[::-1]  # joint j's value j, in reversed order
    np.testing.assert_array_equal(inputs.to_robot("position", values, order), np.arange(6.0))
    torque = inputs.to_robot("torque", values, order)
    np.testing.assert_array_equal(torque, np.arange(6.0) * [10.0, 10.6956, 8.4566, 9.0029, 9.48, 10.1232])
    with pytest.raises(SampleError, match="^name: 'elbow' is not a joint"):
        inputs.order(names[:-1] + ["elbow"])
    with pytest.raises(SampleError, match="given twice"):
        inputs.order(names + names[:1])
    with pytest.raises(SampleError, match="missing"):
        inputs.order(names[1:])


def test_a_monitor_refuses_what_it_cannot_monitor():
    scenario = load_scenario(FREE, variants=["do"])
    with pytest.raises(InputError, match="no variant 'tosmo'"):
        Monitor(scenario, "tosmo")
    bare = load_scenario(FREE, variants=["do"], overrides=["diagnosis=null"])
    with pytest.raises(InputError, match="diagnosis: a monitor needs a diagnosis section"):
        Monitor(bare)
    monitor = Monitor(scenario)
    with pytest.raises(SampleError, match="^velocity: missing"):
        monitor.push(0.0, np.zeros(6), None, np.zeros(6))
    with pytest.raises(SampleError, match="^torque: has 5 values for 6 joints"):
        monitor.push(0.0, np.zeros(6), np.zeros(6), np.zeros(5))
    assert len(monitor.push(0.0, np.zeros(6), np.zeros(6), np.zeros(6))) == 1
    with pytest.raises(SampleError, match="^time: "):
        monitor.push(0.0, np.zeros(6), np.zeros(6), np.zeros(6))
