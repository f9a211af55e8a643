"""Chapter 2's disturbance observer (DO), eqs. (2.6)/(2.20), on measured velocities.

Plant: double_integrator.py's (one joint, qdd = tau / m + d(t), integrated exactly). Its ``simulate`` hands an
observer positions only, so :class:`Tachometer` adds the measured velocity: before each ``update`` it calls
``measure(q, v)`` with the plant's true velocity, rebuilt from the same closed form as the plant.

Bounds were measured first and set with a 2-3x margin; the measured value is written beside each.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from pydantic import ValidationError

from double_integrator import DT, SLOW, FakeStepModel, simulate

from ftc_mj.methods.observers import DisturbanceObserver
from ftc_mj.config.errors import InputError
from ftc_mj.scenario.loading import load_scenario

GAINS = {"k1": 8.0, "k2": 18.0, "p1": 10.0, "p2": 10.0}  # Table 2.2
ROOT = Path(__file__).resolve().parents[3]


def make(n_joints: int = 1, **gains) -> DisturbanceObserver:
    config = DisturbanceObserver.Config.model_validate(gains or GAINS, context={"n_joints": n_joints})
    return DisturbanceObserver(config, n_joints, DT)


class Tachometer:
    """The DO inside ``simulate``: v(t_k) = v(0) + sum of M^-1 tau dt + integral of d from 0 to t_k, which is
    the plant's own update summed. ``simulate`` must be called with ``qd_error=0`` so that ``reset`` receives
    the true v(0); the DO's own velocity state x2_hat then starts ``offset`` away from it."""

    def __init__(self, observer: DisturbanceObserver, offset: float):
        self.observer, self.offset = observer, offset
        self.torque_part = None

    def __getattr__(self, name):  # q_hat, qd_hat, luaf_hat, ... of the DO
        return getattr(self.observer, name)

    def reset(self, q_hat, qd_hat):
        self.torque_part = np.array(qd_hat, dtype=float)
        self.observer.reset(q_hat, qd_hat)
        self.observer.velocity_state += self.offset

    def update(self, t, q_meas, model):
        self.observer.measure(q_meas, self.torque_part + SLOW.int1(t))
        self.observer.update(t, q_meas, model)

    def advance(self, tau, model):
        self.observer.advance(tau, model)
        self.torque_part += DT * model.solve_M(tau)


# --------------------------------------------------------------------------------------------------
# configuration and the protocol


@pytest.mark.parametrize(
    "gains",
    [
        {"k1": 8.0, "k2": 18.0, "p1": 10.0},  # p2 missing
        {**GAINS, "k2": 0.0},  # gains positive
        {**GAINS, "p1": -1.0},
        {**GAINS, "k1": [8.0, 8.0]},  # wrong length for 3 joints
        {**GAINS, "L": 9.0},  # unknown key
    ],
)
def test_config_errors_raise_validation_error(gains):
    with pytest.raises(ValidationError):
        DisturbanceObserver.Config.model_validate(gains, context={"n_joints": 3})


def test_measure_passes_the_readings_on_and_needs_velocities():
    observer = make(2)
    observer.reset(np.zeros(2), np.zeros(2))
    observer.measure(np.array([0.1, -0.2]), np.array([1.5, -0.5]))
    np.testing.assert_array_equal(observer.q_hat, [0.1, -0.2])
    np.testing.assert_array_equal(observer.qd_hat, [1.5, -0.5])
    np.testing.assert_array_equal(observer.velocity_state, 0.0)  # x2_hat is the DO's own state
    with pytest.raises(ValueError, match="velocit"):
        observer.measure(np.array([0.1, -0.2]), None)


def test_two_periods_by_hand():
    """zeta_hat = k1 |x2~|^(1/2) sign(x2~) + p1 x2~ + z (2.20) is the LUaF estimate and the injection;
    x2_hat += dt (Psi + M^-1 tau + zeta_hat), z += dt (k2 sign(x2~) + p2 x2~) (2.6)."""
    k1, k2, p1, p2 = np.array([8.0, 4.0, 2.0]), np.array([18.0, 9.0, 3.0]), np.array([10.0, 5.0, 1.0]), 10.0
    observer = make(3, k1=list(k1), k2=list(k2), p1=list(p1), p2=p2)
    M = np.array([[2.0, 0.3, 0.1], [0.3, 1.5, -0.2], [0.1, -0.2, 0.8]])
    step = FakeStepModel(M, psi_hat=[0.3, -1.1, 2.0])
    x2_hat, z = np.array([0.5, 0.0, -1.0]), np.zeros(3)
    observer.reset(np.zeros(3), x2_hat)
    for q, qd, tau in [
        ([0.1, 0.2, 0.3], [0.9, -0.04, -1.0], [1.0, -2.0, 0.5]),  # x2~ of both signs and zero
        ([0.11, 0.19, 0.29], [0.7, 0.3, -1.2], [0.5, 1.0, -0.5]),
    ]:
        observer.measure(np.array(q), np.array(qd))
        observer.update(0.0, np.array(q), step)
        error = np.array(qd) - x2_hat
        zeta = k1 * np.sqrt(np.abs(error)) * np.sign(error) + p1 * error + z
        np.testing.assert_allclose(observer.luaf_hat, zeta, rtol=1e-13)
        np.testing.assert_array_equal(observer.injection, observer.luaf_hat)

        observer.advance(np.array(tau), step)
        x2_hat = x2_hat + DT * (step.psi_hat + np.linalg.solve(M, tau) + zeta)
        z = z + DT * (k2 * np.sign(error) + p2 * error)
        np.testing.assert_allclose(observer.velocity_state, x2_hat, rtol=1e-13)
        np.testing.assert_array_equal(observer.qd_hat, qd)  # the measurement, not x2_hat


# --------------------------------------------------------------------------------------------------
# convergence on the double integrator


def test_estimate_converges_to_the_unknown_input():
    """x2_hat starts 1 rad/s off and z = 0 against d(0) = 1; the measured velocity is passed through."""
    run = simulate(Tachometer(make(), offset=1.0), SLOW, T=3.0, qd_error=0.0)
    # qd_hat is the measured velocity: measured 5.9e-13 (the plant's and Tachometer's sums round differently).
    assert np.abs(run["vel_err"]).max() < 2e-12
    t, error = run["t"], run["luaf_err"]
    # The error starts at d(0) - zeta_hat(0) = 1 + k1 + p1 = 19 and stays below 0.05 from 0.296 s (measured).
    assert error[0] == pytest.approx(19.0)
    assert t[np.nonzero(np.abs(error) > 0.05)[0][-1] + 1] < 0.6
    # After 1 s, measured RMS 0.0111, max 0.031 (discrete super-twisting chattering, k2 dt = 0.018).
    after = t >= 1.0
    assert np.sqrt(np.mean(error[after] ** 2)) < 0.03
    assert np.abs(error[after]).max() < 0.08


# --------------------------------------------------------------------------------------------------
# the scenario loader


def scenario_with_do(tmp_path, sensors=None) -> Path:
    """two_link_tosmo_simple.yaml (no tachometers) with the DO as the proposed variant's observer."""
    raw = yaml.safe_load((ROOT / "scenarios" / "two_link_tosmo_simple.yaml").read_text())
    raw["robot"]["model"] = str(ROOT / "models" / "two_link.xml")
    if sensors is not None:
        raw["robot"]["sensors"] = sensors
    raw["variants"]["proposed"]["observer"] = {"type": "do", "gains": GAINS}
    path = tmp_path / "do_without_tachometers.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


def test_loader_refuses_the_do_without_velocity_sensors(tmp_path):
    with pytest.raises(InputError) as caught:
        load_scenario(scenario_with_do(tmp_path), variants=["proposed"])
    assert caught.value.field == "variants.proposed.observer.type"
    assert "velocity" in caught.value.problem
    # The same file with tachometers loads (two_link.xml has jointvel sensors).
    scenario = load_scenario(scenario_with_do(tmp_path, ["position", "velocity"]), variants=["proposed"])
    assert scenario.variants[0].observer_type is DisturbanceObserver
