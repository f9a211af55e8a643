"""Structure and dynamics tests for the MJCF models in ``models/``.

* ``two_link.xml`` is checked against the dissertation's closed-form M(q), C(q, qd) qd and G(q)
  (with the rigid-body M12, see models/README.md) at many random states.
* ``puma560.xml`` is checked against the Robotics Toolbox check values in
  shared/reference/puma560.md (4 decimals).

G(q) = qfrc_bias at qvel = 0 and C(q, qd) qd = qfrc_bias(q, qd) - G(q), each on a fresh MjData.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

MODELS = Path(__file__).resolve().parents[2] / "models"

DOF = {"two_link": 2, "puma560": 3}


# --------------------------------------------------------------------------------------------------
# helpers


def load(name: str) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(MODELS / f"{name}.xml"))


@pytest.fixture(scope="module", params=sorted(DOF))
def named_model(request):
    return request.param, load(request.param)


def dynamics(m: mujoco.MjModel, q, qd):
    """Return M(q), G(q), C(q, qd) qd, each computed on a fresh MjData."""
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_forward(m, d)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    G = d.qfrc_bias.copy()
    assert np.all(d.qfrc_passive == 0.0)

    d = mujoco.MjData(m)
    d.qpos[:] = q
    d.qvel[:] = qd
    mujoco.mj_forward(m, d)
    Cqd = d.qfrc_bias - G
    return M, G, Cqd


# --------------------------------------------------------------------------------------------------
# structure (both models)


def test_models_load(named_model):
    name, m = named_model
    n = DOF[name]
    assert m.nq == m.nv == m.nu == m.njnt == n
    assert m.nsensor == 2 * n  # an encoder and a tachometer per joint


def test_names(named_model):
    name, m = named_model
    n = DOF[name]
    assert [m.joint(i).name for i in range(m.njnt)] == [f"joint{k}" for k in range(1, n + 1)]
    assert [m.actuator(i).name for i in range(m.nu)] == [f"motor{k}" for k in range(1, n + 1)]
    assert [m.sensor(i).name for i in range(m.nsensor)] == (
        [f"joint{k}_pos" for k in range(1, n + 1)] + [f"joint{k}_vel" for k in range(1, n + 1)]
    )
    bodies = [m.body(i).name for i in range(m.nbody)]
    for k in range(1, n + 1):
        assert f"link{k}" in bodies
    # each joint lives in the body of the same number
    for k in range(1, n + 1):
        assert m.body(m.jnt_bodyid[m.joint(f"joint{k}").id]).name == f"link{k}"


def test_joints_are_plain_hinges(named_model):
    _, m = named_model
    assert np.all(m.jnt_type == mujoco.mjtJoint.mjJNT_HINGE)
    assert not np.any(m.jnt_limited)
    assert np.all(m.dof_damping == 0.0)
    assert np.all(m.dof_frictionloss == 0.0)
    assert np.all(m.jnt_stiffness == 0.0)


def test_actuators_are_unit_torque_motors(named_model):
    _, m = named_model
    for i in range(m.nu):
        assert m.actuator_trntype[i] == mujoco.mjtTrn.mjTRN_JOINT
        assert m.actuator_trnid[i, 0] == m.joint(f"joint{i + 1}").id
        assert m.actuator_gear[i, 0] == 1.0
        assert not m.actuator_ctrllimited[i]
        assert not m.actuator_forcelimited[i]
        assert m.actuator_dyntype[i] == mujoco.mjtDyn.mjDYN_NONE
        assert m.actuator_gaintype[i] == mujoco.mjtGain.mjGAIN_FIXED
        assert m.actuator_gainprm[i, 0] == 1.0
        assert m.actuator_biastype[i] == mujoco.mjtBias.mjBIAS_NONE
    # ctrl goes straight to qfrc_actuator
    d = mujoco.MjData(m)
    d.ctrl[:] = np.arange(1, m.nu + 1) * 7.5
    mujoco.mj_forward(m, d)
    np.testing.assert_array_equal(d.qfrc_actuator, d.ctrl)


def test_sensors_are_exact_joint_encoders_and_tachometers(named_model):
    _, m = named_model
    n = m.nq
    assert np.all(m.sensor_type[:n] == mujoco.mjtSensor.mjSENS_JOINTPOS)
    assert np.all(m.sensor_type[n:] == mujoco.mjtSensor.mjSENS_JOINTVEL)
    for i in range(m.nsensor):
        assert m.sensor_objtype[i] == mujoco.mjtObj.mjOBJ_JOINT
        assert m.sensor_objid[i] == m.joint(f"joint{i % n + 1}").id
        assert m.sensor_noise[i] == 0.0
    assert m.nsensordata == 2 * n
    d = mujoco.MjData(m)
    d.qpos[:] = np.linspace(-0.7, 0.9, n)
    d.qvel[:] = np.linspace(1.3, -0.4, n)
    mujoco.mj_step1(m, d)  # the loop's split step computes both stages' sensors
    np.testing.assert_array_equal(d.sensordata[:n], d.qpos)
    np.testing.assert_array_equal(d.sensordata[n:], d.qvel)


def test_no_contacts_possible(named_model):
    _, m = named_model
    assert m.npair == 0
    assert m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT
    assert np.all(m.geom_contype == 0)
    assert np.all(m.geom_conaffinity == 0)
    rng = np.random.default_rng(1)
    d = mujoco.MjData(m)
    for _ in range(20):
        d.qpos[:] = rng.uniform(-np.pi, np.pi, m.nq)
        mujoco.mj_forward(m, d)
        assert d.ncon == 0


def test_options(named_model):
    _, m = named_model
    assert m.opt.timestep == 0.001
    assert m.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    np.testing.assert_array_equal(m.opt.gravity, [0.0, 0.0, -9.81])


def test_mass_matrix_symmetric_positive_definite(named_model):
    _, m = named_model
    rng = np.random.default_rng(2)
    for _ in range(50):
        q = rng.uniform(-np.pi, np.pi, m.nq)
        M, _, _ = dynamics(m, q, np.zeros(m.nv))
        np.testing.assert_allclose(M, M.T, rtol=0, atol=1e-12)
        assert np.linalg.eigvalsh(M).min() > 0.0
        np.linalg.cholesky(M)


# --------------------------------------------------------------------------------------------------
# two-link arm against the closed-form model

M1, M2, L1, L2, R1, R2, I1, I2, GRAV = 1.5, 1.3, 1.0, 0.8, 0.5, 0.4, 1.0, 0.8, 9.81


def two_link_analytic(q, qd):
    q1, q2 = q
    c2, s2 = np.cos(q2), np.sin(q2)
    m11 = M1 * R1**2 + M2 * (L1**2 + R2**2 + 2 * L1 * R2 * c2) + I1 + I2
    m12 = M2 * R2**2 + M2 * L1 * R2 * c2 + I2  # rigid-body value (dissertation prints m1*lc2^2: misprint)
    m22 = M2 * R2**2 + I2
    M = np.array([[m11, m12], [m12, m22]])
    h = M2 * L1 * R2 * s2
    Cqd = np.array([-2 * h * qd[0] * qd[1] - h * qd[1] ** 2, h * qd[0] ** 2])
    G = np.array(
        [
            M1 * GRAV * R1 * np.cos(q1) + M2 * GRAV * (L1 * np.cos(q1) + R2 * np.cos(q1 + q2)),
            M2 * GRAV * R2 * np.cos(q1 + q2),
        ]
    )
    return M, G, Cqd


def test_two_link_parameters():
    m = load("two_link")
    np.testing.assert_allclose(m.body("link1").mass, [M1])
    np.testing.assert_allclose(m.body("link2").mass, [M2])
    assert np.all(m.dof_armature == 0.0)
    # the moment about the joint axis through the COM is I1 / I2
    for body, inertia, com in (("link1", I1, R1), ("link2", I2, R2)):
        b = m.body(body)
        jnt = m.joint(f"joint{body[-1]}")
        d = mujoco.MjData(m)
        mujoco.mj_forward(m, d)
        R = d.ximat[b.id].reshape(3, 3)  # inertia frame -> world
        Iw = R @ np.diag(b.inertia) @ R.T
        axis = d.xaxis[jnt.id]
        assert axis @ Iw @ axis == pytest.approx(inertia, abs=1e-12)
        # COM along the link (+x at q = 0) at distance r from the joint
        np.testing.assert_allclose(d.xipos[b.id] - d.xanchor[jnt.id], [com, 0.0, 0.0], atol=1e-12)
    # joint 2 sits l1 along link 1
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    np.testing.assert_allclose(
        d.xanchor[m.joint("joint2").id] - d.xanchor[m.joint("joint1").id], [L1, 0, 0], atol=1e-12
    )
    np.testing.assert_allclose(
        d.site_xpos[m.site("tip").id] - d.xanchor[m.joint("joint1").id], [L1 + L2, 0, 0], atol=1e-12
    )


def test_two_link_positive_q_turns_upward():
    m = load("two_link")
    d = mujoco.MjData(m)
    d.qpos[:] = [0.3, 0.0]
    mujoco.mj_forward(m, d)
    tip = d.site_xpos[m.site("tip").id] - d.xanchor[m.joint("joint1").id]
    np.testing.assert_allclose(tip, [1.8 * np.cos(0.3), 0.0, 1.8 * np.sin(0.3)], atol=1e-12)


def test_two_link_dynamics_match_closed_form():
    m = load("two_link")
    rng = np.random.default_rng(20240601)
    states = [(np.zeros(2), np.zeros(2))]
    states += [(rng.uniform(-2 * np.pi, 2 * np.pi, 2), rng.uniform(-6.0, 6.0, 2)) for _ in range(200)]
    for q, qd in states:
        M, G, Cqd = dynamics(m, q, qd)
        Ma, Ga, Ca = two_link_analytic(q, qd)
        np.testing.assert_allclose(M, Ma, rtol=1e-9, atol=1e-9, err_msg=f"M at q={q}")
        np.testing.assert_allclose(G, Ga, rtol=1e-9, atol=1e-9, err_msg=f"G at q={q}")
        np.testing.assert_allclose(Cqd, Ca, rtol=1e-9, atol=1e-9, err_msg=f"C qd at q={q}, qd={qd}")


# --------------------------------------------------------------------------------------------------
# PUMA560 against the Robotics Toolbox check values (shared/reference/puma560.md)

PUMA_QD = np.array([0.4, -0.3, 0.9])

PUMA_CHECK = [
    (
        (0.0, 0.0, 0.0),
        [[3.96863, -0.16266, -0.13891], [-0.16266, 4.45662, 0.37274], [-0.13891, 0.37274, 0.93865]],
        [0.0, 37.48367, 0.24893],
        [-0.25258, -0.03952, 0.09834],
    ),
    (
        (-0.5, -0.5, -0.5),
        [[4.40134, 0.2383, -0.07185], [0.2383, 4.82417, 0.55651], [-0.07185, 0.55651, 0.93865]],
        [0.0, 40.68362, 7.51605],
        [-0.44862, -0.17222, 0.08047],
    ),
    (
        (0.3, -1.1, 0.7),
        [[2.88224, 0.47804, -0.12647], [0.47804, 3.95398, 0.12141], [-0.12647, 0.12141, 0.93865]],
        [0.0, 21.44761, 3.64533],
        [-0.37678, -0.16373, 0.07229],
    ),
]


@pytest.mark.parametrize("q, M_ref, G_ref, C_ref", PUMA_CHECK, ids=["qz", "neg_half", "mixed"])
def test_puma560_check_values(q, M_ref, G_ref, C_ref):
    m = load("puma560")
    M, G, Cqd = dynamics(m, np.array(q), PUMA_QD)
    np.testing.assert_allclose(M, M_ref, rtol=0, atol=5e-5, err_msg="M(q)")
    np.testing.assert_allclose(G, G_ref, rtol=0, atol=5e-5, err_msg="G(q)")
    np.testing.assert_allclose(Cqd, C_ref, rtol=0, atol=5e-5, err_msg="C(q, qd) qd")


def test_puma560_parameters():
    m = load("puma560")
    np.testing.assert_allclose(m.dof_armature, [0.784029, 2.324805, 0.576866])
    masses = {f"link{k}": m.body(f"link{k}").mass[0] for k in range(1, 7)}
    np.testing.assert_allclose(
        [masses[f"link{k}"] for k in range(2, 7)], [17.4, 4.8, 0.82, 0.34, 0.09]
    )
    assert masses["link1"] < 1e-3  # negligible (see README)
    # the welded wrist is carried by link 3's joint: subtree mass of link3 = 4.8 + 1.25
    assert m.body("link3").subtreemass[0] == pytest.approx(6.05)
    # link 3 principal moments with Izz raised to 0.020
    np.testing.assert_allclose(np.sort(m.body("link3").inertia), [0.020, 0.066, 0.086])
    # wrist bodies have no joints
    for k in (4, 5, 6):
        assert m.body(f"link{k}").jntnum[0] == 0


def test_puma560_qz_pose_geometry():
    """q = 0 is the toolbox's qz pose: upper arm along +x, forearm up, wrist centre known."""
    m = load("puma560")
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    base = np.array([0.0, 0.0, 0.67183])
    np.testing.assert_allclose(d.xpos[m.body("link1").id], base, atol=1e-12)
    np.testing.assert_allclose(d.xpos[m.body("link3").id] - base, [0.4318, 0, 0], atol=1e-12)
    # wrist centre (DH frame {4}) = (a2 + a3, -d3, d4) relative to the shoulder
    np.testing.assert_allclose(
        d.xpos[m.body("link5").id] - base, [0.4318 + 0.0203, -0.15005, 0.4318], atol=1e-12
    )
    # joint axes at qz: z0 up, z1 = z2 = -y0
    np.testing.assert_allclose(d.xaxis[m.joint("joint1").id], [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(d.xaxis[m.joint("joint2").id], [0, -1, 0], atol=1e-12)
    np.testing.assert_allclose(d.xaxis[m.joint("joint3").id], [0, -1, 0], atol=1e-12)
