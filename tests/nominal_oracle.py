"""A single-state nominal model, the tests' oracle for the engine's batched one: M(q), C qd + G and Psi of a
robot model on one private MjData, evaluated by MuJoCo itself (``mj_fwdPosition``, ``mj_fwdVelocity``,
``mj_fullM``, ``mj_solveM``), and the :class:`~ftc_mj.robot.nominal.StepModel` of one member built from it."""

from __future__ import annotations

import copy

import mujoco
import numpy as np

from ftc_mj.robot.nominal import SparseSolver, StepModel


class NominalModel:
    """Rigid-body terms of a robot model, evaluated on a private MjData; ``mass_scale`` scales masses, inertias
    and armature of the private copy (the controlled model mismatch of ``nominal.mass_scale``)."""

    def __init__(self, model: mujoco.MjModel, mass_scale: float = 1.0):
        self.model = copy.deepcopy(model)
        if mass_scale != 1.0:
            self.model.body_mass[:] *= mass_scale
            self.model.body_inertia[:] *= mass_scale
            self.model.dof_armature[:] *= mass_scale
        self.data = mujoco.MjData(self.model)
        self.n = self.model.nv
        self._zeros = np.zeros(self.n)
        self._rhs = np.zeros((1, self.n))
        self._solution = np.zeros((1, self.n))

    def _set_state(self, q: np.ndarray, qd: np.ndarray) -> None:
        self.data.qpos[:] = q
        self.data.qvel[:] = qd
        # Position and velocity stages only: no control callback, no constraint solver.
        mujoco.mj_fwdPosition(self.model, self.data)
        mujoco.mj_fwdVelocity(self.model, self.data)

    def mass_matrix(self, q: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """Joint-space inertia M(q), dense ``(n, n)``."""
        out = np.empty((self.n, self.n)) if out is None else out
        self.data.qpos[:] = q
        mujoco.mj_fwdPosition(self.model, self.data)
        mujoco.mj_fullM(self.model, self.data, out)
        return out

    def bias(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """C(q, qd) qd + G(q) (a copy)."""
        self._set_state(q, qd)
        return self.data.qfrc_bias.copy()

    def gravity(self, q: np.ndarray) -> np.ndarray:
        """G(q)."""
        return self.bias(q, self._zeros)

    def solve_M(self, vector: np.ndarray) -> np.ndarray:
        """M(q)^-1 vector at the last position evaluated, with MuJoCo's factorisation from mj_fwdPosition
        (no explicit inverse). Returns a view of an internal buffer, valid until the next call."""
        self._rhs[0] = vector
        mujoco.mj_solveM(self.model, self.data, self._solution, self._rhs)
        return self._solution[0]

    def lumped(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """qdd - (Psi(q, qd) + M(q)^-1 tau) = qdd + M^-1 (C qd + G - tau): the lumped uncertainty (5.2)
        that explains an observed acceleration, in this model's terms."""
        self._set_state(q, qd)
        return qdd + self.solve_M(self.data.qfrc_bias - tau)

    def psi(self, q: np.ndarray, qd: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """Psi(q, qd) = -M(q)^-1 (C(q, qd) qd + G(q)), eq. (5.2)."""
        out = np.empty(self.n) if out is None else out
        self._set_state(q, qd)
        np.negative(self.solve_M(self.data.qfrc_bias), out=out)
        return out


def step_model(nominal: NominalModel, q_meas: np.ndarray, q_hat: np.ndarray, qd_hat: np.ndarray,
               qd_meas: np.ndarray | None = None) -> StepModel:
    """One member's period from ``nominal``: Psi at the estimate, M at the measured position; with ``qd_meas``
    the controller's Psi and velocity are the readings'. M(x1)^-1 tau is solved on demand."""
    def row(x: np.ndarray) -> np.ndarray:
        return np.asarray(x, dtype=float).reshape(-1)

    psi = nominal.psi(row(q_hat), row(qd_hat))[None].copy()
    psi_control = None if qd_meas is None else nominal.psi(row(q_meas), row(qd_meas))[None].copy()
    M = nominal.mass_matrix(row(q_meas))[None].copy()  # last: its factorisation stays in the MjData
    data = nominal.data
    return StepModel(M, data.qLD[None].copy(), data.qLDiagInv[None].copy(), psi, SparseSolver(nominal.model),
                     psi_control, None if qd_meas is None else row(qd_meas)[None])
