"""The singular term of Chapter 3's sigmoid NFTSMC: size and frequency of its spikes.

    python studies/sigmoid_spikes.py [--json PATH]

The equivalent control (3.27)/(3.36) contains e_hat b(e) alpha |e|^(alpha - 1) (alpha = 0.6), unbounded as
e -> 0. Once the loop has converged, e crosses 0 between samples; a sample that lands very close to 0 makes
the term (and the torque) spike and kicks s off the surface. This study runs the two sigmoid laws of
scenarios/two_link_tosmo_simple.yaml and _complex.yaml (``proposed``, ``after_convergence``) and reports per
joint, from each joint's first reaching of the surface to the end:

* ``spikes``: periods in which |terminal_slope_term| exceeds the switching gain Delta_d + mu (the term then
  outweighs the reaching law), and ``per_second`` that count per second;
* ``largest_term`` [rad/s^2] and ``largest_torque_step`` [N m] (|tau[k] - tau[k-1]| at a spike), with the
  |e| [rad] of the sample that gave the largest term;
* ``first_reaching_time`` and ``reaching_time`` (for good) of the scenario's metrics;
* ``gain``: the switching gain Delta_d + mu a spike exceeds [rad/s^2].
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from ftc_mj.analysis.metrics import compute_metrics
from ftc_mj.engine.runner import run_scenario
from ftc_mj.scenario.loading import load_scenario

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ("two_link_tosmo_simple", "two_link_tosmo_complex")
VARIANTS = ("proposed", "after_convergence")


def spikes(scenario_name: str, overrides: list[str] | None = None) -> dict[str, dict[str, list[float]]]:
    scenario = load_scenario(ROOT / "scenarios" / f"{scenario_name}.yaml", overrides=overrides or [],
                             variants=list(VARIANTS))
    out = {}
    by_name = {result.name: result for result in run_scenario(scenario, record_poses=False)}
    for variant in scenario.variants:
        result = by_name[variant.name]
        metrics = compute_metrics(result, scenario.spec.metrics, scenario.fault_onsets, scenario.joint_fault_onsets)
        gains = variant.controller_config
        threshold = np.broadcast_to(np.asarray(gains.bound) + np.asarray(gains.mu), (scenario.n_joints,))
        term = result.extras["terminal_slope_term"]
        t, dt = result.t, scenario.spec.control_dt
        step = np.vstack([np.zeros((1, scenario.n_joints)), np.abs(np.diff(result.tau, axis=0))])
        error = np.abs(result.q_meas - result.q_ref)
        row: dict[str, list[float]] = {key: [] for key in (
            "spikes", "per_second", "largest_term", "largest_torque_step", "error_at_largest",
            "first_reaching_time", "reaching_time", "gain")}
        for j in range(scenario.n_joints):
            start = metrics["first_reaching_time"][j]
            after = t >= (start if np.isfinite(start) else np.inf)
            hits = after & (np.abs(term[:, j]) > threshold[j])
            k = int(np.argmax(np.where(after, np.abs(term[:, j]), -1.0)))
            row["spikes"].append(int(hits.sum()))
            row["per_second"].append(float(hits.sum() / max(after.sum() * dt, dt)))
            row["largest_term"].append(float(np.abs(term[k, j])))
            row["largest_torque_step"].append(float(step[hits, j].max()) if hits.any() else 0.0)
            row["error_at_largest"].append(float(error[k, j]))
            row["first_reaching_time"].append(float(metrics["first_reaching_time"][j]))
            row["reaching_time"].append(float(metrics["reaching_time"][j]))
            row["gain"].append(float(threshold[j]))
        out[variant.name] = row
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path)
    parser.add_argument("--set", nargs="*", default=[], dest="overrides", help="scenario overrides, key=value")
    args = parser.parse_args()
    results = {name: spikes(name, args.overrides) for name in SCENARIOS}
    print("| scenario | variant | spikes (per s) | largest term [rad/s^2] | largest torque step [N m] | |e| there [rad]"
          " | first / for good reaching [s] |")
    print("|---|---|---|---|---|---|---|")
    for name, variants in results.items():
        for variant, row in variants.items():
            def per_joint(key: str, fmt: str) -> str:
                return " / ".join(format(v, fmt) for v in row[key])
            counts = " / ".join(f"{n} ({r:.2g})" for n, r in zip(row["spikes"], row["per_second"]))
            reach = " / ".join(f"{a:.3g} -> {b:.3g}" for a, b in zip(row["first_reaching_time"], row["reaching_time"]))
            print(f"| {name} | {variant} | {counts} | {per_joint('largest_term', '.3g')} | "
                  f"{per_joint('largest_torque_step', '.3g')} | {per_joint('error_at_largest', '.2g')} | {reach} |")
    if args.json:
        args.json.write_text(json.dumps(results, indent=1), encoding="utf-8")


if __name__ == "__main__":
    main()
