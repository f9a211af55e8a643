"""Shared closed loop for the controller tests: n decoupled joints, qdd = tau / m + d(t), integrated exactly.

Named ``closed_loop`` rather than ``double_integrator``: the test folders have no ``__init__.py``, so pytest
imports helpers by their bare module name and a second ``double_integrator`` would shadow
``tests/methods/observers/double_integrator.py`` in the same session.

Plant: M = m I, d(t) = 2 sin t + 1 on every joint, integrated in closed form over each control period with the
torque held, so every error left is the controller's. The observer is a fake with exact estimates: ``qd_hat``
is the true velocity and the injection (and the LUaF estimate) the true d(t) at the sample, so that with
``compensation: injection`` the sliding variable obeys ds/dt = -K sign(s): per period s_{k+1} - s_k =
-K dt sign(s_k), up to O(dt^2) from d, the reference and the surface terms varying inside the period.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

DT = 1e-3
MASS = 2.0


def fake_step(M, psi_hat=None) -> SimpleNamespace:
    """What a controller reads from a StepModel on estimated velocity: ``M``, ``psi_control`` (= ``psi_hat``,
    zero unless given), ``control_velocity`` (the observer's x2_hat) and ``apply_M``."""
    M = np.asarray(M, dtype=float)
    psi = np.zeros(len(M)) if psi_hat is None else np.asarray(psi_hat, dtype=float)

    def apply_M(v, out):
        out[...] = (M @ np.asarray(v, dtype=float).T).T
        return out

    return SimpleNamespace(M=M, psi_hat=psi, psi_control=psi, control_velocity=lambda qd_hat: qd_hat,
                           apply_M=apply_M)


class FakeObserver:
    """Only the attributes a controller reads."""

    def __init__(self, n: int = 1):
        self.q_hat = np.zeros(n)
        self.qd_hat = np.zeros(n)
        self.luaf_hat = np.zeros(n)
        self.injection = np.zeros(n)


class Period:
    """Fixed two-joint inputs of one control period, for checking a law by hand. The observer attributes that
    ``compensation`` does not read are NaN (unless ``hide_unread`` is False), so reading a wrong one shows."""

    M = np.array([[2.0, 0.4], [0.4, 1.0]])
    INJECTION = np.array([0.9, -2.0])
    LUAF = np.array([0.6, -1.5])

    def __init__(self, compensation="injection", *, t=0.0, q=(0.3, -0.1), qd_hat=(0.5, 0.2), q_ref=(0.1, 0.0),
                 qd_ref=(0.2, 0.3), qdd_ref=(-0.4, 1.0), hide_unread=True):
        self.t = t
        self.q, self.q_ref, self.qd_ref, self.qdd_ref = (np.array(x, dtype=float) for x in (q, q_ref, qd_ref, qdd_ref))
        self.step = fake_step(self.M, psi_hat=[0.3, -1.7])
        self.observer = FakeObserver(2)
        self.observer.qd_hat[:] = qd_hat
        self.e, self.e_dot = self.q - self.q_ref, self.observer.qd_hat - self.qd_ref
        self.observer.injection[:] = self.INJECTION if compensation == "injection" or not hide_unread else np.nan
        self.observer.luaf_hat[:] = self.LUAF if compensation == "estimate" or not hide_unread else np.nan
        self.u_c = {"injection": self.INJECTION, "estimate": self.LUAF, "none": 0.0}[compensation]

    def compute(self, controller):
        return controller.compute(self.t, self.q_ref, self.qd_ref, self.qdd_ref, self.q, self.observer, self.step)

    def expected(self, terms, K, s):
        """tau = -M (Psi + terms - xdd_d + u_c + K sign(s)), the frame of every law."""
        return -self.M @ (self.step.psi_control + terms - self.qdd_ref + self.u_c + K * np.sign(s))


def d(t):
    return 2.0 * np.sin(t) + 1.0


def d_int1(t):
    return 2.0 * (1.0 - np.cos(t)) + t


def d_int2(t):
    return 2.0 * (t - np.sin(t)) + 0.5 * t * t


def reference(t):
    return 0.5 * np.sin(t), 0.5 * np.cos(t), -0.5 * np.sin(t)


def make(cls, n_joints: int = 1, **gains):
    return cls(cls.Config.model_validate(gains, context={"n_joints": n_joints}), n_joints, DT)


def simulate(controller, *, T=2.5, e0=0.2, ed0=1.0, injection=None, luaf_hat=None) -> dict:
    """Closed loop on the exact plant with exact estimates; every joint tracks 0.5 sin t.

    ``e0``, ``ed0``: initial errors (scalar or per joint). ``injection`` / ``luaf_hat`` override what the fake
    observer reports (default: the true d(t)). Returns arrays of shape (steps, n); ``signals`` holds each of the
    controller's signals as recorded after ``compute`` (as the runner does)."""
    n = controller.n
    observer, step = FakeObserver(n), fake_step(MASS * np.eye(n))
    q_ref, qd_ref, _ = reference(0.0)
    q, v = q_ref + np.broadcast_to(e0, n), qd_ref + np.broadcast_to(ed0, n)
    steps = int(round(T / DT))
    out = {key: np.empty((steps, n)) for key in ("e", "e_dot", "s", "tau", *controller.signals)}
    out["t"] = np.arange(steps) * DT
    for k, t in enumerate(out["t"]):
        q_ref, qd_ref, qdd_ref = (np.full(n, x) for x in reference(t))
        observer.qd_hat[:] = v
        observer.injection[:] = d(t) if injection is None else injection
        observer.luaf_hat[:] = d(t) if luaf_hat is None else luaf_hat
        tau = controller.compute(t, q_ref, qd_ref, qdd_ref, q.copy(), observer, step)
        for key, value in (("e", q - q_ref), ("e_dot", v - qd_ref), ("s", controller.sliding), ("tau", tau)):
            out[key][k] = value
        for key, value in controller.signals.items():
            out[key][k] = value
        a, h = tau / MASS, DT
        q, v = (
            q + v * h + 0.5 * a * h * h + d_int2(t + h) - d_int2(t) - d_int1(t) * h,
            v + a * h + d_int1(t + h) - d_int1(t),
        )
    return out


def reaching(run: dict, K) -> dict:
    """Measure the reaching law ds/dt = -K sign(s) in a run. ``K``: the switching gain, scalar, per joint or per
    period (steps - 1, n).

    Returns ``t_reach``, per joint the first time |s| <= K dt (the band one period's switching covers);
    ``deviation``, the largest |s_{k+1} - s_k + K dt sign(s_k)| before then; ``band_ratio``, the largest
    |s| / (K dt) from then on."""
    s, t = run["s"], run["t"]
    band = np.broadcast_to(np.asarray(K) * DT, s[:-1].shape)
    k_reach = np.argmax(np.abs(s[:-1]) <= band, axis=0)  # per joint
    deviation = np.abs(np.diff(s, axis=0) + band * np.sign(s[:-1]))
    ratio = np.abs(s[:-1]) / band
    return {
        "t_reach": t[k_reach],
        "deviation": float(max(deviation[:k, j].max() for j, k in enumerate(k_reach))),
        "band_ratio": float(max(ratio[k:, j].max() for j, k in enumerate(k_reach))),
    }


def settled(run: dict, after: float) -> dict:
    """RMS of e and e_dot over t >= ``after`` (all joints)."""
    window = run["t"] >= after
    return {key: float(np.sqrt(np.mean(run[key][window] ** 2))) for key in ("e", "e_dot")}


def total_variation(x):
    return float(np.abs(np.diff(x, axis=0)).sum())
