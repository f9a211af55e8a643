"""A small campaign for the campaign tests: the Chapter 5 plant for 0.6 s, a fault term at 0.3 s whose size and
evolution rate are parameters, encoders with noise, a diagnoser, two variants; written into a folder."""

from __future__ import annotations

from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[2]
NFTSMC = {"beta1": 15.0, "beta2": 10.0, "beta3": 10.0, "beta4": 5.0, "gamma1": 0.5, "bound": 0.5, "mu": 0.5,
          "compensation": "injection"}


def scenario() -> dict:
    return {
        "name": "small",
        "robot": {"model": str(ROOT / "models" / "puma560.xml"), "sensors": ["position"]},
        "seed": 5,
        "duration": 0.6,
        "control_dt": 1e-3,
        "timestep": 5e-4,
        "initial": {"q": [-0.5, -0.5, -0.5], "qd": [0.0, 0.0, 0.0]},
        "observer_initial": {"qd_hat": [0.2, 0.2, 0.2]},
        "parameters": {"size": 1.0, "zeta": 50.0},
        "reference": ["cos(pi*t/5) - 1", "sin(pi*t/5 + pi/2) - 1", "sin(pi*t/5 + pi/2) - 1"],
        "terms": [
            {"kind": "friction", "space": "torque", "sign": -1, "value": ["1.9*sin(qd1)", "2.03*sin(qd2)", "1.76*sin(qd3)"]},
            {"name": "fault", "kind": "fault", "space": "torque", "sign": 1, "onset": 0.3, "rate": "zeta",
             "value": ["0", "size", "0"]},
        ],
        "sensors": {"position": {"counts_per_rev": 65536, "noise_std": 1e-5}},
        "diagnosis": {"space": "torque", "baseline": {"start": 0.1, "end": 0.25}, "threshold": {"k": 5.0},
                      "persistence": {"samples": 5}},
        "variants": {
            "hs": {"observer": {"type": "hs_tosmo", "gains": {"D": 22.0, "gamma": 5.0}},
                   "controller": {"type": "nftsmc", "gains": NFTSMC}},
            "tosmo": {"observer": {"type": "tosmo", "gains": {"D": 22.0}},
                      "controller": {"type": "nftsmc", "gains": NFTSMC}},
        },
        "metrics": {"window_start": 0.1, "estimation_window_start": 0.1, "fault_settle": 0.05, "fault_window": 0.2},
    }


def campaign() -> dict:
    return {
        "name": "small",
        "scenario": "scenario.yaml",
        "cases": [
            {"label": "healthy", "values": {"fault_joint": 0}, "set": {"terms.1.value": ["0", "0", "0"]}},
            {"label": "joint2", "values": {"fault_joint": 2}},
        ],
        "samples": {"runs": 4, "method": "sobol", "seed": 1, "fields": {
            "parameters.size": {"log_uniform": [1.0, 30.0]},
            "variants.hs.controller.gains.mu": {"choice": [0.25, 0.5, 1.0]},
        }},
        "replicates": 1,
        "diagnosis": {"threshold_scales": [0.5, 1.0, 2.0]},
        "report": {"metrics": ["rms_error_converged", "detection_delay"], "fault_size": "parameters.size",
                   "bootstrap": 200,
                   "claims": [{"name": "hs faster", "metric": "observer_convergence_time", "better": "hs",
                               "worse": "tosmo"}]},
    }


def write(folder: Path, scenario_changes: dict | None = None, campaign_changes: dict | None = None) -> Path:
    """The scenario and the campaign in ``folder``; the campaign file's path."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "scenario.yaml").write_text(yaml.safe_dump({**scenario(), **(scenario_changes or {})}))
    path = folder / "campaign.yaml"
    path.write_text(yaml.safe_dump({**campaign(), **(campaign_changes or {})}))
    return path
