"""Shared plant for the observer tests: one joint, qdd = tau / m + d(t), integrated exactly.

The applied torque is known (tau = m sin(2t) / 2, non-zero so that a wrong use of M^-1 u shows), held over each
control period, and the unknown input d(t) is a sinusoid integrated in closed form: every error left is the
observer's. The observer runs the runner's protocol at DT: ``update(t, q_meas, model)``, then
``advance(tau, model)``.
"""

from __future__ import annotations

import numpy as np

DT = 1e-3
MASS = 2.0


class FakeStepModel:
    """What the observers read from a StepModel: ``M``, ``psi_hat``, ``solve_M`` and ``command_acceleration``."""

    def __init__(self, M, psi_hat=None):
        self.M = np.asarray(M, dtype=float)
        self.psi_hat = np.zeros(len(self.M)) if psi_hat is None else np.asarray(psi_hat, dtype=float)

    def solve_M(self, v):
        # Works on (n,) and on (batch, n).
        return np.linalg.solve(self.M, np.asarray(v, dtype=float).T).T

    def command_acceleration(self, tau):
        return self.solve_M(tau)

    def apply_M(self, v, out):
        out[...] = (self.M @ np.asarray(v, dtype=float).T).T
        return out


class Sinusoid:
    """d(t) = amp sin(w t) + offset with its first and second integrals from 0."""

    def __init__(self, amp: float, w: float, offset: float):
        self.amp, self.w, self.offset = amp, w, offset

    def __call__(self, t):
        return self.amp * np.sin(self.w * t) + self.offset

    def int1(self, t):
        return self.amp * (1.0 - np.cos(self.w * t)) / self.w + self.offset * t

    def int2(self, t):
        return self.amp * (t - np.sin(self.w * t) / self.w) / self.w + 0.5 * self.offset * t * t


#: d(t) = 2 sin t + 1: |d'| <= 2, well below the design bounds used in the tests.
SLOW = Sinusoid(2.0, 1.0, 1.0)
#: d(t) = sin 10t + 1, for filter lag.
FAST = Sinusoid(1.0, 10.0, 1.0)


def tau_of(t: float, mass: float) -> float:
    """The known applied torque."""
    return mass * 0.5 * np.sin(2.0 * t)


def simulate(observer, d: Sinusoid = SLOW, step=None, *, mass: float = MASS, T: float = 5.0,
             qd_error: float = 1.0) -> dict:
    """Run the observer on the plant; return time, d, velocity error, LUaF estimate and LUaF error.

    ``step`` is a FakeStepModel (default: M = mass) or a real StepModel (then updated every period).
    """
    step = FakeStepModel(mass * np.eye(1)) if step is None else step
    q, v = 0.3, -0.2
    observer.reset(np.array([q]), np.array([v + qd_error]))
    n = int(round(T / DT))
    t_all = np.arange(n) * DT
    vel_err = np.empty(n)
    luaf = np.empty(n)
    for k, t in enumerate(t_all):
        q_meas = np.array([q])
        if hasattr(step, "update"):  # the real StepModel
            step.update(q_meas, observer.q_hat, observer.qd_hat)
        observer.update(t, q_meas, step)
        vel_err[k] = v - observer.qd_hat[0]
        luaf[k] = observer.luaf_hat[0]
        tau = tau_of(t, mass)
        a, h = tau / mass, DT
        q, v = (
            q + v * h + 0.5 * a * h * h + d.int2(t + h) - d.int2(t) - d.int1(t) * h,
            v + a * h + d.int1(t + h) - d.int1(t),
        )
        observer.advance(np.array([tau]), step)
    d_values = d(t_all)
    return {"t": t_all, "d": d_values, "vel_err": vel_err, "luaf": luaf, "luaf_err": d_values - luaf}
