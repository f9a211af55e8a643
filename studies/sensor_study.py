"""Sensor study: velocity and LUaF estimation error of SOSMO, TOSMO and high-speed TOSMO against encoder
resolution and noise level.

    python studies/sensor_study.py [--duration 8] [--seed 0] [--json PATH]

Each observer runs in its own Chapter 5 closed loop (scenarios/puma_fault.yaml: the variants nftsmc_sosmo,
nftsmc_tosmo and proposed, i.e. the compensated NFTSMC with that observer), before the fault (8 s; the fault
is at 10 s), with one sensor setting at a time: quantisation to 2^16, 2^12 or 2^10 counts per revolution
(no noise), or white noise of 1e-5, 1e-4 or 1e-3 rad (no quantisation). A cell is the RMS over the three
joints of the per-joint RMS errors over the scenario's estimation window (from 2 s); ``diverged`` where the
closed loop did not survive the sensor. Every setting uses the same seed, so the noise sequences are the same
up to their scale.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from ftc_mj import load_scenario, run_scenario
from ftc_mj.analysis.metrics import compute_metrics

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "puma_fault.yaml"
#: (column title, variant of puma_fault.yaml)
OBSERVERS = (("SOSMO", "nftsmc_sosmo"), ("TOSMO", "nftsmc_tosmo"), ("HS-TOSMO", "proposed"))
#: (row label, ``--set`` overrides of the sensors section)
SETTINGS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("perfect", ()),
    ("2^16 counts/rev", ("sensors.position.counts_per_rev=65536",)),
    ("2^12 counts/rev", ("sensors.position.counts_per_rev=4096",)),
    ("2^10 counts/rev", ("sensors.position.counts_per_rev=1024",)),
    ("noise 1e-5 rad", ("sensors.position.noise_std=1e-5",)),
    ("noise 1e-4 rad", ("sensors.position.noise_std=1e-4",)),
    ("noise 1e-3 rad", ("sensors.position.noise_std=1e-3",)),
)


def run_setting(overrides: tuple[str, ...], duration: float, seed: int) -> dict[str, dict[str, float] | None]:
    """Per observer: the joint-RMS velocity and LUaF errors, or None if the loop diverged."""
    scenario = load_scenario(SCENARIO, overrides=[*overrides, f"seed={seed}", "diagnosis=null"], duration=duration,
                             variants=[variant for _, variant in OBSERVERS])
    out: dict[str, dict[str, float] | None] = {}
    for result in run_scenario(scenario, record_poses=False):
        if result.status != "ok":
            out[result.name] = None
            continue
        metrics = compute_metrics(result, scenario.spec.metrics, scenario.fault_onsets, scenario.joint_fault_onsets)
        out[result.name] = {
            "velocity": float(np.sqrt(np.mean(metrics["rms_velocity_error"] ** 2))),
            "luaf": float(np.sqrt(np.mean(metrics["rms_luaf_error"] ** 2))),
        }
    return out


def table(results: dict[str, dict[str, dict[str, float] | None]]) -> str:
    """A Markdown table: one row per sensor setting, velocity and LUaF error per observer."""
    header = "| sensor | " + " | ".join(f"{title} vel. [rad/s] | {title} LUaF [rad/s^2]" for title, _ in OBSERVERS) + " |"
    lines = [header, "|---|" + "---|---|" * len(OBSERVERS)]
    for label, _ in SETTINGS:
        cells = []
        for _, variant in OBSERVERS:
            errors = results[label][variant]
            cells += ["diverged", "diverged"] if errors is None else [f"{errors['velocity']:.2g}", f"{errors['luaf']:.3g}"]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=8.0, help="seconds per run (default 8, before the fault)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", type=Path, help="also write the numbers as JSON")
    args = parser.parse_args()
    results = {label: run_setting(overrides, args.duration, args.seed) for label, overrides in SETTINGS}
    print(table(results))
    if args.json is not None:
        args.json.write_text(json.dumps(results, indent=2) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
