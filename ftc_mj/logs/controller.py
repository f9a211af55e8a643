"""The controller of a replayed log: the logged torque, which is what the observers are told was applied.

A log holds no controller to run: every variant of a scenario with a ``log`` section is driven by
:class:`LogController`, which returns the plant's logged torque of the period
(:class:`~ftc_mj.engine.plant.LogPlant`). It has no sliding variable (NaN in the recording)."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ftc_mj.methods.controllers.base import Controller
from ftc_mj.methods.gains import GainConfig
from ftc_mj.methods.observers.base import Observer
from ftc_mj.robot.nominal import StepModel


class NoGains(GainConfig):
    """A log's controller has no gains."""


class LogController(Controller):
    """Returns the logged torque of the period: a live ``(members, n)`` view of the plant's, given by
    :meth:`follow` before the run."""

    name: ClassVar[str] = "log"
    Config: ClassVar[type[GainConfig]] = NoGains

    def follow(self, torque: np.ndarray) -> None:
        """``torque``: the plant's logged torque of this controller's rows, current at each period."""
        self.tau = torque

    def reset(self) -> None:
        self.sliding[:] = np.nan

    def compute(self, t: float, q_ref: np.ndarray, qd_ref: np.ndarray, qdd_ref: np.ndarray, q_meas: np.ndarray,
                observer: Observer, model: StepModel) -> np.ndarray:
        return self.tau
