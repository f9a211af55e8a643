"""De Luca and Mattone's generalized momentum observer: with the velocity measured exactly, the residual
follows a step of the fault torque as the first-order filter of its design, r_k = f (1 - (1 - K_I T)^k) (time
constant 1 / K_I per joint), in a closed loop on the PUMA560 through the engine (so with the nominal model's
C^T qd and G); the same within the differentiator's accuracy on Levant's velocity; the LUaF estimate is
M^-1 r (an acceleration); the sensors each name needs.

The plant is MuJoCo's PUMA560 without friction or any term but the fault, stepped at 0.1 ms under an SMC at
1 kHz along a fast reference (joint speeds up to about 3 rad/s, so that C^T qd is several N m); the fault is
a constant torque from 0.5 s.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from double_integrator import FakeStepModel
from pydantic import ValidationError

from ftc_mj.engine.loop import simulate
from ftc_mj.engine.members import members_from_overrides
from ftc_mj.engine.runner import variant_result
from ftc_mj.methods.observers import BUILTIN, LevantMomentumObserver, MomentumObserver
from ftc_mj.robot.nominal import NEEDS
from ftc_mj.scenario.loading import load_scenario

PUMA = Path(__file__).resolve().parents[3] / "models" / "puma560.xml"
DT = 1e-3
ONSET = 0.5
#: The step of the fault torque [N m] and K_I per joint [1/s] (time constants 25, 12.5, 10 ms).
FAULT = np.array([4.0, -3.0, 2.0])
K = np.array([40.0, 80.0, 100.0])


def scenario_dict(observer: dict) -> dict:
    return {
        "name": "momentum_step",
        "robot": {"model": str(PUMA), "sensors": ["position", "velocity"]},
        "duration": 0.8,
        "control_dt": DT,
        "timestep": 1e-4,
        "initial": {"q": [0.0, -0.5, 0.5], "qd": [0.0, 0.0, 0.0]},
        "reference": ["0.8*sin(4*t)", "-0.5 + 0.6*sin(5*t)", "0.5 + 0.8*sin(6*t)"],
        "terms": [{"kind": "fault", "space": "torque", "sign": 1, "value": [str(f) for f in FAULT],
                   "onset": ONSET}],
        "controller_velocity": "measured",
        "metrics": {"window_start": 0.1, "estimation_window_start": 0.1},
        "variants": {"momentum": {"observer": observer, "controller": {
            "type": "smc", "gains": {"c": 20.0, "bound": 5.0, "mu": 0.5, "compensation": "none"}}}},
    }


def run(tmp_path: Path, observer: dict):
    path = tmp_path / "momentum.yaml"
    path.write_text(yaml.safe_dump(scenario_dict(observer), sort_keys=False), encoding="utf-8")
    scenario = load_scenario(path)
    return variant_result(scenario, simulate(scenario, members_from_overrides(scenario, [{}]), nthread=1), 0, 0)


def first_order_step(t: np.ndarray) -> np.ndarray:
    """The discrete filter's response to the step: the fault acts from the period at ONSET, so the residual
    moves from the next sample on, r_k = f (1 - (1 - K T)^(k - k0))."""
    periods = np.maximum(np.rint((t - ONSET) / DT), 0.0)[:, None]
    return FAULT * (1.0 - (1.0 - K * DT) ** periods)


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    return run(tmp_path_factory.mktemp("momentum"), {"type": "momentum", "gains": {"K": K.tolist()}})


def test_the_residual_is_a_first_order_lag_of_a_step_fault_torque(measured):
    """r follows the step as (1 - (1 - K T)^k) f, each joint with its own time constant 1 / K, decoupled, and
    zero before the fault, to 0.03 N m (measured: 0.02, in the first 0.2 s where the SMC's torques reach
    300 N m; the trapezoidal sum of the model terms against the plant's 0.1 ms steps). A missing C^T qd or a
    wrong sign of it (5 and 11 N m of error along this motion), a wrong sign of r or of its feedback (the
    observer diverges), +G for -G: all far outside it. The continuous filter 1 - e^(-K t) is within K T / (2e)
    f of the discrete one."""
    result = measured
    residual, t = result.extras["residual"], result.t
    np.testing.assert_array_equal(result.fault_torque[t >= ONSET], np.broadcast_to(FAULT, (int((t >= ONSET).sum()), 3)))
    expected = first_order_step(t)
    error = np.abs(residual - expected)
    assert error.max() < 0.03, error.max(axis=0)
    # Each joint reaches 1 - 1/e of its step one time constant 1 / K after the onset, within the sampling.
    for j in range(3):
        reached = t[np.argmax(residual[:, j] / FAULT[j] >= 1.0 - np.exp(-1.0))]
        assert abs(reached - (ONSET + 1.0 / K[j])) <= 1.5 * DT, (j, reached)
    continuous = FAULT * (1.0 - np.exp(-K * np.maximum(t - ONSET, 0.0)[:, None]))
    assert np.abs(residual - continuous).max() < 0.03 + (K * DT * np.abs(FAULT)).max() / (2 * np.e)
    # The motion is fast enough for C^T qd to matter: |qd| reaches ~3 rad/s.
    assert np.abs(result.qd_true).max() > 2.0


def test_the_luaf_estimate_is_the_residual_in_acceleration_units(measured):
    """luaf_hat = M(x1)^-1 r: after the fault it approaches M^-1 f (the fault torque as an acceleration),
    which is the testbed's fault_acceleration."""
    result = measured
    late = result.t > ONSET + 0.1
    np.testing.assert_allclose(result.luaf_hat[late], result.fault_acceleration[late], rtol=0,
                               atol=0.03 * np.abs(result.fault_acceleration[late]).max())


class JointModel(FakeStepModel):
    """One joint of inertia ``mass`` under a constant gravity torque: C^T qd = 0, G = ``gravity``."""

    def __init__(self, mass: float, gravity: float):
        super().__init__(np.array([[mass]]))
        self.coriolis_transpose, self.gravity = np.zeros(1), np.array([gravity])


def one_joint(observer, steps: int, measured: bool) -> np.ndarray:
    """Residuals ``(steps,)`` on m qdd = tau + f - G (f from ONSET), integrated exactly over each period."""
    mass, gravity, fault = 2.0, 3.0, FAULT[0]
    model = JointModel(mass, gravity)
    q, v = 0.3, -0.2
    observer.reset(np.array([q]), np.array([v]))
    out = np.empty(steps)
    for k in range(steps):
        t = k * DT
        tau = 2.0 * np.sin(3.0 * t) + gravity
        observer.measure(np.array([q]), np.array([v]) if measured else None)
        observer.update(t, np.array([q]), model)
        out[k] = observer.residual[0]
        a = (tau + (fault if t >= ONSET else 0.0) - gravity) / mass
        q, v = q + v * DT + 0.5 * a * DT**2, v + a * DT
        observer.advance(np.array([tau]), model)
    return out


def test_the_levant_velocity_gives_the_same_lag_within_its_accuracy():
    """Position-only, one joint: on the exact velocity the residual is the discrete filter to rounding; on
    Levant's (order 2, L = 50 rad/s^3 for the 18 rad/s^3 of this motion), whose error enters p = M qd_hat, it
    follows the same lag within 0.05 N m (measured: 0.023) outside the 150 ms after the step, where the
    acceleration's jump (beyond any L) is the differentiator's transient (1 N m at most), and it converges to
    the fault."""
    k = np.arange(1000)
    expected = FAULT[0] * (1.0 - (1.0 - 50.0 * DT) ** np.maximum(k - round(ONSET / DT), 0))
    exact = one_joint(MomentumObserver(MomentumObserver.Config.model_validate(
        {"K": 50.0}, context={"n_joints": 1}), 1, DT), 1000, measured=True)
    np.testing.assert_allclose(exact, expected, rtol=0, atol=1e-9)
    levant = one_joint(LevantMomentumObserver(LevantMomentumObserver.Config.model_validate(
        {"K": 50.0, "order": 2, "L": 50.0}, context={"n_joints": 1}), 1, DT), 1000, measured=False)
    error = np.abs(levant - expected)
    transient = (k >= round(ONSET / DT)) & (k < round((ONSET + 0.15) / DT))
    assert error[~transient].max() < 0.05 and error[transient].max() < 1.5
    assert levant[-1] == pytest.approx(FAULT[0], abs=0.05)


def test_sensors_needs_and_schema():
    assert BUILTIN["momentum"] is MomentumObserver and BUILTIN["momentum_levant"] is LevantMomentumObserver
    assert MomentumObserver.requires == {"position", "velocity"} and LevantMomentumObserver.requires == {"position"}
    assert MomentumObserver.needs == LevantMomentumObserver.needs == {"coriolis_transpose", "gravity"} <= NEEDS
    assert BUILTIN["ndob"].needs == frozenset()  # the default: the engine computes nothing more
    observer = MomentumObserver(MomentumObserver.Config.model_validate({"K": 50.0}, context={"n_joints": 2}), 2, DT)
    with pytest.raises(ValueError, match="measured velocities"):
        observer.measure(np.zeros(2), None)
    observer.reset(np.zeros(2), np.zeros(2))
    with pytest.raises(ValueError, match="coriolis_transpose and gravity"):
        observer.update(0.0, np.zeros(2), FakeStepModel(np.eye(2)))  # a StepModel without C^T qd and G
    with pytest.raises(ValidationError):
        MomentumObserver.Config.model_validate({"K": 0.0}, context={"n_joints": 2})
    with pytest.raises(ValidationError):
        MomentumObserver.Config.model_validate({"K": 1.0, "L": 3.0}, context={"n_joints": 2})
    with pytest.raises(ValidationError):
        LevantMomentumObserver.Config.model_validate({"K": 1.0}, context={"n_joints": 2})  # L missing
