"""The nominal model of a kinematic tree of hinge and slide joints (every shipped robot's) by the rigid-body
algorithms: compiled (:mod:`ftc_mj.fast.rigid`) with the fast paths on, their NumPy definition
(:mod:`ftc_mj.robot.nominal.algorithms`) with them off, the same bits either way."""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache, partial

import mujoco
import numpy as np

from ftc_mj import fast
from ftc_mj.fast.crossovers import POINTS_PER_THREAD
from ftc_mj.fast.rigid import RigidTree, evaluation
from ftc_mj.robot.nominal.algorithms import evaluate_tree
from ftc_mj.robot.nominal.batch import MassAtReadings, NominalBatch, PlantMassSource, checked_momentum_points
from ftc_mj.robot.nominal.matrices import DenseMass
from ftc_mj.robot.nominal.readings import MassPoints


@lru_cache(maxsize=None)
def _threads(count: int) -> ThreadPoolExecutor:
    """A pool of ``count`` threads, made once per process and shared by every batch."""
    return ThreadPoolExecutor(max_workers=count, thread_name_prefix="ftc_mj-nominal")


class TreeNominal(NominalBatch):
    """:class:`NominalBatch` by the rigid-body algorithms: the compiled kernel of :mod:`ftc_mj.fast.rigid` (about
    a quarter of MuJoCo's forward pass per point) with the fast paths on, its NumPy definition
    (:func:`~ftc_mj.robot.nominal.algorithms.evaluate_tree`) with them off, chosen when the batch is made;
    both give the same bits, equal to MuJoCo's forward pass to rounding (1e-15), not bit for bit."""

    def __init__(self, tree: RigidTree, model: mujoco.MjModel, mass_scale: np.ndarray, mass_only: bool = False,
                 momentum_points: np.ndarray | None = None, nthread: int = 1, mass_points: np.ndarray | None = None):
        """``model``: the rigid-body model whose tree ``tree`` is (for M's sparse layout). ``nthread`` > 1: the
        points are cut into as many slices (at least :data:`POINTS_PER_THREAD` each), evaluated at once on
        threads (the kernel releases the GIL; with the fast paths off, one: NumPy's
        calls on a few points hold it); a point's numbers come from its inputs alone, so its bits are
        the same however the points are cut. ``mass_points``: the mass scales of more points, after these,
        where only M is wanted (M at the readings, evaluated in the same call: :meth:`mass_at_readings`)."""
        velocity_points, n = 0 if mass_only else len(mass_scale), model.nv
        extra = np.zeros(0) if mass_points is None else np.asarray(mass_points, dtype=float)
        points = len(mass_scale) + len(extra)
        self._tree, self._inertias = tree, tree.scaled(np.concatenate([np.asarray(mass_scale, dtype=float), extra]))
        self.qpos, self.qvel, self.applied = np.zeros((points, n)), np.zeros((points, n)), np.zeros((points, n))
        self.qacc, self._bias = np.zeros((points, n)), np.zeros((points, n))
        self._sparse_M = np.zeros((points, model.nM))
        self.factor, self.diagonal_inverse = np.zeros((points, model.nM)), np.ones((points, n))
        self._dense = DenseMass(model, points)
        self._momentum_points = checked_momentum_points(momentum_points, len(mass_scale), mass_only)
        self.coriolis_transpose = self.gravity = None
        if self._momentum_points is not None:
            self._momentum_points = np.concatenate([self._momentum_points, np.zeros(len(extra), dtype=np.bool_)])
            self.coriolis_transpose, self.gravity = np.zeros((points, n)), np.zeros((points, n))
        #: The M-only points (views), or None.
        readings = slice(len(mass_scale), points)
        self._at_readings = None if mass_points is None else MassPoints(
            self.qpos[readings], self.qvel[readings], self.applied[readings], self._sparse_M[readings],
            self.factor[readings], self.diagonal_inverse[readings], model)
        self._compiled = fast.enabled()
        threads = max(1, min(nthread if self._compiled else 1, len(mass_scale) // POINTS_PER_THREAD))
        # Each thread's kernel calls, their arguments (views) made once. One thread: one call over every point.
        # More: each an equal share of the points with velocity terms and one of the M-only points (cheaper
        # per point), so that no thread waits for another.
        if threads == 1:
            self._tasks = [[self._call(self._arguments(slice(0, points), velocity_points))]]
        else:
            self._tasks = [[self._call(self._arguments(part, velocity_points))
                            for part in (_share(0, len(mass_scale), t, threads), _share(len(mass_scale), points, t,
                                                                                        threads))
                            if part.stop > part.start]
                           for t in range(threads)]
        # Threads from the second call on: the first may compile the kernel (and say so), once.
        self._pool: ThreadPoolExecutor | None = None
        self._threads = threads - 1

    def _call(self, arguments: tuple) -> Callable[[], None]:
        """The algorithms on ``arguments`` as a call without arguments: the compiled kernel's or the NumPy one's."""
        return evaluation(arguments) if self._compiled else partial(evaluate_tree, *arguments)

    def _arguments(self, points: slice, velocity_points: int) -> tuple:
        """The kernel's arguments for the points ``points`` (of which those before ``velocity_points`` have the
        velocity terms)."""
        cut = lambda array: None if array is None else array[points]  # noqa: E731
        return self._tree.arguments(
            *(array[points] for array in self._inertias), self.qpos[points], self.qvel[points],
            self.applied[points], self._sparse_M[points], self.factor[points], self.diagonal_inverse[points],
            self.qacc[points], self._bias[points], True, cut(self._momentum_points),
            cut(self.coriolis_transpose), cut(self.gravity),
            velocity_points=min(max(velocity_points - points.start, 0), points.stop - points.start))

    def evaluate(self) -> None:
        pool = self._pool
        if pool is None:  # one thread, or the first call
            for task in self._tasks:
                _run(task)
            if self._threads:
                self._pool = _threads(self._threads)
            return
        first, *others = self._tasks
        pending = [pool.submit(_run, task) for task in others]
        _run(first)  # the first thread's share on the calling thread, meanwhile
        for future in pending:
            future.result()

    def mass_matrices(self) -> np.ndarray:
        return self._dense.update(self._sparse_M)

    def mass_at_readings(self, plant: PlantMassSource | None) -> MassAtReadings:
        """The batch's own M-only points: its M rounds otherwise than a MuJoCo plant's, so never the plant's."""
        if self._at_readings is None:
            raise ValueError("M at the readings: the nominal batch was made without mass_points")
        return self._at_readings


def _share(start: int, stop: int, part: int, parts: int) -> slice:
    """Part ``part`` of ``parts`` near-equal consecutive parts of ``start:stop``."""
    bounds = np.linspace(start, stop, parts + 1).astype(int)
    return slice(int(bounds[part]), int(bounds[part + 1]))


def _run(task: list[Callable[[], None]]) -> None:
    """One thread's kernel calls."""
    for call in task:
        call()

