"""Suite v2 on a reduced protocol for the tests: its robots, loops, encoders, model mismatch and diagnosis,
shortened (2.3 s runs, 0.4 s windows from 1.5 s and 1.9 s, 16 calibration and 16 healthy runs, a bias of 10
residual units and a float on each fault joint, 3 draws)."""

from __future__ import annotations

import yaml

from ftc_mj.ranking.suite import SUITES


def reduced_suite() -> dict:
    suite = yaml.safe_load((SUITES / "v2.yaml").read_text())
    suite["version"] = "v2_reduced"
    for robot in suite["robots"].values():
        robot["scenario"] = str((SUITES / robot["scenario"]).resolve())
    protocol = suite["protocol"]
    protocol["diagnosis"]["baseline"] = {"start": 0.8, "end": 1.4}
    protocol["metrics"] = {"window_start": 1.0, "estimation_window_start": 0.8, "fault_settle": 0.2,
                           "fault_window": 0.4}
    protocol["onsets"], protocol["fault_length"] = [1.5, 1.9], 0.4
    suite["calibration"]["windows"] = [0.4]
    suite["faults"] = {"bias_relative_to": "residual_unit", "bias": [10.0], "float": True}
    suite["tiers"] = {"quick": {"duration": 2.3, "calibration_runs": 16, "healthy_runs": 16, "fault_runs": 3,
                                "tracking_healthy_runs": 1, "tracking_fault_runs": 1, "tune_runs": 1}}
    return suite
