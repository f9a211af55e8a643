"""Cost per control step against the number of joints: the Chapter 5 ``proposed`` variant (high-speed TOSMO +
NFTSMC) on the 3-joint PUMA560 (scenarios/puma_fault.yaml), the 6-joint UR5e-like arm and the 7-joint
Panda-like arm (scenarios/robots/), for a single run and for a batch, with where the time goes.

Per arm and mode it measures, alternating rounds and keeping the fastest of each (this machine's speed drifts):

* closed loop: a single run (:func:`ftc_mj.engine.runner.simulate_variant`, no recording) or a batch of B
  members (:func:`ftc_mj.engine.runner.run_batch`), per member and control period;
* physics: a bare ``mujoco.batch.Batch`` of the same model, substeps and B that only writes ``ctrl``;
* nominal model: one evaluation (M, C qd + G, M^-1) of the nominal batch
  (:func:`ftc_mj.robot.nominal.nominal_batch`) on B points, as the loop does once per period;
* the rest (methods' math, sensors, terms, bookkeeping) is the closed loop minus the two.

Prints a table and writes ``benchmarks/joint_cost.png`` (needs matplotlib) and ``benchmarks/joint_cost.json``.

    python benchmarks/joint_cost.py [--members 200] [--duration 1.0] [--rounds 3] [--plot-only]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import mujoco
import numpy as np

from batch_cost import bare  # the bare physics batch, measured as batch_cost.py measures it (this folder is on sys.path)

from ftc_mj.engine.members import replicates
from ftc_mj.engine.runner import run_batch, simulate_variant
from ftc_mj.robot.nominal import nominal_batch
from ftc_mj.scenario.loading import load_scenario

HERE = Path(__file__).resolve().parent
SCENARIOS = {3: HERE.parent / "scenarios" / "puma_fault.yaml",
             6: HERE.parent / "scenarios" / "robots" / "ur5e_fault.yaml",
             7: HERE.parent / "scenarios" / "robots" / "panda_fault.yaml"}


def nominal_evaluation(model: mujoco.MjModel, members: int, periods: int, threads: int) -> float:
    """Seconds per point of one evaluation of the nominal batch (M, C qd + G and the solve)."""
    nominal = nominal_batch(model, np.ones(members), nthread=threads)
    nominal.qpos[:] = 0.1
    start = time.perf_counter()
    for _ in range(periods):
        nominal.evaluate()
    return (time.perf_counter() - start) / (periods * members)


def measure(joints: int, members: int, duration: float, rounds: int, threads: int) -> dict[str, dict[str, float]]:
    scenario = load_scenario(SCENARIOS[joints], duration=duration, variants=["proposed"])
    assert scenario.n_joints == joints
    periods, variant = len(scenario.times), scenario.variants[0]
    batch = replicates(scenario, members)
    best = {mode: {"closed": np.inf, "physics": np.inf, "nominal": np.inf} for mode in ("single", "batch")}
    simulate_variant(load_scenario(SCENARIOS[joints], duration=0.05, variants=["proposed"]), variant)  # warm-up
    for _ in range(rounds):
        start = time.perf_counter()
        assert simulate_variant(scenario, variant).status == "ok"
        cost = best["single"]
        cost["closed"] = min(cost["closed"], (time.perf_counter() - start) / periods)
        cost["physics"] = min(cost["physics"], bare(scenario.model, 1, scenario.substeps, periods, 1))
        cost["nominal"] = min(cost["nominal"], nominal_evaluation(scenario.model, 1, periods, 1))
        start = time.perf_counter()
        assert all(o.status == "ok" for o in run_batch(scenario, batch, nthread=threads))
        cost = best["batch"]
        cost["closed"] = min(cost["closed"], (time.perf_counter() - start) / (periods * members))
        cost["physics"] = min(cost["physics"], bare(scenario.model, members, scenario.substeps, periods, threads))
        cost["nominal"] = min(cost["nominal"], nominal_evaluation(scenario.model, members, periods, threads))
    for cost in best.values():
        cost["rest"] = cost["closed"] - cost["physics"] - cost["nominal"]
    return best


def figure(results: dict[int, dict], members: int, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    joints = sorted(results)
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.6), constrained_layout=True)
    titles = {"single": "single run (B = 1)", "batch": f"batch (B = {members}), per member"}
    parts = [("physics", "physics (4 MuJoCo steps)", "#4c72b0"), ("nominal", "nominal model (1 evaluation)", "#55a868"),
             ("rest", "methods, sensors, terms, bookkeeping", "#c44e52")]
    for axis, mode in zip(axes, ("single", "batch")):
        bottom = np.zeros(len(joints))
        for key, label, colour in parts:
            values = np.array([results[n][mode][key] * 1e6 for n in joints])
            axis.bar([str(n) for n in joints], values, bottom=bottom, label=label, color=colour, width=0.6)
            bottom += values
        for x, total in enumerate(bottom):
            axis.text(x, total, f"{total:.1f} us", ha="center", va="bottom", fontsize=10)
        axis.set_title(titles[mode])
        axis.set_xlabel("joints (PUMA560 / UR5e-like / Panda-like)")
        axis.set_ylabel("us per control step")
        axis.set_ylim(0, bottom.max() * 1.18)
        axis.grid(axis="y", alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=3, fontsize=9, frameon=False)
    fig.suptitle("Cost per control step of the Chapter 5 method (HS-TOSMO + NFTSMC) against the number of joints")
    fig.savefig(path, dpi=110)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--members", type=int, default=200)
    parser.add_argument("--duration", type=float, default=1.0, help="simulated seconds per run")
    parser.add_argument("--threads", type=int, default=0, help="batch threads; 0: all cores")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--plot-only", action="store_true", help="redraw the figure from joint_cost.json")
    args = parser.parse_args()
    if args.plot_only:
        saved = json.loads((HERE / "joint_cost.json").read_text())
        figure({int(n): modes for n, modes in saved["results"].items()}, saved["members"], HERE / "joint_cost.png")
        return
    threads = args.threads or os.cpu_count() or 1
    results = {n: measure(n, args.members, args.duration, args.rounds, threads) for n in sorted(SCENARIOS)}
    print(f"us per control step (batch: per member, B = {args.members}, {threads} threads); fastest of "
          f"{args.rounds} rounds")
    print(f"{'joints':>6} {'mode':>6} {'closed':>8} {'physics':>8} {'nominal':>8} {'rest':>8} {'closed/physics':>15}")
    for n, modes in results.items():
        for mode, cost in modes.items():
            print(f"{n:>6} {mode:>6} " + " ".join(f"{cost[k] * 1e6:8.2f}" for k in ("closed", "physics", "nominal", "rest"))
                  + f" {cost['closed'] / cost['physics']:15.2f}")
    (HERE / "joint_cost.json").write_text(json.dumps({"members": args.members, "threads": threads,
                                                      "results": results}, indent=1))
    try:
        figure(results, args.members, HERE / "joint_cost.png")
    except ImportError:
        print("matplotlib is not installed: no figure")


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
