"""Imperfect sensors: what the controller side reads instead of the true joint positions (and velocities).

A channel (``position``: the encoders, ``velocity``: the tachometers) turns the true reading x(t_k) of
sample k into the measurement, in this order:

1. delay: the true reading of ``delay_samples`` samples ago (before the first sample: the first reading);
2. plus ``bias`` + ``drift_rate`` t + Gaussian noise of standard deviation ``noise_std``;
3. quantised to the nearest multiple of the resolution (encoders: 2 pi / ``counts_per_rev``, the count
   origin at 0; or ``resolution`` in the reading's unit);
4. stuck: from ``stuck.onset`` until ``stuck.end`` the reading holds its last value before the onset.

Every number is per joint (one value for all joints or a list). Observers and controllers see the corrupted
measurement; ``qpos`` and the recorded truth stay true. Time-dependent parts (bias, drift, noise, the stuck
intervals) are tabulated before the loop, the noise drawn from the scenario's seed
(:mod:`ftc_mj.effects.randomness`); a step reads one row.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

import mujoco
import numpy as np
from pydantic import Field, StrictInt, model_validator

from ftc_mj import fast
from ftc_mj.fast import sensors as compiled
from ftc_mj.config.types import (
    FiniteFloat,
    Interval,
    JointSelection,
    NonNegativeFloat,
    PositiveFloat,
    Strict,
    joint_indices,
    joint_mask,
    per_joint,
)

PositiveInt = Annotated[StrictInt, Field(gt=0)]


class StuckSpec(Interval):
    """The reading freezes from ``onset`` until ``end`` (for good when absent) [s]."""

    #: Stuck joints, 1-based or by name; all when absent.
    joints: JointSelection = None


class ChannelSpec(Strict):
    """Effects on one kind of reading; each number is one for all joints or a list with one per joint."""

    #: Quantisation step in the reading's unit (rad or m, rad/s or m/s); none when absent.
    resolution: PositiveFloat | list[PositiveFloat] | None = None
    #: Standard deviation of additive white Gaussian noise.
    noise_std: NonNegativeFloat | list[NonNegativeFloat] = 0.0
    #: Constant offset.
    bias: FiniteFloat | list[FiniteFloat] = 0.0
    #: Offset growing linearly with time [unit/s].
    drift_rate: FiniteFloat | list[FiniteFloat] = 0.0
    #: From ``onset`` until ``end`` the listed joints hold their last reading.
    stuck: StuckSpec | None = None
    #: Transport delay in whole control periods.
    delay_samples: Annotated[StrictInt, Field(ge=0)] = 0


class EncoderSpec(ChannelSpec):
    #: Encoder counts per revolution of the joint: quantisation step 2 pi / counts_per_rev [rad].
    counts_per_rev: PositiveInt | list[PositiveInt] | None = None

    @model_validator(mode="after")
    def _one_resolution(self) -> "EncoderSpec":
        if self.counts_per_rev is not None and self.resolution is not None:
            raise ValueError("give counts_per_rev or resolution, not both")
        return self


class SensorsSpec(Strict):
    """The ``sensors`` section: effects on the encoders and (with ``robot.sensors: [position, velocity]``)
    on the tachometers."""

    #: Effects on the encoder readings.
    position: EncoderSpec | None = None
    #: Effects on the tachometer readings (needs ``robot.sensors: [position, velocity]``).
    velocity: ChannelSpec | None = None


@dataclass
class Channel:
    """A compiled sensor channel; arrays are per joint."""

    resolution: np.ndarray  # 0 = not quantised
    noise_std: np.ndarray
    bias: np.ndarray
    drift_rate: np.ndarray
    delay_samples: int = 0
    stuck_onset: float | None = None
    stuck_end: float | None = None
    stuck_joints: np.ndarray | None = None  # boolean mask

    def stuck(self, times: np.ndarray) -> np.ndarray:
        """Per sample and joint, whether the reading is stuck, ``(N, n)``."""
        if self.stuck_onset is None:
            return np.zeros((len(times), len(self.bias)), dtype=bool)
        on = times >= self.stuck_onset
        if self.stuck_end is not None:
            on &= times < self.stuck_end
        return on[:, None] & self.stuck_joints


#: Samples of noise drawn at a time, per member.
NOISE_CHUNK = 1000


class Measurement:
    """One channel over the rows of a batch: :meth:`read` turns the true readings of sample k into measurements.

    Rows are ``blocks`` variant blocks of the same members (variant-major). Each member draws its noise from its
    own generator, in chunks of :data:`NOISE_CHUNK` samples (the same numbers as one draw for the whole run, in
    memory that does not grow with the duration), and every variant's block reads the same noise: a paired
    comparison.
    """

    def __init__(self, channel: Channel, times: np.ndarray, generators: list[np.random.Generator], blocks: int = 1):
        n = len(channel.bias)
        members = len(generators)
        self.offset = channel.bias + channel.drift_rate * times[:, None]  # (N, n), shared by every member
        self._generators = generators
        self._noise_std = channel.noise_std
        self._noisy = bool(np.any(channel.noise_std > 0))
        self._offsets = np.zeros((min(NOISE_CHUNK, len(times)), members, n))  # this chunk's offsets per member
        self._offset = self._noisy or bool(np.any(self.offset))
        self.quantised = channel.resolution > 0
        self._quantise = bool(self.quantised.any())
        self.step = channel.resolution
        self.inverse_step = np.divide(1.0, channel.resolution, out=np.zeros(n), where=self.quantised)
        self.stuck = channel.stuck(times)
        self.stuck_at: list[bool] = self.stuck.any(axis=1).tolist()
        self.delay = channel.delay_samples
        rows = blocks * members
        self._history = np.zeros((self.delay + 1, rows, n))
        self._last = np.zeros((rows, n))
        self._no_offsets = np.zeros((1, n))
        self._never_stuck = np.zeros(n, dtype=bool)
        #: :func:`measure`, or its accelerator with the fast paths on (checked by Numba's dispatcher per call: the
        #: source and the output are the caller's, of any layout).
        self._measure = compiled.measure if fast.enabled() else measure

    def _draw(self, k: int) -> None:
        """The offsets of samples k .. k + NOISE_CHUNK: bias, drift and each member's noise."""
        chunk = self.offset[k:k + len(self._offsets)]
        self._offsets[:len(chunk)] = chunk[:, None, :]
        if self._noisy:
            for member, generator in enumerate(self._generators):
                self._offsets[:len(chunk), member] += generator.standard_normal(chunk.shape) * self._noise_std

    def read(self, k: int, true: np.ndarray, out: np.ndarray) -> None:
        """Write the measurements of sample ``k`` (true readings ``true``, ``(rows, n)``) into ``out``."""
        source = true
        if self.delay:
            if k == 0:
                self._history[:] = true
            self._history[k % (self.delay + 1)] = true
            source = self._history[(k + 1) % (self.delay + 1)]  # written delay samples ago
        offsets = self._no_offsets
        if self._offset:
            index = k % len(self._offsets)
            if index == 0:
                self._draw(k)
            offsets = self._offsets[index]
        stuck = self.stuck[k] if self.stuck_at[k] and k else self._never_stuck  # from the first sample: held
        if out.ndim == 1:  # one row, as (n,): views with the rows' axis
            out = out[None]
        if source.ndim == 1:
            source = source[None]
        self._measure(source, offsets, self._offset, self._quantise, self.inverse_step, self.step, self.quantised,
                      stuck, self._last, out)


def measure(source: np.ndarray, offsets: np.ndarray, offset: bool, quantise: bool, inverse_step: np.ndarray,
            step: np.ndarray, quantised: np.ndarray, stuck: np.ndarray, last: np.ndarray, out: np.ndarray) -> None:
    """Steps 2-4 of the module docstring for every row (blocks of the same members, variant-major: row r is
    member r % members): the offset added, then ``rint(x * (1 / resolution)) * resolution`` where quantised,
    the last reading where stuck; ``last`` keeps the measurement. (Accelerated by
    :func:`ftc_mj.fast.sensors.measure`.)"""
    rows, n = out.shape
    members = offsets.shape[0]
    value = source + offsets[np.arange(rows) % members] if offset else source.copy()
    if quantise:
        value = np.where(quantised, np.rint(value * inverse_step) * step, value)
    value = np.where(stuck, last, value)
    out[...] = value
    last[...] = value


def compile_channel(spec: ChannelSpec | None, file: str, field: str, model: mujoco.MjModel) -> Channel | None:
    """The effects of a validated ``sensors.position`` or ``sensors.velocity`` section; None: perfect."""
    if spec is None:
        return None
    n = model.nv
    resolution = np.zeros(n)
    if spec.resolution is not None:
        resolution = per_joint(spec.resolution, n, file, f"{field}.resolution")
    if isinstance(spec, EncoderSpec) and spec.counts_per_rev is not None:
        resolution = 2.0 * np.pi / per_joint(spec.counts_per_rev, n, file, f"{field}.counts_per_rev")
    stuck = spec.stuck
    return Channel(
        resolution=resolution,
        noise_std=per_joint(spec.noise_std, n, file, f"{field}.noise_std"),
        bias=per_joint(spec.bias, n, file, f"{field}.bias"),
        drift_rate=per_joint(spec.drift_rate, n, file, f"{field}.drift_rate"),
        delay_samples=spec.delay_samples,
        stuck_onset=None if stuck is None else stuck.onset,
        stuck_end=None if stuck is None else stuck.end,
        stuck_joints=None if stuck is None else joint_mask(
            joint_indices(stuck.joints, model, file, f"{field}.stuck.joints"), n),
    )
