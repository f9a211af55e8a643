"""The controller's nominal model: M(q) and Psi(q, qd) = -M^-1 (C qd + G) from the MJCF (eq. (5.2)).

It owns a private copy of the MjModel and its own MjData, so evaluating it at an estimated state never
touches the simulation. ``mass_scale`` scales every body's mass and inertia (and the joint armature) of the
copy, which gives a controlled model mismatch.
"""

from __future__ import annotations

import copy

import mujoco
import numpy as np


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
        psi_hat: Psi at the observer's state estimate, Psi(x1_hat, x2_hat): what the observers integrate.
        psi_control: Psi at the state the controller uses. With ``measured_velocity`` (a robot with
            tachometers whose chapter feeds the controller the measured velocity, Chapter 2: H(x) of (2.25),
            (2.32)) it is Psi(x1, x2) at the readings; otherwise it is ``psi_hat`` itself (the same array).
        qd_measured: the tachometer reading the controller uses, or None when it uses the estimate x2_hat.
    """

    def __init__(self, nominal: NominalModel, measured_velocity: bool = False):
        self.nominal = nominal
        self.M = np.eye(nominal.n)
        self.psi_hat = np.zeros(nominal.n)
        self.measured_velocity = measured_velocity
        self.psi_control = np.zeros(nominal.n) if measured_velocity else self.psi_hat
        self.qd_measured: np.ndarray | None = None

    def update(self, q_meas: np.ndarray, q_hat: np.ndarray, qd_hat: np.ndarray,
               qd_meas: np.ndarray | None = None) -> None:
        """Refresh in place for this control period (``qd_meas``: the tachometer reading, used only with
        ``measured_velocity``, which needs it)."""
        self.nominal.psi(q_hat, qd_hat, out=self.psi_hat)
        if self.measured_velocity:
            if qd_meas is None:
                raise ValueError("a controller on measured velocity needs the tachometer reading")
            self.nominal.psi(q_meas, qd_meas, out=self.psi_control)
            self.qd_measured = qd_meas
        # Last, so that the private MjData keeps the factorisation of M(x1) for solve_M.
        self.nominal.mass_matrix(q_meas, out=self.M)

    def control_velocity(self, observer_qd_hat: np.ndarray) -> np.ndarray:
        """The velocity x2 the controller uses: the tachometer reading or the observer's x2_hat."""
        return observer_qd_hat if self.qd_measured is None else self.qd_measured

    def solve_M(self, vector: np.ndarray) -> np.ndarray:
        """M(x1)^-1 vector, with MuJoCo's sparse factorisation (no explicit inverse).

        Returns a view of an internal buffer (no allocation in the per-step loop): valid until the next call.
        """
        return self.nominal.solve_M(vector)
