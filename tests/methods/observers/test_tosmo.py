"""TOSMO (3.11) and high-speed TOSMO (5.6) on a plant-free double integrator.

Plant: one joint, qdd = tau / m + d(t) with the smooth unknown input d(t) = 2 sin t + 1 (|d'| <= 2, well below
the design bound D = 10 of Remark 5.3). The plant is integrated exactly over each control period (tau is held,
d is integrated in closed form), so every error left is the observer's. The observer runs the runner's
protocol at dt = 1 ms: ``update(t, q_meas, model)``, then ``advance(tau, model)`` with the applied torque.

Bounds were measured first and set with a 2-3x margin; the measured value is written beside each.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from pydantic import ValidationError

from double_integrator import DT, MASS, FakeStepModel, simulate
from nominal_oracle import NominalModel, step_model

from ftc_mj.methods.observers import HighSpeedTOSMO, TOSMO
from ftc_mj.methods.observers.base import signed_power

D_BOUND = 10.0
GAMMA = 5.0  # the scenario's Gamma (scenarios/puma_fault.yaml)
VEL_TOL = 0.02  # rad/s, the scenario's velocity_tolerance

# A single hinge with a point-like mass 1 m from the axis and gravity off: M constant, Psi = 0.
HINGE_XML = """
<mujoco>
  <option gravity="0 0 0" timestep="0.001"/>
  <worldbody>
    <body>
      <joint name="j" type="hinge" axis="0 0 1"/>
      <geom type="sphere" size="0.01" pos="1 0 0" mass="2"/>
    </body>
  </worldbody>
</mujoco>
"""


# --------------------------------------------------------------------------------------------------
# plant and helpers


def settling_time(t: np.ndarray, err: np.ndarray, tol: float) -> float:
    """First time after which |err| stays below tol."""
    above = np.nonzero(np.abs(err) > tol)[0]
    return 0.0 if len(above) == 0 else float(t[above[-1] + 1])


def make(cls, n_joints: int = 1, **gains):
    return cls(cls.Config.model_validate(gains, context={"n_joints": n_joints}), n_joints, DT)


def fake_step() -> FakeStepModel:
    return FakeStepModel(MASS * np.eye(1))


# --------------------------------------------------------------------------------------------------
# configuration


def test_gains_from_D_follow_remark_5_3():
    config = TOSMO.Config.model_validate({"D": [1.0, 8.0, 27.0]}, context={"n_joints": 3})
    k1, k2, k3 = config.gains()
    np.testing.assert_allclose(k1, 2.0 * np.array([1.0, 2.0, 3.0]), rtol=1e-12)
    np.testing.assert_allclose(k2, 2.12 * np.array([1.0, 4.0, 9.0]), rtol=1e-12)
    np.testing.assert_allclose(k3, 1.1 * np.array([1.0, 8.0, 27.0]), rtol=1e-12)
    observer = TOSMO(config, 3, DT)
    np.testing.assert_allclose(observer.k1, k1)
    assert not hasattr(observer, "linear_gain")  # (3.11) has no Gamma terms


def test_scalar_D_is_broadcast_to_every_joint():
    observer = make(HighSpeedTOSMO, 3, D=D_BOUND, gamma=GAMMA)
    np.testing.assert_allclose(observer.k1, np.full(3, 2.0 * D_BOUND ** (1 / 3)))
    np.testing.assert_allclose(observer.k2, np.full(3, 2.12 * D_BOUND ** (2 / 3)))
    np.testing.assert_allclose(observer.k3, np.full(3, 1.1 * D_BOUND))
    assert observer.linear_gain == GAMMA


def test_explicit_gains_are_used_as_given():
    observer = make(HighSpeedTOSMO, 2, k1=[3.0, 4.0], k2=5.0, k3=[6.0, 7.0], gamma=1.5)
    np.testing.assert_array_equal(observer.k1, [3.0, 4.0])
    np.testing.assert_array_equal(observer.k2, [5.0, 5.0])
    np.testing.assert_array_equal(observer.k3, [6.0, 7.0])
    assert observer.linear_gain == 1.5


@pytest.mark.parametrize(
    "cls, gains",
    [
        (TOSMO, {}),  # neither D nor k1..k3
        (TOSMO, {"k1": 1.0, "k2": 1.0}),  # k3 missing
        (TOSMO, {"D": 1.0, "k1": 1.0}),  # both
        (TOSMO, {"D": 1.0, "k1": 1.0, "k2": 1.0, "k3": 1.0}),  # both
        (TOSMO, {"D": -1.0}),  # non-positive bound
        (TOSMO, {"D": 0.0}),
        (TOSMO, {"D": [1.0, 2.0]}),  # wrong length for 3 joints
        (TOSMO, {"D": 1.0, "gamma": 1.0}),  # Gamma belongs to the high-speed TOSMO only
        (TOSMO, {"D": 1.0, "K1": 1.0}),  # unknown key
        (HighSpeedTOSMO, {"D": 1.0}),  # gamma missing
        (HighSpeedTOSMO, {"D": 1.0, "gamma": -0.1}),
        (HighSpeedTOSMO, {"gamma": 1.0}),  # neither D nor k1..k3
        (HighSpeedTOSMO, {"D": 1.0, "k3": 1.0, "gamma": 1.0}),  # both
    ],
)
def test_config_errors_raise_validation_error(cls, gains):
    with pytest.raises(ValidationError):
        cls.Config.model_validate(gains, context={"n_joints": 3})


# --------------------------------------------------------------------------------------------------
# one period by hand


@pytest.mark.parametrize("cls, gamma", [(TOSMO, 0.0), (HighSpeedTOSMO, 0.0), (HighSpeedTOSMO, 3.0)])
def test_one_period_by_hand(cls, gamma):
    """Injection = the printed (5.6) bracket k2|e|^(1/3)sign(e) + Gamma (dx1_hat - x2_hat) + luaf_hat, and
    one forward-Euler step of (5.6) with the LUaF as the integral of k3 sign(e), eq. (5.13)."""
    gains = {"k1": [2.0, 3.0, 1.5], "k2": [4.0, 2.5, 3.0], "k3": [5.0, 6.0, 7.0]}
    if cls is HighSpeedTOSMO:
        gains["gamma"] = gamma
    observer = make(cls, 3, **gains)
    k1, k2, k3 = (np.asarray(gains[k]) for k in ("k1", "k2", "k3"))

    q_hat = np.array([0.1, -0.2, 0.3])
    qd_hat = np.array([0.5, 0.0, -1.0])
    luaf = np.array([0.7, -0.4, 1.2])
    observer.reset(q_hat, qd_hat)
    observer.luaf_hat[:] = luaf
    M = np.array([[2.0, 0.3, 0.1], [0.3, 1.5, -0.2], [0.1, -0.2, 0.8]])
    step = FakeStepModel(M, psi_hat=[0.3, -1.1, 2.0])
    q_meas = np.array([0.15, -0.2001, 0.25])  # errors of both signs and very different sizes
    tau = np.array([1.0, -2.0, 0.5])

    e = q_meas - q_hat
    x1_rate_correction = k1 * np.abs(e) ** (2 / 3) * np.sign(e) + gamma * e  # dx1_hat/dt - x2_hat
    expected_injection = k2 * np.abs(e) ** (1 / 3) * np.sign(e) + gamma * x1_rate_correction + luaf

    observer.update(0.0, q_meas, step)
    np.testing.assert_allclose(observer.injection, expected_injection, rtol=1e-13, atol=1e-15)

    observer.advance(tau, step)
    np.testing.assert_allclose(observer.q_hat, q_hat + DT * (qd_hat + x1_rate_correction), rtol=1e-13)
    qdd_hat = step.psi_hat + np.linalg.solve(M, tau) + expected_injection
    np.testing.assert_allclose(observer.qd_hat, qd_hat + DT * qdd_hat, rtol=1e-13)
    np.testing.assert_allclose(observer.luaf_hat, luaf + DT * k3 * np.sign(e), rtol=1e-13)


def test_reset_zeroes_luaf_and_injection():
    observer = make(TOSMO, 2, D=D_BOUND)
    observer.update(0.0, np.array([0.1, -0.1]), FakeStepModel(np.eye(2)))
    observer.advance(np.zeros(2), FakeStepModel(np.eye(2)))
    observer.reset(np.array([1.0, 2.0]), np.array([3.0, 4.0]))
    np.testing.assert_array_equal(observer.q_hat, [1.0, 2.0])
    np.testing.assert_array_equal(observer.qd_hat, [3.0, 4.0])
    np.testing.assert_array_equal(observer.luaf_hat, 0.0)
    np.testing.assert_array_equal(observer.injection, 0.0)


# --------------------------------------------------------------------------------------------------
# convergence on the double integrator


def test_gamma_zero_high_speed_equals_tosmo_exactly():
    a = simulate(make(TOSMO, D=D_BOUND), step=fake_step(), T=2.0)
    b = simulate(make(HighSpeedTOSMO, D=D_BOUND, gamma=0.0), step=fake_step(), T=2.0)
    np.testing.assert_array_equal(a["vel_err"], b["vel_err"])
    np.testing.assert_array_equal(a["luaf_err"], b["luaf_err"])


@pytest.mark.parametrize(
    "cls, gains",
    [(TOSMO, {"D": D_BOUND}), (HighSpeedTOSMO, {"D": D_BOUND, "gamma": GAMMA})],
    ids=["tosmo", "hs_tosmo"],
)
def test_reaches_true_velocity_and_unknown_input(cls, gains):
    run = simulate(make(cls, **gains), step=fake_step(), T=6.0)
    after = run["t"] >= 2.0
    # Measured after 2 s: max |velocity error| 1.25e-3 rad/s (both); RMS LUaF error 0.0125 (TOSMO), 0.0126
    # (high-speed); max |LUaF error| 0.030 (both).
    assert np.abs(run["vel_err"][after]).max() < 3e-3
    assert np.sqrt(np.mean(run["luaf_err"][after] ** 2)) < 0.03
    assert np.abs(run["luaf_err"][after]).max() < 0.08


class _RealStepModel:
    """The real StepModel of one member, evaluated anew every period (as the engine evaluates its batch), with
    the standalone observer's (n,) shapes."""

    def __init__(self, nominal: NominalModel):
        self.nominal = nominal

    def update(self, q_meas, q_hat, qd_hat) -> None:
        self._step = step_model(self.nominal, q_meas, q_hat, qd_hat)
        self.M, self.psi_hat = self._step.M[0], self._step.psi_hat[0]

    def solve_M(self, vector):
        return self._step.solve_M(np.atleast_2d(vector))[0]

    def command_acceleration(self, tau):
        return self._step.command_acceleration(np.atleast_2d(tau))[0]


@pytest.mark.slow  # a closed-loop run of seconds
def test_converges_with_the_real_step_model():
    """The same run through NominalModel/StepModel of a one-hinge MJCF (M constant, Psi = 0)."""
    nominal = NominalModel(mujoco.MjModel.from_xml_string(HINGE_XML))
    step = _RealStepModel(nominal)
    mass = nominal.mass_matrix(np.zeros(1))[0, 0]  # 2 kg at 1 m plus the sphere's own 8e-5 kg m^2
    assert mass == pytest.approx(2.00008, rel=1e-9)
    np.testing.assert_allclose(nominal.psi(np.array([0.4]), np.array([3.0])), 0.0, atol=1e-12)
    run = simulate(make(HighSpeedTOSMO, D=D_BOUND, gamma=GAMMA), step=step, mass=mass, T=6.0)
    after = run["t"] >= 2.0
    # Measured: as with the fake model, 1.25e-3 rad/s and RMS 0.0126.
    assert np.abs(run["vel_err"][after]).max() < 3e-3
    assert np.sqrt(np.mean(run["luaf_err"][after] ** 2)) < 0.03


def test_high_speed_tosmo_converges_faster():
    """Same initial velocity error (1 rad/s): the linear terms of (5.6) shorten the settling time."""
    times = {}
    for gamma in (0.0, GAMMA, 20.0):
        run = simulate(make(HighSpeedTOSMO, D=D_BOUND, gamma=gamma), step=fake_step(), T=2.0)
        times[gamma] = settling_time(run["t"], run["vel_err"], VEL_TOL)
    # Measured settling times to 0.02 rad/s: 0.967 s (Gamma = 0, the TOSMO), 0.505 s (Gamma = 5),
    # 0.241 s (Gamma = 20); the TOSMO / high-speed ratio at Gamma = 5 is 1.91.
    assert 0.3 < times[0.0] < 1.5
    assert times[0.0] / times[GAMMA] > 1.5
    assert times[GAMMA] > times[20.0]


def test_joints_are_independent_with_per_joint_gains():
    """Two joints with different D and a diagonal M behave like two one-joint observers."""
    rng = np.random.default_rng(1)
    both = make(HighSpeedTOSMO, 2, D=[5.0, 20.0], gamma=GAMMA)
    single = [make(HighSpeedTOSMO, 1, D=D, gamma=GAMMA) for D in (5.0, 20.0)]
    M = np.diag([2.0, 0.5])
    both.reset(np.zeros(2), np.ones(2))
    for j, obs in enumerate(single):
        obs.reset(np.zeros(1), np.ones(1))
    for k in range(200):
        q, tau = rng.normal(size=2), rng.normal(size=2)
        both.update(k * DT, q, FakeStepModel(M))
        both.advance(tau, FakeStepModel(M))
        for j, obs in enumerate(single):
            obs.update(k * DT, q[j : j + 1], FakeStepModel(M[j : j + 1, j : j + 1]))
            obs.advance(tau[j : j + 1], FakeStepModel(M[j : j + 1, j : j + 1]))
    for j, obs in enumerate(single):
        np.testing.assert_allclose(both.qd_hat[j], obs.qd_hat[0], rtol=1e-12)
        np.testing.assert_allclose(both.luaf_hat[j], obs.luaf_hat[0], rtol=1e-12)


def test_batched_state_matches_row_by_row():
    """base.py says the math runs on (batch, n). The classes size their state with np.zeros(n_joints), so a
    shape (batch, n) passed as ``n_joints`` gives a batched observer; each row must equal its own run."""
    rng = np.random.default_rng(2)
    batch, n = 4, 2
    config = HighSpeedTOSMO.Config.model_validate({"D": [5.0, 20.0], "gamma": GAMMA}, context={"n_joints": n})
    batched = HighSpeedTOSMO(config, n, DT, members=batch)
    rows = [HighSpeedTOSMO(config, n, DT) for _ in range(batch)]
    M = np.array([[2.0, 0.3], [0.3, 0.5]])
    q0, qd0 = rng.normal(size=(batch, n)), rng.normal(size=(batch, n))
    batched.reset(q0, qd0)
    for b, obs in enumerate(rows):
        obs.reset(q0[b], qd0[b])
    for k in range(100):
        q, tau = rng.normal(size=(batch, n)), rng.normal(size=(batch, n))
        batched.update(k * DT, q, FakeStepModel(M))
        batched.advance(tau, FakeStepModel(M))
        for b, obs in enumerate(rows):
            obs.update(k * DT, q[b], FakeStepModel(M))
            obs.advance(tau[b], FakeStepModel(M))
    for b, obs in enumerate(rows):
        np.testing.assert_allclose(batched.q_hat[b], obs.q_hat, rtol=1e-12)
        np.testing.assert_allclose(batched.qd_hat[b], obs.qd_hat, rtol=1e-12)
        np.testing.assert_allclose(batched.luaf_hat[b], obs.luaf_hat, rtol=1e-12)


def test_signed_power_on_batched_arrays():
    x = np.array([[-8.0, 0.0, 27.0], [1.0, -1.0, 0.125]])
    np.testing.assert_allclose(signed_power(x, 1 / 3), [[-2.0, 0.0, 3.0], [1.0, -1.0, 0.5]], rtol=1e-12)
    np.testing.assert_allclose(signed_power(x, 2 / 3), [[-4.0, 0.0, 9.0], [1.0, -1.0, 0.25]], rtol=1e-12)
