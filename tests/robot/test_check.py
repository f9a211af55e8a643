"""The robot check (ftc_mj.robot.check): its numbers against MuJoCo's own (gravity at rest, inverse dynamics
along a reference), its warnings on a synthetic arm with a tiny wrist inertia, and none but true ones on the
shipped scenarios."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from ftc_mj.robot.check import SAMPLING_MARGIN, check_robot
from ftc_mj.scenario.loading import load_scenario

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = sorted(str(p.relative_to(ROOT)) for p in (ROOT / "scenarios").rglob("*.yaml") if "bases" not in p.parts)


def arm(wrist_inertia: float = 1e-4, damping: float = 2.0, armature: float = 0.0, limit: float = 50.0,
        frictionloss: float = 0.0) -> mujoco.MjModel:
    """Three hinges in the testbed's form; the last one a wrist of inertia ``wrist_inertia`` about its axis."""
    xml = f"""
<mujoco>
  <option timestep="0.001" integrator="implicitfast"/>
  <worldbody>
    <body name="upper">
      <joint name="shoulder" axis="0 1 0" damping="{damping}" armature="{armature}" frictionloss="{frictionloss}"/>
      <inertial pos="0.2 0 0" mass="3" diaginertia="0.01 0.04 0.04"/>
      <body name="fore" pos="0.4 0 0">
        <joint name="elbow" axis="0 1 0" damping="{damping}" armature="{armature}" frictionloss="{frictionloss}"/>
        <inertial pos="0.15 0 0" mass="1.5" diaginertia="0.005 0.01 0.01"/>
        <body name="wrist" pos="0.3 0 0">
          <joint name="wrist" axis="1 0 0" damping="{damping}" armature="{armature}" frictionloss="{frictionloss}"/>
          <inertial pos="0 0 0" mass="0.1" diaginertia="{wrist_inertia} {wrist_inertia} {wrist_inertia}"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor joint="shoulder" ctrlrange="-{limit} {limit}"/>
    <motor joint="elbow" ctrlrange="-{limit} {limit}"/>
    <motor joint="wrist" ctrlrange="-{limit} {limit}"/>
  </actuator>
</mujoco>"""
    return mujoco.MjModel.from_xml_string(xml)


def reference(times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    w = np.pi / 5
    q = np.stack([0.5 * np.cos(w * times) - 0.5, -0.3 * np.sin(w * times), 0.2 * np.cos(w * times)], axis=1)
    qd = np.stack([-0.5 * w * np.sin(w * times), -0.3 * w * np.cos(w * times), -0.2 * w * np.sin(w * times)], axis=1)
    qdd = np.stack([-0.5 * w**2 * np.cos(w * times), 0.3 * w**2 * np.sin(w * times), -0.2 * w**2 * np.cos(w * times)],
                   axis=1)
    return q, qd, qdd


def test_gravity_and_reference_torques_are_mujocos_inverse_dynamics():
    model = arm(damping=0.0)
    times = np.linspace(0, 10, 101)
    q, qd, qdd = reference(times)
    report = check_robot(model, q0=q[0], reference=(q, qd, qdd), reference_times=times, control_dt=0.001)
    data = mujoco.MjData(model)
    data.qpos[:] = q[0]
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose([c.gravity for c in report.joints], data.qfrc_bias, rtol=1e-9, atol=1e-12)
    full = np.zeros((3, 3))
    mujoco.mj_fullM(model, data, full)
    np.testing.assert_allclose([c.mass_diagonal for c in report.joints], np.diag(full), rtol=1e-12)
    assert report.min_eigenvalue == pytest.approx(np.linalg.eigvalsh(full)[0], rel=1e-9)
    peak = np.zeros(3)
    for k in range(len(times)):
        data.qpos[:], data.qvel[:], data.qacc[:] = q[k], qd[k], qdd[k]
        mujoco.mj_inverse(model, data)
        peak = np.maximum(peak, np.abs(data.qfrc_inverse))
    np.testing.assert_allclose([c.peak_reference_torque for c in report.joints], peak, rtol=1e-9)
    assert [c.torque_limit for c in report.joints] == [50.0, 50.0, 50.0]


def test_tiny_wrist_inertia_is_warned_and_the_armature_needed_fixes_it():
    report = check_robot(arm(wrist_inertia=1e-4), control_dt=0.001)
    wrist = report.joints[2]
    assert wrist.sampling_ratio == pytest.approx(2.0 * 0.001 / wrist.mass_diagonal)
    assert wrist.sampling_ratio > 1 and wrist.armature_needed > 0
    assert report.joints[0].armature_needed == 0 and report.joints[1].armature_needed == 0
    text = "\n".join(report.warnings)
    assert "joint 'wrist': damping 2" in text and "heuristic" in text
    assert "joint 'wrist': M_jj" in text and "no armature" in text
    assert "no joint has armature" in text
    assert not any("'shoulder'" in w or "'elbow'" in w for w in report.warnings)
    fixed = check_robot(arm(wrist_inertia=1e-4, armature=wrist.armature_needed), control_dt=0.001)
    assert fixed.joints[2].sampling_ratio == pytest.approx(SAMPLING_MARGIN, rel=1e-6)
    assert not any("damping" in w for w in fixed.warnings)
    # the same wrist, heavier: nothing to say about sampling or lightness
    heavy = check_robot(arm(wrist_inertia=0.05, armature=0.1), control_dt=0.001)
    assert heavy.warnings == []


def test_observer_rate_and_friction_warnings_follow_D():
    model = arm(wrist_inertia=1e-3, damping=0.5, frictionloss=0.2, armature=0.0)
    times = np.linspace(0, 10, 201)
    ref = reference(times)
    low = check_robot(model, q0=ref[0][0], reference=ref, reference_times=times, control_dt=0.001,
                      observer_rate_bounds=[("proposed", np.full(3, 22.0))])
    assert any("joint 'wrist': friction loss 0.2" in w and "D = 22" in w for w in low.warnings)
    high = check_robot(model, q0=ref[0][0], reference=ref, reference_times=times, control_dt=0.001,
                       observer_rate_bounds=[("proposed", np.full(3, 1e5))])
    assert not any("friction loss" in w or "observer's D" in w for w in high.warnings)


def test_torque_limit_below_gravity_and_reference():
    times = np.linspace(0, 10, 101)
    ref = reference(times)
    report = check_robot(arm(limit=1.0, armature=0.1, wrist_inertia=0.05), q0=np.zeros(3), reference=ref,
                         reference_times=times, control_dt=0.001)
    assert any(w.startswith("joint 'shoulder': gravity alone needs") for w in report.warnings)
    bent = check_robot(arm(limit=5.0, armature=0.1, wrist_inertia=0.05), q0=np.array([1.5707963, 0, 0]),
                       reference=ref, reference_times=times, control_dt=0.001)
    assert any(w.startswith("joint 'shoulder': the reference needs") and "clipped" in w for w in bent.warnings)


def test_wrong_units_are_warned():
    model = arm(wrist_inertia=0.05, armature=0.1)
    model.body_inertia[1] *= 1e6  # as if given in g m^2... a gyration radius of kilometres
    assert any("body 'upper'" in w and "wrong units" in w for w in check_robot(model).warnings)


@pytest.mark.slow  # a closed-loop run of seconds
@pytest.mark.parametrize("path", SHIPPED)
def test_shipped_scenarios_get_only_true_warnings(path):
    from ftc_mj.cli.robot import _check

    scenario = load_scenario(ROOT / path)
    report = _check(str(ROOT / path), [])
    no_armature = not np.any(scenario.model.dof_armature)
    assert [w for w in report.warnings if not w.startswith("no joint has armature")] == []
    assert any(w.startswith("no joint has armature") for w in report.warnings) == no_armature


def test_model_terms_left_out_of_the_nominal_model_are_warned():
    from ftc_mj.robot.friction import FrictionSpec

    model = arm(wrist_inertia=0.05, armature=0.1, damping=2.0, frictionloss=0.3)
    held = check_robot(model)
    assert not any("missing from the nominal model" in w for w in held.warnings)
    left_out = check_robot(model, friction=FrictionSpec.model_validate({"from_model": {"damping": False}}))
    assert [w for w in left_out.warnings if "missing from the nominal model" in w] == [
        "the model file's joint damping ('shoulder', 'elbow', 'wrist') is missing from the nominal model "
        "(nominal.friction.from_model.damping: false): it acts on the plant only, a healthy lumped uncertainty "
        "every observer must estimate and a benchmark must declare"]
