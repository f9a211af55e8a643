"""The refactor check: a SHA-256 of every series and metric of every shipped scenario, and of a small batch's
metrics.

A change that must keep results bit-identical is run before and after::

    python benchmarks/series_hashes.py --out before.json
    ... change ...
    python benchmarks/series_hashes.py --out after.json --compare before.json

Every scenario under ``scenarios/`` (not the fragments of ``scenarios/bases/``) runs as written (one member,
every variant and monitor, every series, extras and diagnosis arrays, each variant's metrics and each diagnosis'
campaign detection statistics at the default threshold scales); a batch of five members of
``scenarios/puma_fault.yaml`` with per-member gains, seeds, parameters and mass scales is run through
``run_batch`` and its metrics hashed too, so the member path (overrides, stacking) is covered. ``--compare``
prints every series that moved and exits 1 if any did. Scenarios whose robot cannot be loaded here (the
``robots`` extra missing) are listed as skipped.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

#: Shared fragments that scenarios name as their ``base``: not scenarios to run.
FRAGMENTS = ROOT / "scenarios" / "bases"

#: Per-member values of the batch check: one of each kind a campaign or a tuning sets.
BATCH_MEMBERS = [
    {},
    {"seed": 7, "variants.proposed.controller.gains.mu": 0.5},
    {"plant.mass_scale": 1.1, "variants.proposed.observer.gains.gamma": 3.0},
    {"nominal.mass_scale": 0.9, "parameters.zeta": 0.5},
    {"initial.q": [0.05, -0.05, 0.02], "variants.nftsmc_tosmo.controller.gains.beta1": 2.0},
]


def digest(values: np.ndarray) -> str:
    array = np.ascontiguousarray(values)
    return hashlib.sha256(str(array.dtype).encode() + str(array.shape).encode() + array.tobytes()).hexdigest()[:16]


def result_hashes(result) -> dict[str, str]:
    """Every array of a VariantResult (and its diagnosis), by name."""
    hashes = {}
    for name, value in vars(result).items():
        if isinstance(value, np.ndarray):
            hashes[name] = digest(value)
    for name, value in result.extras.items():
        hashes[f"extras.{name}"] = digest(value)
    if result.diagnosis is not None:
        for name, value in vars(result.diagnosis).items():
            if isinstance(value, np.ndarray):
                hashes[f"diagnosis.{name}"] = digest(value)
    hashes["status"] = f"{result.status}@{result.diverged_at}"
    return hashes


def scenario_hashes(path: Path) -> dict[str, dict[str, str]]:
    from ftc_mj import load_scenario, run_scenario
    from ftc_mj.analysis.diagnosis import detection_statistics
    from ftc_mj.analysis.metrics import compute_metrics
    from ftc_mj.campaign.schema import DEFAULT_THRESHOLD_SCALES

    scenario = load_scenario(path)
    hashes = {}
    for result in run_scenario(scenario, nthread=1):
        metrics = compute_metrics(result, scenario.spec.metrics, scenario.fault_onsets, scenario.joint_fault_onsets,
                                  scenario.torque_limits)
        hashes[result.name] = result_hashes(result) | {f"metrics.{name}": digest(np.asarray(value, dtype=float))
                                                       for name, value in sorted(metrics.items())}
        if scenario.diagnoser is not None:  # a campaign's statistics of each result and monitor
            for one in (result, *result.monitors):
                statistics = detection_statistics(one.diagnosis, scenario.diagnoser.persistence,
                                                  scenario.joint_fault_onsets, list(DEFAULT_THRESHOLD_SCALES),
                                                  scenario.n_joints)
                hashes[result.name] |= {f"detection.{one.name}.{name}": digest(value)
                                        for name, value in sorted(statistics.items())}
    return hashes


def batch_hashes() -> dict[str, dict[str, str]]:
    from ftc_mj import load_scenario
    from ftc_mj.engine.members import members_from_overrides
    from ftc_mj.engine.runner import run_batch

    scenario = load_scenario(ROOT / "scenarios/puma_fault.yaml", duration=3.0)
    outcomes = run_batch(scenario, members_from_overrides(scenario, BATCH_MEMBERS), nthread=1)
    return {f"member{o.member}.{o.variant}": {name: digest(np.asarray(value, dtype=float))
                                              for name, value in sorted(o.metrics.items())}
            | {"status": f"{o.status}@{o.diverged_at}"} for o in outcomes}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="JSON file of the hashes")
    parser.add_argument("--compare", type=Path, help="hashes of an earlier run to compare with")
    parser.add_argument("--only", nargs="*", default=(), help="scenario files (default: every shipped one)")
    args = parser.parse_args()

    files = [Path(f) for f in args.only] or sorted(path for path in (ROOT / "scenarios").rglob("*.yaml")
                                                   if FRAGMENTS not in path.parents)
    hashes: dict[str, dict] = {}
    for path in files:
        key = str(path.resolve().relative_to(ROOT))
        start = time.perf_counter()
        try:
            hashes[key] = scenario_hashes(path)
        except Exception as exc:  # e.g. a robot of the `robots` extra that is not installed here
            print(f"skipped {key}: {exc}", file=sys.stderr)
            continue
        print(f"{key}: {sum(len(v) for v in hashes[key].values())} series in {time.perf_counter() - start:.1f} s")
    if not args.only:
        hashes["batch:scenarios/puma_fault.yaml"] = batch_hashes()
        print("batch of 5 members: metrics hashed")
    args.out.write_text(json.dumps(hashes, indent=1, sort_keys=True))

    if args.compare is None:
        return 0
    before = json.loads(args.compare.read_text())
    moved = []
    for key in sorted(before.keys() | hashes.keys()):
        if key not in hashes or key not in before:
            moved.append(f"{key}: only in {'the earlier run' if key in before else 'this run'}")
            continue
        for variant in sorted(before[key].keys() | hashes[key].keys()):
            old, new = before[key].get(variant, {}), hashes[key].get(variant, {})
            for name in sorted(old.keys() | new.keys()):
                if old.get(name) != new.get(name):
                    moved.append(f"{key}: {variant}.{name}")
    for line in moved:
        print("moved:", line)
    total = sum(len(v) for s in hashes.values() for v in s.values())
    print(f"{len(moved)} of {total} hashes moved")
    return 1 if moved else 0


if __name__ == "__main__":
    sys.exit(main())
