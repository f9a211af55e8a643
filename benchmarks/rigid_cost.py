"""The rigid-body kernel's cost per evaluation point (``ftc_mj/fast/rigid.py``), and against another version of
that file in the same process, alternated round by round, with a check that both give the same bits.

::

    python benchmarks/rigid_cost.py                                  # this version, PUMA560, 672 points
    git show main:ftc_mj/fast/rigid.py > /tmp/rigid_main.py
    python benchmarks/rigid_cost.py --against /tmp/rigid_main.py --model ur5e.xml --rounds 10

The points are random states with a mass scale each; two thirds have the velocity terms (as a campaign's
batch: Psi points and M-only points at the readings) and every other one the momentum terms. Each round times
5 x 200 calls of every version and keeps the best (ns per point); the medians over rounds are compared.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import time
from pathlib import Path
from types import ModuleType

import mujoco
import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def _load(name: str, path: Path) -> ModuleType:
    """A version of ``rigid.py`` as a module of its own (its Numba cache beside it)."""
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="puma560.xml", help="a model under models/")
    parser.add_argument("--points", type=int, default=672)
    parser.add_argument("--rounds", type=int, default=6)
    parser.add_argument("--against", type=Path, help="another version of ftc_mj/fast/rigid.py")
    args = parser.parse_args()

    from ftc_mj.fast import rigid
    from ftc_mj.robot.nominal import rigid_body_model

    versions = {"this": rigid} | ({"against": _load(args.against.stem, args.against)} if args.against else {})
    model = rigid_body_model(mujoco.MjModel.from_xml_path(str(ROOT / "models" / args.model)))
    rng = np.random.default_rng(0)
    points, n, nM = args.points, model.nv, model.nM
    q, qd, applied = rng.uniform(-3, 3, (points, n)), rng.normal(size=(points, n)), rng.normal(size=(points, n))
    scale, wanted = rng.uniform(0.8, 1.2, points), np.arange(points) % 2 == 0
    calls, outputs = {}, {}
    for name, module in versions.items():
        tree = module.RigidTree.from_model(model)
        out = [np.zeros((points, nM)), np.zeros((points, nM))] + [np.zeros((points, n)) for _ in range(5)]
        arguments = tree.arguments(*tree.scaled(scale), q, qd, applied, *out[:5], True, wanted, *out[5:],
                                   velocity_points=points * 2 // 3)
        start = time.perf_counter()
        calls[name] = module.evaluation(arguments)
        calls[name]()
        print(f"{name}: first call {time.perf_counter() - start:.1f} s (a compilation where its cache is cold)")
        outputs[name] = out
    if args.against:
        same = all(np.array_equal(a, b) for a, b in zip(outputs["this"], outputs["against"]))
        print(f"the same bits: {same}")
    costs: dict[str, list[float]] = {name: [] for name in versions}
    for round_ in range(args.rounds):
        for name in (list(versions) if round_ % 2 == 0 else list(versions)[::-1]):
            call, best = calls[name], np.inf
            for _ in range(5):
                start = time.perf_counter()
                for _ in range(200):
                    call()
                best = min(best, (time.perf_counter() - start) / 200 / points * 1e9)
            costs[name].append(best)
    for name, values in costs.items():
        print(f"{name}: ns per point by round " + ", ".join(f"{v:.0f}" for v in values)
              + f" (median {np.median(values):.0f})")
    if args.against:
        print(f"this / against (medians): {np.median(costs['this']) / np.median(costs['against']):.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
