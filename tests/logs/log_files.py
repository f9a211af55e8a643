"""Small logs of the two-link arm, written by the tests (no committed binaries), and a scenario that replays one."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[2]
TWO_LINK = ROOT / "models" / "two_link.xml"
JOINTS = ["joint1", "joint2"]


def trajectory(steps: int = 200, dt: float = 0.01) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Time, positions, velocities and torques of a smooth motion of both joints."""
    t = np.arange(steps) * dt
    q = np.column_stack([0.3 * np.sin(t), -0.2 * np.cos(2 * t)])
    qd = np.column_stack([0.3 * np.cos(t), 0.4 * np.sin(2 * t)])
    tau = np.column_stack([2.0 + np.sin(t), 1.0 - 0.5 * np.cos(t)])
    return t, q, qd, tau


def write_csv(path: Path, t, q, qd, tau, header: bool = True) -> Path:
    table = np.column_stack([t, q, qd, tau])
    names = "t,q1,q2,qd1,qd2,i1,i2"
    np.savetxt(path, table, fmt="%.17g", delimiter=",", header=names if header else "", comments="")
    return path


def log_scenario(tmp_path: Path, log: dict, variants: dict | None = None, **extra) -> Path:
    """A scenario on the two-link arm that replays ``log``."""
    raw = {
        "name": "replay",
        "robot": {"model": str(TWO_LINK)},
        "log": log,
        "variants": variants or {"eso": {"observer": {"type": "eso", "gains": {"bandwidth": 20.0}}}},
        "metrics": {"window_start": 0.5, "estimation_window_start": 0.5},
        **extra,
    }
    path = tmp_path / "replay.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path


CSV_LOG = {"format": "csv", "columns": {"time": "t", "position": ["q1", "q2"], "velocity": ["qd1", "qd2"],
                                        "torque": ["i1", "i2"]},
           "steps": {"resample": 0.01}}


