"""The true robots of a run, one row per (variant, member): what the loop needs of them (:class:`Plant`) and
the simulated robots that give it, every row one simulation of a :class:`mujoco.batch.Batch`
(:class:`MuJoCoPlant`), or a recorded log played back (:class:`LogPlant`).

Per control period the engine reads the sensors (current: the batch computes the position and velocity
stages at the new state after each step), writes ``ctrl`` and ``qfrc_applied``, and calls
:meth:`MuJoCoPlant.step`: one substep whose acceleration is the period's ground truth (the acceleration at the
sampled state under the period's inputs), then the remaining substeps with the inputs held (zero-order hold).

A row that diverges stops: NaN or inf, a state beyond ``divergence`` limits, or any of MuJoCo's bad-qacc,
bad-qpos and bad-qvel warnings (MuJoCo resets such a simulation to its initial state; here that reset is a
divergence, never a silent restart). The other rows go on.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from functools import partial
from typing import Protocol

import mujoco
import numpy as np
from mujoco.batch import Batch, SimulationError

from ftc_mj import fast
from ftc_mj.fast import plant as compiled
from ftc_mj.fast.crossovers import PERSISTENT_ROWS
from ftc_mj.fast.kernels import bound
from ftc_mj.logs.trajectory import Log
from ftc_mj.robot.model import position_sensor_addresses, velocity_sensor_addresses
from ftc_mj.robot.nominal import DenseMass, scale_masses

_POSITION_VELOCITY_STAGE = int(mujoco.mjtStage.mjSTAGE_VEL)
_NO_STAGE = int(mujoco.mjtStage.mjSTAGE_NONE)
#: MuJoCo warnings after which it resets a simulation: that is a divergence here.
_RESET_WARNINGS = slice(int(mujoco.mjtWarning.mjWARN_BADQPOS), int(mujoco.mjtWarning.mjWARN_BADQACC) + 1)
assert _RESET_WARNINGS.stop - _RESET_WARNINGS.start == 3  # bad qpos, bad qvel, bad qacc: adjacent in mjtWarning


class Plant(Protocol):
    """What the loop needs of the true robots, ``rows`` of them (a row per variant and member).

    The arrays are live ``(rows, ...)`` buffers, current at the sample instant of the period: the loop reads
    them after :meth:`reset` and after each :meth:`step`, and writes ``ctrl`` and ``applied`` before the step.
    A row that diverges stops (:meth:`check`, :meth:`step` return it); the others go on.

    Attributes:
        qpos, qvel: the true state.
        ctrl, applied: the command and the generalized force (terms, actuator faults) of this period.
        bias: C(q, qd) qd + G(q) of the true robot.
        factor, diagonal_inverse: the factorisation of the true M(q) in MuJoCo's sparse layout (``qLD``,
            ``qLDiagInv``; solved by :class:`~ftc_mj.robot.nominal.SparseSolver`).
        alive: rows still running (a mask); running: how many.
        reads_state_exactly: whether the encoders read the joint positions exactly.
        has_truth: whether the rows have a true state, M(q) and acceleration (the truths of a run).
    """

    qpos: np.ndarray
    qvel: np.ndarray
    ctrl: np.ndarray
    applied: np.ndarray
    bias: np.ndarray
    factor: np.ndarray
    diagonal_inverse: np.ndarray
    alive: np.ndarray
    running: int
    reads_state_exactly: bool
    has_truth: bool

    def reset(self, q0: np.ndarray, qd0: np.ndarray) -> None:
        """Every row at its initial state ``(rows, n)``, running, its readings and M(q) current."""

    def read_positions(self, out: np.ndarray) -> None:
        """The encoders' true readings into ``out``, ``(rows, n)``."""

    def read_velocities(self, out: np.ndarray) -> None:
        """The tachometers' true readings into ``out``."""

    def mass_matrices(self) -> np.ndarray:
        """The true M(q) of every row, ``(rows, n, n)`` (an internal buffer)."""

    def poses(self) -> tuple[np.ndarray, np.ndarray]:
        """Live ``(rows, bodies, 3)`` positions and ``(rows, bodies, 4)`` quaternions of the bodies."""

    def check(self) -> np.ndarray | None:
        """Stop the rows whose state left the plausible range; the newly stopped rows (a mask), or None."""

    def step(self, acceleration: np.ndarray) -> np.ndarray | None:
        """Advance one control period under ``ctrl`` and ``applied``, the period's true acceleration into
        ``acceleration`` ``(rows, n)``; the newly stopped rows (a mask), or None."""


class MuJoCoPlant(Plant):
    """:class:`Plant` simulated by MuJoCo: one simulation of a :class:`mujoco.batch.Batch` per row."""

    has_truth = True

    def __init__(self, model: mujoco.MjModel, rows: int, substeps: int, nthread: int,
                 mass_scale: np.ndarray | None = None, max_position: float = np.inf, max_velocity: float = np.inf):
        """``mass_scale``: one per row, scales masses, inertias and armature of that row's model."""
        self.batch = Batch(model, rows, nthread=nthread, persistent=rows <= PERSISTENT_ROWS)
        if mass_scale is not None and np.any(mass_scale != 1.0):
            scale_masses(self.batch.expand, mass_scale)
            self.batch.set_const()
        self._bind(model, rows, substeps, max_position, max_velocity, self.batch.bind)
        #: The bad-state warning counts of every row (a live view of the batch's warnings).
        self._reset_counts = self.batch.warning[:, _RESET_WARNINGS, 1]

    def _bind(self, model: mujoco.MjModel, rows: int, substeps: int, max_position: float, max_velocity: float,
              bind: Callable[[str], np.ndarray]) -> None:
        """The live ``(rows, ...)`` fields, ``bind(name)`` each, and what is derived from the model."""
        self.substeps = substeps
        self.qpos, self.qvel = bind("qpos"), bind("qvel")
        self.ctrl, self.applied = bind("ctrl"), bind("qfrc_applied")
        self.qacc = bind("qacc")
        self.bias = bind("qfrc_bias")
        self._sensordata = bind("sensordata")
        self._sparse_M = bind("M")
        self.factor, self.diagonal_inverse = bind("qLD"), bind("qLDiagInv")
        self._dense = DenseMass(model, rows)
        self._position_readings = _columns(self._sensordata, position_sensor_addresses(model))
        self._velocity_readings = _columns(self._sensordata, velocity_sensor_addresses(model))
        self.reads_state_exactly = bool(np.all(model.sensor_cutoff[self._sensor_ids(model)] == 0))
        self.max_position, self.max_velocity = max_position, max_velocity
        self.alive = np.ones(rows, dtype=bool)
        self._position, self._velocity = np.zeros_like(self.qpos), np.zeros_like(self.qvel)
        self._ids: np.ndarray | None = None  # None: all rows step
        self.running = rows
        arguments = (self.qpos, self.qvel, self.alive, float(max_position), float(max_velocity))
        self._within = bound(compiled.within, *arguments) if fast.enabled() else partial(within, *arguments)

    def reset(self, q0: np.ndarray, qd0: np.ndarray) -> None:
        self.batch.reset(stage=_NO_STAGE)  # MuJoCo's defaults, warnings cleared; the state is written next
        self.alive[:] = True
        self._ids, self.running = None, len(self.alive)
        self.qpos[:] = q0
        self.qvel[:] = qd0
        self.batch.forward(stage=_POSITION_VELOCITY_STAGE)

    def poses(self) -> tuple[np.ndarray, np.ndarray]:
        """Bound on demand (every bound field is copied out after each call); the stages computed again at the
        current state fill them at once (a bound derived field is zero until the next call)."""
        poses = self.batch.bind("xpos"), self.batch.bind("xquat")
        self.batch.forward(stage=_POSITION_VELOCITY_STAGE)
        return poses

    @staticmethod
    def _sensor_ids(model: mujoco.MjModel) -> np.ndarray:
        return np.flatnonzero(model.sensor_type == mujoco.mjtSensor.mjSENS_JOINTPOS)

    def read_positions(self, out: np.ndarray) -> None:
        """The ``jointpos`` sensors."""
        self._position_readings(out)

    def read_velocities(self, out: np.ndarray) -> None:
        """The ``jointvel`` sensors."""
        self._velocity_readings(out)

    def mass_matrices(self) -> np.ndarray:
        return self._dense.update(self._sparse_M)

    def check(self) -> np.ndarray | None:
        # NaN fails every comparison, so it stops its row too (the engine runs under np.errstate(all="ignore")).
        if self._within():
            return None  # every running row within: one compiled pass, the usual case (also once rows stopped)
        np.abs(self.qpos, out=self._position)
        np.abs(self.qvel, out=self._velocity)
        within = (self._position <= self.max_position).all(axis=1) & (self._velocity <= self.max_velocity).all(axis=1)
        return self._stop(~within & self.alive)

    def step(self, acceleration: np.ndarray) -> np.ndarray | None:
        """MuJoCo's errors and bad-state warnings stop their rows.

        The first substep alone, whose acceleration goes into ``acceleration`` ``(rows, n)``: the true qdd at
        the sampled state under this period's inputs; then the others, ending with the position and velocity
        stages at the new state (what ``mj_step1`` computes), so that sensors and M(q) are current for the
        next period."""
        rest = self.substeps - 1
        failed = self._call(1, 0 if rest else _POSITION_VELOCITY_STAGE, None)
        acceleration[...] = self.qacc
        if rest:
            failed = self._call(rest, _POSITION_VELOCITY_STAGE, failed)
        if np.count_nonzero(self._reset_counts):  # counts since the start: a warned row stops
            failed = self._reset_counts.any(axis=1) | (False if failed is None else failed)
        return None if failed is None else self._stop(failed)

    def _call(self, nstep: int, stage: int, failed: np.ndarray | None) -> np.ndarray | None:
        """One batch step of the running rows; the rows MuJoCo failed (added to ``failed``), or ``failed``."""
        try:
            self.batch.step(ids=self._ids, nstep=nstep, stage=stage)
        except SimulationError as error:  # those rows kept their state; the others ran
            failed = np.zeros(len(self.alive), dtype=bool) if failed is None else failed
            failed[error.ids] = True
        return failed

    def _stop(self, rows: np.ndarray) -> np.ndarray | None:
        """Stop ``rows`` (a mask); returns the rows newly stopped, or None."""
        new = rows & self.alive
        if not new.any():
            return None
        self.alive &= ~new
        self._ids = np.flatnonzero(self.alive)
        self.running = len(self._ids)
        return new


class OneRowPlant(MuJoCoPlant):
    """:class:`MuJoCoPlant` of a single row on one MjData, stepped by MuJoCo's own calls (a single run).

    The same bits as a persistent batch of one row, whose guarantee is a loop over one MjData per simulation:
    a period is ``mj_step2`` (the first substep, continuing from the stages computed at the sample instant),
    ``mj_step`` for the others, and ``mj_step1`` (the position and velocity stages at the new state); it saves
    the batch's two calls a period, each loading and saving the row. MuJoCo's ``mj_step2`` integrates with
    Euler or an implicit integrator only, so a model on RK4 runs as a batch of one (:func:`plant_for`)."""

    def __init__(self, model: mujoco.MjModel, substeps: int, mass_scale: np.ndarray | None = None,
                 max_position: float = np.inf, max_velocity: float = np.inf):
        """``mass_scale``: ``(1,)``, scales masses, inertias and armature of a copy of ``model``."""
        if not splits_steps(model):
            raise ValueError("mj_step2 does not integrate with RK4: step this model as a batch")
        if mass_scale is not None and np.any(mass_scale != 1.0):
            model = copy.copy(model)  # MjModel's copy is whole (mj_copyModel)
            scale_masses(lambda name: getattr(model, name)[None], mass_scale)
            mujoco.mj_setConst(model, mujoco.MjData(model))
        self.model, self.data = model, mujoco.MjData(model)
        self._bind(model, 1, substeps, max_position, max_velocity, lambda name: getattr(self.data, name)[None])
        self._warnings = [self.data.warning[w] for w in range(_RESET_WARNINGS.start, _RESET_WARNINGS.stop)]
        self._row = np.ones(1, dtype=bool)

    def reset(self, q0: np.ndarray, qd0: np.ndarray) -> None:
        mujoco.mj_resetData(self.model, self.data)  # MuJoCo's defaults, warnings cleared
        self.alive[:] = True
        self.running = 1
        self.qpos[:] = q0
        self.qvel[:] = qd0
        mujoco.mj_step1(self.model, self.data)

    def poses(self) -> tuple[np.ndarray, np.ndarray]:
        """Live views, current after every reset and step (``mj_step1`` computes them)."""
        return self.data.xpos[None], self.data.xquat[None]

    def step(self, acceleration: np.ndarray) -> np.ndarray | None:
        """As :meth:`MuJoCoPlant.step`; a MuJoCo error or bad-state warning stops the row."""
        model, data, rest = self.model, self.data, self.substeps - 1
        try:
            mujoco.mj_step2(model, data)
            acceleration[...] = self.qacc
            if rest:  # MuJoCo's own loop of mj_step: the same steps, one call
                mujoco.mj_step(model, data, rest)
            mujoco.mj_step1(model, data)
        except mujoco.FatalError:
            return self._stop(self._row)
        warnings = self._warnings
        if warnings[0].number or warnings[1].number or warnings[2].number:
            return self._stop(self._row)
        return None


def splits_steps(model: mujoco.MjModel) -> bool:
    """Whether MuJoCo's ``mj_step1`` + ``mj_step2`` step ``model`` as ``mj_step`` does (Euler or an implicit
    integrator: ``mj_step2`` does not run RK4)."""
    return model.opt.integrator != mujoco.mjtIntegrator.mjINT_RK4


def plant_for(model: mujoco.MjModel, rows: int, substeps: int, nthread: int,
              mass_scale: np.ndarray | None = None, max_position: float = np.inf,
              max_velocity: float = np.inf) -> MuJoCoPlant:
    """The simulated robots of ``rows`` rows: one MjData for a single row (:class:`OneRowPlant`) where MuJoCo's
    split step integrates the model, else a batch (:class:`MuJoCoPlant`)."""
    if rows == 1 and splits_steps(model):
        return OneRowPlant(model, substeps, mass_scale, max_position, max_velocity)
    return MuJoCoPlant(model, rows, substeps, nthread, mass_scale, max_position, max_velocity)


def _columns(values: np.ndarray, addresses: np.ndarray) -> Callable[[np.ndarray], None]:
    """A function that copies ``values[:, addresses]`` into its argument: a view's copy where the addresses
    are consecutive (the usual sensor layout), else ``take``."""
    if len(addresses) and np.array_equal(addresses, np.arange(addresses[0], addresses[0] + len(addresses))):
        view = values[:, addresses[0]:addresses[0] + len(addresses)]

        def copy(out: np.ndarray) -> None:
            out[...] = view  # a plain copy: np.copyto's call costs more on a row

        return copy
    return lambda out: values.take(addresses, axis=1, out=out)


class LogPlant(Plant):
    """:class:`Plant` that plays a recorded trajectory back (:class:`~ftc_mj.logs.trajectory.Log`): every row
    reads the log's positions (and velocities) of the period, and :attr:`torque` holds the logged torque,
    which the log's controller hands to the observers (:class:`~ftc_mj.logs.controller.LogController`).

    There is no true state: ``qpos``, ``qvel`` and the period's acceleration are NaN (the truth series of the
    run), and no true M(q) (:attr:`has_truth` is False: the loop records no truths). The bodies' poses are
    the robot's at the logged positions (forward kinematics, computed once), for the recording's 3-D view.
    """

    reads_state_exactly = False
    #: Whether the loop may take truths from this plant.
    has_truth = False

    def __init__(self, model: mujoco.MjModel, log: Log, rows: int):
        n = model.nv
        self._log = log
        self.qpos, self.qvel = np.full((rows, n), np.nan), np.full((rows, n), np.nan)
        self.ctrl, self.applied = np.zeros((rows, n)), np.zeros((rows, n))
        self.bias = np.full((rows, n), np.nan)
        self.factor = self.diagonal_inverse = np.zeros((rows, 0))
        #: The logged torque of the period, ``(rows, n)``.
        self.torque = np.zeros((rows, n))
        self._position, self._velocity = np.zeros((rows, n)), np.zeros((rows, n))
        self.alive = np.ones(rows, dtype=bool)
        self.running = rows
        self._xpos, self._xquat = _kinematics(model, log.position)
        self._pose = np.zeros((rows,) + self._xpos.shape[1:]), np.zeros((rows,) + self._xquat.shape[1:])
        self._k = 0

    def reset(self, q0: np.ndarray, qd0: np.ndarray) -> None:
        """Back to the log's first sample (``q0``, ``qd0`` are the log's own: nothing to set)."""
        self._load(0)

    def _load(self, k: int) -> None:
        log = self._log
        self._k = k
        self._position[:] = log.position[k]
        if log.velocity is not None:
            self._velocity[:] = log.velocity[k]
        self.torque[:] = log.torque[k]
        self._pose[0][:] = self._xpos[k]
        self._pose[1][:] = self._xquat[k]

    def read_positions(self, out: np.ndarray) -> None:
        np.copyto(out, self._position)

    def read_velocities(self, out: np.ndarray) -> None:
        np.copyto(out, self._velocity)

    def mass_matrices(self) -> np.ndarray:
        raise TypeError("a log holds no true M(q)")

    def poses(self) -> tuple[np.ndarray, np.ndarray]:
        return self._pose

    def check(self) -> np.ndarray | None:
        return None

    def step(self, acceleration: np.ndarray) -> np.ndarray | None:
        """The next sample (the last one stays after the last period); no true acceleration: NaN."""
        acceleration[:] = np.nan
        if self._k + 1 < self._log.steps:
            self._load(self._k + 1)
        return None


def _kinematics(model: mujoco.MjModel, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The bodies' world positions ``(steps, bodies, 3)`` and quaternions ``(steps, bodies, 4)`` at each
    row of ``positions``."""
    data = mujoco.MjData(model)
    xpos, xquat = np.empty((len(positions), model.nbody, 3)), np.empty((len(positions), model.nbody, 4))
    for k, q in enumerate(positions):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        xpos[k], xquat[k] = data.xpos, data.xquat
    return xpos, xquat


def within(qpos: np.ndarray, qvel: np.ndarray, alive: np.ndarray, max_position: float, max_velocity: float) -> bool:
    """Whether every |qpos| <= max_position and every |qvel| <= max_velocity (NaN is not) in the rows still
    ``alive``: a stopped row keeps the state it stopped in, which would otherwise send every later period to
    the row-by-row comparison. (Accelerated by :func:`ftc_mj.fast.plant.within`.)"""
    return bool((np.abs(qpos[alive]) <= max_position).all() and (np.abs(qvel[alive]) <= max_velocity).all())
