"""Suite v2's faults against the healthy residual: whether each fault case acts on the plant (checked when a
bench is built, from one healthy run per robot) and the robot's residual unit (measured once, written into the
suite file).

A case acts when the torque it would put on the plant, held for the diagnoser's persistence, reaches
:data:`ACTS` of the robot's residual unit inside its window: from the healthy command tau of the reference loop
(its first calibration run), a bias puts b on the joint, a loss of effectiveness alpha |tau|, a saturation at L
max(|tau| - L, 0), a float |tau| and a lock |tau(onset) - tau|. A case under it (``saturation`` at 0.8 of the
peak torque on the PUMA560, UR5e and Panda: none at all; at 0.6 on the PUMA560, spikes shorter than the
persistence) is refused: one line naming the suite file, the fault and the robot.

``python -m ftc_mj.ranking.sizing SUITE [--tier quick]`` measures each robot's residual unit: per fault joint,
the 99th percentile of oracle_luaf's held residual (the true LUaF in the diagnosis space less its baseline
mean, :mod:`ftc_mj.ranking.windows`) over the joint's scored windows of the calibration runs, and prints the
``residual_unit`` lines of the suite file.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import yaml

from ftc_mj.config.errors import InputError
from ftc_mj.ranking.suite import REFERENCE, Suite, load_suite
from ftc_mj.ranking.windows import held

#: A fault case acts when its held torque reaches this share of the robot's residual unit in its window.
ACTS = 0.05


def _loop_scenario(suite: Suite, robot: str, tier: str, folder: Path) -> Path:
    """The robot's reference loop without monitors, as the suite's diagnosis scenario, in ``folder``."""
    files = {"stage.yaml": suite.stage(robot),
             "scenario.yaml": suite.scenario(robot, "diagnosis", tier, {REFERENCE: suite.loop(robot)})}
    for name, content in files.items():
        (folder / name).write_text(yaml.safe_dump(content, sort_keys=False), encoding="utf-8")
    return folder / "scenario.yaml"


def healthy_command(suite: Suite, robot: str, tier: str) -> tuple[np.ndarray, np.ndarray, int]:
    """The reference loop's healthy run on the first calibration seed at the nominal mass scale: its sample
    times, its command tau ``(N, n)`` and the diagnoser's persistence [samples]."""
    from ftc_mj.engine.members import members_from_overrides
    from ftc_mj.engine.runner import run_batch
    from ftc_mj.scenario.loading import load_scenario

    seeds = suite.spec.populations.get("calibrate")
    seed = seeds.seed if seeds is not None else suite.spec.protocol.seed
    with tempfile.TemporaryDirectory(prefix="ftc_mj_sizing_") as folder:
        scenario = load_scenario(_loop_scenario(suite, robot, tier, Path(folder)))
    kept: dict[str, np.ndarray] = {}

    def keep(member: int, results: list) -> None:
        kept["t"], kept["tau"] = results[0].t.copy(), results[0].tau.copy()

    run_batch(scenario, members_from_overrides(scenario, [{"seed": seed}]), nthread=1, on_result=keep)
    persistence = max(1, scenario.diagnoser.persistence) if scenario.diagnoser is not None else 1
    return kept["t"], kept["tau"], persistence


def case_torque(case: dict, t: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """The torque a fault case would put on its joint, from the healthy command, over the run ``(N,)``."""
    fault = case["set"]["actuator_faults"][0]
    joint = fault["joints"][0] - 1
    onset, end = fault["profile"]["onset"], fault["profile"]["end"]
    u = tau[:, joint]
    on = (t >= onset) & (t < end)
    kind = fault["kind"]
    if kind == "bias":
        torque = np.full_like(u, abs(fault["offset"]))
    elif kind == "loss_of_effectiveness":
        torque = fault["alpha"] * np.abs(u)
    elif kind == "saturation":
        torque = np.maximum(np.abs(u) - fault["limit"], 0.0)
    elif kind == "float":
        torque = np.abs(u)
    else:  # lock: the command frozen at the onset
        frozen = u[np.argmax(on)] if on.any() else 0.0
        torque = np.abs(frozen - u)
    return np.where(on, torque, 0.0)


def check_faults_act(suite: Suite, tier: str) -> dict[str, dict[str, float]]:
    """Each robot's fault cases' held torque peak [N m] (from :func:`healthy_command`).

    Raises:
        InputError: naming the suite file and the fault kind, for a case that would not act.
    """
    out: dict[str, dict[str, float]] = {}
    for robot, spec in suite.spec.robots.items():
        t, tau, persistence = healthy_command(suite, robot, tier)
        unit = min(spec.residual_unit or spec.torque_scale)
        out[robot] = {}
        for case in suite.fault_cases(robot, "diagnosis"):
            peak = float(np.nanmax(held(case_torque(case, t, tau)[:, None], persistence), initial=0.0))
            out[robot][case["label"]] = peak
            if peak < ACTS * unit:
                kind = case["values"]["kind"]
                raise InputError(str(suite.path), f"faults.{kind}", f"{case['label']} would put {peak:.3g} N m on "
                                 f"{robot}'s plant for the persistence, under {ACTS:g} x its residual unit "
                                 f"({unit:.3g} N m): a case that does not act cannot be scored")
    return out


def residual_units(windows: dict[str, np.ndarray], suite: Suite, robot: str) -> list[float]:
    """Per fault joint, the 99th percentile of oracle_luaf's held residual envelope over its stratum windows of
    the calibration runs (a ``windows.npz`` of the calibrate population)."""
    dt, steps = windows["times"]
    block = windows["envelope/oracle_luaf"].shape[1]
    block_seconds = dt * steps / block
    units = []
    longest = max(suite.spec.calibration.windows) if suite.spec.calibration else 1.0
    for onset, joint in zip(suite.spec.protocol.onsets, suite.spec.robots[robot].fault_joints):
        first, last = int(round(onset / block_seconds)), int(round((onset + longest) / block_seconds))
        values = windows["envelope/oracle_luaf"][:, first:last, joint - 1]
        units.append(float(np.nanpercentile(values, 99)))
    return units


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m ftc_mj.ranking.sizing",
                                     description="Measure a v2 suite's residual units from a bench's calibration "
                                     "runs (run `ftc-mj bench` first; its output directory holds them).")
    parser.add_argument("suite")
    parser.add_argument("out", type=Path, help="a bench's output directory")
    args = parser.parse_args(argv)
    from ftc_mj.ranking.windows import load

    suite = load_suite(args.suite)
    for robot in suite.spec.robots:
        found = sorted((args.out / "runs" / "diagnosis" / robot / "calibrate").glob("*/results/windows.npz"))
        if not found:
            print(f"{robot}: no calibration runs in {args.out}", file=sys.stderr)
            continue
        units = residual_units(load(found[0]), suite, robot)
        print(f"{robot}: residual_unit: [{', '.join(f'{u:.3g}' for u in units)}]")
    return 0


if __name__ == "__main__":
    sys.exit(main())
