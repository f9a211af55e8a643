"""Least-squares identification of a robot's joint friction (and, with enough excitation, its inertial
parameters and armature) from logged motion: what ``ftc-mj identify`` runs (:mod:`ftc_mj.cli.identify`).

The model is linear in its parameters (:mod:`ftc_mj.robot.regressor`, :mod:`ftc_mj.robot.friction`):

    tau = Y(q, qd, qdd) phi + diag(qdd) a + Y_f(qd) theta_f,     Y_f: (qd_j, s(qd_j), 1) on joint j

with phi the bodies' standard inertial parameters, a the armature and theta_f = (b_j, c_j, o_j) the friction.
Velocity and acceleration come from the log through a zero-phase low-pass filter (Butterworth, forward and
backward, ``scipy.signal.filtfilt``): the velocity filtered (the logged one, or the positions' central
difference), the acceleration the central difference of the filtered velocity, filtered again. The torque
and every regressor column are then filtered by the same filter ("parallel filtering", Gautier, IEEE TCST
5(4), 1997): the model being linear in its parameters, the filtered torque is the filtered regressor times
them, also where a column is not smooth (the Coulomb term's tanh at each velocity reversal, which the torque
column carries smoothed by the filter).

* **friction only** (``mode="friction"``): the rigid body (phi, a) kept as the model has it; per joint, the
  three friction parameters fit tau_j - (rigid-body inverse dynamics)_j by bounded least squares
  (``scipy.optimize.lsq_linear``: b, c >= 0).
* **all** (``mode="all"``): every parameter. Only the base parameters (the combinations the data determine)
  are identifiable: their number is the rank of the stacked regressor, found by QR with column pivoting
  (``scipy.linalg.qr``) on columns scaled to unit norm. The fit is bounded least squares with a small ridge
  pulling every parameter to the model's value (the ridge decides only the unidentifiable directions, which
  keep the model's values), armature and friction b, c >= 0. The result is refused where a body's parameters
  are not physical (a mass not positive, an inertia about the centre of mass not positive definite) and
  where the excitation cannot support it (:func:`excitation`).

Both refuse a log too short or too slow (:data:`MIN_SAMPLES`, :data:`MIN_SPEED`), with an
:class:`~ftc_mj.config.errors.InputError` naming the log.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np
from scipy import linalg, optimize, signal

from ftc_mj.config.errors import InputError
from ftc_mj.robot.friction import DEFAULT_VELOCITY_SCALE, JointFriction
from ftc_mj.robot.regressor import Regressor, physical_problem

#: The fewest samples a log must have [-].
MIN_SAMPLES = 200
#: Every joint must reach this speed in both directions for its friction to be identified [rad/s].
MIN_SPEED = 0.1
#: ``all`` needs at least this speed in both directions on every joint [rad/s] ...
ALL_MIN_SPEED = 0.3
#: ... this range of positions on every joint [rad] ...
ALL_MIN_RANGE = 1.0
#: ... and the scaled base regressor's condition number at most this.
ALL_MAX_CONDITION = 200.0
#: Ridge weight (relative to the regressor's column norms) holding the unidentifiable directions at the
#: model's values in ``all``.
RIDGE = 1e-6
#: Default cutoff of the zero-phase filter [Hz] and its order.
DEFAULT_CUTOFF = 5.0
FILTER_ORDER = 4
#: Periods of the cutoff left out at each end of a log (filtfilt's padding and the differences' one-sided ends).
EDGE_PERIODS = 2.0


@dataclass
class Motion:
    """One log for identification: its filtered q, qd, qdd and torque ``(samples, n)`` on the whole log, its
    name and sample period, the samples to fit on (``keep``) and the filter (:meth:`columns`)."""

    name: str
    dt: float
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    keep: np.ndarray
    filter: tuple[np.ndarray, np.ndarray]

    def columns(self, values: np.ndarray) -> np.ndarray:
        """``values`` (samples first) through the same zero-phase filter as the torque, at the kept samples."""
        return signal.filtfilt(*self.filter, values, axis=0)[self.keep]

    @property
    def torque(self) -> np.ndarray:
        """The filtered torque at the kept samples."""
        return self.tau[self.keep]


def filtered_motion(name: str, times: np.ndarray, position: np.ndarray, velocity: np.ndarray | None,
                    torque: np.ndarray, cutoff: float = DEFAULT_CUTOFF, keep: np.ndarray | None = None) -> Motion:
    """The zero-phase filtered velocity, acceleration and torque of a log on a uniform grid ``times``; with
    ``keep`` (a mask of the samples), only those samples, filtered with the whole log (e.g. outside a log's
    labelled events, where an external torque acts that the model does not hold)."""
    samples = len(times)
    if samples < MIN_SAMPLES:
        raise InputError(name, "log", f"has {samples} samples, fewer than the {MIN_SAMPLES} identification needs")
    dt = float(times[1] - times[0])
    nyquist = 0.5 / dt
    if not 0 < cutoff < nyquist:
        raise InputError(name, "--cutoff", f"{cutoff:g} Hz must be between 0 and the log's Nyquist frequency "
                         f"{nyquist:g} Hz")
    b, a = signal.butter(FILTER_ORDER, cutoff / nyquist)
    zero_phase = lambda x: signal.filtfilt(b, a, x, axis=0)  # noqa: E731
    qd = zero_phase(np.gradient(position, dt, axis=0) if velocity is None else velocity)
    qdd = zero_phase(np.gradient(qd, dt, axis=0))
    kept = np.ones(samples, dtype=bool) if keep is None else np.array(keep, dtype=bool)
    edge = min(samples // 10, int(np.ceil(EDGE_PERIODS / (cutoff * dt))))
    kept[:edge] = kept[samples - edge:] = False  # the filter's and the differences' edge effects
    if kept.sum() < MIN_SAMPLES:
        raise InputError(name, "log.events", f"leave {int(kept.sum())} samples outside the events, fewer than the "
                         f"{MIN_SAMPLES} identification needs")
    return Motion(name, dt, np.asarray(position, dtype=float), qd, qdd, zero_phase(torque), kept, (b, a))


@dataclass
class Excitation:
    """How well the logs excite the model (:func:`excitation`)."""

    samples: int
    #: Per joint: the most negative and the most positive filtered velocity [rad/s], the position range [rad].
    speed_negative: np.ndarray
    speed_positive: np.ndarray
    position_range: np.ndarray
    #: The number of base parameters (rank) and the condition number of the scaled base regressor; None in
    #: friction-only mode.
    base_parameters: int | None = None
    condition: float | None = None
    #: Why ``all`` cannot be supported (empty: it can).
    problems: list[str] = field(default_factory=list)

    def lines(self, joints: list[str]) -> list[str]:
        out = [f"excitation: {self.samples} samples"]
        for j, name in enumerate(joints):
            out.append(f"  {name}: velocity {self.speed_negative[j]:+.3f} .. {self.speed_positive[j]:+.3f} rad/s, "
                       f"position range {self.position_range[j]:.3f} rad")
        if self.base_parameters is not None:
            out.append(f"  base parameters {self.base_parameters}, condition number of the scaled base regressor "
                       f"{self.condition:.3g}")
        out += [f"  cannot support --all: {problem}" for problem in self.problems]
        return out


def excitation(motions: list[Motion], joints: list[str]) -> Excitation:
    """Per-joint velocity reach in both signs and position range over the logs, and what keeps ``all`` out."""
    qd = np.concatenate([m.qd[m.keep] for m in motions])
    q = np.concatenate([m.q[m.keep] for m in motions])
    report = Excitation(len(qd), qd.min(axis=0), qd.max(axis=0), q.max(axis=0) - q.min(axis=0))
    for j, name in enumerate(joints):
        reach = min(-report.speed_negative[j], report.speed_positive[j])
        if reach < ALL_MIN_SPEED:
            report.problems.append(f"{name} reaches {reach:.3g} rad/s in both directions, less than {ALL_MIN_SPEED}")
        if report.position_range[j] < ALL_MIN_RANGE:
            report.problems.append(f"{name} moves over {report.position_range[j]:.3g} rad, less than {ALL_MIN_RANGE}")
    return report


def check_speed(motions: list[Motion], joints: list[str]) -> None:
    """Refuse logs on which a joint never reaches :data:`MIN_SPEED` in both directions (no friction to fit)."""
    qd = np.concatenate([m.qd[m.keep] for m in motions])
    for j, name in enumerate(joints):
        reach = min(-qd[:, j].min(), qd[:, j].max())
        if reach < MIN_SPEED:
            raise InputError(", ".join(m.name for m in motions), "log",
                             f"too slow to identify from: joint {name} reaches {reach:.3g} rad/s in both directions, "
                             f"less than {MIN_SPEED} rad/s")


@dataclass
class Identified:
    """The fitted parameters: friction per joint, and in ``all`` mode the bodies' standard parameters and the
    armature (None in friction mode: the model's own)."""

    friction: JointFriction
    mode: str
    phi: np.ndarray | None = None
    armature: np.ndarray | None = None
    excitation: Excitation | None = None
    #: Residual RMS per joint on the fit's own logs [N m].
    fit_rms: np.ndarray | None = None


def _rigid_torque(model: mujoco.MjModel, motion: Motion) -> np.ndarray:
    """The rigid-body inverse dynamics M qdd + C qd + G (armature included, no damping) along a motion."""
    rigid = _rigid_copy(model)
    data = mujoco.MjData(rigid)
    out = np.zeros(motion.q.shape)
    for s in range(len(out)):
        data.qpos[:], data.qvel[:], data.qacc[:] = motion.q[s], motion.qd[s], motion.qdd[s]
        mujoco.mj_inverse(rigid, data)
        out[s] = data.qfrc_inverse
    return out


def _rigid_copy(model: mujoco.MjModel) -> mujoco.MjModel:
    import copy

    rigid = copy.deepcopy(model)
    rigid.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT | mujoco.mjtDisableBit.mjDSBL_DAMPER
                                  | mujoco.mjtDisableBit.mjDSBL_SPRING | mujoco.mjtDisableBit.mjDSBL_ACTUATION)
    return rigid


def fit_friction(model: mujoco.MjModel, motions: list[Motion], joints: list[str],
                 velocity_scale: float = DEFAULT_VELOCITY_SCALE) -> Identified:
    """Friction only, the model's rigid body kept (module docstring)."""
    check_speed(motions, joints)
    n = len(joints)
    shape = JointFriction(np.zeros(n), np.zeros(n), np.zeros(n), velocity_scale)
    target = np.concatenate([m.torque - m.columns(_rigid_torque(model, m)) for m in motions])
    Y = np.concatenate([m.columns(shape.regressor(m.qd)) for m in motions])  # (samples, n, 3 n)
    coefficients = np.zeros((n, 3))
    for j in range(n):
        columns = Y[:, j, 3 * j:3 * j + 3]
        solution = optimize.lsq_linear(columns, target[:, j], bounds=([0.0, 0.0, -np.inf], [np.inf] * 3))
        coefficients[j] = solution.x
    friction = JointFriction(coefficients[:, 0], coefficients[:, 1], coefficients[:, 2], velocity_scale)
    fit_rms = np.sqrt(np.mean((target - Y @ coefficients.reshape(-1)) ** 2, axis=0))
    return Identified(friction, "friction", excitation=excitation(motions, joints), fit_rms=fit_rms)


def fit_all(model: mujoco.MjModel, motions: list[Motion], joints: list[str],
            velocity_scale: float = DEFAULT_VELOCITY_SCALE) -> Identified:
    """Every parameter: base parameters by QR, bounded and ridge-held least squares (module docstring)."""
    check_speed(motions, joints)
    report = excitation(motions, joints)
    regressor = Regressor(model)
    n = len(joints)
    shape = JointFriction(np.zeros(n), np.zeros(n), np.zeros(n), velocity_scale)
    blocks, torques = [], []
    for m in motions:
        Y = regressor(m.q, m.qd, m.qdd)
        armature_columns = np.zeros((len(m.q), n, n))
        armature_columns[:, np.arange(n), np.arange(n)] = m.qdd
        blocks.append(m.columns(np.concatenate([Y, armature_columns, shape.regressor(m.qd)], axis=2)))
        torques.append(m.torque)
    W = np.concatenate(blocks).reshape(-1, blocks[0].shape[2])
    y = np.concatenate(torques).reshape(-1)
    prior = np.concatenate([regressor.parameters(), model.dof_armature, np.zeros(3 * n)])
    norms = np.linalg.norm(W, axis=0)
    used = norms > 1e-9 * norms.max()
    scaled = W[:, used] / norms[used]
    _, R, pivots = linalg.qr(scaled, mode="economic", pivoting=True)
    diagonal = np.abs(np.diag(R))
    rank = int(np.sum(diagonal > 1e-8 * diagonal[0]))
    base = scaled[:, pivots[:rank]]
    singular = np.linalg.svd(base, compute_uv=False)
    report.base_parameters, report.condition = rank, float(singular[0] / singular[-1])
    if report.condition > ALL_MAX_CONDITION:
        report.problems.append(f"the scaled base regressor's condition number {report.condition:.3g} is above "
                               f"{ALL_MAX_CONDITION:g}")
    if report.problems:
        raise InputError(", ".join(m.name for m in motions), "--all",
                         "the logs cannot support identifying every parameter: " + "; ".join(report.problems)
                         + " (--only friction keeps the rigid body)")
    # Bounded least squares in scaled parameters, ridge towards the prior.
    p = W.shape[1]
    scale = np.where(norms > 0, norms, 1.0)
    weight = np.sqrt(RIDGE) * np.ones(p)
    A = np.vstack([W / scale, np.diag(weight)])
    rhs = np.concatenate([y, weight * prior * scale])
    lower, upper = np.full(p, -np.inf), np.full(p, np.inf)
    body_columns = 10 * len(regressor.bodies)
    lower[body_columns:body_columns + n] = 0.0  # armature
    for j in range(n):
        lower[body_columns + n + 3 * j] = lower[body_columns + n + 3 * j + 1] = 0.0  # b, c
    solution = optimize.lsq_linear(A, rhs, bounds=(lower * scale, upper * scale)).x / scale
    phi = solution[:body_columns].reshape(len(regressor.bodies), 10)
    for k, body in enumerate(regressor.bodies):
        problem = physical_problem(phi[k])
        if problem is not None:
            raise InputError(", ".join(m.name for m in motions), "--all",
                             f"the fit is not physical: body {model.body(body).name!r}: {problem}")
    friction_parameters = solution[body_columns + n:].reshape(n, 3)
    friction = JointFriction(friction_parameters[:, 0], friction_parameters[:, 1], friction_parameters[:, 2],
                             velocity_scale)
    fit_rms = np.sqrt(np.mean((W @ solution - y).reshape(-1, n) ** 2, axis=0))
    return Identified(friction, "all", phi=phi, armature=solution[body_columns:body_columns + n],
                      excitation=report, fit_rms=fit_rms)


def predicted_torque(model: mujoco.MjModel, identified: Identified, motion: Motion) -> np.ndarray:
    """The identified model's torque along a motion (its rigid body: the model's own in friction mode), through
    the motion's filter, at its kept samples."""
    if identified.mode == "all":
        regressor = Regressor(model)
        rigid = regressor(motion.q, motion.qd, motion.qdd) @ identified.phi.reshape(-1)
        rigid += identified.armature * motion.qdd
    else:
        rigid = _rigid_torque(model, motion)
    return motion.columns(rigid + identified.friction.torque(motion.qd))


def residual_rms(model: mujoco.MjModel, identified: Identified, motion: Motion) -> np.ndarray:
    """Per joint, the RMS of the logged (filtered) torque minus the identified model's [N m], at the motion's
    kept samples."""
    return np.sqrt(np.mean((motion.torque - predicted_torque(model, identified, motion)) ** 2, axis=0))
