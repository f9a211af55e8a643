"""A streaming monitor: a scenario's observer and diagnosis beside a real robot, one sample at a time.

Built from a scenario (its robot, nominal model, one variant's observer, its ``diagnosis`` section), a
:class:`Monitor` takes samples ``(t, q, qd or None, tau)`` as they come and returns, each control period, the
residual, the threshold, the alarms and the isolated joints; there is no simulated plant. Per period it runs
the engine's own loop on the readings (:class:`~ftc_mj.engine.stream.PeriodStepper`: the observer, the
nominal model, M(q_meas) times the estimate in torque space, the causal diagnoser
:class:`~ftc_mj.analysis.causal.CausalDiagnoser` inside the loop), so a log streamed through it gives what the log's replay
(``ftc-mj run`` on a scenario with a ``log`` section) gives, bit for bit.

Sample times: the monitor steps on the scenario's uniform grid from the first sample's time, each signal
linearly interpolated between samples as the replay does (:mod:`ftc_mj.online.grid`): irregular times are
handled, a period completes when the first sample at or after its instant arrives, and time that does not
increase is refused. Inputs are in the robot's joint order and SI units; :class:`~ftc_mj.online.inputs.InputMap`
maps a source's joint names and units (the scenario's ``log`` section) to them.

    from ftc_mj import load_scenario
    from ftc_mj.online import Monitor

    monitor = Monitor(load_scenario("scenarios/real/ur10e_pushed.yaml"), variant="do")
    for t, q, qd, tau in samples:
        for period in monitor.push(t, q, qd, tau):
            print(period.time, period.residual, period.alarm)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ftc_mj.analysis.causal import require_causal
from ftc_mj.config.errors import InputError
from ftc_mj.engine.stream import PeriodStepper
from ftc_mj.online.grid import GridResampler, SampleError
from ftc_mj.scenario.definition import Scenario


@dataclass
class Period:
    """One control period's output, ``(n,)`` arrays of its own."""

    #: The period's index k and its time k DT from the first sample [s].
    index: int
    time: float
    #: The LUaF estimate in the diagnosis space (M(q_meas) luaf_hat in torque space [N m], else [rad/s^2]).
    estimate: np.ndarray
    #: Filtered estimate minus the baseline mean (NaN until the baseline is learned).
    fault_estimate: np.ndarray
    #: The decision statistic and its threshold (NaN while the diagnoser is not armed).
    residual: np.ndarray
    threshold: np.ndarray
    #: Per joint: the debounced alarm; whether its alarm has been on since the monitor started.
    alarm: np.ndarray
    isolated: np.ndarray
    armed: bool


class Monitor:
    """One variant of ``scenario`` (default: its first) monitoring a stream (the module docstring).

    Raises:
        InputError: the scenario has no ``diagnosis`` section, its diagnosis is not causal, or it has no
            variant ``variant``.
    """

    def __init__(self, scenario: Scenario, variant: str | None = None):
        file = str(scenario.path)
        names = [v.name for v in scenario.variants]
        if variant is None:
            variant = names[0]
        if variant not in names:
            raise InputError(file, "variants", f"no variant {variant!r} (the scenario has {', '.join(names)})")
        if scenario.diagnoser is None:
            raise InputError(file, "diagnosis", "a monitor needs a diagnosis section (residuals, thresholds, alarms)")
        require_causal(scenario.diagnoser, 0.0, file)
        self.scenario, self.variant = scenario, variant
        self.stepper = PeriodStepper(scenario, [variant])
        #: The variant's causal diagnoser, stepped in the loop (one row).
        self.diagnoser = self.stepper.diagnosers[0]
        self.n = scenario.n_joints
        self.dt = self.stepper.dt
        #: Whether a sample must hold the velocity (the scenario's readings include it).
        self.needs_velocity = self.stepper.measures_velocity
        self.grid = GridResampler(self.dt, ("position", "velocity", "torque"))

    @property
    def origin(self) -> float | None:
        """The first sample's time [s] (the grid's origin), None before it."""
        return self.grid.origin

    def push(self, t: float, q: np.ndarray, qd: np.ndarray | None, tau: np.ndarray) -> list[Period]:
        """Take the sample of time ``t`` [s] (any origin: the first sample's is the grid's zero): positions,
        velocities (None where not measured) and applied torques, ``(n,)`` each in the robot's joint order and
        SI units. Returns the periods it completes, oldest first (usually none or one).

        Raises:
            SampleError: a signal of the wrong length or not finite, a velocity missing where the scenario
                reads it, or a time that does not come after the previous sample's.
        """
        for name, values in (("position", q), ("velocity", qd), ("torque", tau)):
            if values is not None and np.shape(values) != (self.n,):
                raise SampleError(name, f"has {np.size(values)} values for {self.n} joints")
        if qd is None and self.needs_velocity:
            raise SampleError("velocity", "missing: the scenario's observers read the measured velocity")
        periods = []
        for k, (position, velocity, torque) in self.grid.push(float(t), q, qd if self.needs_velocity else None, tau):
            periods.append(self._step(k, position, velocity, torque))
        return periods

    def _step(self, k: int, position: np.ndarray, velocity: np.ndarray | None, torque: np.ndarray) -> Period:
        stepper, diagnoser = self.stepper, self.diagnoser
        sample = stepper.step(position, velocity, torque)
        estimate = stepper.luaf_torque(sample)
        if estimate is None:
            estimate = stepper.luaf_hat(sample)
        time = k * self.dt  # the replay's grid instant
        return Period(k, time, estimate[0].copy(), diagnoser.fault_estimate[0].copy(), diagnoser.residual[0].copy(),
                      diagnoser.threshold[0].copy(), diagnoser.alarm[0].copy(), diagnoser.isolated[0].copy(),
                      bool(diagnoser.armed))
