"""A period's copies of live buffers into the series' samples (and into ``ctrl``), or of a sample into a live
buffer (the reference's rows), in one compiled call.

Each control period the loop writes some ten small arrays into the series: the readings, the true state, the
torque, each variant's estimates and sliding variable, the bodies' poses; and the command into the plant's
``ctrl``. As NumPy assignments ``series[k] = source`` each costs NumPy's call, far more than the copy of a
single run's row, and a compiled kernel that takes the arrays as arguments pays about as much again to unbox
them (``benchmarks/step_phases.py`` measures the period's copies).
:class:`SampleCopies` takes none: it keeps a table of the entries' addresses (source, destination at sample 0,
the destination's bytes per sample, elements), built once, and one call of a kernel copies every entry for
sample k.

**The same bytes.** An entry is a float64 source (or source sample) and a float64 destination sample (or
destination) of the same shape, both contiguous: the copy is ``destination[k] = source`` (or
``destination[...] = source[k]``) element for element, and any other pair (another dtype,
strides, a shape NumPy would broadcast) is copied by that NumPy assignment instead. The entries are copied in
the order they were added (consecutive entries of the kernel in one call), so an entry may read what an
earlier one wrote: the loop copies each controller's command into ``tau`` and then ``tau`` into ``ctrl``.

**The same arrays.** The table holds addresses; the entries hold the arrays they were made of (so the memory
stays alive as long as the table) and it copies what those array objects hold, as NumPy would. What it cannot
know is that a caller's attribute now names another array (a plugin may rebind its ``qd_hat`` rather than write
into it): its caller compares them each period (``is``) and, where one differs,
:meth:`SampleCopies.rebind` gives the entries the new arrays and moves them to the NumPy assignments for the
rest of the run (the table is rebuilt once, not at every later rebinding).

**The definition** is the NumPy assignment of every entry, which is what runs with the fast paths off.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import partial

import numba
import numpy as np
from numba import types
from numba.extending import intrinsic

from ftc_mj import fast
from ftc_mj.fast.kernels import bound

#: Columns of the table: source address at sample 0, source bytes per sample, destination address at sample 0,
#: destination bytes per sample (0: the same buffer every sample), elements.
_SOURCE, _SOURCE_STRIDE, _DESTINATION, _STRIDE, _COUNT = range(5)


class SampleCopies:
    """``destination[k] = source`` (or ``buffer[...] = source``, ``buffer[...] = series[k]``) for every entry,
    each period, in one call.

    Entries are added before the first call (:meth:`sample`, :meth:`into`, :meth:`row`), each with a group: the key of the
    owner that may rebind its arrays (:meth:`rebind`). Then ``copies(k)`` copies them all for sample k."""

    def __init__(self) -> None:
        #: Per entry: (group, source, destination, which of them is per sample: "destination", "source" or "").
        self._entries: list[tuple[object, np.ndarray, np.ndarray, str]] = []
        #: The groups whose entries NumPy copies (their ``id``: a group is any object, hashable or not).
        self._assigned: set[int] = set()
        self._call: Callable[[int], None] | None = None
        #: How many entries the kernel copies (the rest NumPy's assignments), as of the last call.
        self.kernel_entries = 0

    def sample(self, source: np.ndarray, series: np.ndarray, group: object = None) -> None:
        """``series[k] = source`` at every call's k (``series`` is ``(steps, ...)``)."""
        self._add(group, source, series, "destination")

    def into(self, source: np.ndarray, buffer: np.ndarray, group: object = None) -> None:
        """``buffer[...] = source`` at every call."""
        self._add(group, source, buffer, "")

    def row(self, series: np.ndarray, buffer: np.ndarray, group: object = None) -> None:
        """``buffer[...] = series[k]`` at every call's k."""
        self._add(group, series, buffer, "source")

    def _add(self, group: object, source: np.ndarray, destination: np.ndarray, per_sample: str) -> None:
        self._entries.append((group, source, destination, per_sample))
        self._call = None

    def rebind(self, group: object, sources: Sequence[np.ndarray]) -> None:
        """``group``'s owner now holds ``sources`` (in the order its entries were added), of which some are other
        objects than the entries': the entries take them, and NumPy copies them from now on. An owner that
        rebinds once may rebind every period: the table is rebuilt the first time only (NumPy's assignments
        read the entries as they are at each call)."""
        entries = [index for index, entry in enumerate(self._entries) if entry[0] is group]
        for index, source in zip(entries, sources):
            _, _, destination, per_sample = self._entries[index]
            self._entries[index] = (group, source, destination, per_sample)
        if id(group) not in self._assigned:
            self._assigned.add(id(group))
            self._call = None

    def __call__(self, k: int) -> None:
        call = self._call
        if call is None:
            call = self._call = self._build()
        call(k)

    def _build(self) -> Callable[[int], None]:
        """The entries in the order they were added, cut into runs that the kernel copies (a table each) and runs
        that NumPy copies: an entry may read what an earlier one wrote (a block's command, then ``ctrl``)."""
        runs: list[tuple[bool, list]] = []  # (by the kernel?, table rows or entry indices)
        entries, compiled = self._entries, fast.enabled()
        for index, (group, source, destination, per_sample) in enumerate(entries):
            origin = source[0] if per_sample == "source" else source
            target = destination[0] if per_sample == "destination" else destination
            by_kernel = compiled and id(group) not in self._assigned and _copyable(origin, target)
            if not runs or runs[-1][0] != by_kernel:
                runs.append((by_kernel, []))
            if by_kernel:
                runs[-1][1].append((origin.ctypes.data, source.strides[0] if per_sample == "source" else 0,
                                    target.ctypes.data, destination.strides[0] if per_sample == "destination" else 0,
                                    origin.size))
            else:
                runs[-1][1].append(index)
        self.kernel_entries = sum(len(items) for by_kernel, items in runs if by_kernel)
        steps = [bound(_copy, np.array(items, dtype=np.int64), free=(0,)) if by_kernel
                 else partial(_assign, entries, items)
                 for by_kernel, items in runs]
        if len(steps) == 1:
            return steps[0]
        if not steps:
            return _nothing

        def call(k: int) -> None:
            for step in steps:
                step(k)

        return call


def _assign(entries: list[tuple[object, np.ndarray, np.ndarray, str]], indices: list[int], k: int) -> None:
    """NumPy's assignment of each of ``entries[indices]`` for sample ``k``."""
    for index in indices:
        _, source, destination, per_sample = entries[index]
        if per_sample == "destination":
            destination[k] = source
        elif per_sample == "source":
            destination[...] = source[k]
        else:
            destination[...] = source


def _copyable(source: np.ndarray, target: np.ndarray) -> bool:
    """Whether copying ``source`` into ``target`` element for element is NumPy's assignment of it: both float64
    arrays, contiguous, of one shape, the target writeable."""
    return (type(source) is np.ndarray and type(target) is np.ndarray and source.dtype == np.float64
            and target.dtype == np.float64 and source.shape == target.shape and source.flags.c_contiguous
            and target.flags.c_contiguous and target.flags.writeable)


@intrinsic
def _pointer(typingctx, address):  # noqa: ANN001, ANN202 (Numba's typing)
    """The float64 pointer at the integer ``address``."""
    signature = types.CPointer(types.float64)(types.int64)

    def codegen(context, builder, signature, arguments):  # noqa: ANN001, ANN202
        return builder.inttoptr(arguments[0], context.get_value_type(types.CPointer(types.float64)))

    return signature, codegen


def _nothing(k: int) -> None:
    """No entry for the kernel."""


@numba.njit(cache=True)
def _copy(table, k):  # noqa: ANN001, ANN202
    """Every entry of ``table`` for sample ``k``: its elements from the source's address plus k times its stride
    to the destination's address plus k times its stride."""
    for entry in range(table.shape[0]):
        count = table[entry, _COUNT]
        source = numba.carray(_pointer(table[entry, _SOURCE] + k * table[entry, _SOURCE_STRIDE]), count)
        destination = numba.carray(_pointer(table[entry, _DESTINATION] + k * table[entry, _STRIDE]), count)
        for i in range(count):
            destination[i] = source[i]
