"""The rule for sample times: a stream is stepped on the scenario's uniform grid, causally resampled.

The observers fold their period into constants when they are made (:mod:`ftc_mj.logs.schema`), so a monitor,
like a log's replay, steps on a uniform grid of period DT (``log.steps.resample``, else ``control_dt``) from
the first sample's time: grid instant k is at k DT. A sample at time t steps every grid instant not yet
stepped with k DT <= t, each signal linearly interpolated between the sample before and this one (an instant
equal to a sample's time takes that sample as it is): the values :func:`numpy.interp` gives the replay of a
whole log (:func:`ftc_mj.logs.trajectory.resample`), bit for bit, one sample later at most. So irregular
sample times are handled, a gap included (interpolated across, as the replay does); time that does not
increase is refused (:class:`SampleError`), as is a value that is not a finite number.
"""

from __future__ import annotations

import numpy as np


class SampleError(ValueError):
    """A sample a monitor cannot take: its ``field`` (``time``, ``position``, ``velocity``, ``torque``) and
    what is wrong with it."""

    def __init__(self, field: str, problem: str):
        self.field, self.problem = field, problem
        super().__init__(f"{field}: {problem}")


class GridResampler:
    """Samples ``(t, *signals)`` in, grid instants ``(k, signals at k DT)`` out (the module docstring).
    ``names``: the signals each sample carries, in order (a signal may be ``None``: absent)."""

    def __init__(self, dt: float, names: tuple[str, ...]):
        self.dt = dt
        self.names = names
        #: The first sample's time (the grid's origin) [s], None before it.
        self.origin: float | None = None
        #: The next grid instant's index.
        self.next = 0
        self._time = 0.0  # the last sample's time relative to the origin
        self._values: list[np.ndarray | None] = [None] * len(names)

    def push(self, t: float, *values: np.ndarray | None) -> list[tuple[int, list[np.ndarray | None]]]:
        """The grid instants this sample completes, in order: ``(k, signals at k DT)``, the signals new arrays
        (or None).

        Raises:
            SampleError: ``t`` is not finite or not after the previous sample's time, or a value not finite.
        """
        if not np.isfinite(t):
            raise SampleError("time", f"{t} is not a finite number")
        for name, value in zip(self.names, values):
            if value is not None and not np.all(np.isfinite(value)):
                raise SampleError(name, f"{np.asarray(value).tolist()} is not all finite numbers")
        instants = []
        if self.origin is None:
            self.origin, self._time = t, 0.0
        else:
            relative = t - self.origin  # as the replay: the log's times minus its first
            if not relative > self._time:
                raise SampleError("time", f"{t:.9g} s does not come after the previous sample "
                                  f"({self._time + self.origin:.9g} s)")
            instants = self._between(relative, values)
            self._time = relative
        first = self.next == 0
        self._values = [None if v is None else np.array(v, dtype=float) for v in values]
        if first:  # the grid's first instant is the first sample's time
            self.next = 1
            instants.append((0, [None if v is None else v.copy() for v in self._values]))
        return instants

    def _between(self, relative: float, values: tuple) -> list[tuple[int, list[np.ndarray | None]]]:
        """The instants in (previous sample, this one], interpolated as :func:`numpy.interp` does."""
        before, start = self._values, self._time
        span = relative - start
        instants = []
        while self.next * self.dt <= relative:
            instant = self.next * self.dt
            out: list[np.ndarray | None] = []
            for old, new in zip(before, values):
                if new is None or old is None:
                    out.append(None)
                elif instant == relative:
                    out.append(np.array(new, dtype=float))
                else:
                    slope = (np.asarray(new, dtype=float) - old) / span
                    out.append(slope * (instant - start) + old)
            instants.append((self.next, out))
            self.next += 1
        return instants
