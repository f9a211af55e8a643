"""How a compiled kernel is declared and called: its options, a call bound to its buffers past Numba's
dispatcher, one compiled version for every layout of a dtype, and whether its first call will compile.

A Numba dispatcher resolves the types of its arguments on every call (an array's dtype, dimensions, layout
and flags, each scalar's type) to choose the compiled function, which on a single run's few rows often costs
more than the kernel's own work. The compiled function itself
resolves nothing: handed an array of another dtype, dimension or layout than it was compiled for, it reads
that array's memory as if it were of the compiled one, silently. So it is never handed out on its own here:

* :func:`bound` takes every array a call site uses (buffers read and written in place, and the arrays from
  outside that the site is handed), checks them at its boundary (each an exact, aligned ``numpy.ndarray``),
  compiles for exactly their types and returns a call of those objects, the period's own numbers (a sample
  index, a time, a flag) the only arguments left. An array cannot change type later (its dtype, dimensions
  and strides are fixed for its life), so that check holds for every call. A caller handed an array from
  outside binds it too and binds again when it is handed another object: an identity check (``is``) per
  array and call, as the fused laws (:mod:`ftc_mj.fast.laws`) do.
* :func:`for_any_layout` compiles for the arguments' dtypes and dimensions in layout ``A`` (any strides) and
  finds that function again by exactly what decides its types, so any layout of those dtypes is read right.
* Any other call goes through the dispatcher, which checks every argument.

**Without Numba's runtime.** A compiled function passes each array argument to its code with a
reference-counted wrapper of Numba's runtime (allocated and freed around every call); the kernels called
every period are compiled without it (:data:`WITHOUT_RUNTIME`): an array argument is then passed as it is,
which is safe because such a kernel allocates nothing and keeps no reference to its arguments after the call.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from functools import partial

import numpy as np
from numba.core.dispatcher import Dispatcher
from numba.core.types import Array, Type as NumbaType

#: The options of a kernel called every control period (with ``cache=True, nogil=True``): compiled without
#: Numba's runtime (the module docstring). Numba refuses at compile time a kernel that would need it (one that
#: allocates an array or copies one array into a slice of another).
WITHOUT_RUNTIME = {"_nrt": False}

#: The numbers and flags :func:`bound` accepts as a call's free (per-call) argument.
_SCALARS = (bool, int, float, np.bool_, np.integer, np.floating)


def bound(dispatcher: Dispatcher | Callable, *arguments: object, free: tuple = ()) -> Callable[..., object]:
    """``dispatcher`` on ``arguments`` (the same objects at every call) and then the call's own ``free``
    arguments (given here by an example of each: numbers or flags), as a call of those alone, past the
    dispatcher: ``call(*free)`` runs ``dispatcher(*arguments, *free)``.

    Checked here, once: every array among ``arguments`` is an exact, aligned ``numpy.ndarray`` (the function is
    compiled for its dtype, dimensions and layout, which it keeps for life), and every free argument is a number
    or a flag (an array is bound instead: a caller given another array binds again, the module docstring). A
    plain function (Numba's JIT disabled) is bound as it is."""
    for position, argument in enumerate(arguments):
        if isinstance(argument, np.ndarray) and (type(argument) is not np.ndarray or not argument.flags.aligned):
            raise TypeError(f"bound: argument {position} is a {type(argument).__name__} that is not an aligned "
                            "numpy.ndarray")
    for position, example in enumerate(free):
        if not isinstance(example, _SCALARS):
            raise TypeError(f"bound: free argument {position} must be a number or a flag, not "
                            f"{type(example).__name__} (bind an array)")
    if not isinstance(dispatcher, Dispatcher):
        return partial(dispatcher, *arguments)
    types = [dispatcher.typeof_pyval(argument) for argument in arguments]
    types += [dispatcher.typeof_pyval(example) for example in free]
    return partial(dispatcher.compile(tuple(types)), *arguments)


def for_any_layout(dispatcher: Dispatcher | Callable, *arguments: object) -> Callable:
    """``dispatcher``'s compiled function for the dtypes, dimensions and writability of ``arguments`` in any
    layout (compiled now, or loaded from Numba's cache), called without the dispatcher's resolution: strided
    views, broadcasts and contiguous arrays of one dtype and dimension share one compiled version, where the
    dispatcher would compile one per layout. For calls made a few times each, on those very arguments (or
    others of the same dtypes and dimensions: the function is found again by what determines its types,
    :func:`_type_key`, not by Numba's typing of every argument, dearer than many a kernel). A plain function (Numba's
    JIT disabled) is itself."""
    if not isinstance(dispatcher, Dispatcher):
        return dispatcher
    key = (dispatcher, *(_type_key(dispatcher, argument) for argument in arguments))
    compiled = _FOR_ANY_LAYOUT.get(key)
    if compiled is None:
        types = tuple(_any_layout(dispatcher.typeof_pyval(argument)) for argument in arguments)
        compiled = _FOR_ANY_LAYOUT[key] = dispatcher.compile(types)
    return compiled


#: :func:`for_any_layout`'s compiled functions by dispatcher and argument types.
_FOR_ANY_LAYOUT: dict[tuple, Callable] = {}


def _type_key(dispatcher: Dispatcher, argument: object) -> object:
    """What fixes ``argument``'s Numba type in layout ``A``: an array's type, dtype, dimensions, writability and
    alignment; a bool's, float's or NumPy scalar's Python type; else its Numba type."""
    if isinstance(argument, np.ndarray):
        return type(argument), argument.dtype, argument.ndim, argument.flags.writeable, argument.flags.aligned
    if isinstance(argument, (bool, float, np.generic)):
        return type(argument)
    return dispatcher.typeof_pyval(argument)  # an int's type depends on its value (int64 or uint64)


def _any_layout(kind: NumbaType) -> NumbaType:
    """An array type as the same type of layout ``A`` (any strides); another type as it is."""
    return kind.copy(layout="A") if isinstance(kind, Array) else kind


def cache_is_cold(dispatcher: Dispatcher, source: str) -> bool:
    """Whether the first call in this process of a kernel cached on disk will compile: Numba's cache holds no
    index of it, or one older than its source file ``source`` (Numba then compiles again)."""
    cache = getattr(dispatcher, "_cache", None)
    index = getattr(getattr(cache, "_cache_file", None), "_index_path", None)
    if index is None:  # a Numba without this layout: say nothing rather than something wrong
        return False
    try:
        return os.stat(index).st_mtime < os.stat(source).st_mtime
    except OSError:
        return True


def cache_folder(dispatcher: Dispatcher) -> str:
    """Where Numba caches ``dispatcher``'s compiled code (for the first run's announcement)."""
    return getattr(getattr(dispatcher, "_cache", None), "_cache_path", "Numba's cache")
