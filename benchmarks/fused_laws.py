"""What the fused laws save: the methods' period (every variant's observer ``update``, controller ``compute``,
observer ``advance``) of ``scenarios/puma_fault.yaml`` fused and as the NumPy reference, in one process.

    python benchmarks/fused_laws.py [--members 1 41 84 1000] [--repeats 2000] [--rounds 3]

For each batch size a run of the four Chapter 5 variants is set up and stepped for a few hundred periods (the
states and the nominal model of a real run), once with the fused laws and once built inside
``laws.without_accelerators()`` (every other fast path on); then each runs the methods' calls of one period ``--repeats`` times, alternated over
``--rounds`` (the fastest of each counts: this machine's speed drifts). Prints microseconds per row and period
of each and their ratio. The laws' bits are the same either way (``tests/fast/test_fused_laws.py``).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from ftc_mj import load_scenario
from ftc_mj.engine import loop
from ftc_mj.engine.members import single
from ftc_mj.fast import laws

ROOT = Path(__file__).resolve().parents[1]
WARM_UP_PERIODS = 300


def prepared_run(scenario, members: int) -> loop._Run:
    """A run of ``members`` copies of the scenario's first member, stepped for :data:`WARM_UP_PERIODS`."""
    run = loop._Run.set_up(scenario, single(scenario).select(np.zeros(members, dtype=int)), False, 1)
    with np.errstate(all="ignore"):
        for k in range(WARM_UP_PERIODS):
            run.sense(k)
            run.evaluate_nominal(k)
            run.control(k, run.times[k])
            run.actuate(k, run.times[k])
            run.advance(k)
    return run


def methods_seconds(run: loop._Run, repeats: int) -> float:
    """Seconds per period of every block's methods calls (the same inputs every repeat)."""
    k = WARM_UP_PERIODS
    t = run.times[k]
    q_ref, qd_ref, qdd_ref = (values[k] for values in run.reference)
    start = time.perf_counter()
    with np.errstate(all="ignore"):
        for _ in range(repeats):
            for block in run.blocks:
                block.observer.update(t, block.q_meas, block.model)
                block.controller.compute(t, q_ref, qd_ref, qdd_ref, block.q_meas, block.observer, block.model)
                block.observer.advance(block.tau, block.model)
    return (time.perf_counter() - start) / repeats


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--members", type=int, nargs="+", default=[1, 41, 84, 1000])
    parser.add_argument("--repeats", type=int, default=2000)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    scenario = load_scenario(ROOT / "scenarios" / "puma_fault.yaml", duration=(WARM_UP_PERIODS + 1) * 1e-3)
    print(f"{scenario.name}: {len(scenario.variants)} variants, the methods' calls of one period, us per row-period")
    print(f"{'members':>8s} {'rows':>6s} {'fused':>8s} {'reference':>10s} {'reference / fused':>18s}")
    for members in args.members:
        fused = prepared_run(scenario, members)
        with laws.without_accelerators():
            reference = prepared_run(scenario, members)
        repeats = max(20, args.repeats // members)
        best = {"fused": np.inf, "reference": np.inf}
        for _ in range(args.rounds):
            best["fused"] = min(best["fused"], methods_seconds(fused, repeats))
            best["reference"] = min(best["reference"], methods_seconds(reference, repeats))
        rows = fused.rows
        print(f"{members:8d} {rows:6d} {best['fused'] / rows * 1e6:8.3f} {best['reference'] / rows * 1e6:10.3f} "
              f"{best['reference'] / best['fused']:18.2f}")


if __name__ == "__main__":
    main()
