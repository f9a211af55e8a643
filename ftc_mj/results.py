"""What a run leaves behind: per variant, time series of estimates beside the ground truth, and the diagnoser's
output. A leaf: the engine fills these, analysis and outputs read them.

Every array is sampled once per control period, at the instant the controller runs (before its command acts).
Shapes: ``(N,)`` for time, ``(N, n)`` for per-joint series, ``(N, nbody, 3|4)`` for body poses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np



@dataclass
class Diagnosis:
    """What the diagnoser produced for one run; per-joint series are ``(N, n)``.

    Attributes:
        space: ``acceleration`` or ``torque``.
        t: sample times.
        signal: the (filtered) LUaF estimate in the diagnosis space.
        fault_estimate: signal - baseline mean.
        residual: the decision statistic: |fault_estimate| (threshold rule), Page's CUSUM g (cusum rule).
        threshold: per sample and joint (h for the cusum rule); NaN before the diagnoser is armed.
        alarm: per sample and joint.
        armed: per sample.
        mean, std: the baseline per joint (0 without one).
        injected: the injected fault in the same space (ground truth, for the metrics and the recording).
    """

    space: str
    t: np.ndarray
    signal: np.ndarray
    fault_estimate: np.ndarray
    residual: np.ndarray
    threshold: np.ndarray
    alarm: np.ndarray
    armed: np.ndarray
    mean: np.ndarray
    std: np.ndarray
    injected: np.ndarray

    @property
    def raised(self) -> np.ndarray:
        """Samples at which an alarm is raised (rising edges), ``(N, n)``."""
        before = np.vstack([np.zeros((1, self.alarm.shape[1]), dtype=bool), self.alarm[:-1]])
        return self.alarm & ~before

    @property
    def cleared(self) -> np.ndarray:
        """Samples at which an alarm is cleared (falling edges), ``(N, n)``."""
        before = np.vstack([np.zeros((1, self.alarm.shape[1]), dtype=bool), self.alarm[:-1]])
        return ~self.alarm & before

    def alarm_times(self) -> list[list[float]]:
        """Per joint, the times at which an alarm is raised."""
        raised = self.raised
        return [self.t[raised[:, j]].tolist() for j in range(raised.shape[1])]

    def isolated(self, first_onset: float) -> np.ndarray:
        """Joints the diagnoser names faulty: an alarm at or after the first fault onset (at any armed time in
        a run without faults), ``(n,)``."""
        after = self.t >= first_onset if math.isfinite(first_onset) else self.armed
        return self.alarm[after].any(axis=0)


@dataclass
class VariantResult:
    """Recorded signals of one controller-observer variant.

    Attributes:
        name: variant name from the scenario.
        observer: observer plugin name.
        controller: controller plugin name.
        t: sample times [s].
        q_ref, qd_ref, qdd_ref: reference position, velocity, acceleration.
        q_meas: position measured by the sensors (what the controller saw).
        qd_meas: velocity measured by the tachometers (what the controller saw); None without them.
        q_true, qd_true, qdd_true: true joint state and its acceleration at the sample instant.
        qd_hat: observer's velocity estimate.
        luaf_hat: observer's lumped-uncertainty-and-fault estimate, in acceleration units (rad/s^2).
        luaf_true: true lumped uncertainty qdd - (Psi(q, qd) + M(q)^-1 tau), nominal Psi and M.
        tau: commanded torque [N m] (what the controller asked for, in ``ctrl``).
        sliding: the controller's sliding variable.
        fault: the injected fault signal: the sum of the fault terms, each in the space it was declared in
            (rad/s^2 for acceleration-space faults, N m for torque-space ones; mixing both mixes units).
        fault_active: whether any fault (term or actuator fault) is on.
        tau_delivered: the torque the actuators deliver (tau unless an actuator fault acts) [N m].
        fault_torque: the generalized force all faults add to the plant: fault terms (acceleration-space
            ones through the true M(q)) plus delivered - commanded torque [N m].
        fault_acceleration: the same in acceleration units, M(q)^-1 fault_torque with the true M: the fault's
            share of the true lumped uncertainty [rad/s^2].
        body_xpos, body_xquat: world pose of every body (MuJoCo order, quaternion wxyz); may be empty.
        status: "ok" or "diverged".
        diverged_at: time of divergence [s], or None.
        extras: further per-joint series a plugin chose to expose (name -> (N, n)).
        diagnosis: the diagnoser's output, when the scenario has a ``diagnosis`` section.
    """

    name: str
    observer: str
    controller: str
    t: np.ndarray
    q_ref: np.ndarray
    qd_ref: np.ndarray
    qdd_ref: np.ndarray
    q_meas: np.ndarray
    q_true: np.ndarray
    qd_true: np.ndarray
    qdd_true: np.ndarray
    qd_hat: np.ndarray
    luaf_hat: np.ndarray
    luaf_true: np.ndarray
    tau: np.ndarray
    sliding: np.ndarray
    fault: np.ndarray
    fault_active: np.ndarray
    body_xpos: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 3)))
    body_xquat: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 4)))
    status: str = "ok"
    diverged_at: float | None = None
    extras: dict[str, np.ndarray] = field(default_factory=dict)
    qd_meas: np.ndarray | None = None
    tau_delivered: np.ndarray | None = None
    fault_torque: np.ndarray | None = None
    fault_acceleration: np.ndarray | None = None
    diagnosis: Diagnosis | None = None
    #: The results of the variant's monitors (``variants.NAME.monitors``): the same trajectory with each
    #: monitor's estimates, named ``<variant>.<monitor>``.
    monitors: list["VariantResult"] = field(default_factory=list)
    #: For a monitor's result, the variant whose closed loop it observes (its tracking series are the host's);
    #: None for a variant's own result.
    host: str | None = None

    @property
    def tracking_error(self) -> np.ndarray:
        """e = q - q_d on the true position (5.3)."""
        return self.q_true - self.q_ref

    @property
    def velocity_error(self) -> np.ndarray:
        """Velocity estimation error x2 - x2_hat."""
        return self.qd_true - self.qd_hat

    @property
    def luaf_error(self) -> np.ndarray:
        """Lumped-uncertainty estimation error, truth minus estimate."""
        return self.luaf_true - self.luaf_hat

    def truncated(self, n_samples: int) -> "VariantResult":
        """The first ``n_samples`` rows of every series (used when a variant diverges)."""
        cut = {}
        for name, value in vars(self).items():
            if isinstance(value, np.ndarray) and value.ndim >= 1 and len(value) > n_samples:
                cut[name] = value[:n_samples]
        extras = {k: v[:n_samples] for k, v in self.extras.items()}
        return VariantResult(**{**vars(self), **cut, "extras": extras})
