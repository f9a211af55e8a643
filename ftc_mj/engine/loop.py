"""The closed loop of a batch: every variant of a scenario and every member, stepped together.

Rows: the plant is one :class:`mujoco.batch.Batch` with a row per (variant, member), variant-major, so that
the members of one variant are a contiguous block and each variant's observer, controller and monitors work
on views of that block with state shaped ``(members, joints)``. A single run is one member.

Per control period k (time t_k = k * control_dt, zero-order hold on the command):

1. the sensors of every row are current (the batch computes positions, velocities and sensors at the new
   state after each step, as ``mj_step1`` does); the true readings are corrupted by the scenario's sensor
   effects, per member (:mod:`ftc_mj.effects.sensors`);
2. each observer takes the measurement (``measure``); the nominal model is evaluated for all rows at once on
   a second batch (:class:`~ftc_mj.robot.nominal.NominalBatch`): Psi at each observer's estimate, M at the
   measured position, and, one period late, the true lumped uncertainty at the previous sample;
3. each observer forms its injection (``update``); each controller computes its torque; ``ctrl`` = torque;
4. friction, disturbance and fault terms on the *true* state of all rows, and what the actuator faults
   deliver beyond the command, go to ``qfrc_applied`` (:mod:`ftc_mj.effects.terms`, :mod:`~.faults`);
5. the plant steps (:class:`~ftc_mj.engine.plant.Plant`); each observer integrates over the period.

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
    spec = scenario.spec
    n, dt, times = scenario.n_joints, spec.control_dt, scenario.times
    steps, count = len(times), members.count
    variants = scenario.variants
    rows = count * len(variants)
    threads = nthread if nthread > 0 else _default_threads(rows)

    def per_row(values: np.ndarray) -> np.ndarray:  # member values repeated for every variant's block
        return np.concatenate([values] * len(variants))

    plant = Plant(scenario.model, per_row(members.q0), per_row(members.qd0), scenario.substeps, threads,
                  mass_scale=per_row(members.plant_mass_scale), max_position=spec.divergence.max_position,
                  max_velocity=spec.divergence.max_velocity)

    # Nominal evaluation points: Psi at each estimate (host observer and monitors of every variant), M at every
    # row's measured position, and every row's true lumped uncertainty in the nominal terms (one period late).
    # Where the controller's model is the plant's (no mass scale), the plant's own M(q), its factorisation and
    # C qd + G at the sample instant are the same numbers: they give the truth, and, where the encoders read the
    # state exactly (no sensor effects), M at the measured position, at no extra evaluation.
    plant_is_nominal = bool(np.all(members.nominal_mass_scale == 1.0) and np.all(members.plant_mass_scale == 1.0))
    mass_from_plant = plant_is_nominal and scenario.position_sensor is None and plant.reads_state_exactly
    # Per variant: Psi at the observer's estimate, at each monitor's, and, for a controller on measured
    # velocity (``controller_velocity``), at the readings.
    measured = [variant.controller_velocity == "measured" for variant in variants]
    estimators = [1 + len(v.monitors) + on_readings for v, on_readings in zip(variants, measured)]
    psi_points = count * sum(estimators)
    mass_rows = 0 if mass_from_plant else rows
    truth_rows = 0 if plant_is_nominal else rows
    nominal = NominalBatch(
        scenario.model,
        np.concatenate([np.concatenate([members.nominal_mass_scale] * sum(estimators)),
                        per_row(members.nominal_mass_scale)[:mass_rows],
                        per_row(members.nominal_mass_scale)[:truth_rows]]),
        threads,
    )
    mass_points = slice(psi_points, psi_points + mass_rows)
    truth_points = slice(psi_points + mass_rows, psi_points + mass_rows + truth_rows)
    if mass_from_plant:  # buffers refreshed by every mass_matrices() call
        mass, factor, diagonal_inverse = plant.mass_matrices(), plant.factor, plant.diagonal_inverse
    else:
        mass = nominal.mass_matrices()[mass_points]
        factor, diagonal_inverse = nominal.factor[mass_points], nominal.diagonal_inverse[mass_points]
    solver = SparseSolver(scenario.model)

    measures_velocity = scenario.measures_velocity
    qd_meas = np.zeros((rows, n)) if measures_velocity else None  # the tachometers' readings
    blocks: list[VariantBlock] = []
    point = 0
    for v, variant in enumerate(variants):
        block_rows = slice(v * count, (v + 1) * count)
        config = members.variants[v]

        def step_model(first: int, control: int | None = None) -> StepModel:
            return StepModel(M=mass[block_rows], factor=factor[block_rows],
                             diagonal_inverse=diagonal_inverse[block_rows], solver=solver,
                             psi_hat=nominal.qacc[first:first + count],
                             psi_control=None if control is None else nominal.qacc[control:control + count],
                             qd_measured=None if control is None else qd_meas[block_rows])

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
        point += count * measured[v]
        blocks.append(VariantBlock(variant.name, block_rows, observer, controller, host_model, monitors,
                                   config.q_hat0, config.qd_hat0))

    terms = PlantTerms(scenario.terms, rows, n, per_row(members.parameters), list(spec.parameters))
    actuators = ActuatorFaults(scenario.actuator_faults, times, (rows, n)) if scenario.actuator_faults else None
    has_faults = actuators is not None or any(term.kind == "fault" for term in scenario.terms)
    position_sensor = velocity_sensor = None
    if scenario.position_sensor is not None:
        position_sensor = Measurement(scenario.position_sensor, times, _generators(members, randomness.POSITION_NOISE),
                                      len(variants))
    if scenario.velocity_sensor is not None and measures_velocity:
        velocity_sensor = Measurement(scenario.velocity_sensor, times, _generators(members, randomness.VELOCITY_NOISE),
                                      len(variants))

    # (N, n), or (N, members, n) where the reference uses parameters: every variant's block follows its members'.
    q_ref, qd_ref, qdd_ref = scenario.reference.evaluate(times, members.parameters if spec.parameters else None)
    series = {name: np.full((steps, rows, n), np.nan) for name in SERIES}
    fault_active = np.zeros((steps, rows), dtype=bool)
    q_meas, q_read = np.zeros((rows, n)), np.zeros((rows, n))
    qd_read = np.zeros((rows, n))
    qd_measured = np.full((steps, rows, n), np.nan) if measures_velocity else None
    torque_space = scenario.diagnoser is not None and scenario.diagnoser.space == "torque"
    luaf_torque = np.full((steps, rows, n), np.nan) if torque_space else None
    monitor_series = {
        block.name: {name: {key: np.full((steps, count, n), np.nan) for key in ("qd_hat", "luaf_hat")}
                     | ({"luaf_torque": np.full((steps, count, n), np.nan)} if torque_space else {})
                     for name, _, _ in block.monitors}
        for block in blocks
    }
    signals = [{**b.observer.signals, **b.controller.signals} for b in blocks]
    extras = {b.name: {name: np.full((steps, count, n), np.nan) for name in s} for b, s in zip(blocks, signals)}
    body_xpos = body_xquat = None
    if record_poses:
        xpos, xquat = plant.batch.bind("xpos"), plant.batch.bind("xquat")
        body_xpos = np.zeros((steps,) + xpos.shape)
        body_xquat = np.zeros((steps,) + xquat.shape)
    tau = np.zeros((rows, n))
    truth_tau = nominal.applied[truth_points]
    fault_acceleration = np.zeros((rows, n))
    plant_factor, plant_diagonal_inverse = plant.factor, plant.diagonal_inverse
    plant_bias = plant.batch.bind("qfrc_bias")  # C(q, qd) qd + G(q) at the sample instant
    truth_force, truth_acceleration = np.zeros((rows, n)), np.zeros((rows, n))
    done = np.full(rows, steps)
    diverged_at = np.full(rows, np.nan)
    alive = plant.alive

    def stop(stopped: np.ndarray | None, k: int) -> None:
        if stopped is not None:
            done[stopped] = k
            diverged_at[stopped] = times[k]

    pending: int | None = None  # the sample whose true lumped uncertainty the next evaluation gives
    with np.errstate(all="ignore"):  # stopped rows may hold NaN; they are cut off from their time on
        for k in range(steps):
            t = times[k]
            stop(plant.check(), k)
            if not plant.running:
                break
            plant.read_positions(q_read)
            if position_sensor is None:
                np.copyto(q_meas, q_read)
            else:
                position_sensor.read(k, q_read, q_meas)
            if qd_meas is not None:
                plant.read_velocities(qd_read)
                if velocity_sensor is None:
                    np.copyto(qd_meas, qd_read)
                else:
                    velocity_sensor.read(k, qd_read, qd_meas)
            point = 0
            for block in blocks:
                q_b = q_meas[block.rows]
                qd_b = None if qd_meas is None else qd_meas[block.rows]
                estimators_b = block.estimators
                if k == 0:  # from the first reading unless the scenario says otherwise
                    q_hat0 = q_b if block.q_hat0 is None else block.q_hat0
                    for observer in estimators_b:
                        observer.reset(q_hat0, block.qd_hat0)
                for observer in estimators_b:
                    observer.measure(q_b, qd_b)
                    nominal.qpos[point:point + count] = observer.q_hat
                    nominal.qvel[point:point + count] = observer.qd_hat
                    point += count
                if block.model.qd_measured is not None:  # the controller's Psi at the readings
                    nominal.qpos[point:point + count] = q_b
                    nominal.qvel[point:point + count] = qd_b
                    point += count
            if not mass_from_plant:
                nominal.qpos[mass_points] = q_meas
            if plant.running < rows:  # stopped rows may hold NaN or inf: evaluate them at rest instead
                _rest(nominal, alive, done < k, count, estimators, mass_points, truth_points)
            nominal.evaluate()
            (plant if mass_from_plant else nominal).mass_matrices()  # refreshes ``mass``
            if pending is not None:  # last period's truth: qdd - (Psi(q, qd) + M(q)^-1 tau) at its true state
                np.subtract(series["qdd_true"][pending], nominal.qacc[truth_points], out=series["luaf_true"][pending])
            pending = None if plant_is_nominal else k
            for b, block in enumerate(blocks):
                rows_b = block.rows
                q_b = q_meas[rows_b]
                block.observer.update(t, q_b, block.model)
                for name, observer, model in block.monitors:
                    observer.update(t, q_b, model)
                    monitor_series[block.name][name]["qd_hat"][k] = observer.qd_hat
                    monitor_series[block.name][name]["luaf_hat"][k] = observer.luaf_hat
                    if torque_space:
                        model.apply_M(observer.luaf_hat, out=monitor_series[block.name][name]["luaf_torque"][k])
                tau[rows_b] = block.controller.compute(t, q_ref[k], qd_ref[k], qdd_ref[k], q_b, block.observer,
                                                       block.model)
                series["qd_hat"][k, rows_b] = block.observer.qd_hat
                series["luaf_hat"][k, rows_b] = block.observer.luaf_hat
                series["sliding"][k, rows_b] = block.controller.sliding
                if luaf_torque is not None:
                    block.model.apply_M(block.observer.luaf_hat, out=luaf_torque[k, rows_b])
                for name, signal in signals[b].items():
                    extras[block.name][name][k] = signal
            plant.ctrl[:] = tau
            series["q_meas"][k] = q_meas
            series["q_true"][k] = plant.qpos
            series["qd_true"][k] = plant.qvel
            series["tau"][k] = tau
            if qd_measured is not None:
                qd_measured[k] = qd_meas
            if record_poses:
                body_xpos[k] = xpos
                body_xquat[k] = xquat
            true_mass = (mass if mass_from_plant else plant.mass_matrices()) if terms.needs_mass else None
            if plant_is_nominal:  # M(q)^-1 tau + Psi(q, qd) = M^-1 (tau - C qd - G) at the true state
                np.subtract(tau, plant_bias, out=truth_force)
                solver.solve(plant_factor, plant_diagonal_inverse, truth_force, truth_acceleration)
            terms.apply(t, plant.qpos, plant.qvel, true_mass, plant.applied)
            series["fault"][k] = terms.fault
            any_fault = terms.fault_active  # profiles depend on time only: the same for every row
            delivered = tau
            if actuators is not None:
                # The actuators deliver something else than the command: the difference acts through
                # qfrc_applied, so ctrl (and the recorded tau) stay what the controller asked for.
                actuators.apply(k, tau)
                plant.applied += actuators.torque
                terms.fault_force += actuators.torque
                any_fault = any_fault or actuators.active[k]
                delivered = actuators.delivered
            fault_active[k] = any_fault
            series["tau_delivered"][k] = delivered
            if has_faults:
                series["fault_torque"][k] = terms.fault_force
                if any_fault:  # M(q)^-1 of the fault force, with the true M of the sample instant
                    solver.solve(plant_factor, plant_diagonal_inverse, terms.fault_force, fault_acceleration)
                else:
                    fault_acceleration[:] = 0.0
                series["fault_acceleration"][k] = fault_acceleration
            if not plant_is_nominal:  # the truth point of this row, evaluated with the next period's nominal call
                nominal.qpos[truth_points] = plant.qpos
                nominal.qvel[truth_points] = plant.qvel
                truth_tau[:] = tau
            # The observers integrate over the period with this period's model (before the plant's M moves on).
            for block in blocks:
                tau_b = tau[block.rows]
                block.observer.advance(tau_b, block.model)
                for _, observer, model in block.monitors:
                    observer.advance(tau_b, model)
            stop(plant.step(), k)
            series["qdd_true"][k] = plant.acceleration
            if plant_is_nominal:
                np.subtract(plant.acceleration, truth_acceleration, out=series["luaf_true"][k])
            if progress is not None and (k + 1) % PROGRESS_EVERY == 0:
                progress(PROGRESS_EVERY)
        if pending is not None:  # the last recorded sample's truth
            nominal.evaluate()
            np.subtract(series["qdd_true"][pending], nominal.qacc[truth_points], out=series["luaf_true"][pending])
    if progress is not None:
        progress(steps % PROGRESS_EVERY)
    if not has_faults:
        series["fault_torque"][:] = 0.0
        series["fault_acceleration"][:] = 0.0
    for rows_series in (*series.values(), qd_measured, luaf_torque):
        if rows_series is not None:
            _cut(rows_series, done)
    for block in blocks:
        block_done = done[block.rows]
        for name_series in (*monitor_series[block.name].values(), extras[block.name]):
            for values in name_series.values():
                _cut(values, block_done)
    return BatchRun(times=times, members=count, variants=[b.name for b in blocks], series=series,
                    reference=(q_ref, qd_ref, qdd_ref),
                    monitor_series=monitor_series, extras=extras, fault_active=fault_active,
                    qd_measured=qd_measured, luaf_torque=luaf_torque, body_xpos=body_xpos, body_xquat=body_xquat,
                    done=done, diverged_at=diverged_at)


def _rest(nominal: NominalBatch, alive: np.ndarray, stopped_before: np.ndarray, count: int, estimators: list[int],
          mass_points: slice, truth_points: slice) -> None:
    """Evaluate the stopped rows' points at rest: they may hold NaN or inf. The truth point of a row that stopped
    this period still holds its last recorded sample's state, which is finite and still wanted."""
    stopped = ~alive
    psi_stopped = np.concatenate([np.tile(stopped[v * count:(v + 1) * count], e) for v, e in enumerate(estimators)])
    for points, mask in ((slice(0, len(psi_stopped)), psi_stopped), (mass_points, stopped),
                         (truth_points, stopped_before)):
        if points.stop == points.start:  # no such points (M and the truth from the plant)
            continue
        nominal.qpos[points][mask] = 0.0
        nominal.qvel[points][mask] = 0.0
        nominal.applied[points][mask] = 0.0


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


def series_bytes_per_member(scenario: Scenario) -> int:
    """Memory one member's kept series take (all variants and monitors), for choosing chunk sizes."""
    per_variant = len(SERIES) + 2 + 1  # the series, qd_measured and luaf_torque, fault_active
    per_variant += sum(3 * len(v.monitors) for v in scenario.variants) / max(len(scenario.variants), 1) + 2
    return int(len(scenario.times) * len(scenario.variants) * scenario.n_joints * 8 * per_variant)
