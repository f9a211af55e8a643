"""A monitor's plugin signals reach the recording: the momentum observer run as a monitor beside the loop has
its residual under ``/extras/residual/joint<k>``, in its own column, as the run computed it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from ftc_mj import load_scenario, run_scenario
from ftc_mj.outputs.recording import read_layout, read_series, write_recording

ROOT = Path(__file__).resolve().parents[2]


def test_a_monitors_residual_is_recorded_in_its_column(tmp_path: Path) -> None:
    spec = {
        "name": "monitor_signals",
        "robot": {"model": str(ROOT / "models" / "puma560.xml"), "sensors": ["position", "velocity"]},
        "duration": 0.2,
        "control_dt": 1e-3,
        "timestep": 5e-4,
        "initial": {"q": [-0.5, -0.5, -0.5]},
        "reference": ["cos(pi*t/5) - 1", "sin(pi*t/5 + pi/2) - 1", "0.3*sin(2*t) - 0.5"],
        "terms": [{"kind": "fault", "space": "acceleration", "sign": 1, "onset": 0.1, "value": ["10", "5", "0"]}],
        "variants": {"loop": {
            "observer": {"type": "hs_tosmo", "gains": {"D": 22.0, "gamma": 5.0}},
            "controller": {"type": "smc", "gains": {"c": 10.0, "bound": 5.0, "mu": 0.5}},
            "monitors": {"momentum": {"type": "momentum", "gains": {"K": 100.0}},
                         "eso": {"type": "eso", "gains": {"bandwidth": 40.0}}}}},
        "metrics": {"window_start": 0.05, "estimation_window_start": 0.05},
    }
    path = tmp_path / "monitor_signals.yaml"
    path.write_text(yaml.safe_dump(spec, sort_keys=False), encoding="utf-8")
    scenario = load_scenario(path)
    results = run_scenario(scenario)
    monitor = next(r for r in results if r.name == "loop.momentum")
    assert set(monitor.extras) == {"residual"}
    residual = monitor.extras["residual"]
    assert np.abs(residual[-1, :2]).max() > 1.0  # it follows the fault torque after the onset

    rrd = tmp_path / "run.rrd"
    write_recording(rrd, scenario=scenario.name, model=scenario.model, results=results)
    names = [style.name for style in read_layout(rrd).variants]
    column = names.index("loop.momentum")
    for joint in range(3):
        times, values = read_series(rrd, f"/extras/residual/joint{joint + 1}")
        np.testing.assert_array_equal(values[:, column], residual[:, joint].astype(np.float32))
        others = [c for c in range(len(names)) if c != column]
        assert np.isnan(values[:, others]).all()  # the loop and the ESO have no residual
