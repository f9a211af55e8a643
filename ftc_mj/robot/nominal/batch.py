"""What every implementation of the nominal model offers (:class:`NominalBatch`): the model at many evaluation
points at once, and M at the readings (:class:`MassAtReadings`)."""

from __future__ import annotations

from typing import Protocol

import numpy as np


class MassAtReadings(Protocol):
    """M(x1) at every row's measured position, ``(rows, n, n)``, and its factorisation in MuJoCo's sparse layout
    (``factor``, ``diagonal_inverse``): the M of the period's :class:`~ftc_mj.robot.nominal.step.StepModel`,
    buffers that :meth:`evaluate` refreshes once per period. Given by :meth:`NominalBatch.mass_at_readings`."""

    M: np.ndarray
    factor: np.ndarray
    diagonal_inverse: np.ndarray
    #: Whether ``M`` is the plant's own M(q) at the true positions (:class:`~ftc_mj.robot.nominal.readings.PlantMass`).
    from_plant: bool

    def prepare(self, q_meas: np.ndarray, stopped: np.ndarray | None) -> None:
        """Take the readings ``q_meas`` ``(rows, n)``; the ``stopped`` rows (indices or a mask, or None) at rest
        instead. Before the nominal model is evaluated."""

    def evaluate(self) -> None:
        """M at the readings taken: after the nominal model is evaluated."""


class PlantMassSource(Protocol):
    """What M at the readings takes from a plant whose M(q) it is: the plant's dense M and factorisation."""

    factor: np.ndarray
    diagonal_inverse: np.ndarray

    def mass_matrices(self) -> np.ndarray:
        """``(rows, n, n)``: the plant's M(q) at its current state."""


class NominalBatch(Protocol):
    """The controller side's model of many evaluation points at once (eq. (5.2)).

    Each point is an evaluation point: set its ``qpos``, ``qvel`` and ``applied`` (``(points, n)``), call
    :meth:`evaluate`, and its ``qacc`` is M(q)^-1 (applied - C(q, qd) qd - G(q)) and :meth:`mass_matrices` is
    M(q), with M's factorisation in MuJoCo's sparse layout (``factor``, ``diagonal_inverse``; solved by
    :class:`~ftc_mj.robot.nominal.solve.SparseSolver`). With ``applied`` = 0 the acceleration is Psi(q, qd) of
    eq. (5.2). A point's mass scale is its own. A ``mass_only`` batch holds points where only M(q) is wanted:
    no velocity terms, no ``qacc``. A point's numbers do not depend on the number of points, so a batch member
    gets its single run's bits. Made by :func:`~ftc_mj.robot.nominal.nominal_batch`.

    Where the batch was made with ``momentum_points``, :meth:`evaluate` also gives C(q, qd)^T qd and G(q)
    (:data:`~ftc_mj.robot.nominal.step.NEEDS`) at least at those points, in ``coriolis_transpose`` and
    ``gravity``; else these are None. Where it was made with ``mass_points`` (the mass scales of the rows),
    :meth:`mass_at_readings` gives M at every row's readings.
    """

    qpos: np.ndarray
    qvel: np.ndarray
    applied: np.ndarray
    #: MuJoCo's factorisation of M at each point (``qLD``, ``qLDiagInv``), from the last :meth:`evaluate`.
    factor: np.ndarray
    diagonal_inverse: np.ndarray
    #: ``(points, n)`` C(q, qd)^T qd and G(q) from the last :meth:`evaluate`, or None (no ``momentum_points``).
    coriolis_transpose: np.ndarray | None
    gravity: np.ndarray | None

    #: ``(points, n)``: M^-1 (applied - C qd - G) at each point, from the last :meth:`evaluate` (not in a
    #: ``mass_only`` batch).
    qacc: np.ndarray

    def evaluate(self) -> None:
        """Forward dynamics at every point (positions, velocities and applied forces as set), or M alone in a
        ``mass_only`` batch."""

    def mass_matrices(self) -> np.ndarray:
        """``(points, n, n)``: M(q) at each point, from the last :meth:`evaluate` (an internal buffer)."""

    def mass_at_readings(self, plant: PlantMassSource | None) -> MassAtReadings:
        """M(x1) at every row's readings (one row per mass scale of ``mass_points``), as this implementation
        gives it best. ``plant``: the plant where its M(q) is M at the readings (the same model, no mass scale
        on either, readings that are the true positions), else None; an implementation whose M is MuJoCo's,
        bit for bit, then takes the plant's at no extra evaluation."""


def checked_momentum_points(momentum_points: np.ndarray | None, points: int, mass_only: bool) -> np.ndarray | None:
    """The mask of the points that want C^T qd and G, checked; None where none does."""
    if momentum_points is None:
        return None
    mask = np.asarray(momentum_points, dtype=np.bool_)
    if mask.shape != (points,):
        raise ValueError(f"momentum_points: a mask of the {points} points, not of shape {mask.shape}")
    if mass_only and mask.any():
        raise ValueError("momentum_points: a mass-only batch has no velocity terms")
    return np.ascontiguousarray(mask) if mask.any() else None


def at_rest(batch: NominalBatch | MassAtReadings, points: np.ndarray) -> None:
    """Put ``points`` (a mask or indices) of ``batch`` at rest, q = qd = 0 with no applied force: where a
    stopped row's estimate may hold NaN or inf."""
    batch.qpos[points] = 0.0
    batch.qvel[points] = 0.0
    batch.applied[points] = 0.0
