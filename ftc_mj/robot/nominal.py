"""The controller's nominal model: M(q) and Psi(q, qd) = -M^-1 (C qd + G) from the MJCF (eq. (5.2)).

It owns a private copy of the MjModel and its own MjData, so evaluating it at an estimated state never
touches the simulation. ``mass_scale`` scales every body's mass and inertia (and the joint armature) of the
copy, which gives a controlled model mismatch (the scenario's ``nominal`` section, :class:`NominalSpec`).
"""

from __future__ import annotations

import copy

import mujoco
import numpy as np

from ftc_mj.spec.schema import PositiveFloat, Strict


class NominalSpec(Strict):
    #: Scales masses, inertias and armature of the controller's model (1 = exact model).
    mass_scale: PositiveFloat = 1.0


class NominalModel:
    """Rigid-body terms of a robot model, evaluated on a private MjData."""

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


class StepModel:
    """Nominal quantities of one control period, computed once and shared by observer and controller.

    Attributes:
        M: M(x1) at the measured position.
        psi_hat: Psi at the observer's state estimate, Psi(x1_hat, x2_hat).
    """

    def __init__(self, nominal: NominalModel):
        self.nominal = nominal
        self.M = np.eye(nominal.n)
        self.psi_hat = np.zeros(nominal.n)

    def update(self, q_meas: np.ndarray, q_hat: np.ndarray, qd_hat: np.ndarray) -> None:
        """Refresh in place for this control period."""
        self.nominal.psi(q_hat, qd_hat, out=self.psi_hat)
        # Last, so that the private MjData keeps the factorisation of M(x1) for solve_M.
        self.nominal.mass_matrix(q_meas, out=self.M)

    def solve_M(self, vector: np.ndarray) -> np.ndarray:
        """M(x1)^-1 vector, with MuJoCo's sparse factorisation (no explicit inverse).

        Returns a view of an internal buffer (no allocation in the per-step loop): valid until the next call.
        """
        return self.nominal.solve_M(vector)
