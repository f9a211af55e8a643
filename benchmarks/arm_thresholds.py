"""Diagnosis thresholds of a scenario on runs they were not made from: false alarms on healthy runs and
detection on faulty ones, over a range of seeds (the calibration's are 1000 + the scenario's seed and up).

    PYTHONPATH=. python benchmarks/arm_thresholds.py scenarios/robots/ur5e_fault.yaml --runs 60 --first-seed 5000
    ... --set diagnosis.threshold.fixed=10        # the same with other thresholds (e.g. without calibration)

Healthy runs: the scenario without its actuator faults and fault terms; a false alarm of a run and joint is
any alarm there (``false_alarms`` > 0). The per-run rate per joint is given pooled over the joints with its
95% Clopper-Pearson interval, and per joint. Faulty runs: the scenario as it is; detection rate, delay
(median and range) on the faulty joints, and the runs with a false alarm on a healthy joint.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from scipy.stats import beta

from ftc_mj.engine.members import members_from_overrides
from ftc_mj.engine.runner import run_batch
from ftc_mj.scenario.loading import load_scenario


def clopper_pearson(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """The exact binomial interval of k successes in n trials."""
    a = (1 - level) / 2
    low = 0.0 if k == 0 else float(beta.ppf(a, k, n - k + 1))
    high = 1.0 if k == n else float(beta.ppf(1 - a, k + 1, n - k))
    return low, high


def outcomes(path: Path, seeds: list[int], overrides: list[str], healthy: bool, variants: list[str]
             ) -> dict[str, list[dict]]:
    assignments = None
    if healthy:
        terms = load_scenario(path, overrides=overrides).written("terms") or []
        assignments = {"actuator_faults": [], "terms": [t for t in terms if t.get("kind") != "fault"]}
    scenario = load_scenario(path, overrides=overrides, assignments=assignments, variants=variants)
    found: dict[str, list[dict]] = {}
    for o in run_batch(scenario, members_from_overrides(scenario, [{"seed": s} for s in seeds])):
        found.setdefault(o.variant, []).append(
            {k: np.asarray(v, dtype=float) for k, v in o.metrics.items()} | {"status": o.status})
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenario", type=Path)
    parser.add_argument("--runs", type=int, default=60, help="healthy runs (0: none)")
    parser.add_argument("--faulty-runs", type=int, help="faulty runs (default: --runs)")
    parser.add_argument("--variant", nargs="+", default=[], help="healthy runs of these variants only")
    parser.add_argument("--faulty-variant", nargs="+", default=[], help="faulty runs of these variants only")
    parser.add_argument("--first-seed", type=int, default=5000)
    parser.add_argument("--set", action="append", default=[], dest="overrides")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    seeds = list(range(args.first_seed, args.first_seed + args.runs))
    faulty_seeds = list(range(args.first_seed, args.first_seed + (args.runs if args.faulty_runs is None
                                                                 else args.faulty_runs)))
    scenario = load_scenario(args.scenario, overrides=args.overrides)
    faulty_joints = np.flatnonzero(np.isfinite(scenario.joint_fault_onsets))
    report: dict = {"scenario": str(args.scenario), "first_seed": args.first_seed, "set": args.overrides}
    for name, runs in (outcomes(args.scenario, seeds, args.overrides, True, args.variant) if seeds else {}).items():
        alarms = np.array([r["false_alarms"] > 0 for r in runs if r["status"] == "ok"])
        k, n = int(alarms.sum()), alarms.size
        low, high = clopper_pearson(k, n)
        report.setdefault(name, {})["healthy"] = {
            "runs": len(alarms), "joint_runs_with_alarm": k, "joint_runs": n, "rate": k / n, "ci95": [low, high],
            "per_joint": alarms.mean(axis=0).tolist()}
        print(f"{name} healthy: {k} of {n} joint-runs with a false alarm, rate {k / n:.4f} "
              f"[{low:.4f}, {high:.4f}]; per joint {np.round(alarms.mean(axis=0), 3).tolist()}")
    faulty = outcomes(args.scenario, faulty_seeds, args.overrides, False, args.faulty_variant) if faulty_seeds else {}
    for name, runs in faulty.items():
        ok = [r for r in runs if r["status"] == "ok"]
        detected = np.array([[r["missed_detection"][j] == 0 for j in faulty_joints] for r in ok])
        delays = np.array([r["detection_delay"][j] for r in ok for j in faulty_joints])
        delays = delays[np.isfinite(delays)]
        healthy_joints = [j for j in range(scenario.n_joints) if j not in faulty_joints]
        false = int(sum(np.any(r["false_alarms"][healthy_joints] > 0) for r in ok))
        entry = {"runs": len(ok), "detection_rate": float(detected.mean()),
                 "delay_median": float(np.median(delays)) if delays.size else None,
                 "delay_range": [float(delays.min()), float(delays.max())] if delays.size else None,
                 "runs_with_false_alarm_on_healthy_joint": false}
        report.setdefault(name, {})["faulty"] = entry
        print(f"{name} faulty: detected {detected.sum()} of {detected.size}; delay median "
              f"{entry['delay_median']} s, range {entry['delay_range']}; {false} of {len(ok)} runs with a false "
              "alarm on a healthy joint")
    if args.json is not None:
        args.json.write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
