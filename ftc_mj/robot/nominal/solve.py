"""M(q)^-1 v for many rows at once from MuJoCo's factorisation of each row's M, as ``mj_solveM`` computes it."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

import mujoco
import numpy as np

from ftc_mj import fast
from ftc_mj.fast.kernels import bound
from ftc_mj.fast.rigid import solve_factored


class SparseSolver:
    """M(q)^-1 v for many rows at once with MuJoCo's own factorisation ``qLD``, ``qLDiagInv`` of each row: the
    operations of ``mj_solveM`` in its order (:func:`solve_sparse`; with the fast paths on, its accelerator
    :func:`~ftc_mj.fast.rigid.solve_factored`), so each row's answer is bit for bit what ``mj_solveM`` gives on
    one MjData (tested), in one call whatever the batch size. The model is the one whose sparsity the factors
    have (any mass scale: only the structure is used)."""

    def __init__(self, model: mujoco.MjModel):
        # The rows with entries left of the diagonal, in order, and those entries (address in qLD, column),
        # row after row: mj_solveM's loops over the sparse structure, flattened.
        rows, starts, addresses, columns = [], [0], [], []
        for i in range(model.nv):
            first = model.M_rowadr[i]
            entries = [(int(first + j), int(model.M_colind[first + j])) for j in range(model.M_rownnz[i] - 1)]
            if entries:
                rows.append(i)
                addresses += [address for address, _ in entries]
                columns += [column for _, column in entries]
                starts.append(len(addresses))
        self._structure = tuple(np.asarray(values, dtype=np.int64) for values in (rows, starts, addresses, columns))
        self._n = model.nv

    @property
    def structure(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The flattened sparse structure :func:`solve_sparse` takes after ``out``: the rows
        with entries left of the diagonal, their entries' starts, addresses in qLD and columns."""
        return self._structure

    def solve(self, factor: np.ndarray, diagonal_inverse: np.ndarray, vector: np.ndarray, out: np.ndarray) -> np.ndarray:
        """``out = M^-1 vector`` per row, from the rows' ``qLD`` ``(rows, nM)`` and ``qLDiagInv`` ``(rows, n)``;
        ``vector`` is ``(rows, n)`` or one ``(n,)`` for every row."""
        if vector.ndim == 1:
            vector = np.broadcast_to(vector, (len(out), self._n))
        (solve_factored if fast.enabled() else solve_sparse)(factor, diagonal_inverse, vector, out,
                                                              *self._structure)
        return out

    def bound(self, factor: np.ndarray, diagonal_inverse: np.ndarray, vector: np.ndarray,
              out: np.ndarray) -> Callable[[], None]:
        """:meth:`solve` of these buffers (``vector`` ``(rows, n)``), as a call without arguments (with the fast
        paths on, past Numba's dispatcher: :func:`~ftc_mj.fast.kernels.bound`): for a loop that solves the same
        buffers every period."""
        if fast.enabled():
            return bound(solve_factored, factor, diagonal_inverse, vector, out, *self._structure)
        return partial(solve_sparse, factor, diagonal_inverse, vector, out, *self._structure)


def solve_sparse(factor: np.ndarray, diagonal_inverse: np.ndarray, vector: np.ndarray, out: np.ndarray,
                 rows: np.ndarray, starts: np.ndarray, addresses: np.ndarray, columns: np.ndarray) -> None:
    """The definition of :class:`SparseSolver`'s solve: ``out[r] = M_r^-1 vector[r]`` from MuJoCo's
    factorisation M = L' D L of each row r (``qLD`` ``(rows, nM)``, ``qLDiagInv``), with ``mj_solveM``'s
    operations in its order, on every row at once: x <- L'^-1 x from the last row up, x <- D^-1 x, x <- L^-1 x
    from the first row down, each sparse dot product summed as ``mju_dotSparse`` sums it (four lanes over whole
    groups of four, added as (0 + 2) + (1 + 3), then the rest; fewer than four from the left). The structure
    is :attr:`SparseSolver.structure`."""
    out[...] = vector
    for k in range(len(rows) - 1, -1, -1):  # x <- L'^-1 x
        x_i = out[:, rows[k]].copy()
        for e in range(starts[k], starts[k + 1]):
            out[:, columns[e]] -= factor[:, addresses[e]] * x_i
    out *= diagonal_inverse  # x <- D^-1 x
    for k in range(len(rows)):  # x <- L^-1 x
        first, count = int(starts[k]), int(starts[k + 1] - starts[k])
        term = lambda e: factor[:, addresses[e]] * out[:, columns[e]]  # noqa: E731
        whole = count - count % 4
        if whole:
            lanes = [term(first + lane) for lane in range(4)]
            for j in range(4, whole, 4):
                for lane in range(4):
                    lanes[lane] += term(first + j + lane)
            dot = lanes[0] + lanes[2]
            dot += lanes[1] + lanes[3]
        else:
            dot, whole = term(first), 1
        for j in range(whole, count):
            dot += term(first + j)
        out[:, rows[k]] -= dot

