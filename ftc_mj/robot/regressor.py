"""The joint-torque regressor of a MuJoCo robot: the inverse dynamics written linear in the inertial parameters,
tau = Y(q, qd, qdd) phi + A qdd (A the armature), computed from the model itself (the same kinematics, joint
order and locked joints as the nominal model), for least-squares identification (:mod:`ftc_mj.robot.identify`).

Per body b, the ten standard inertial parameters about the body frame's origin, in the body frame
(Khalil and Dombre, "Modeling, identification and control of robots", 2002, ch. 9; Atkeson, An and Hollerbach,
IJRR 5(3), 1986):

    phi_b = (m, m c_x, m c_y, m c_z, I_xx, I_xy, I_xz, I_yy, I_yz, I_zz)

c the centre of mass and I the inertia about the origin, I = I_c + m (c'c 1 - c c'). With w, v the body's
angular velocity and its origin's linear velocity, alpha and a (gravity included: a_0 = -g) their classical
accelerations, all in the body frame, the Newton-Euler force and moment at the origin are linear in phi_b:

    f = m a + alpha x (m c) + w x (w x (m c))
    n = I alpha + w x (I w) + (m c) x a

and tau = sum_b (J_r,b' n_b + J_p,b' f_b), J_r,b and J_p,b the body's rotational Jacobian and its origin's
translational one in the body frame (virtual work). The columns are computed from MuJoCo's own kinematics
(``mj_objectVelocity``, ``mj_objectAcceleration`` of the body frame, ``mjOBJ_XBODY``, after ``mj_rnePostConstraint``, ``mj_jacBody``), and checked
against ``mj_inverse`` (tests: 1e-9). Pinocchio's ``computeJointTorqueRegressor`` computes the same matrix on
its own model; this one needs no second model of the robot, and its parameters are those of the model the
nominal model evaluates.
"""

from __future__ import annotations

import mujoco
import numpy as np

#: The standard parameters of a body, in the order of its ten regressor columns.
PARAMETER_NAMES = ("m", "mcx", "mcy", "mcz", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz")


def moving_bodies(model: mujoco.MjModel) -> list[int]:
    """The bodies whose motion depends on a joint (those a regressor has columns for), in MuJoCo's order."""
    return [b for b in range(1, model.nbody) if model.body_dofnum[b] > 0 or _has_moving_ancestor(model, b)]


def _has_moving_ancestor(model: mujoco.MjModel, body: int) -> bool:
    parent = int(model.body_parentid[body])
    while parent > 0:
        if model.body_dofnum[parent] > 0:
            return True
        parent = int(model.body_parentid[parent])
    return False


def standard_parameters(model: mujoco.MjModel, bodies: list[int]) -> np.ndarray:
    """phi of each body of ``bodies`` from the model's mass, centre of mass and principal inertia,
    ``(bodies, 10)``."""
    phi = np.zeros((len(bodies), 10))
    for k, b in enumerate(bodies):
        m, c = float(model.body_mass[b]), np.array(model.body_ipos[b], dtype=float)
        rotation = np.zeros(9)
        mujoco.mju_quat2Mat(rotation, model.body_iquat[b])
        rotation = rotation.reshape(3, 3)
        inertia = rotation @ np.diag(model.body_inertia[b]) @ rotation.T + m * (c @ c * np.eye(3) - np.outer(c, c))
        phi[k] = [m, *(m * c), inertia[0, 0], inertia[0, 1], inertia[0, 2], inertia[1, 1], inertia[1, 2],
                  inertia[2, 2]]
    return phi


def body_inertial(phi: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, centre of mass and the inertia about it (3 x 3, body frame) of one body's ten parameters."""
    m = float(phi[0])
    c = np.asarray(phi[1:4]) / m if m > 0 else np.zeros(3)
    Ixx, Ixy, Ixz, Iyy, Iyz, Izz = phi[4:]
    inertia = np.array([[Ixx, Ixy, Ixz], [Ixy, Iyy, Iyz], [Ixz, Iyz, Izz]])
    return m, c, inertia - m * (c @ c * np.eye(3) - np.outer(c, c))


def physical_problem(phi: np.ndarray) -> str | None:
    """What makes one body's parameters non-physical (a mass not positive, the inertia about the centre of
    mass not positive definite or breaking the triangle inequality), or None."""
    m, _, inertia = body_inertial(phi)
    if not m > 0:
        return f"mass {m:.3g} kg is not positive"
    moments = np.linalg.eigvalsh(0.5 * (inertia + inertia.T))
    if moments[0] <= 0:
        return f"inertia about the centre of mass is not positive definite (smallest moment {moments[0]:.3g})"
    if moments[0] + moments[1] < moments[2] * (1 - 1e-9):
        return "principal moments break the triangle inequality"
    return None


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _wrench_matrix(w: np.ndarray, alpha: np.ndarray, a: np.ndarray) -> np.ndarray:
    """``(6, 10)``: [n; f] at the body origin = this matrix times phi (the module docstring's equations)."""
    out = np.zeros((6, 10))
    Sw, Sa = _skew(w), _skew(alpha)
    # f = m a + (alpha x + w x w x) (m c)
    out[3:, 0] = a
    out[3:, 1:4] = Sa + Sw @ Sw
    # n = (m c) x a = -a x (m c)
    out[:3, 1:4] = -_skew(a)
    # I alpha + w x (I w), I symmetric from (Ixx, Ixy, Ixz, Iyy, Iyz, Izz)
    for k, (i, j) in enumerate(((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))):
        unit = np.zeros((3, 3))
        unit[i, j] = unit[j, i] = 1.0
        out[:3, 4 + k] = unit @ alpha + Sw @ (unit @ w)
    return out


class Regressor:
    """Y(q, qd, qdd) of a model, sample by sample: ``(samples, n, 10 bodies)`` for the moving bodies'
    parameters, and the armature's columns (qdd_j on joint j)."""

    def __init__(self, model: mujoco.MjModel):
        self.model = model
        self.bodies = moving_bodies(model)
        self._data = mujoco.MjData(model)
        self._jacp, self._jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
        self._velocity, self._acceleration = np.zeros(6), np.zeros(6)

    @property
    def n(self) -> int:
        return self.model.nv

    def __call__(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """``(samples, n, 10 * bodies)`` for the samples' positions, velocities and accelerations."""
        model, data = self.model, self._data
        samples = len(q)
        Y = np.zeros((samples, model.nv, 10 * len(self.bodies)))
        rotation = np.zeros(9)
        for s in range(samples):
            data.qpos[:], data.qvel[:], data.qacc[:] = q[s], qd[s], qdd[s]
            mujoco.mj_fwdPosition(model, data)
            mujoco.mj_fwdVelocity(model, data)
            mujoco.mj_rnePostConstraint(model, data)  # cacc, gravity included
            for k, b in enumerate(self.bodies):
                mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_XBODY, b, self._velocity, 1)
                mujoco.mj_objectAcceleration(model, data, mujoco.mjtObj.mjOBJ_XBODY, b, self._acceleration, 1)
                mujoco.mj_jacBody(model, data, self._jacp, self._jacr, b)
                rotation[:] = data.xmat[b]
                R = rotation.reshape(3, 3)
                Jr, Jp = R.T @ self._jacr, R.T @ self._jacp
                wrench = _wrench_matrix(self._velocity[:3], self._acceleration[:3], self._acceleration[3:])
                Y[s, :, 10 * k:10 * k + 10] = Jr.T @ wrench[:3] + Jp.T @ wrench[3:]
        return Y

    def parameters(self) -> np.ndarray:
        """The model's own phi, flattened in the regressor's column order."""
        return standard_parameters(self.model, self.bodies).reshape(-1)

    def names(self) -> list[str]:
        """A name per column: ``<body>.<parameter>``."""
        return [f"{self.model.body(b).name or f'body{b}'}.{p}" for b in self.bodies for p in PARAMETER_NAMES]
