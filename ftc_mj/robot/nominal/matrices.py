"""Products and copies of the nominal model's mass matrices for many rows at once: M v (:func:`matvec`, and
:class:`MatvecSite` for a call site that maps the same buffers every period) and dense copies of MuJoCo's
sparse M (:class:`DenseMass`)."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

import mujoco
import numpy as np

from ftc_mj import fast
from ftc_mj.fast.crossovers import PAIRED_COLUMNS
from ftc_mj.fast.kernels import bound
from ftc_mj.fast.matrices import gather, matvec_in_pairs


def matvec(matrices: np.ndarray, vectors: np.ndarray, out: np.ndarray) -> np.ndarray:
    """Row by row, ``out[r] = matrices[r] @ vectors[r]`` (``(rows, n, n)`` by ``(rows, n)``): the definition is
    ``np.einsum("rij,rj->ri")``, each row summed alone (the same bits whatever the number of rows); with the
    fast paths on and at most :data:`~ftc_mj.fast.crossovers.PAIRED_COLUMNS` joints, its accelerator
    :func:`~ftc_mj.fast.matrices.matvec_in_pairs`."""
    if matrices.shape[-1] <= PAIRED_COLUMNS and fast.enabled():
        matvec_in_pairs(matrices, vectors, out)
        return out
    return np.einsum("rij,rj->ri", matrices, vectors, out=out)


class MatvecSite:
    """:func:`matvec` at one call site, past Numba's dispatcher once its matrices, vectors and output are the
    arrays of the call before (the same objects): a loop that maps the same buffers every period then pays the
    compiled function's call alone (:func:`~ftc_mj.fast.kernels.bound`). The caller compares the arrays
    with :attr:`matrices`, :attr:`vectors`, :attr:`out` inline (a method call would cost what it saves) and
    calls :attr:`call` (no arguments: it is bound to those arrays) where they are the same, :meth:`new` where
    not; a caller whose own buffers never change need compare only the others. The same bits either way."""

    __slots__ = ("matrices", "vectors", "out", "call", "_seen")

    def __init__(self) -> None:
        #: The arrays :attr:`call` is bound to (None: none yet), and the bound call.
        self.matrices: np.ndarray | None = None
        self.vectors: np.ndarray | None = None
        self.out: np.ndarray | None = None
        self.call: Callable[[], None] = _unbound
        self._seen: tuple[np.ndarray, np.ndarray] | None = None

    def new(self, matrices: np.ndarray, vectors: np.ndarray, out: np.ndarray) -> np.ndarray:
        """:func:`matvec` of arrays other than the bound call's; where the vectors and output are those of the
        last call too, the compiled product is bound to these arrays for the next calls (fast paths on)."""
        seen, self._seen = self._seen, (vectors, out)
        if (seen is not None and seen[0] is vectors and seen[1] is out and matrices.shape[-1] <= PAIRED_COLUMNS
                and fast.enabled() and all(type(a) is np.ndarray for a in (matrices, vectors, out))):
            self.matrices, self.vectors, self.out = matrices, vectors, out
            self.call = bound(matvec_in_pairs, matrices, vectors, out)
        return matvec(matrices, vectors, out)


def _unbound() -> None:
    raise RuntimeError("MatvecSite.call before MatvecSite.new bound it")


class DenseMass:
    """Dense ``(rows, n, n)`` copies of MuJoCo's sparse joint-space inertia ``M`` (lower triangle, CSR)."""

    def __init__(self, model: mujoco.MjModel, rows: int):
        n = model.nv
        # For every dense entry, the sparse entry that holds it (or a zero appended after the last one).
        index = np.full((n, n), model.nM)
        for i in range(n):
            start = model.M_rowadr[i]
            for j in range(model.M_rownnz[i]):
                column = model.M_colind[start + j]
                index[i, column] = index[column, i] = start + j
        self._index = index.reshape(-1)
        # A chain's M has no structural zero: every dense entry is taken straight from the sparse values.
        self._padded = np.zeros((rows, model.nM + 1)) if np.any(self._index == model.nM) else None
        self.out = np.zeros((rows, n, n))
        self._flat = self.out.reshape(rows, n * n)
        #: The sparse values last filled from, and the gather bound to them (the definition ``numpy.take``; with the
        #: fast paths on, its accelerator :func:`~ftc_mj.fast.matrices.gather`).
        self._source: np.ndarray | None = None
        self._gather: Callable[[], None] = lambda: None

    def update(self, sparse: np.ndarray) -> np.ndarray:
        """Fill from the sparse values ``(rows, nM)`` and return the dense matrices."""
        if sparse is not self._source:  # callers fill from the same live buffer every period: bound once
            self._source = sparse
            values = sparse if self._padded is None else self._padded
            if fast.enabled():
                self._gather = bound(gather, values, self._index, self._flat)
            else:
                self._gather = partial(values.take, self._index, 1, self._flat)
        if self._padded is not None:  # a tree: gather from the values with a zero appended
            self._padded[:, :-1] = sparse
        self._gather()
        return self.out

