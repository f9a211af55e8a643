"""Time profiles of faults: which fraction of a fault is present at time t, per joint, in [0, 1].

Shapes, each from ``onset`` Tf (default 0) until an optional ``end`` (off from then on):

* ``abrupt``:        1
* ``incipient``:     1 - exp(-rate (t - Tf)), the dissertation's omega(t - Tf) of (5.1); ``rate`` per joint
* ``ramp``:          min(1, (t - Tf) / ramp_time)
* ``intermittent``:  1 during the first ``duty`` fraction of every ``period`` from Tf, else 0

A profile is evaluated on the whole time grid before a run (:meth:`Profile.evaluate`), so the loop only
reads a table; :meth:`Profile.weight` gives one instant, for plant terms and tests.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Literal

import numpy as np
from pydantic import Field

from ftc_mj.config.types import Interval, NonNegativeFloat, PositiveFloat, per_joint, tagged_union

_PHASE_TOLERANCE = 1e-9


class _ProfileSpec(Interval):
    #: Fault onset Tf [s]; the fault is gone from ``end`` on (never when absent).
    onset: NonNegativeFloat = 0.0


class AbruptSpec(_ProfileSpec):
    shape: Literal["abrupt"] = "abrupt"


class IncipientSpec(_ProfileSpec):
    shape: Literal["incipient"]
    #: Evolution rate of 1 - exp(-rate (t - onset)) [1/s], one number or one per joint.
    rate: PositiveFloat | list[PositiveFloat]


class RampSpec(_ProfileSpec):
    shape: Literal["ramp"]
    #: Time from 0 to the full fault [s].
    ramp_time: PositiveFloat


class IntermittentSpec(_ProfileSpec):
    shape: Literal["intermittent"]
    #: On/off cycle [s].
    period: PositiveFloat
    #: Fraction of each period the fault is on, from the start of the period.
    duty: Annotated[float, Field(gt=0, le=1, allow_inf_nan=False)]


SHAPES = {"abrupt": AbruptSpec, "incipient": IncipientSpec, "ramp": RampSpec, "intermittent": IntermittentSpec}
ProfileSpec = tagged_union("shape", SHAPES, default="abrupt")


@dataclass(frozen=True)
class Profile:
    """A compiled time profile (see the module docstring); ``rate`` is per joint."""

    shape: str
    onset: float = 0.0
    end: float | None = None
    rate: np.ndarray | None = None
    ramp_time: float | None = None
    period: float | None = None
    duty: float | None = None

    @classmethod
    def from_spec(cls, spec: AbruptSpec | IncipientSpec | RampSpec | IntermittentSpec, rate: np.ndarray | None = None) -> "Profile":
        """The profile of a validated spec; ``rate`` is the incipient rate already expanded per joint."""
        return cls(shape=spec.shape, onset=spec.onset, end=spec.end, rate=rate,
                   ramp_time=getattr(spec, "ramp_time", None), period=getattr(spec, "period", None),
                   duty=getattr(spec, "duty", None))

    def weight(self, t: float) -> float | np.ndarray | None:
        """The fraction present at ``t``: None while off, else a number or (incipient) one per joint."""
        if t < self.onset or (self.end is not None and t >= self.end):
            return None
        elapsed = t - self.onset
        if self.shape == "incipient":
            return 1.0 - np.exp(-self.rate * elapsed)
        if self.shape == "ramp":
            return min(1.0, elapsed / self.ramp_time)
        if self.shape == "intermittent" and not self._in_duty(np.float64(elapsed)):
            return None
        return 1.0

    def _in_duty(self, elapsed: np.ndarray) -> np.ndarray:
        """Within the on fraction of the period. Sample times k * dt carry rounding (0.6 - 0.5 is
        0.09999999999999998): within 1e-9 of a period, a boundary counts as reached."""
        cycles = elapsed / self.period
        phase = cycles - np.floor(cycles + _PHASE_TOLERANCE)
        return phase < self.duty - _PHASE_TOLERANCE

    def active(self, times: np.ndarray) -> np.ndarray:
        """Whether the fault is on at each time of a grid (an incipient fault is on from its onset, where its
        fraction is still 0), ``(len(times),)``."""
        times = np.asarray(times, dtype=float)
        on = times >= self.onset
        if self.end is not None:
            on &= times < self.end
        if self.shape == "intermittent":
            on &= self._in_duty(np.maximum(times - self.onset, 0.0))
        return on

    def evaluate(self, times: np.ndarray, n_joints: int) -> np.ndarray:
        """The fraction present on a time grid, ``(len(times), n_joints)``, 0 where off."""
        times = np.asarray(times, dtype=float)
        elapsed = np.maximum(times - self.onset, 0.0)[:, None]
        if self.shape == "incipient":
            value = 1.0 - np.exp(-self.rate * elapsed)
        elif self.shape == "ramp":
            value = np.minimum(1.0, elapsed / self.ramp_time)
        else:
            value = np.ones_like(elapsed)
        return np.broadcast_to(np.where(self.active(times)[:, None], value, 0.0), (len(times), n_joints)).copy()


def compile_profile(spec: ProfileSpec, file: str, field: str, n: int) -> Profile:
    """The profile of a validated ``profile:`` section, its rate expanded to the robot's ``n`` joints."""
    rate = getattr(spec, "rate", None)
    if rate is not None:
        rate = per_joint(rate, n, file, f"{field}.rate")
    return Profile.from_spec(spec, rate)
