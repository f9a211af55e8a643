"""The closed loop of a batch: every variant of a scenario and every member, stepped together.

Rows and points: the plant has a row per (variant, member), variant-major; the nominal model is evaluated at
points laid out per variant (:mod:`ftc_mj.engine.rows`). A single run is one member.

Per control period k (time t_k = k * control_dt, zero-order hold on the command):

1. the readings of every row are current (the plant computes them at the new state after each step); they
   are corrupted by the scenario's sensor effects, per member (:mod:`ftc_mj.effects.sensors`);
2. each observer takes the measurement (``measure``); the nominal model is evaluated for all rows at once
   (:func:`~ftc_mj.robot.nominal.nominal_batch`): Psi at each observer's estimate (and, for an observer that
   declares them in ``needs``, C^T qd and G there), and M at the measured position (:mod:`ftc_mj.engine.mass`);
3. each observer forms its injection (``update``); each controller computes its torque; ``ctrl`` = torque;
4. friction, disturbance and fault terms on the *true* state of all rows, and what the actuator faults
   deliver beyond the command, go to ``applied`` (:mod:`ftc_mj.effects.terms`, :mod:`~.faults`); the
   truths that need the plant's M(q)^-1 at the sample instant are solved (:mod:`ftc_mj.engine.truths`);
5. M(x1)^-1 tau of every row's command is solved at once; each observer integrates over the period; the
   plant steps (:class:`~ftc_mj.engine.plant.Plant`).

After the last period, the true LUaF is completed from the true accelerations (:mod:`ftc_mj.engine.truths`);
the series (:mod:`ftc_mj.engine.series`) are cut where each row stopped.

A scenario with a ``log`` section replays it instead of simulating (:class:`~ftc_mj.engine.plant.LogPlant`):
the readings are the log's, every controller is the log's torque
(:class:`~ftc_mj.logs.controller.LogController`), and there are no truths (NaN).

A row that diverges stops with its own time; the others go on. Observers and controllers never see the
plant: only readings, time, the reference, their own commands and the nominal model.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cached_property

import mujoco
import numpy as np

from ftc_mj.analysis.causal import RecordedDiagnoser
from ftc_mj.config.errors import InputError
from ftc_mj.effects import randomness
from ftc_mj.effects.faults import ActuatorFaults
from ftc_mj.effects.sensors import Measurement
from ftc_mj.effects.terms import PlantTerms
from ftc_mj.fast.copies import SampleCopies
from ftc_mj.engine.rows import RowLayout
from ftc_mj.engine.mass import mass_at_readings, true_mass
from ftc_mj.engine.members import Members
from ftc_mj.engine.plant import LogPlant, Plant, plant_for
from ftc_mj.engine.series import BatchRun, BlockSeries, Series
from ftc_mj.engine.truths import Truths
from ftc_mj.methods.controllers.base import Controller
from ftc_mj.methods.observers.base import Observer
from ftc_mj.robot.friction import NominalFriction, nominal_friction
from ftc_mj.robot.nominal import NEEDS, MassAtReadings, NominalBatch, SparseSolver, StepModel, at_rest, nominal_batch
from ftc_mj.scenario.definition import Scenario

ProgressCallback = Callable[[int], None]
#: Called every :data:`PROGRESS_EVERY` periods with the number of samples written so far (``stop``: samples
#: ``[0, stop)`` of every series are final), the run's series and its reference ``(q_d, qd_d, qdd_d)``: a
#: live viewer's stream reads them there. It must not write to them.
ChunkCallback = Callable[[int, Series, tuple[np.ndarray, np.ndarray, np.ndarray]], None]
PROGRESS_EVERY = 500


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
    #: Where each estimator's (observer, monitors) estimate goes in the nominal batch: (observer, its
    #: ``measure``, or None where it keeps the base class's, which reads nothing; qpos, qvel).
    points: list[tuple[Observer, Callable[[np.ndarray, np.ndarray | None], None] | None, np.ndarray, np.ndarray]]
    #: The nominal points at the readings (a controller on measured velocity), or None.
    reading_points: tuple[np.ndarray, np.ndarray] | None
    #: The plugins' signals recorded each period: name -> ``(members, n)``.
    signals: dict[str, np.ndarray]
    #: The arrays the run's :class:`SampleCopies` copies each period into the block's rows of ``tau`` and of the
    #: series ``qd_hat``, ``luaf_hat`` and ``sliding``: the command the controller returned, the observer's
    #: ``qd_hat``, ``luaf_hat`` and the controller's ``sliding`` as they were when the copies were set up
    #: (compared each period: a plugin may return or rebind other arrays).
    copied: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] = ()
    #: The scenario's diagnosis stepped on the observer's estimate each period before the controller commands
    #: (a controller that declares ``reads_diagnosis`` gets its component as ``controller.diagnosis``), or None.
    diagnoser: RecordedDiagnoser | None = None

    @cached_property
    def estimators(self) -> list[Observer]:
        """The variant's observer and its monitors, in the order of their nominal points."""
        return [self.observer] + [observer for _, observer, _ in self.monitors]


@dataclass
class Readings:
    """The measurement of every row, ``(rows, n)``: the encoders' (and tachometers') true readings, corrupted
    by the sensor effects where the scenario has them."""

    q_meas: np.ndarray
    #: The tachometers' readings, or None without them.
    qd_meas: np.ndarray | None
    #: The true readings before the sensor effects.
    q_read: np.ndarray
    qd_read: np.ndarray
    position_sensor: Measurement | None
    velocity_sensor: Measurement | None

    def read(self, k: int, plant: Plant) -> None:
        """The readings of sample k."""
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


@dataclass
class PlantInputs:
    """What acts on the true robots beside the command: the terms and the actuator faults."""

    terms: PlantTerms
    actuators: ActuatorFaults | None
    #: Per sample, whether any fault is on (profiles depend on time only: the same for every row).
    fault_on: list[bool]
    #: Per sample, whether a fault term is on. Where none is, the fault sums are zero (the series start at
    #: zero and are written only where they may not be); actuator faults add to the fault force whenever there
    #: are any.
    fault_terms_on: list[bool]


@dataclass
class Stops:
    """Per row: the number of samples recorded (``steps`` unless it stopped) and the time it stopped; the stopped
    rows and their nominal model's Psi points, as indices kept from stop to stop (each period puts them at rest)."""

    done: np.ndarray
    diverged_at: np.ndarray
    rows: np.ndarray | None = None
    points: np.ndarray | None = None


def simulate(
    scenario: Scenario,
    members: Members,
    *,
    record_poses: bool = False,
    progress: ProgressCallback | None = None,
    nthread: int = 0,
    on_chunk: ChunkCallback | None = None,
    diagnose_in_loop: bool = False,
) -> BatchRun:
    """Run every variant of ``scenario`` for every member of ``members``, stepped together; ``on_chunk``
    (:data:`ChunkCallback`) sees the series every :data:`PROGRESS_EVERY` periods. The scenario's diagnosis is
    stepped inside the loop for the variants whose controller reads it, and for all with ``diagnose_in_loop``
    (else it runs after the run, on the recorded estimate: the same numbers).

    MuJoCo's printed warnings are silenced meanwhile: the bad-state warnings are each row's divergence, which
    the run reports itself (with the variant, the member and the time)."""
    with quiet_warnings():
        return _simulate(scenario, members, record_poses, progress, nthread, on_chunk, diagnose_in_loop)


_quiet_lock = threading.Lock()
_quiet_depth = 0
_previous_warning: Callable[[str], None] | None = None


@contextmanager
def quiet_warnings() -> Iterator[None]:
    """MuJoCo's printed warnings silenced meanwhile (the batch still counts them per simulation). Runs on
    several threads at once share it: the first to enter installs the silent handler, the last to leave puts
    the previous one back (MuJoCo's handler is global, not per thread)."""
    global _quiet_depth, _previous_warning
    with _quiet_lock:
        if _quiet_depth == 0:
            _previous_warning = mujoco.get_mju_user_warning()
            mujoco.set_mju_user_warning(_quiet)
        _quiet_depth += 1
    try:
        yield
    finally:
        with _quiet_lock:
            _quiet_depth -= 1
            if _quiet_depth == 0:
                mujoco.set_mju_user_warning(_previous_warning)


def _quiet(message: str) -> None:
    """A MuJoCo warning handler that prints nothing (the batch still counts the warnings per simulation)."""


def _simulate(scenario: Scenario, members: Members, record_poses: bool, progress: ProgressCallback | None,
              nthread: int, on_chunk: ChunkCallback | None = None, diagnose_in_loop: bool = False) -> BatchRun:
    run = _Run.set_up(scenario, members, record_poses, nthread, diagnose_in_loop)
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
            if (k + 1) % PROGRESS_EVERY == 0:
                if progress is not None:
                    progress(PROGRESS_EVERY)
                if on_chunk is not None:
                    on_chunk(k + 1, run.series, run.reference)
        run.finish_truth()
    if progress is not None:
        progress(run.steps % PROGRESS_EVERY)
    return run.result()


@dataclass
class _Run:
    """One batch run's state: set up once (:meth:`set_up`), then stepped period by period (the phases of the
    module docstring)."""

    times: np.ndarray
    layout: RowLayout
    plant: Plant
    readings: Readings
    #: Psi at every point of the layout.
    nominal: NominalBatch
    #: M(x1) at every row's measured position.
    mass: MassAtReadings
    solver: SparseSolver
    #: The commanded torque of every row, ``(rows, n)``, and M(x1)^-1 of it, solved at once before the
    #: observers advance (:attr:`solve_commands`).
    tau: np.ndarray
    command_acceleration: np.ndarray
    solve_commands: Callable[[], None]
    blocks: list[VariantBlock]
    #: Each period's copies of the live buffers into the series' samples and of the command into ``ctrl``.
    copies: SampleCopies
    inputs: PlantInputs
    #: q_d and its derivatives: ``(steps, n)``, or ``(steps, members, n)`` where the reference uses parameters.
    reference: tuple[np.ndarray, np.ndarray, np.ndarray]
    #: The period's rows of the reference, ``(n,)`` or ``(members, n)`` each: buffers the controllers are handed
    #: every period (the same objects, as the readings: a fused law binds them once), filled by
    #: :attr:`reference_copies` at the start of :meth:`control`.
    reference_rows: tuple[np.ndarray, np.ndarray, np.ndarray]
    reference_copies: SampleCopies
    series: Series
    #: The plant's live body poses to record, or None.
    poses: tuple[np.ndarray, np.ndarray] | None
    #: None where the plant has no truth (a log).
    truths: Truths | None
    stops: Stops
    #: The nominal model's joint friction (:mod:`ftc_mj.robot.friction`), or None where it has none.
    friction: NominalFriction | None = None

    @property
    def steps(self) -> int:
        return len(self.times)

    @property
    def rows(self) -> int:
        return self.layout.rows

    @classmethod
    def set_up(cls, scenario: Scenario, members: Members, record_poses: bool, nthread: int,
               diagnose_in_loop: bool = False) -> _Run:
        spec, variants, times = scenario.spec, scenario.variants, scenario.times
        n, dt, steps, count = scenario.n_joints, spec.control_dt, len(times), members.count
        layout = RowLayout.of(count, [len(v.monitors) for v in variants],
                           [v.controller_velocity == "measured" for v in variants])
        rows, per_row = layout.rows, layout.per_row
        threads = nthread if nthread > 0 else _default_threads(rows)
        plant = _plant(scenario, members, rows, per_row, threads)
        plant.reset(per_row(members.q0), per_row(members.qd0))
        # What each estimator (the variant's observer, then its monitors) reads beyond M and Psi.
        needs = [[_needs(kind) for kind in (v.observer_type, *(m.observer_type for m in v.monitors))] for v in variants]
        nominal = nominal_batch(scenario.model, layout.per_point(members.nominal_mass_scale), threads,
                                momentum_points=layout.estimator_points([[bool(s) for s in v] for v in needs]),
                                mass_points=per_row(members.nominal_mass_scale))
        mass = mass_at_readings(plant, nominal, per_row(members.nominal_mass_scale),
                                per_row(members.plant_mass_scale), scenario.position_sensor is not None)
        solver = SparseSolver(scenario.model)
        readings = _readings(scenario, members, layout)
        friction = nominal_friction(scenario.model, spec.nominal.friction, nominal, layout.points,
                                    readings.qd_meas, layout.point_rows, str(scenario.path))
        tau, command_acceleration = np.zeros((rows, n)), np.zeros((rows, n))
        blocks = []
        for v, (variant, block) in enumerate(zip(variants, layout.blocks)):
            config = members.variants[v]

            def step_model(points: slice, control: slice | None = None,
                           quantities: frozenset[str] = frozenset()) -> StepModel:  # M at the block's rows
                rows_b = block.rows
                return StepModel(M=mass.M[rows_b], factor=mass.factor[rows_b],
                                 diagonal_inverse=mass.diagonal_inverse[rows_b], solver=solver,
                                 psi_hat=nominal.qacc[points],
                                 psi_control=None if control is None else nominal.qacc[control],
                                 qd_measured=None if control is None else readings.qd_meas[rows_b],
                                 command=command_acceleration[rows_b],
                                 friction=None if friction is None else friction.torque[points],
                                 **{name: getattr(nominal, name)[points] for name in quantities})

            observer = variant.observer_type(config.observer, n, dt, members=count)
            controller = variant.controller_type(config.controller, n, dt, members=count)
            if isinstance(plant, LogPlant):  # the log's torque is the command
                controller.follow(plant.torque[block.rows])
            controller.reset()
            monitors = [(monitor.name, monitor.observer_type(monitor_config, n, dt, members=count),
                         step_model(points, quantities=monitor_needs))
                        for monitor, monitor_config, points, monitor_needs
                        in zip(variant.monitors, config.monitors, block.monitors, needs[v][1:])]
            estimators = [observer] + [monitor for _, monitor, _ in monitors]
            qd_meas = readings.qd_meas
            blocks.append(VariantBlock(
                variant.name, block.rows, observer, controller,
                step_model(block.observer, block.readings, needs[v][0]), monitors,
                config.q_hat0, config.qd_hat0, q_meas=readings.q_meas[block.rows],
                qd_meas=None if qd_meas is None else qd_meas[block.rows], tau=tau[block.rows],
                points=[(estimator, _measure(estimator), nominal.qpos[points], nominal.qvel[points])
                        for estimator, points in zip(estimators, block.estimators)],
                reading_points=None if block.readings is None else (nominal.qpos[block.readings],
                                                                    nominal.qvel[block.readings]),
                signals={**observer.signals, **controller.signals},
                diagnoser=_diagnoser(scenario, variant.name, controller, count, steps, diagnose_in_loop)))

        inputs = _inputs(scenario, members, layout)
        used = [list(spec.parameters).index(name) for name in scenario.reference.parameters]
        reference = scenario.reference.evaluate(times, members.parameters[:, used] if used else None)
        poses = plant.poses() if record_poses else None
        series = Series.allocate(
            steps, rows, n, count, [BlockSeries(b.name, b.rows, [name for name, _, _ in b.monitors], list(b.signals),
                                                {name: list(monitor.signals) for name, monitor, _ in b.monitors
                                                 if monitor.signals})
                                    for b in blocks],
            np.asarray(inputs.fault_on, dtype=bool), scenario.measures_velocity,
            scenario.diagnoser is not None and scenario.diagnoser.space == "torque", poses,
            delivered_is_command=inputs.actuators is None)
        copies = _sample_copies(plant, readings, tau, poses, series, blocks)
        truths = None
        if plant.has_truth:
            rows_series = series.rows
            truths = Truths.allocate(solver, plant,
                                     per_row(members.nominal_mass_scale) / per_row(members.plant_mass_scale), tau,
                                     rows_series["luaf_true"], rows_series["fault_torque"],
                                     rows_series["fault_acceleration"],
                                     bias=None if friction is None else np.zeros((rows, n)))
        solve_commands = solver.bound(mass.factor, mass.diagonal_inverse, tau, command_acceleration)
        reference_rows = tuple(np.zeros(values.shape[1:]) for values in reference)
        reference_copies = SampleCopies()
        for values, row in zip(reference, reference_rows):
            reference_copies.row(values, row)
        return cls(times, layout, plant, readings, nominal, mass, solver, tau, command_acceleration, solve_commands,
                   blocks, copies, inputs, reference, reference_rows, reference_copies, series, poses, truths,
                   Stops(np.full(rows, steps), np.full(rows, np.nan)), friction)

    def stop(self, stopped: np.ndarray | None, k: int) -> None:
        """Rows stopped at sample k (a mask, or None): their recording ends before it."""
        if stopped is not None:
            stops = self.stops
            stops.done[stopped] = k
            stops.diverged_at[stopped] = self.times[k]
            rows = ~self.plant.alive
            stops.rows, stops.points = np.flatnonzero(rows), np.flatnonzero(rows[self.layout.point_rows])

    def sense(self, k: int) -> None:
        """1. The readings of sample k, corrupted by the sensor effects."""
        self.readings.read(k, self.plant)

    def evaluate_nominal(self, k: int) -> None:
        """2. The observers take the readings; the nominal model at every point."""
        for block in self.blocks:
            q_b, qd_b = block.q_meas, block.qd_meas
            if k == 0:  # from the first reading unless the scenario says otherwise
                q_hat0 = q_b if block.q_hat0 is None else block.q_hat0
                for observer in block.estimators:
                    observer.reset(q_hat0, block.qd_hat0)
            for observer, measure, qpos, qvel in block.points:
                if measure is not None:
                    measure(q_b, qd_b)
                qpos[...] = observer.q_hat
                qvel[...] = observer.qd_hat
            if block.reading_points is not None:  # the controller's Psi at the readings
                qpos, qvel = block.reading_points
                qpos[...] = q_b
                qvel[...] = qd_b
        stops, nominal = self.stops, self.nominal
        if stops.rows is not None:  # stopped rows may hold NaN or inf: evaluate them at rest instead
            at_rest(nominal, stops.points)  # the Psi points alone
        self.mass.prepare(self.readings.q_meas, stops.rows)
        if self.friction is not None:  # the nominal joint friction: applied = -F(qd) at every Psi point
            self.friction.apply()
        nominal.evaluate()
        self.mass.evaluate()

    def control(self, k: int, t: float) -> None:
        """3. Each observer's injection, each controller's torque; the commands go to ``ctrl``."""
        recorded = self.series
        luaf_torque = recorded.luaf_torque
        self.reference_copies(k)
        q_ref, qd_ref, qdd_ref = self.reference_rows
        for block in self.blocks:
            rows_b, q_b = block.rows, block.q_meas
            block.observer.update(t, q_b, block.model)
            for name, observer, model in block.monitors:
                observer.update(t, q_b, model)
                monitor = recorded.monitors[block.name][name]
                monitor["qd_hat"][k] = observer.qd_hat
                monitor["luaf_hat"][k] = observer.luaf_hat
                if luaf_torque is not None:
                    model.apply_M(observer.luaf_hat, out=monitor["luaf_torque"][k])
                if observer.signals:
                    monitor_extras = recorded.monitor_extras[block.name][name]
                    for signal_name, signal in observer.signals.items():
                        monitor_extras[signal_name][k] = signal
            observer, controller = block.observer, block.controller
            if luaf_torque is not None:  # before the controller: the diagnosis in torque space reads it
                block.model.apply_M(observer.luaf_hat, out=luaf_torque[k, rows_b])
            if block.diagnoser is not None:
                estimate = observer.luaf_hat if luaf_torque is None else luaf_torque[k, rows_b]
                block.diagnoser.step(k, t, estimate, q_b, observer.qd_hat)
            command = controller.compute(t, q_ref, qd_ref, qdd_ref, q_b, observer, block.model)
            copied_command, qd_hat, luaf_hat, sliding = block.copied
            if (command is not copied_command or observer.qd_hat is not qd_hat or observer.luaf_hat is not luaf_hat
                    or controller.sliding is not sliding):
                block.copied = (command, observer.qd_hat, observer.luaf_hat, controller.sliding)
                self.copies.rebind(block, block.copied)
            if block.signals:
                extras = recorded.extras[block.name]
                for name, signal in block.signals.items():
                    extras[name][k] = signal
        # Each block's command into its rows of tau; ctrl = tau; q_meas, q_true, qd_true, tau, the measured velocity
        # and the poses into sample k; each block's qd_hat, luaf_hat and sliding variable into its rows of sample k.
        self.copies(k)

    def actuate(self, k: int, t: float) -> None:
        """4. Terms on the true state and what the actuators deliver go to ``applied``; the fault truth."""
        plant, inputs, series, tau = self.plant, self.inputs, self.series.rows, self.tau
        terms = inputs.terms
        # The dense M(q) only in the periods whose terms map accelerations (e.g. from a fault's onset on).
        mass = true_mass(self.mass, plant) if terms.maps_acceleration(k) else None
        terms.apply(k, t, plant.qpos, plant.qvel, mass, plant.applied)
        fault_terms_on = inputs.fault_terms_on[k]
        if fault_terms_on:
            series["fault"][k] = terms.fault
        actuators = inputs.actuators
        if actuators is not None:
            # The actuators deliver something else than the command: the difference acts through
            # ``applied``, so ctrl (and the recorded tau) stay what the controller asked for.
            actuators.apply(k, tau)
            plant.applied += actuators.torque
            terms.fault_force += actuators.torque
            series["tau_delivered"][k] = actuators.delivered
        fault_torque = actuators is not None or fault_terms_on
        if fault_torque:
            series["fault_torque"][k] = terms.fault_force
        truths = self.truths
        if truths is not None:  # M(q)^-1 (tau / c - C qd - G) at the sample instant; the fault's M(q)^-1 f
            if self.friction is not None:  # the nominal friction at the true state: bias + F / c
                np.add(plant.bias, self.friction.at_true_state(plant.qvel, truths.scale), out=truths.bias)
            truths.record(k, fault_torque and inputs.fault_on[k])

    def advance(self, k: int) -> None:
        """5. The observers integrate over the period (:meth:`integrate_observers`); the plant steps
        (:meth:`step_plant`)."""
        self.integrate_observers()
        self.step_plant(k)

    def integrate_observers(self) -> None:
        """M(x1)^-1 tau of every row's command in one solve; every observer integrates over the period, with this
        period's model (before the plant's M moves on)."""
        self.solve_commands()
        for block in self.blocks:
            tau_b = block.tau
            block.observer.advance(tau_b, block.model)
            for _, observer, model in block.monitors:
                observer.advance(tau_b, model)

    def step_plant(self, k: int) -> None:
        """The plant steps over the period; the period's true acceleration."""
        self.stop(self.plant.step(self.series.rows["qdd_true"][k]), k)

    def finish_truth(self) -> None:
        """The true LUaF from the true accelerations and the per-period solves (:meth:`Truths.finish`)."""
        series = self.series.rows
        if self.truths is None:  # no true LUaF; no fault acts on a log (its fault series stay zero)
            series["luaf_true"].fill(np.nan)
            return
        self.truths.finish(series["qdd_true"], series["luaf_true"])

    def result(self) -> BatchRun:
        """The series, cut where each row stopped."""
        recorded, done = self.series, self.stops.done
        recorded.cut(done)
        return BatchRun(times=self.times, members=self.layout.members, variants=[b.name for b in self.blocks],
                        series=recorded.rows, reference=self.reference, monitor_series=recorded.monitors,
                        extras=recorded.extras, fault_active=recorded.fault_active,
                        qd_measured=recorded.qd_measured, luaf_torque=recorded.luaf_torque,
                        body_xpos=recorded.body_xpos, body_xquat=recorded.body_xquat, done=done,
                        diverged_at=self.stops.diverged_at, monitor_extras=recorded.monitor_extras,
                        diagnosis={b.name: b.diagnoser.series for b in self.blocks if b.diagnoser is not None})


def _sample_copies(plant: Plant, readings: Readings, tau: np.ndarray, poses: tuple[np.ndarray, np.ndarray] | None,
                   series: Series, blocks: list[VariantBlock]) -> SampleCopies:
    """What :meth:`_Run.control` copies each period, after the controllers, in this order: each block's command
    (the controller's ``tau``) into its rows of ``tau``, ``tau`` into ``ctrl``, the readings, the true state, the
    torque (and the tachometers' readings, the poses) into the series' sample, each block's estimates and sliding
    variable into its rows of it."""
    copies = SampleCopies()
    for block in blocks:
        block.copied = (block.controller.tau, block.observer.qd_hat, block.observer.luaf_hat, block.controller.sliding)
        copies.into(block.copied[0], block.tau, group=block)
    copies.into(tau, plant.ctrl)
    rows = series.rows
    for name, source in (("q_meas", readings.q_meas), ("q_true", plant.qpos), ("qd_true", plant.qvel), ("tau", tau)):
        copies.sample(source, rows[name])
    if series.qd_measured is not None:
        copies.sample(readings.qd_meas, series.qd_measured)
    if poses is not None:
        copies.sample(poses[0], series.body_xpos)
        copies.sample(poses[1], series.body_xquat)
    for block in blocks:
        for source, name in zip(block.copied[1:], ("qd_hat", "luaf_hat", "sliding")):
            copies.sample(source, rows[name][:, block.rows], group=block)
    return copies


def _diagnoser(scenario: Scenario, variant: str, controller: Controller, members: int, steps: int,
               in_loop: bool) -> RecordedDiagnoser | None:
    """The variant's diagnosis stepped in the loop, where its controller reads it (then given to it as
    ``controller.diagnosis``) or ``in_loop`` asks for it; None otherwise."""
    reads = bool(getattr(controller, "reads_diagnosis", False))
    if scenario.diagnoser is None:
        if reads:
            raise InputError(str(scenario.path), f"variants.{variant}.controller",
                             "the controller reads the diagnosis: the scenario needs a diagnosis section")
        return None
    if not (reads or in_loop):
        return None
    recorded = RecordedDiagnoser(scenario.diagnoser, members, steps)
    if reads:
        controller.diagnosis = recorded.component
    return recorded


def _plant(scenario: Scenario, members: Members, rows: int, per_row: Callable[[np.ndarray], np.ndarray],
           threads: int) -> Plant:
    """The true robots: the scenario's log played back, or its robot simulated by MuJoCo."""
    if scenario.log is not None:
        return LogPlant(scenario.model, scenario.log, rows)
    spec = scenario.spec
    return plant_for(scenario.model, rows, scenario.substeps, threads, mass_scale=per_row(members.plant_mass_scale),
                     max_position=spec.divergence.max_position, max_velocity=spec.divergence.max_velocity)


def _readings(scenario: Scenario, members: Members, layout: RowLayout) -> Readings:
    """The buffers of the readings and the scenario's sensor effects, per member."""
    rows, n, variants = layout.rows, scenario.n_joints, len(layout.blocks)
    position_sensor = velocity_sensor = None
    if scenario.position_sensor is not None:
        position_sensor = Measurement(scenario.position_sensor, scenario.times,
                                      _generators(members, randomness.POSITION_NOISE), variants)
    if scenario.velocity_sensor is not None and scenario.measures_velocity:
        velocity_sensor = Measurement(scenario.velocity_sensor, scenario.times,
                                      _generators(members, randomness.VELOCITY_NOISE), variants)
    return Readings(np.zeros((rows, n)), np.zeros((rows, n)) if scenario.measures_velocity else None,
                    np.zeros((rows, n)), np.zeros((rows, n)), position_sensor, velocity_sensor)


def _inputs(scenario: Scenario, members: Members, layout: RowLayout) -> PlantInputs:
    """The scenario's plant terms and actuator faults over every row."""
    rows, n, times = layout.rows, scenario.n_joints, scenario.times
    terms = PlantTerms(scenario.terms, times, rows, n, layout.per_row(members.parameters),
                       list(scenario.spec.parameters), scenario.terms_function)
    limits = scenario.torque_limits if scenario.spec.faults_after_torque_limit else None
    actuators = (ActuatorFaults(scenario.actuator_faults, times, (rows, n), limits) if scenario.actuator_faults
                 else None)
    fault_on = terms.fault_on | (False if actuators is None else actuators.active)
    return PlantInputs(terms, actuators, fault_on.tolist(), terms.fault_on.tolist())


def _generators(members: Members, stream: int) -> list[np.random.Generator]:
    """Each member's generator of one random stream (:mod:`ftc_mj.effects.randomness`)."""
    return [randomness.generator(int(seed), stream) for seed in members.seeds]


def _measure(observer: Observer) -> Callable[[np.ndarray, np.ndarray | None], None] | None:
    """The observer's ``measure``, or None where it is :class:`Observer`'s own, which reads nothing."""
    if type(observer).measure is Observer.measure and "measure" not in vars(observer):
        return None
    return observer.measure


def _needs(observer_type: type[Observer]) -> frozenset[str]:
    """The nominal quantities beyond M and Psi an observer declares it reads (:data:`NEEDS`), checked."""
    needs = frozenset(getattr(observer_type, "needs", ()))
    unknown = needs - NEEDS
    if unknown:
        raise ValueError(f"observer {observer_type.name!r} needs {sorted(unknown)}: the nominal model gives "
                         f"{sorted(NEEDS)} beyond M and Psi")
    return needs


def _default_threads(rows: int) -> int:
    """All cores, but no more threads than rows."""
    return max(1, min(os.cpu_count() or 1, rows))
