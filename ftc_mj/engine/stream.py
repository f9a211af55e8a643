"""The engine's own loop driven one control period at a time by readings that come from outside: what a
monitor beside a real robot runs (:mod:`ftc_mj.online`).

A replayed log (:class:`~ftc_mj.engine.plant.LogPlant`) hands the loop the logged positions, velocities and
torque of each period; :class:`StreamPlant` is the same plant with no log behind it, whose period's readings
are given by :meth:`PeriodStepper.step` as they arrive. :class:`PeriodStepper` runs the phases of
:func:`ftc_mj.engine.loop.simulate` on it (readings, observers, nominal model, the diagnosis in the loop,
the log's controller, the observers' integration), so a stream gives the replay's numbers bit for bit: the same code on the same
inputs, not a second implementation of it. Its series hold two samples, the first period's and the current
one's (the loop's first period is where the observers start, so it keeps its own index); nothing grows with
the length of the stream.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from ftc_mj.engine.loop import _Run, quiet_warnings
from ftc_mj.engine.members import single
from ftc_mj.engine.plant import LogPlant
from ftc_mj.logs.controller import LogController
from ftc_mj.logs.trajectory import Log
from ftc_mj.scenario.definition import Scenario

#: The samples a stepper's series hold: the first period's and every later one's, in turn.
_SAMPLES = 2


class StreamPlant(LogPlant):
    """:class:`LogPlant` whose period's readings and torque are given one period at a time (:meth:`feed`)
    instead of read from its log (a stand-in of two samples, which gives only the buffers' shapes). No true
    state, no truths."""

    def feed(self, position: np.ndarray, velocity: np.ndarray | None, torque: np.ndarray) -> None:
        """The readings and the applied torque of the next period, ``(n,)`` each (every row reads the same)."""
        self._position[:] = position
        if velocity is not None:
            self._velocity[:] = velocity
        self.torque[:] = torque

    def reset(self, q0: np.ndarray, qd0: np.ndarray) -> None:
        """Nothing to set: the first period's readings are fed before it."""

    def step(self, acceleration: np.ndarray) -> np.ndarray | None:
        """No true acceleration (NaN); the next readings are fed."""
        acceleration[:] = np.nan
        return None


class PeriodStepper:
    """The loop of ``scenario``'s variants ``variants`` (default: all) stepped one control period at a time on
    fed readings, each variant's controller the fed torque (the log's, :class:`LogController`), monitors
    left out. A scenario without a ``log`` section is monitored the same way: its controllers and everything
    that acts on the simulated robot (terms, faults, sensor effects) are left out, since the readings and the
    torque are the real robot's."""

    def __init__(self, scenario: Scenario, variants: list[str] | None = None):
        chosen = scenario.variants if variants is None else [v for v in scenario.variants if v.name in variants]
        n, dt = scenario.n_joints, scenario.spec.control_dt
        velocity = scenario.measures_velocity
        times = np.arange(_SAMPLES) * dt
        log = Log(Path(scenario.path), times, np.zeros((_SAMPLES, n)), np.zeros((_SAMPLES, n)) if velocity else None,
                  np.zeros((_SAMPLES, n)), dt, 0.0, (dt, dt, dt))
        spec = scenario.spec.model_copy(update={"duration": _SAMPLES * dt})
        streamed = dataclasses.replace(
            scenario, spec=spec, log=log, terms=[], actuator_faults=[], position_sensor=None, velocity_sensor=None,
            terms_function=None,
            variants=[dataclasses.replace(v, controller_type=LogController, controller_config=LogController.Config(),
                                          monitors=[], controller_velocity="estimated") for v in chosen])
        self.scenario = streamed
        self.variants = [v.name for v in streamed.variants]
        self.measures_velocity = velocity
        with quiet_warnings():
            run = _Run.set_up(streamed, single(streamed), record_poses=False, nthread=1, diagnose_in_loop=True)
        self.plant = StreamPlant(scenario.model, log, run.rows)
        run.plant = self.plant
        for block in run.blocks:
            block.controller.follow(self.plant.torque[block.rows])
        self._run = run
        #: Periods stepped so far; the time of the next one is ``periods * dt``.
        self.periods = 0
        self.dt = dt
        series = run.series
        self._luaf_hat = series.rows["luaf_hat"]
        self._luaf_torque = series.luaf_torque
        self._qd_hat = series.rows["qd_hat"]
        self._q_meas = series.rows["q_meas"]

    @property
    def diagnosers(self) -> list:
        """Each variant's causal diagnoser (:class:`~ftc_mj.analysis.causal.CausalDiagnoser`, one row), stepped
        in the loop: its outputs are the last period's; None without a diagnosis section."""
        return [None if block.diagnoser is None else block.diagnoser.component for block in self._run.blocks]

    @property
    def rows(self) -> list[slice]:
        """Each variant's row (one member each) of the estimates."""
        return [block.rows for block in self._run.blocks]

    def step(self, position: np.ndarray, velocity: np.ndarray | None, torque: np.ndarray) -> int:
        """One control period on the readings ``position`` (and ``velocity``) and the applied ``torque``; its
        sample's index in the estimates' buffers (:meth:`luaf_hat`, :meth:`luaf_torque`, :meth:`qd_hat`)."""
        run, k = self._run, self.periods
        sample = min(k, _SAMPLES - 1)
        self.plant.feed(position, velocity, torque)
        t = k * self.dt
        with np.errstate(all="ignore"):
            run.sense(sample)
            run.evaluate_nominal(sample)  # the first period starts the observers
            run.control(sample, t)
            run.actuate(sample, t)
            run.advance(sample)
        self.periods = k + 1
        return sample

    def luaf_hat(self, sample: int) -> np.ndarray:
        """Every row's LUaF estimate of the period ``sample`` (``(rows, n)``, a view)."""
        return self._luaf_hat[sample]

    def luaf_torque(self, sample: int) -> np.ndarray | None:
        """M(q_meas) times it, where the scenario diagnoses in torque space (else None)."""
        return None if self._luaf_torque is None else self._luaf_torque[sample]

    def qd_hat(self, sample: int) -> np.ndarray:
        """Every row's velocity estimate of the period."""
        return self._qd_hat[sample]

    def q_meas(self, sample: int) -> np.ndarray:
        """Every row's position reading of the period."""
        return self._q_meas[sample]
