"""Where each row of a batch run and each of its nominal evaluation points lives.

Rows: the plant has a row per (variant, member), variant-major, so that the members of one variant are a
contiguous block and each variant's observer, controller and monitors work on views of that block with
state shaped ``(members, joints)``. A single run is one member.

Points: the nominal batch that gives Psi holds, per variant in order, a block of ``members`` points at the
observer's estimate, one at each monitor's estimate and, for a controller on measured velocity
(``controller_velocity``), one at the readings. M at the measured positions, where the nominal model
evaluates it (:mod:`ftc_mj.engine.mass`), has one point per row.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np


@dataclass(frozen=True)
class BlockLayout:
    """One variant's rows of the plant and its points of the Psi batch."""

    rows: slice
    #: Psi at the observer's estimate, Psi(x1_hat, x2_hat).
    observer: slice
    #: Psi at each monitor's estimate, in the variant's order of monitors.
    monitors: tuple[slice, ...]
    #: Psi at the readings, Psi(x1, x2), for a controller on measured velocity; else None.
    readings: slice | None

    @property
    def estimators(self) -> tuple[slice, ...]:
        """The points of the observer and of each monitor, in that order."""
        return (self.observer, *self.monitors)


@dataclass(frozen=True)
class RowLayout:
    """The rows and points of a batch run: ``members`` per variant, one :class:`BlockLayout` per variant."""

    members: int
    blocks: tuple[BlockLayout, ...]
    #: How many points the Psi batch has.
    points: int
    #: ``(points,)``: the plant row each point belongs to (its variant's block, its member).
    point_rows: np.ndarray

    @classmethod
    def of(cls, members: int, monitors: Sequence[int], on_readings: Sequence[bool]) -> RowLayout:
        """The layout of variants with ``monitors[v]`` monitors each, whose controller uses the readings'
        velocity where ``on_readings[v]``."""
        blocks, point_rows, point = [], [], 0

        def take(rows: slice) -> slice:
            nonlocal point
            point_rows.append(np.arange(rows.start, rows.stop))
            point += members
            return slice(point - members, point)

        for v, (count, readings) in enumerate(zip(monitors, on_readings, strict=True)):
            rows = slice(v * members, (v + 1) * members)
            observer = take(rows)
            watching = tuple(take(rows) for _ in range(count))
            blocks.append(BlockLayout(rows, observer, watching, take(rows) if readings else None))
        return cls(members, tuple(blocks), point, np.concatenate(point_rows) if point_rows else np.zeros(0, int))

    @cached_property
    def rows(self) -> int:
        """How many rows the plant has."""
        return self.members * len(self.blocks)

    def per_row(self, values: np.ndarray) -> np.ndarray:
        """Member values ``(members, ...)`` repeated for every variant's block: ``(rows, ...)``."""
        return np.concatenate([values] * len(self.blocks))

    def estimator_points(self, wanted: Sequence[Sequence[bool]]) -> np.ndarray | None:
        """The mask ``(points,)`` of the points of the estimators ``wanted[v][e]`` (variant v's observer, e = 0,
        then its monitors in order), or None where none is wanted."""
        if not any(any(flags) for flags in wanted):
            return None
        mask = np.zeros(self.points, dtype=bool)
        for block, flags in zip(self.blocks, wanted, strict=True):
            for points, flag in zip(block.estimators, flags, strict=True):
                mask[points] = flag
        return mask

    def per_point(self, values: np.ndarray) -> np.ndarray:
        """Member values ``(members, ...)`` for every point of the Psi batch: ``(points, ...)``."""
        return np.concatenate([values] * (self.points // self.members))
