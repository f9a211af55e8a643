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

import math

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
        # The last sample's signals stacked, ``(signals present, n)``: each grid instant is a few operations on
        # the stack, not on every signal apart (the same bits: every operation is element by element).
        self._values: np.ndarray | None = None
        self._present: tuple[bool, ...] = ()

    def push(self, t: float, *values: np.ndarray | None) -> list[tuple[int, list[np.ndarray | None]]]:
        """The grid instants this sample completes, in order: ``(k, signals at k DT)``, the signals new arrays
        (or None where absent); every signal of a sample has the same length.

        Raises:
            SampleError: ``t`` is not finite or not after the previous sample's time, a value not finite, or a
                signal present in one sample and absent in the next.
        """
        if not math.isfinite(t):
            raise SampleError("time", f"{t} is not a finite number")
        present = tuple(value is not None for value in values)
        stacked = np.array([value for value in values if value is not None], dtype=float)
        if not np.isfinite(stacked).all():
            name, value = next((name, value) for name, value in zip(self.names, values)
                               if value is not None and not np.isfinite(value).all())
            raise SampleError(name, f"{np.asarray(value).tolist()} is not all finite numbers")
        instants = []
        if self.origin is None:
            self.origin, self._time = t, 0.0
        else:
            if present != self._present:
                name = self.names[next(i for i, (a, b) in enumerate(zip(present, self._present)) if a != b)]
                raise SampleError(name, "given in one sample and not in the one before")
            relative = t - self.origin  # as the replay: the log's times minus its first
            if not relative > self._time:
                raise SampleError("time", f"{t:.9g} s does not come after the previous sample "
                                  f"({self._time + self.origin:.9g} s)")
            instants = self._between(relative, stacked)
            self._time = relative
        first = self.next == 0
        self._values, self._present = stacked, present
        if first:  # the grid's first instant is the first sample's time
            self.next = 1
            instants.append((0, self._signals(stacked)))
        return instants

    def _signals(self, stacked: np.ndarray) -> list[np.ndarray | None]:
        """The stack's rows as the signals, None where absent."""
        rows = iter(stacked)
        return [next(rows) if present else None for present in self._present]

    def _between(self, relative: float, new: np.ndarray) -> list[tuple[int, list[np.ndarray | None]]]:
        """The instants in (previous sample, this one], interpolated as :func:`numpy.interp` does:
        slope (x - x_j) + f_j, slope = (f_(j+1) - f_j) / (x_(j+1) - x_j); an instant on a sample takes it."""
        old, start = self._values, self._time
        slope = None
        instants = []
        while self.next * self.dt <= relative:
            instant = self.next * self.dt
            if instant == relative:
                value = new
            else:
                if slope is None:
                    slope = (new - old) / (relative - start)
                value = slope * (instant - start) + old
            instants.append((self.next, self._signals(value)))
            self.next += 1
        return instants
