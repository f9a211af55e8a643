"""The closed loop of a batch: every variant of a scenario and every member, stepped together.

Rows: the plant is one :class:`mujoco.batch.Batch` with a row per (variant, member), variant-major, so that
the members of one variant are a contiguous block and each variant's observer, controller and monitors work
on views of that block with state shaped ``(members, joints)``. A single run is one member.

Per control period k (time t_k = k * control_dt, zero-order hold on the command):

1. the sensors of every row are current (the batch computes positions, velocities and sensors at the new
   state after each step, as ``mj_step1`` does); the true readings are corrupted by the scenario's sensor
   effects, per member (:mod:`ftc_mj.effects.sensors`);
2. each observer takes the measurement (``measure``); the nominal model is evaluated for all rows at once
   (:class:`~ftc_mj.robot.nominal.NominalBatch`, compiled rigid-body algorithms): Psi at each observer's
   estimate, and M at the measured position;
3. each observer forms its injection (``update``); each controller computes its torque; ``ctrl`` = torque;
4. friction, disturbance and fault terms on the *true* state of all rows, and what the actuator faults
   deliver beyond the command, go to ``qfrc_applied`` (:mod:`ftc_mj.effects.terms`, :mod:`~.faults`); the
   plant's factorisation of M(q) is kept for the truths;
5. M(x1)^-1 tau of every row's command is solved at once; each observer integrates over the period; the
   plant steps (:class:`~ftc_mj.engine.plant.Plant`).

After the last period, the truths that need M(q)^-1 (the true LUaF, the fault's acceleration) are solved over
every sample at once (:meth:`_Run.finish_truth`).

A row that diverges stops with its own time; the others go on. Observers and controllers never see the
simulation: only readings, time, the reference, their own commands and the nominal model.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import mujoco
import numpy as np

from ftc_mj.effects import randomness
from ftc_mj.effects.faults import ActuatorFaults
from ftc_mj.effects.sensors import Measurement
from ftc_mj.effects.terms import PlantTerms
from ftc_mj.engine.members import Members
from ftc_mj.engine.plant import Plant
from ftc_mj.methods.controllers.base import Controller
from ftc_mj.methods.observers.base import Observer
from ftc_mj.robot.nominal import NominalBatch, SparseSolver, StepModel
from ftc_mj.spec.scenario import Scenario

ProgressCallback = Callable[[int], None]
PROGRESS_EVERY = 500
#: Samples whose truths are solved together after the run (bounds the temporary arrays).
TRUTH_CHUNK = 2048

#: The per-row series a run keeps, each ``(steps, rows, n)``.
SERIES = ("q_meas", "q_true", "qd_true", "qdd_true", "qd_hat", "luaf_hat", "luaf_true", "tau", "sliding",
          "fault", "tau_delivered", "fault_torque", "fault_acceleration")


@dataclass
class VariantBlock:
    """One variant's methods over its members: rows ``start:stop`` of the plant."""

    name: str
    rows: slice
    observer: Observer
    controller: Controller
    model: StepModel
    monitors: list[tuple[str, Observer, StepModel]]
    q_hat0: np.ndarray | None
    qd_hat0: np.ndarray
    #: Views of the block's rows of the loop's buffers, made once: readings and the commanded torque.
    q_meas: np.ndarray
    qd_meas: np.ndarray | None
    tau: np.ndarray
    #: Where each estimator's (observer, monitors) estimate goes in the nominal batch: (observer, qpos, qvel).
    points: list[tuple[Observer, np.ndarray, np.ndarray]]
    #: The nominal points at the readings (a controller on measured velocity), or None.
    reading_points: tuple[np.ndarray, np.ndarray] | None

    @cached_property
    def estimators(self) -> list[Observer]:
        """The variant's observer and its monitors, in the order of their nominal points."""
        return [self.observer] + [observer for _, observer, _ in self.monitors]


@dataclass
class BatchRun:
    """What a batch leaves behind: series ``(steps, rows, n)`` (NaN after a row stopped), per-row status."""

    times: np.ndarray
    members: int
    variants: list[str]
    series: dict[str, np.ndarray]
    #: q_d, its first and second derivatives: ``(steps, n)``, or ``(steps, members, n)`` with parameters.
    reference: tuple[np.ndarray, np.ndarray, np.ndarray]
    #: Per variant: monitor name -> {"qd_hat", "luaf_hat", "luaf_torque"} series ``(steps, members, n)``.
    monitor_series: dict[str, dict[str, dict[str, np.ndarray]]]
    #: Plugin signals per variant: name -> ``(steps, members, n)``.
    extras: dict[str, dict[str, np.ndarray]]
    fault_active: np.ndarray  # (steps, rows)
    qd_measured: np.ndarray | None
    luaf_torque: np.ndarray | None
    body_xpos: np.ndarray | None
    body_xquat: np.ndarray | None
    #: Per row: the number of samples recorded (``steps`` unless it diverged) and the time it diverged.
    done: np.ndarray
    diverged_at: np.ndarray


def simulate(
    scenario: Scenario,
    members: Members,
    *,
    record_poses: bool = False,
    progress: ProgressCallback | None = None,
    nthread: int = 0,
) -> BatchRun:
    """Run every variant of ``scenario`` for every member of ``members``, stepped together.

    MuJoCo's printed warnings are silenced meanwhile: the bad-state warnings are each row's divergence, which
    the run reports itself (with the variant, the member and the time)."""
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(_quiet)
    try:
        return _simulate(scenario, members, record_poses, progress, nthread)
    finally:
        mujoco.set_mju_user_warning(previous)


def _quiet(message: str) -> None:
    """A MuJoCo warning handler that prints nothing (the batch still counts the warnings per simulation)."""


def _simulate(scenario: Scenario, members: Members, record_poses: bool, progress: ProgressCallback | None,
              nthread: int) -> BatchRun:
    run = _Run(scenario, members, record_poses, nthread)
    with np.errstate(all="ignore"):  # stopped rows may hold NaN; they are cut off from their time on
        for k in range(run.steps):
            run.stop(run.plant.check(), k)
            if not run.plant.running:
                break
            t = run.times[k]
            run.sense(k)
            run.evaluate_nominal(k)
            run.control(k, t)
            run.actuate(k, t)
            run.advance(k)
            if progress is not None and (k + 1) % PROGRESS_EVERY == 0:
                progress(PROGRESS_EVERY)
        run.finish_truth()
    if progress is not None:
        progress(run.steps % PROGRESS_EVERY)
    return run.result()


class _Run:
    """One batch run's state: set up once, then stepped period by period (the phases of the module docstring)."""

    def __init__(self, scenario: Scenario, members: Members, record_poses: bool, nthread: int):
        spec = scenario.spec
        self.scenario = scenario
        n, dt, self.times = scenario.n_joints, spec.control_dt, scenario.times
        self.steps, count = len(self.times), members.count
        self.count = count
        variants = scenario.variants
        rows = self.rows = count * len(variants)
        threads = nthread if nthread > 0 else _default_threads(rows)

        def per_row(values: np.ndarray) -> np.ndarray:  # member values repeated for every variant's block
            return np.concatenate([values] * len(variants))

        plant = self.plant = Plant(
            scenario.model, per_row(members.q0), per_row(members.qd0), scenario.substeps, threads,
            mass_scale=per_row(members.plant_mass_scale), max_position=spec.divergence.max_position,
            max_velocity=spec.divergence.max_velocity)

        # Nominal evaluation points: Psi at each estimate (host observer and monitors of every variant) on one
        # batch, and M at every row's measured position on a second, without the velocity terms.
        # Per variant: Psi at the observer's estimate, at each monitor's, and, for a controller on measured
        # velocity (``controller_velocity``), at the readings.
        measured = [variant.controller_velocity == "measured" for variant in variants]
        self.estimators = [1 + len(v.monitors) + on_readings for v, on_readings in zip(variants, measured)]
        nominal = self.nominal = NominalBatch(
            scenario.model, np.concatenate([members.nominal_mass_scale] * sum(self.estimators)), threads)
        # Where MuJoCo itself evaluates the nominal model (a robot the compiled one does not cover), the
        # controller's model is the plant's (no mass scale) and the encoders read the state exactly (no sensor
        # effects), M at the measured position is the plant's own M(q) and its factorisation, bit for bit, at no
        # extra evaluation. The compiled model rounds otherwise than the plant: it evaluates its own M.
        plant_is_nominal = bool(np.all(members.nominal_mass_scale == 1.0) and np.all(members.plant_mass_scale == 1.0))
        mass_from_plant = (nominal.tree is None and plant_is_nominal and scenario.position_sensor is None
                           and plant.reads_state_exactly)
        #: M at the measured positions, one point per row, without the velocity terms (None: the plant's).
        self.nominal_mass = None
        if mass_from_plant:  # buffers refreshed by every mass_matrices() call
            self.mass, factor, diagonal_inverse = plant.mass_matrices(), plant.factor, plant.diagonal_inverse
        else:
            mass_batch = self.nominal_mass = NominalBatch(scenario.model, per_row(members.nominal_mass_scale),
                                                          threads, mass_only=True)
            self.mass, factor, diagonal_inverse = (mass_batch.mass_matrices(), mass_batch.factor,
                                                   mass_batch.diagonal_inverse)
        self.solver = solver = SparseSolver(scenario.model)
        self.factor, self.diagonal_inverse = factor, diagonal_inverse
        #: M(x1)^-1 tau of every row's command, solved at once before the observers advance.
        self.command_acceleration = np.zeros((rows, n))

        self.measures_velocity = scenario.measures_velocity
        qd_meas = self.qd_meas = np.zeros((rows, n)) if self.measures_velocity else None  # the tachometers'
        self.q_meas, self.q_read, self.qd_read = np.zeros((rows, n)), np.zeros((rows, n)), np.zeros((rows, n))
        self.tau = np.zeros((rows, n))

        def points(first: int) -> tuple[np.ndarray, np.ndarray]:  # the nominal batch's qpos, qvel of a point's rows
            return nominal.qpos[first:first + count], nominal.qvel[first:first + count]

        self.blocks = blocks = []
        point = 0
        for v, variant in enumerate(variants):
            block_rows = slice(v * count, (v + 1) * count)
            config = members.variants[v]

            def step_model(first: int, control: int | None = None) -> StepModel:
                return StepModel(M=self.mass[block_rows], factor=factor[block_rows],
                                 diagonal_inverse=diagonal_inverse[block_rows], solver=solver,
                                 psi_hat=nominal.qacc[first:first + count],
                                 psi_control=None if control is None else nominal.qacc[control:control + count],
                                 qd_measured=None if control is None else qd_meas[block_rows],
                                 command=self.command_acceleration[block_rows])

            observer = variant.observer_type(config.observer, n, dt, members=count)
            controller = variant.controller_type(config.controller, n, dt, members=count)
            controller.reset()
            host = point
            point += count
            monitors = []
            for monitor, monitor_config in zip(variant.monitors, config.monitors):
                monitors.append((monitor.name, monitor.observer_type(monitor_config, n, dt, members=count),
                                 step_model(point)))
                point += count
            host_model = step_model(host, point if measured[v] else None)
            reading_points = points(point) if measured[v] else None
            point += count * measured[v]
            estimators = [observer] + [monitor for _, monitor, _ in monitors]
            blocks.append(VariantBlock(
                variant.name, block_rows, observer, controller, host_model, monitors, config.q_hat0,
                config.qd_hat0, q_meas=self.q_meas[block_rows],
                qd_meas=None if qd_meas is None else qd_meas[block_rows], tau=self.tau[block_rows],
                points=[(estimator, *points(host + i * count)) for i, estimator in enumerate(estimators)],
                reading_points=reading_points))

        self.terms = PlantTerms(scenario.terms, self.times, rows, n, per_row(members.parameters),
                                list(spec.parameters), scenario.terms_function)
        self.actuators = (ActuatorFaults(scenario.actuator_faults, self.times, (rows, n))
                          if scenario.actuator_faults else None)
        # Whether a fault is on: profiles depend on time only, so the same for every row, known before the run.
        fault_on = self.terms.fault_on | (False if self.actuators is None else self.actuators.active)
        self.fault_on = fault_on.tolist()
        # Where no fault term is on, the fault sums are zero (the series start at zero and are written only
        # where they may not be); actuator faults add to the fault force whenever there are any.
        self.fault_terms_on = self.terms.fault_on.tolist()
        self.position_sensor = self.velocity_sensor = None
        if scenario.position_sensor is not None:
            self.position_sensor = Measurement(scenario.position_sensor, self.times,
                                               _generators(members, randomness.POSITION_NOISE), len(variants))
        if scenario.velocity_sensor is not None and self.measures_velocity:
            self.velocity_sensor = Measurement(scenario.velocity_sensor, self.times,
                                               _generators(members, randomness.VELOCITY_NOISE), len(variants))

        # (N, n), or (N, members, n) where the reference uses parameters: each variant's block follows its members'.
        used = [list(spec.parameters).index(name) for name in scenario.reference.parameters]
        self.reference = scenario.reference.evaluate(self.times, members.parameters[:, used] if used else None)
        steps = self.steps
        # Every sample of every series below is written before the run ends, or lies past its row's stop, where
        # result() writes NaN: no fill beforehand (a pass over gigabytes in a campaign's batch). The fault series
        # are written only while a fault may be on, so they start at zero.
        self.series = {name: np.empty((steps, rows, n)) for name in SERIES}
        for name in ("fault", "fault_torque", "fault_acceleration"):
            self.series[name] = np.zeros((steps, rows, n))
        self.fault_active = np.repeat(fault_on[:, None], rows, axis=1)
        self.qd_measured = np.empty((steps, rows, n)) if self.measures_velocity else None
        self.torque_space = scenario.diagnoser is not None and scenario.diagnoser.space == "torque"
        self.luaf_torque = np.empty((steps, rows, n)) if self.torque_space else None
        self.monitor_series = {
            block.name: {name: {key: np.empty((steps, count, n)) for key in ("qd_hat", "luaf_hat")}
                         | ({"luaf_torque": np.empty((steps, count, n))} if self.torque_space else {})
                         for name, _, _ in block.monitors}
            for block in blocks
        }
        self.signals = [{**b.observer.signals, **b.controller.signals} for b in blocks]
        self.extras = {b.name: {name: np.empty((steps, count, n)) for name in signals}
                       for b, signals in zip(blocks, self.signals)}
        self.body_xpos = self.body_xquat = None
        if record_poses:
            self.xpos, self.xquat = plant.batch.bind("xpos"), plant.batch.bind("xquat")
            self.body_xpos = np.zeros((steps,) + self.xpos.shape)
            self.body_xquat = np.zeros((steps,) + self.xquat.shape)
        self.plant_bias = plant.batch.bind("qfrc_bias")  # C(q, qd) qd + G(q) at the sample instant
        # The truths need M(q)^-1 at the sample instant: Psi + M^-1 tau of the nominal model at the true state, for
        # the true LUaF, and M^-1 of the fault force. They are solved after the run over every sample at once
        # (:meth:`finish_truth`): each period keeps the plant's factorisation of M(q) and the right-hand side.
        # The nominal model is the plant's with its masses, inertias and armature scaled by c = nominal scale /
        # plant scale, so its M and C qd + G are c times the plant's: Psi + M^-1 tau = M_plant^-1 (tau / c - C qd - G)
        # (for c = 1 the plant's numbers themselves; otherwise equal up to rounding).
        self.sample_factor = np.zeros((steps, rows) + plant.factor.shape[1:])
        self.sample_diagonal_inverse = np.zeros((steps, rows, n))
        #: tau / c - C qd - G of the plant at each sample.
        self.truth_force = np.zeros((steps, rows, n))
        scale = per_row(members.nominal_mass_scale) / per_row(members.plant_mass_scale)
        self.truth_scale = None if np.all(scale == 1.0) else scale[:, None]
        self.done = np.full(rows, steps)
        self.diverged_at = np.full(rows, np.nan)

    def stop(self, stopped: np.ndarray | None, k: int) -> None:
        """Rows stopped at sample k: their recording ends before it."""
        if stopped is not None:
            self.done[stopped] = k
            self.diverged_at[stopped] = self.times[k]

    def sense(self, k: int) -> None:
        """1. The readings of sample k, corrupted by the sensor effects."""
        plant = self.plant
        if self.position_sensor is None:  # the encoders read exactly
            plant.read_positions(self.q_meas)
        else:
            plant.read_positions(self.q_read)
            self.position_sensor.read(k, self.q_read, self.q_meas)
        if self.qd_meas is not None:
            if self.velocity_sensor is None:
                plant.read_velocities(self.qd_meas)
            else:
                plant.read_velocities(self.qd_read)
                self.velocity_sensor.read(k, self.qd_read, self.qd_meas)

    def evaluate_nominal(self, k: int) -> None:
        """2. The observers take the readings; the nominal model at every point."""
        nominal, count = self.nominal, self.count
        for block in self.blocks:
            q_b, qd_b = block.q_meas, block.qd_meas
            if k == 0:  # from the first reading unless the scenario says otherwise
                q_hat0 = q_b if block.q_hat0 is None else block.q_hat0
                for observer in block.estimators:
                    observer.reset(q_hat0, block.qd_hat0)
            for observer, qpos, qvel in block.points:
                observer.measure(q_b, qd_b)
                qpos[...] = observer.q_hat
                qvel[...] = observer.qd_hat
            if block.reading_points is not None:  # the controller's Psi at the readings
                qpos, qvel = block.reading_points
                qpos[...] = q_b
                qvel[...] = qd_b
        mass_batch = self.nominal_mass
        if mass_batch is not None:
            np.copyto(mass_batch.qpos, self.q_meas)
        if self.plant.running < self.rows:  # stopped rows may hold NaN or inf: evaluate them at rest instead
            _rest(nominal, mass_batch, self.plant.alive, count, self.estimators)
        nominal.evaluate()
        if mass_batch is None:
            self.plant.mass_matrices()  # refreshes ``mass``
        else:
            mass_batch.evaluate()
            mass_batch.mass_matrices()

    def control(self, k: int, t: float) -> None:
        """3. Each observer's injection, each controller's torque; the commands go to ``ctrl``."""
        series, q_meas, tau = self.series, self.q_meas, self.tau
        q_ref, qd_ref, qdd_ref = self.reference[0][k], self.reference[1][k], self.reference[2][k]
        for b, block in enumerate(self.blocks):
            rows_b, q_b = block.rows, block.q_meas
            block.observer.update(t, q_b, block.model)
            for name, observer, model in block.monitors:
                observer.update(t, q_b, model)
                recorded = self.monitor_series[block.name][name]
                recorded["qd_hat"][k] = observer.qd_hat
                recorded["luaf_hat"][k] = observer.luaf_hat
                if self.torque_space:
                    model.apply_M(observer.luaf_hat, out=recorded["luaf_torque"][k])
            block.tau[...] = block.controller.compute(t, q_ref, qd_ref, qdd_ref, q_b, block.observer, block.model)
            series["qd_hat"][k, rows_b] = block.observer.qd_hat
            series["luaf_hat"][k, rows_b] = block.observer.luaf_hat
            series["sliding"][k, rows_b] = block.controller.sliding
            if self.luaf_torque is not None:
                block.model.apply_M(block.observer.luaf_hat, out=self.luaf_torque[k, rows_b])
            if self.signals[b]:
                for name, signal in self.signals[b].items():
                    self.extras[block.name][name][k] = signal
        plant = self.plant
        plant.ctrl[:] = tau
        series["q_meas"][k] = q_meas
        series["q_true"][k] = plant.qpos
        series["qd_true"][k] = plant.qvel
        series["tau"][k] = tau
        if self.qd_measured is not None:
            self.qd_measured[k] = self.qd_meas
        if self.body_xpos is not None:
            self.body_xpos[k] = self.xpos
            self.body_xquat[k] = self.xquat

    def actuate(self, k: int, t: float) -> None:
        """4. Terms on the true state and what the actuators deliver go to ``qfrc_applied``; the fault truth."""
        plant, terms, series, tau = self.plant, self.terms, self.series, self.tau
        true_mass = (self.mass if self.nominal_mass is None else plant.mass_matrices()) if terms.needs_mass else None
        # M(q) of the sample instant and tau / c - C qd - G, for the truths solved after the run.
        self.sample_factor[k] = plant.factor
        self.sample_diagonal_inverse[k] = plant.diagonal_inverse
        if self.truth_scale is None:
            np.subtract(tau, self.plant_bias, out=self.truth_force[k])
        else:
            force = np.divide(tau, self.truth_scale, out=self.truth_force[k])
            force -= self.plant_bias
        terms.apply(k, t, plant.qpos, plant.qvel, true_mass, plant.applied)
        if self.fault_terms_on[k]:
            series["fault"][k] = terms.fault
        actuators = self.actuators
        if actuators is not None:
            # The actuators deliver something else than the command: the difference acts through
            # qfrc_applied, so ctrl (and the recorded tau) stay what the controller asked for.
            actuators.apply(k, tau)
            plant.applied += actuators.torque
            terms.fault_force += actuators.torque
            series["tau_delivered"][k] = actuators.delivered
        if actuators is not None or self.fault_terms_on[k]:
            series["fault_torque"][k] = terms.fault_force

    def advance(self, k: int) -> None:
        """5. The observers integrate over the period (:meth:`integrate_observers`); the plant steps; the
        period's true acceleration."""
        self.integrate_observers()
        self.stop(self.plant.step(self.series["qdd_true"][k]), k)

    def integrate_observers(self) -> None:
        """M(x1)^-1 tau of every row's command in one solve; every observer integrates over the period, with this
        period's model (before the plant's M moves on)."""
        self.solver.solve(self.factor, self.diagonal_inverse, self.tau, self.command_acceleration)
        for block in self.blocks:
            tau_b = block.tau
            block.observer.advance(tau_b, block.model)
            for _, observer, model in block.monitors:
                observer.advance(tau_b, model)

    def finish_truth(self) -> None:
        """The truths solved with the samples' factorisations of M(q): the true LUaF, qdd - (Psi + M^-1 tau) of
        the nominal model at the true state, and the fault's acceleration M^-1 fault force while a fault is on
        (0 otherwise). The same operations as ``mj_solveM`` per sample
        (:class:`~ftc_mj.robot.nominal.SparseSolver`), in chunks of samples."""
        series, solver = self.series, self.solver
        fault_samples = np.flatnonzero(self.fault_on)
        for start in range(0, self.steps, TRUTH_CHUNK):
            samples = slice(start, min(start + TRUTH_CHUNK, self.steps))
            acceleration = _solve_samples(solver, self.sample_factor[samples], self.sample_diagonal_inverse[samples],
                                          self.truth_force[samples])
            np.subtract(series["qdd_true"][samples], acceleration, out=series["luaf_true"][samples])
        for start in range(0, len(fault_samples), TRUTH_CHUNK):
            samples = fault_samples[start:start + TRUTH_CHUNK]
            series["fault_acceleration"][samples] = _solve_samples(
                solver, self.sample_factor[samples], self.sample_diagonal_inverse[samples],
                series["fault_torque"][samples])

    def result(self) -> BatchRun:
        """The series, cut where each row stopped."""
        series, done = self.series, self.done
        if self.actuators is None:  # the actuators delivered the command
            np.copyto(series["tau_delivered"], series["tau"])
        for rows_series in (*series.values(), self.qd_measured, self.luaf_torque):
            if rows_series is not None:
                _cut(rows_series, done)
        for block in self.blocks:
            block_done = done[block.rows]
            for name_series in (*self.monitor_series[block.name].values(), self.extras[block.name]):
                for values in name_series.values():
                    _cut(values, block_done)
        return BatchRun(times=self.times, members=self.count, variants=[b.name for b in self.blocks],
                        series=series, reference=self.reference, monitor_series=self.monitor_series,
                        extras=self.extras, fault_active=self.fault_active, qd_measured=self.qd_measured,
                        luaf_torque=self.luaf_torque, body_xpos=self.body_xpos, body_xquat=self.body_xquat,
                        done=done, diverged_at=self.diverged_at)


def _solve_samples(solver: SparseSolver, factor: np.ndarray, diagonal_inverse: np.ndarray,
                   vector: np.ndarray) -> np.ndarray:
    """M^-1 vector for ``(samples, rows, ...)`` factorisations and vectors, every (sample, row) at once."""
    rows = factor.shape[0] * factor.shape[1]
    return solver.solve(factor.reshape(rows, -1), diagonal_inverse.reshape(rows, -1), vector.reshape(rows, -1),
                        np.empty((rows, vector.shape[-1]))).reshape(vector.shape)


def _rest(nominal: NominalBatch, mass_batch: NominalBatch | None, alive: np.ndarray, count: int,
          estimators: list[int]) -> None:
    """Evaluate the stopped rows' points at rest: they may hold NaN or inf."""
    stopped = ~alive
    psi_stopped = np.concatenate([np.tile(stopped[v * count:(v + 1) * count], e) for v, e in enumerate(estimators)])
    for batch, mask in ((nominal, psi_stopped), (mass_batch, stopped)):
        if batch is None:  # no such points (M from the plant)
            continue
        batch.qpos[mask] = 0.0
        batch.qvel[mask] = 0.0
        batch.applied[mask] = 0.0


def _cut(values: np.ndarray, done: np.ndarray) -> None:
    """NaN from each row's stop on (``values`` is ``(steps, rows, ...)``)."""
    for row in np.flatnonzero(done < len(values)):
        values[done[row]:, row] = np.nan


def _generators(members: Members, stream: int) -> list[np.random.Generator]:
    """Each member's generator of one random stream (:mod:`ftc_mj.effects.randomness`)."""
    return [randomness.generator(int(seed), stream) for seed in members.seeds]


def _default_threads(rows: int) -> int:
    """All cores, but no more threads than rows."""
    return max(1, min(os.cpu_count() or 1, rows))

