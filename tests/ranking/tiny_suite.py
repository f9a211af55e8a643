"""A tiny suite and bench file for the bench tests: the PUMA560 of the Chapter 5 scenario for 0.8 s, a
baseline window of 0.2 s, two faults (a bias and a lock) at 0.5 s, three healthy runs and two per fault."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

ROOT = Path(__file__).resolve().parents[2]
NFTSMC = {"beta1": 15.0, "beta2": 10.0, "beta3": 10.0, "beta4": 5.0, "gamma1": 0.5, "bound": 0.5, "mu": 0.5,
          "compensation": "injection"}


def suite() -> dict[str, Any]:
    return {
        "version": "tiny",
        "description": "The PUMA560 for 0.8 s.",
        "protocol": {
            "seed": 3, "mass_scale": [0.95, 1.05],
            "encoders": {"counts_per_rev": 65536, "noise_std": 1.0e-5},
            "diagnosis": {"space": "torque", "baseline": {"start": 0.2, "end": 0.4}, "threshold": {"k": 5.0},
                          "persistence": {"samples": 5}},
            "metrics": {"window_start": 0.3, "estimation_window_start": 0.2, "fault_settle": 0.05,
                        "fault_window": 0.2},
            "onsets": [0.5], "fault_length": 0.2,
        },
        "faults": {"bias": [0.5], "lock": True},
        "tiers": {"quick": {"duration": 0.8, "healthy_runs": 3, "fault_runs": 2, "tracking_healthy_runs": 1,
                            "tracking_fault_runs": 1}},
        "robots": {"puma560": {"scenario": str(ROOT / "scenarios" / "puma_fault.yaml"), "loop": "proposed",
                               "terms": ["friction"], "fault_joints": [2], "torque_scale": [40.0]}},
    }


def entries() -> dict[str, Any]:
    return {
        "suite": "suite.yaml",
        "diagnosis": {
            "hs_tosmo": {"gains_from": "Chapter 5", "gains": {"puma560": {"D": 22.0, "gamma": 5.0}}},
            "tosmo": {"gains_from": "Chapter 5", "gains": {"puma560": {"D": 22.0}}},
        },
        "tracking": {
            "proposed": {"observer": "hs_tosmo", "controller": "nftsmc", "gains_from": "Chapter 5",
                         "gains": {"puma560": {"observer": {"D": 22.0, "gamma": 5.0}, "controller": NFTSMC}}},
        },
    }


def write(folder: Path, bench: dict[str, Any] | None = None, name: str = "bench.yaml") -> Path:
    """The tiny suite and a bench file (default: :func:`entries`) in ``folder``; the bench file's path."""
    (folder / "suite.yaml").write_text(yaml.safe_dump(suite(), sort_keys=False), encoding="utf-8")
    path = folder / name
    path.write_text(yaml.safe_dump(bench if bench is not None else entries(), sort_keys=False), encoding="utf-8")
    return path
