"""Residual RMS per variant and joint of a scenario over a time window, and the times its alarms are raised:
the before/after tables of docs/results/arms.md and docs/results/real-logs.md.

    python tools/residual_rms.py SCENARIO.yaml [START [END]] [--set KEY=VALUE ...]

The residual is the diagnosis' filtered signal (torque space where the scenario diagnoses there) and, for an
observer with a ``residual`` signal (the momentum observer), that signal as well.
"""

from __future__ import annotations

import argparse

import numpy as np

from ftc_mj.engine.runner import run_scenario
from ftc_mj.scenario.loading import load_scenario


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario")
    parser.add_argument("start", nargs="?", type=float, default=0.5)
    parser.add_argument("end", nargs="?", type=float, default=np.inf)
    parser.add_argument("--set", action="append", default=[], dest="overrides")
    args = parser.parse_args()
    scenario = load_scenario(args.scenario, overrides=args.overrides)
    for result in run_scenario(scenario, record_poses=False):
        window = (result.t >= args.start) & (result.t < args.end)
        diagnosis = result.diagnosis
        line = f"{result.name:12s}"
        if diagnosis is not None:
            rms = np.sqrt(np.mean(diagnosis.signal[window] ** 2, axis=0))
            line += " signal RMS " + " ".join(f"{x:6.2f}" for x in rms)
        residual = (result.extras or {}).get("residual")
        if residual is not None:
            line += " | residual RMS " + " ".join(f"{x:6.2f}" for x in np.sqrt(np.mean(residual[window] ** 2, axis=0)))
        print(line)
        if diagnosis is not None:
            raised = [np.round(diagnosis.t[diagnosis.raised[:, j]], 2).tolist() for j in range(diagnosis.alarm.shape[1])]
            print(f"{'':12s} alarms raised at [s], per joint: {raised}")


if __name__ == "__main__":
    main()
