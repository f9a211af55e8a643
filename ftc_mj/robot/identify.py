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
  keep the model's values), armature and friction b, c >= 0. Where that fit asks for a body that is not
  physical (its pseudo-inertia not positive definite: :func:`pseudo_inertia`), the same fit is solved over
  physical bodies only, each written by the log-Cholesky factor of its pseudo-inertia (Rucker and Wensing
  2022), and the logs are refused if that leaves more than :data:`PHYSICAL_COST_RATIO` times the squared
  residual (they ask for a non-physical arm: a wrong torque sign or scale, an external force). Refused too
  where the excitation cannot support the fit (:func:`excitation`).

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
#: ``all`` refuses logs whose best physical fit leaves more than this many times the squared residual of the
#: best fit (which asked for a non-physical body).
PHYSICAL_COST_RATIO = 4.0
#: At most this many iterations of the physical fit.
PHYSICAL_ITERATIONS = 100
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
    # ||A x - rhs||^2 = ||R x - Q' rhs||^2 + ||rhs||^2 - ||Q' rhs||^2 (A = Q R): the same minima on a square
    # system (the solvers' SVD of the tall one, per iteration, cost seconds).
    Q, R = np.linalg.qr(A)
    target = Q.T @ rhs
    constant = max(float(rhs @ rhs - target @ target), 0.0)
    linear = optimize.lsq_linear(R, target, bounds=(lower * scale, upper * scale)).x / scale
    bodies = len(regressor.bodies)
    if all(physical_problem(phi) is None for phi in linear[:body_columns].reshape(bodies, 10)):
        solution = linear
    else:  # the same fit over physical bodies only: each body's pseudo-inertia J = U U' (log-Cholesky)
        solution = _physical_fit(R, target, scale, prior, bodies, lower, upper, linear)
        linear_cost, physical_cost = (float(np.sum((R @ (x * scale) - target) ** 2)) + constant
                                      for x in (linear, solution))
        if physical_cost > PHYSICAL_COST_RATIO * linear_cost:
            worst = next(k for k, phi in enumerate(linear[:body_columns].reshape(bodies, 10))
                         if physical_problem(phi) is not None)
            raise InputError(", ".join(m.name for m in motions), "--all",
                             f"the fit is not physical: the logs' best fit needs body "
                             f"{model.body(regressor.bodies[worst]).name!r} with "
                             f"{physical_problem(linear[10 * worst:10 * worst + 10])}, and the best physical fit "
                             f"leaves {np.sqrt(physical_cost / linear_cost):.3g} times its residual")
    phi = solution[:body_columns].reshape(bodies, 10)
    for k, body in enumerate(regressor.bodies):
        problem = physical_problem(phi[k])
        if problem is not None:  # pragma: no cover - the log-Cholesky parametrisation keeps every body physical
            raise InputError(", ".join(m.name for m in motions), "--all",
                             f"the fit is not physical: body {model.body(body).name!r}: {problem}")
    friction_parameters = solution[body_columns + n:].reshape(n, 3)
    friction = JointFriction(friction_parameters[:, 0], friction_parameters[:, 1], friction_parameters[:, 2],
                             velocity_scale)
    fit_rms = np.sqrt(np.mean((W @ solution - y).reshape(-1, n) ** 2, axis=0))
    return Identified(friction, "all", phi=phi, armature=solution[body_columns:body_columns + n],
                      excitation=report, fit_rms=fit_rms)


def pseudo_inertia(phi: np.ndarray) -> np.ndarray:
    """The 4 x 4 pseudo-inertia J = [[Sigma, m c], [m c', m]] of one body's ten parameters, Sigma = tr(I)/2 1 - I
    (I about the body origin): the body is physical (a mass distribution with these moments exists) iff J is
    positive definite (Wensing, Kim and Slotine, IEEE RA-L 3(1), 2018)."""
    m, h = phi[0], np.asarray(phi[1:4])
    Ixx, Ixy, Ixz, Iyy, Iyz, Izz = phi[4:]
    inertia = np.array([[Ixx, Ixy, Ixz], [Ixy, Iyy, Iyz], [Ixz, Iyz, Izz]])
    J = np.zeros((4, 4))
    J[:3, :3] = 0.5 * np.trace(inertia) * np.eye(3) - inertia
    J[:3, 3] = J[3, :3] = h
    J[3, 3] = m
    return J


_UPPER = np.triu_indices(4, 1)
_FLIP = np.eye(4)[::-1]


def _cholesky_parameters(phi: np.ndarray) -> np.ndarray:
    """u (10) with U upper triangular, diag(U) = exp(u[:4]), its upper entries u[4:], U U' = J(phi)
    (log-Cholesky, Rucker and Wensing, IEEE RA-L 7(2), 2022)."""
    J = pseudo_inertia(phi) + 1e-9 * np.eye(4)
    lower = np.linalg.cholesky(_FLIP @ J @ _FLIP)
    U = _FLIP @ lower @ _FLIP  # upper triangular, U U' = J
    return np.concatenate([np.log(np.diag(U)), U[_UPPER]])


def _parameters_of_cholesky(u: np.ndarray) -> np.ndarray:
    """phi of the pseudo-inertia U U' (:func:`_cholesky_parameters`' inverse): always physical."""
    U = np.diag(np.exp(u[:4]))
    U[_UPPER] = u[4:]
    J = U @ U.T
    sigma = J[:3, :3]
    inertia = np.trace(sigma) * np.eye(3) - sigma
    return np.array([J[3, 3], *J[:3, 3], inertia[0, 0], inertia[0, 1], inertia[0, 2], inertia[1, 1],
                     inertia[1, 2], inertia[2, 2]])


def _physical_fit(R: np.ndarray, target: np.ndarray, scale: np.ndarray, prior: np.ndarray, bodies: int,
                  lower: np.ndarray, upper: np.ndarray, start: np.ndarray) -> np.ndarray:
    """The ridge-held least squares of :func:`fit_all` (its square form ``R``, ``target``, in parameters scaled
    by ``scale``) with each body's parameters written by their
    log-Cholesky factor (physical by construction), the armature and friction bounded as before
    (``scipy.optimize.least_squares``, trust-region reflective), from the prior's bodies and the linear fit's
    armature and friction."""
    body_columns = 10 * bodies
    u0 = np.concatenate([_cholesky_parameters(phi) for phi in prior[:body_columns].reshape(bodies, 10)])
    rest0 = np.clip(start[body_columns:], lower[body_columns:], upper[body_columns:])

    def theta(x: np.ndarray) -> np.ndarray:
        phis = [_parameters_of_cholesky(x[10 * k:10 * k + 10]) for k in range(bodies)]
        return np.concatenate([*phis, x[body_columns:]])

    scaled = R * scale

    def residual(x: np.ndarray) -> np.ndarray:
        return scaled @ theta(x) - target

    def jacobian(x: np.ndarray) -> np.ndarray:
        """A diag(scale) dtheta/dx: dtheta/dx is block diagonal, each body's 10 x 10 block by central differences
        of :func:`_parameters_of_cholesky` (cheap), the identity on the armature and friction."""
        out = scaled.copy()
        for k in range(bodies):
            block = slice(10 * k, 10 * k + 10)
            u, step = x[block], 1e-6
            derivative = np.column_stack([(_parameters_of_cholesky(u + step * e) - _parameters_of_cholesky(u - step * e))
                                          / (2 * step) for e in np.eye(10)])
            out[:, block] = scaled[:, block] @ derivative
        return out

    x_lower = np.concatenate([np.full(body_columns, -np.inf), lower[body_columns:]])
    x_upper = np.concatenate([np.full(body_columns, np.inf), upper[body_columns:]])
    result = optimize.least_squares(residual, np.concatenate([u0, rest0]), jac=jacobian, bounds=(x_lower, x_upper),
                                    x_scale="jac", max_nfev=PHYSICAL_ITERATIONS)
    return theta(result.x)


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
