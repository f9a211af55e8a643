"""Joint friction and damping in the nominal model (ftc_mj/robot/friction.py): the law, the model file's terms
taken in, the engine's Psi and truth holding them, and the momentum observer subtracting them."""

from __future__ import annotations

import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from ftc_mj.config.errors import InputError
from ftc_mj.engine.runner import run_scenario
from ftc_mj.methods.observers import MomentumObserver
from ftc_mj.robot.friction import FrictionSpec, FromModelSpec, JointFriction
from ftc_mj.scenario.loading import load_scenario

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "methods" / "observers"))
from double_integrator import FakeStepModel  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
UR5E = ROOT / "models" / "ur5e.xml"


def test_the_law_viscous_coulomb_offset_with_a_smooth_sign():
    friction = JointFriction(viscous=[2.0, 0.0], coulomb=[3.0, 1.0], offset=[0.5, -0.2], velocity_scale=0.02)
    qd = np.array([[0.1, -1.0], [0.0, 0.0], [-0.01, 0.005]])
    expected = (np.array([2.0, 0.0]) * qd + np.array([3.0, 1.0]) * np.tanh(qd / 0.02) + np.array([0.5, -0.2]))
    np.testing.assert_allclose(friction.torque(qd), expected, rtol=1e-15, atol=1e-15)
    # Into given buffers, the same numbers; F(0) is the offset alone; F is odd about the offset.
    out, scratch = np.empty_like(qd), np.empty_like(qd)
    assert friction.torque(qd, out=out, scratch=scratch) is out
    np.testing.assert_array_equal(out, friction.torque(qd))
    np.testing.assert_array_equal(out[1], [0.5, -0.2])
    np.testing.assert_allclose(friction.torque(-qd) - friction.offset, -(out - friction.offset), atol=1e-15)
    # The regressor reproduces F: Y theta with theta = (b, c, o) per joint.
    theta = np.array([2.0, 3.0, 0.5, 0.0, 1.0, -0.2])
    np.testing.assert_allclose(friction.regressor(qd) @ theta, expected, atol=1e-14)


def test_the_deadband_zeroes_the_coulomb_part_below_it():
    friction = JointFriction(viscous=[0.0], coulomb=[5.0], offset=[0.0], velocity_scale=0.01, deadband=0.05)
    qd = np.array([[0.0], [0.04], [-0.049], [0.06], [-0.2]])
    torque = friction.torque(qd)[:, 0]
    np.testing.assert_array_equal(torque[:3], 0.0)
    np.testing.assert_allclose(torque[3:], [5.0 * np.tanh(1.0), -5.0 * np.tanh(15.0)])


def test_the_model_files_damping_and_frictionloss_are_taken_in_by_default():
    model = mujoco.MjModel.from_xml_path(str(UR5E))
    assert model.dof_damping[:3].tolist() == [200.0] * 3
    default = JointFriction.of(FrictionSpec(viscous=[1.0] * 6), model)
    np.testing.assert_array_equal(default.viscous, model.dof_damping + 1.0)
    np.testing.assert_array_equal(default.coulomb, model.dof_frictionloss)
    alone = JointFriction.of(FrictionSpec(from_model=FromModelSpec(damping=False, frictionloss=False)), model)
    assert alone.is_zero
    with pytest.raises(InputError, match="nominal.friction.coulomb"):
        JointFriction.of(FrictionSpec(coulomb=[1.0, 2.0]), model, "f.yaml")


def ur5e_truth(tmp_path: Path, from_model: bool) -> np.ndarray:
    """The true LUaF of the UR5e scenario's proposed variant over 0.2-0.5 s, no friction term or fault, its damping
    in the nominal model or not."""
    scenario = load_scenario(ROOT / "scenarios" / "robots" / "ur5e_fault.yaml", duration=0.5, variants=["proposed"],
                             overrides=["terms=[]", "actuator_faults=[]",
                                        f"nominal.friction.from_model.damping={str(from_model).lower()}"])
    result = run_scenario(scenario, record_poses=False)[0]
    after = result.t >= 0.2  # the start's transient clips the command (the LUaF then holds the clipped part)
    return result.luaf_true[after], result.qd_true[after], result


@pytest.mark.slow  # closed-loop runs
def test_the_nominal_model_holds_the_model_files_damping(tmp_path):
    """The UR5e's plant has 200 N m s/rad on joints 1-3; with its damping in the nominal model (the default)
    the true LUaF (qdd minus the nominal model's, at the true state) is what is left of it: the plant's implicit
    integration of the damping within a period against its value at the sample, under 2 rad/s^2 (measured
    0.3); without, it is -M^-1 D qd, tens of rad/s^2 (measured 96)."""
    with_damping, qd, result = ur5e_truth(tmp_path, True)
    without, _, _ = ur5e_truth(tmp_path, False)
    assert np.abs(qd[:, :3]).max() > 0.1
    assert np.abs(without).max() > 20.0, np.abs(without).max()
    assert np.abs(with_damping).max() < 2.0, np.abs(with_damping).max(axis=0)


class FrictionJoint(FakeStepModel):
    """One joint of inertia 2 with gravity 3 N m and a nominal friction torque F."""

    def __init__(self, friction: float | None):
        super().__init__(np.array([[2.0]]))
        self.coriolis_transpose, self.gravity = np.zeros(1), np.array([3.0])
        self.friction = None if friction is None else np.array([friction])


@pytest.mark.parametrize("friction", [None, 0.0, 4.0])
def test_the_momentum_observer_subtracts_the_nominal_friction(friction):
    """A joint held still by tau = G + F: dp/dt = tau - G - F = 0, so the residual stays 0 where the observer
    subtracts the model's F; an observer that left F out would follow F (4 N m) as a fault."""
    observer = MomentumObserver(MomentumObserver.Config(K=[50.0]), 1, 1e-3)
    model = FrictionJoint(friction)
    observer.reset(np.array([0.1]), np.array([0.0]))
    for k in range(300):
        observer.measure(np.array([0.1]), np.array([0.0]))
        observer.update(k * 1e-3, np.array([0.1]), model)
        observer.advance(np.array([3.0 + (friction or 0.0)]), model)
    assert abs(observer.residual[0]) < 1e-12
    # Told no friction while the arm pays 4 N m of it: the residual follows it (first order, 50 1/s).
    blind = MomentumObserver(MomentumObserver.Config(K=[50.0]), 1, 1e-3)
    blind.reset(np.array([0.1]), np.array([0.0]))
    for k in range(300):
        blind.measure(np.array([0.1]), np.array([0.0]))
        blind.update(k * 1e-3, np.array([0.1]), FrictionJoint(None))
        blind.advance(np.array([7.0]), FrictionJoint(None))
    assert blind.residual[0] < -3.9


def test_measured_velocity_needs_tachometers():
    with pytest.raises(InputError, match="nominal.friction.velocity"):
        scenario = load_scenario(ROOT / "scenarios" / "robots" / "ur5e_fault.yaml", duration=0.01,
                                 overrides=["nominal.friction.velocity=measured"])
        run_scenario(scenario, record_poses=False)


@pytest.mark.slow  # replays
def test_the_velocity_friction_is_evaluated_at():
    """On the UR10e's free-motion log: the momentum observer's estimate is the logged velocity, so F at the
    estimate and at the measurement are the same bits; the TOSMO estimates its own velocity, so they differ."""
    free = ROOT / "scenarios" / "real" / "ur10e_free_motion.yaml"
    runs = {velocity: {r.name: r for r in run_scenario(load_scenario(
        free, variants=["momentum", "tosmo"], overrides=[f"nominal.friction.velocity={velocity}"]),
        record_poses=False)} for velocity in ("estimate", "measured")}
    np.testing.assert_array_equal(runs["estimate"]["momentum"].luaf_hat, runs["measured"]["momentum"].luaf_hat)
    assert not np.array_equal(runs["estimate"]["tosmo"].luaf_hat, runs["measured"]["tosmo"].luaf_hat)
