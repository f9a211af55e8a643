"""The switch-off check: every shipped scenario run with the fast paths on and off in one process, alternated
(``ftc_mj.fast.switched``, what ``FTC_MJ_FAST=0`` does), every series, extras and diagnosis array, metric and
campaign detection statistic compared against the tolerance ``ftc_mj.fast`` states.

::

    python benchmarks/switch_off.py                       # every shipped scenario
    python benchmarks/switch_off.py --only scenarios/puma_fault.yaml --duration 12

With every scenario, a batch of five members of ``scenarios/puma_fault.yaml`` (3 s) with per-member values is
compared too (its metrics), as ``series_hashes.py`` checks the member path.
It prints, per scenario, what moved (nothing, where the guarantee holds) and both runs' times, then per metric
the worst relative difference over every scenario and variant and its ratio to the tolerance (0 where the bits
are equal), per kind of array (series, diagnosis, detection) how many are bit-identical, and exits 1 where
anything lies outside the tolerance. Relative differences are ``|off - on| / max(|on|, tiny)``, NaN where one
run is NaN and the other not (a NaN in both is equal). Scenarios whose robot cannot be loaded here (the
``robots`` extra missing) are listed as skipped.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
#: Shared fragments that scenarios name as their ``base``: not scenarios to run.
FRAGMENTS = ROOT / "scenarios" / "bases"


@dataclass(frozen=True)
class Difference:
    """One compared array: its scenario, variant, kind (``series``, ``diagnosis``, ``detection``, ``metric``),
    name, whether its bits are equal, its worst relative difference and the tolerance that applies to it."""

    scenario: str
    variant: str
    kind: str
    name: str
    equal_bits: bool
    relative: float
    tolerance: float

    @property
    def within(self) -> bool:
        return self.equal_bits or self.relative <= self.tolerance

    @property
    def ratio(self) -> float:
        """The difference over the tolerance (0: equal bits; inf: a difference where none is allowed)."""
        if self.equal_bits:
            return 0.0
        return self.relative / self.tolerance if self.tolerance > 0 else float("inf")


def relative_difference(on: np.ndarray, off: np.ndarray) -> float:
    """The worst ``|off - on| / |on|`` over the entries (NaN where exactly one of the two is NaN)."""
    on, off = np.asarray(on, dtype=float), np.asarray(off, dtype=float)
    if on.shape != off.shape or (np.isnan(on) != np.isnan(off)).any():
        return float("nan")
    both = ~np.isnan(on)
    if not both.any():
        return 0.0
    a, b = on[both], off[both]
    same = a == b  # equal infinities included
    if same.all():
        return 0.0
    return float(np.max(np.abs(b[~same] - a[~same]) / np.maximum(np.abs(a[~same]), np.finfo(float).tiny)))


def arrays(path: Path, duration: float | None) -> dict[str, dict[tuple[str, str], np.ndarray]]:
    """Every array of one run of the scenario, by variant and (kind, name), as ``series_hashes.py`` hashes them."""
    from ftc_mj import load_scenario, run_scenario
    from ftc_mj.analysis.diagnosis import detection_statistics
    from ftc_mj.analysis.metrics import compute_metrics
    from ftc_mj.campaign.schema import DEFAULT_THRESHOLD_SCALES

    scenario = load_scenario(path, duration=duration)
    out = {}
    for result in run_scenario(scenario, nthread=1):
        found = {("series", name): value for name, value in vars(result).items() if isinstance(value, np.ndarray)}
        found |= {("series", f"extras.{name}"): value for name, value in result.extras.items()}
        if result.diagnosis is not None:
            found |= {("diagnosis", name): value for name, value in vars(result.diagnosis).items()
                      if isinstance(value, np.ndarray)}
        metrics = compute_metrics(result, scenario.spec.metrics, scenario.fault_onsets, scenario.joint_fault_onsets,
                                  scenario.torque_limits)
        found |= {("metric", name): np.asarray(value, dtype=float) for name, value in metrics.items()}
        if scenario.diagnoser is not None:
            for one in (result, *result.monitors):
                statistics = detection_statistics(one.diagnosis, scenario.diagnoser.persistence,
                                                  scenario.joint_fault_onsets, list(DEFAULT_THRESHOLD_SCALES),
                                                  scenario.n_joints)
                found |= {("detection", f"{one.name}.{name}"): np.asarray(value)
                          for name, value in statistics.items()}
        found[("series", "status")] = np.array([f"{result.status}@{result.diverged_at}"])
        out[result.name] = found
    return out


def batch_arrays(path: Path, duration: float | None) -> dict[str, dict[tuple[str, str], np.ndarray]]:
    """The metrics of a batch of five members of the scenario with per-member gains, seeds, parameters and mass
    scales (``series_hashes.py``'s batch check: the member path), by member and variant."""
    from ftc_mj import load_scenario
    from ftc_mj.engine.members import members_from_overrides
    from ftc_mj.engine.runner import run_batch

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from series_hashes import BATCH_MEMBERS

    scenario = load_scenario(path, duration=duration)
    outcomes = run_batch(scenario, members_from_overrides(scenario, BATCH_MEMBERS), nthread=1)
    return {f"member{o.member}.{o.variant}": {("metric", name): np.asarray(value, dtype=float)
                                              for name, value in o.metrics.items()}
            | {("series", "status"): np.array([f"{o.status}@{o.diverged_at}"])} for o in outcomes}


def compare(path: Path, duration: float | None = None, batch: bool = False) -> tuple[list[Difference], float, float]:
    """The scenario run with the fast paths on, then off, in this process: every array compared, and the two
    runs' wall times. ``batch``: the batch check's members (:func:`batch_arrays`) instead of one run."""
    from ftc_mj import fast
    from ftc_mj.fast import SWITCH_TOLERANCE

    runs, times = {}, {}
    for enabled in (True, False):
        start = time.perf_counter()
        with fast.switched(enabled):
            runs[enabled] = (batch_arrays if batch else arrays)(path, duration)
        times[enabled] = time.perf_counter() - start
    key = str(path.resolve().relative_to(ROOT)) if path.resolve().is_relative_to(ROOT) else str(path)
    key = f"batch:{key}" if batch else key
    differences = []
    for variant in sorted(runs[True].keys() | runs[False].keys()):
        on, off = runs[True].get(variant, {}), runs[False].get(variant, {})
        for kind, name in sorted(on.keys() | off.keys()):
            if (kind, name) not in on or (kind, name) not in off:
                differences.append(Difference(key, variant, kind, name, False, float("nan"), 0.0))
                continue
            a, b = np.asarray(on[kind, name]), np.asarray(off[kind, name])
            equal = a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()
            relative = 0.0 if equal else (relative_difference(a, b) if a.dtype.kind == "f" else float("nan"))
            differences.append(Difference(key, variant, kind, name, equal, relative, SWITCH_TOLERANCE[kind]))
    return differences, times[True], times[False]


def shipped() -> Iterator[Path]:
    """Every scenario under ``scenarios/`` but the shared fragments."""
    yield from sorted(path for path in (ROOT / "scenarios").rglob("*.yaml") if FRAGMENTS not in path.parents)


def main() -> int:
    from ftc_mj.fast import SWITCH_TOLERANCE

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="*", default=(), help="scenario files (default: every shipped one)")
    parser.add_argument("--duration", type=float, help="override every scenario's duration (s)")
    args = parser.parse_args()
    print(f"stated tolerance (ftc_mj.fast.SWITCH_TOLERANCE, relative): {SWITCH_TOLERANCE}")
    everything: list[Difference] = []
    checks = [(Path(f), False) for f in args.only] or [(path, False) for path in shipped()]
    if not args.only:  # and the member path, as series_hashes.py checks it
        checks.append((ROOT / "scenarios" / "puma_fault.yaml", True))
    for path, batch in checks:
        try:
            differences, on, off = compare(path, 3.0 if batch else args.duration, batch)
        except Exception as exc:  # e.g. a robot of the `robots` extra that is not installed here
            print(f"skipped {path}: {exc}", file=sys.stderr)
            continue
        everything += differences
        moved = [d for d in differences if not d.equal_bits]
        print(f"{differences[0].scenario}: {len(differences)} arrays, {len(moved)} not bit-identical; "
              f"fast paths on {on:.1f} s, off {off:.1f} s ({off / on:.1f}x)", flush=True)
        for d in moved:
            print(f"  {d.variant} {d.kind} {d.name}: relative {d.relative:.3g} (tolerance {d.tolerance:g})")
    if not everything:
        return 1
    print("\nper kind: bit-identical / compared")
    for kind in sorted({d.kind for d in everything}):
        of_kind = [d for d in everything if d.kind == kind]
        print(f"  {kind}: {sum(d.equal_bits for d in of_kind)} / {len(of_kind)}")
    print("\nper metric: worst relative difference over every scenario and variant, its ratio to the tolerance")
    for name in sorted({d.name for d in everything if d.kind == "metric"}):
        worst = max((d for d in everything if d.kind == "metric" and d.name == name),
                    key=lambda d: (np.nan_to_num(d.relative, nan=np.inf), d.scenario))
        print(f"  {name:32s} {worst.relative:9.3g}  ratio {worst.ratio:6.3g}  ({worst.scenario}, {worst.variant})")
    outside = [d for d in everything if not d.within]
    print(f"\n{len(outside)} of {len(everything)} arrays outside the tolerance")
    return 1 if outside else 0


if __name__ == "__main__":
    sys.exit(main())
