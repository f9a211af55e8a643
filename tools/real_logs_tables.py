"""The before/after tables of docs/results/real-logs.md: the shipped UR10e logs (data/ur10) replayed with three
nominal models, the rigid body alone, the friction identified by the logs' source (the shipped scenarios'),
and the friction ``ftc-mj identify --only friction`` fits on the free-motion log:

* the torque residual RMS of each model (filtered, ``ftc_mj.robot.identify.residual_rms``) on the free motion
  and on the pushed log outside its labelled pushes (data not used for any fit here);
* the observers' residual RMS on the free motion (the diagnosis signal from 0.5 s);
* thresholds set on the free motion alone (``calibrate`` on the log: 1.1 times the momentum observer's
  largest residual, floor 3 N m on the wrists) and the pushed log scored against its events with them.

    python tools/real_logs_tables.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ftc_mj.campaign.calibrate import calibrate_log
from ftc_mj.cli.identify import _motions
from ftc_mj.engine.runner import run_scenario
from ftc_mj.logs.events import event_metrics
from ftc_mj.logs.trajectory import joint_names
from ftc_mj.robot.friction import FrictionSpec, JointFriction
from ftc_mj.robot.identify import Identified, fit_friction, residual_rms
from ftc_mj.scenario.loading import load_scenario

ROOT = Path(__file__).resolve().parents[1]
FREE, PUSHED = ROOT / "scenarios/real/ur10e_free_motion.yaml", ROOT / "scenarios/real/ur10e_pushed.yaml"
OBSERVERS = ["momentum", "do", "eso"]


def overrides(friction: JointFriction) -> list[str]:
    return [f"nominal.friction.{name}={np.round(getattr(friction, name), 6).tolist()}"
            for name in ("viscous", "coulomb", "offset")]


def cells(values: np.ndarray, digits: int = 1) -> str:
    return " / ".join("-" if not np.isfinite(v) else f"{v:.{digits}f}" for v in values)


def main() -> None:
    free = load_scenario(FREE)
    model, joints = free.model, joint_names(free.model)
    free_motion, = _motions([FREE], joints, 5.0)
    pushed_motion, = _motions([PUSHED], joints, 5.0)
    source = JointFriction.of(free.spec.nominal.friction, model)
    zero = JointFriction.of(FrictionSpec(), model)
    fitted = fit_friction(model, [free_motion], joints).friction
    models = {"rigid body alone": zero, "source's friction (shipped)": source, "identified on the free motion": fitted}
    print("## Torque residual RMS of the model [N m], joints 1-6\n")
    print("| model | free motion | pushed log outside the pushes |\n|---|---|---|")
    for name, friction in models.items():
        identified = Identified(friction, "friction")
        print(f"| {name} | {cells(residual_rms(model, identified, free_motion))} | "
              f"{cells(residual_rms(model, identified, pushed_motion))} |")
    print("\n## Observers on the free motion: residual RMS [N m], thresholds set on it [N m]\n")
    print("| model | " + " | ".join(OBSERVERS) + " | thresholds (momentum, x1.1) |\n|---|---|---|---|---|")
    thresholds = {}
    for name, friction in models.items():
        results = run_scenario(load_scenario(FREE, overrides=overrides(friction), variants=OBSERVERS),
                               record_poses=False)
        rms = {r.name: np.sqrt(np.mean(r.diagnosis.signal[r.diagnosis.armed] ** 2, axis=0)) for r in results}
        thresholds[name] = calibrate_log(FREE, margin=1.1, overrides=overrides(friction),
                                         variants=["momentum"]).thresholds
        print(f"| {name} | " + " | ".join(cells(rms[o][:3]) for o in OBSERVERS)
              + f" | {cells(thresholds[name])} |")
    print("\n## The pushed log against its labelled pushes, thresholds from the free motion\n")
    print("| model | observer | pushes detected per joint (share) | alarms outside the pushes | "
          "alarms on other joints |\n|---|---|---|---|---|")
    events = load_scenario(PUSHED).log.events
    for name, friction in models.items():
        fixed = f"diagnosis.threshold.fixed={np.round(thresholds[name], 4).tolist()}"
        results = run_scenario(load_scenario(PUSHED, overrides=[*overrides(friction), fixed], variants=OBSERVERS),
                               record_poses=False)
        for result in results:
            metrics = event_metrics(result.diagnosis, events, len(joints))
            print(f"| {name} | {result.name} | {cells(metrics['events_detected'], 2)} | "
                  f"{int(metrics['alarms_outside_events'].sum())} | {int(metrics['alarms_on_other_joints'].sum())} |")
    print("\nidentified friction (b / c / o per joint): "
          + "; ".join(f"{b:.2f} / {c:.2f} / {o:+.2f}" for b, c, o in zip(fitted.viscous, fitted.coulomb, fitted.offset)))


if __name__ == "__main__":
    main()
