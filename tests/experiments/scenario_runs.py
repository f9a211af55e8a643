"""Run a shipped scenario once through the command line and hand its metrics to the claim tests.

Each claim test module runs its scenario in full (30 s of simulated time, 10-20 s of CPU) once, through
``python -m ftc_mj.run`` as a user would, and asserts docs/results/reproduction.md's claims that hold with margins: each
bound sits between the measured value (in a comment) and what a broken method gives.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ftc_mj.run import main

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = ROOT / "scenarios"

Metrics = dict[str, dict[str, np.ndarray]]


def run_scenario(name: str, out: Path, *extra: str) -> tuple[Metrics, Path]:
    """Metrics per variant (metric -> per-joint array, NaN for undefined) and the recording path."""
    recording, metrics_path = out / "rec.rrd", out / "metrics.json"
    status = main([str(SCENARIOS / f"{name}.yaml"), "--quiet", "--out", str(recording), "--json", str(metrics_path),
                   *extra])
    assert status == 0, f"{name}: a variant diverged"
    document = json.loads(metrics_path.read_text(encoding="utf-8"))
    metrics = {
        variant: {metric: np.array(values, dtype=float) for metric, values in entry["metrics"].items()}
        for variant, entry in document["variants"].items()
    }
    return metrics, recording
