"""The controllers that read the diagnosis in the loop, on scenarios/ftc/puma_active.yaml shortened to 9 s (joint 2
losing half its effectiveness from 8 s): each reconfigures at the period its variant's in-loop diagnosis first
alarms; the supervisor is its PID, bit for bit, until then; the accommodation's loss estimate approaches the
injected loss on the faulty joint alone."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ftc_mj import load_scenario, run_scenario

ROOT = Path(__file__).resolve().parents[3]
SCENARIO = ROOT / "scenarios/ftc/puma_active.yaml"


@pytest.mark.slow  # a closed-loop run of 9 s, four variants
def test_loops_reconfigure_when_their_diagnosis_alarms():
    scenario = load_scenario(SCENARIO, duration=9.0, variants=["active", "supervisor", "accommodation", "pid"])
    results = {r.name: r for r in run_scenario(scenario, record_poses=False)}
    for name in ("active", "supervisor", "accommodation"):
        result = results[name]
        alarmed = np.logical_or.accumulate(result.diagnosis.alarm, axis=0)  # the component's isolation, latched
        first = int(np.argmax(alarmed.any(axis=1)))
        assert alarmed.any() and 8.0 < result.t[first] < 8.5, (name, result.t[first])
        reconfigured = result.extras["reconfigured"]
        assert not reconfigured[:first].any() and reconfigured[first:].any(axis=1).all(), name
    supervisor, pid = results["supervisor"], results["pid"]
    switch = int(np.argmax(supervisor.extras["reconfigured"].any(axis=1)))
    np.testing.assert_array_equal(supervisor.tau[:switch], pid.tau[:switch])
    assert not np.array_equal(supervisor.tau[switch:switch + 10], pid.tau[switch:switch + 10])
    loss = results["accommodation"].extras["loss_estimate"]
    assert np.all(loss[:, [0, 2]] == 0.0)  # the healthy joints are never accommodated
    assert 0.35 < loss[-1, 1] < 0.6, loss[-1]  # the actuator delivers (1 - 0.5 (1 - exp(-5 (t - 8)))) of the command
