"""A compiled kernel called straight, past its dispatcher, where a call site's arguments never change type.

A Numba dispatcher resolves the types of its arguments on every call (an array's dtype, dimensions, layout
and flags, each scalar's type) to choose the compiled function: some 0.1 us a call plus 0.02 us an argument,
which on a single run's few rows is often more than the kernel's own work. A call site whose arguments are
the same buffers, or buffers of the same types, period after period can take the compiled function once
(:func:`direct`) and call it without that resolution: the same machine code, the same bits.

The function so taken trusts its arguments' types: an array of another layout or dtype would be read as if
it were of the compiled one. So only call sites that make their arguments' types (allocated once, or views
of those made the same way each call) take it; a plugin in plain NumPy, or a caller of a public function,
never sees it.

**Without Numba's runtime.** A compiled function passes each array argument to its code with a
reference-counted wrapper of Numba's runtime (allocated and freed around every call): some 30 ns an array,
and a period's kernels take over a hundred arrays between them. The kernels called every period are
therefore compiled without the runtime (:data:`WITHOUT_RUNTIME`): an array argument is then passed as it
is, which is safe because such a kernel allocates nothing (its working arrays are its caller's buffers, made
once) and keeps no reference to its arguments after the call. The same machine code otherwise: the same bits.
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_DISABLE_INTEL_SVML", "1")  # before Numba is imported: ftc_mj.robot.rigid says why

from collections.abc import Callable  # noqa: E402
from functools import partial  # noqa: E402

import numpy as np  # noqa: E402
from numba.core.dispatcher import Dispatcher  # noqa: E402
from numba.core.types import Array, Type as NumbaType  # noqa: E402

#: The options of a kernel called every control period (with ``cache=True, nogil=True``): compiled without
#: Numba's runtime (the module docstring). Numba refuses at compile time a kernel that would need it (one that
#: allocates an array or copies one array into a slice of another).
WITHOUT_RUNTIME = {"_nrt": False}


def direct(dispatcher: Dispatcher | Callable, *arguments: object) -> Callable:
    """``dispatcher``'s compiled function for the types of ``arguments`` (compiled now, or loaded from Numba's
    cache): the one a call of ``dispatcher`` on them runs, called without the dispatcher's resolution. Only
    for calls whose arguments have exactly these types. A plain function (Numba's JIT disabled) is itself."""
    if not isinstance(dispatcher, Dispatcher):
        return dispatcher
    return dispatcher.compile(tuple(dispatcher.typeof_pyval(argument) for argument in arguments))


def for_any_layout(dispatcher: Dispatcher | Callable, *arguments: object) -> Callable:
    """``dispatcher``'s compiled function for the dtypes, dimensions and writability of ``arguments`` in any
    layout (compiled now, or loaded from Numba's cache), called without the dispatcher's resolution: strided
    views, broadcasts and contiguous arrays of one dtype and dimension share one compiled version, where the
    dispatcher would compile one per layout. For calls made a few times each: the function is found again by
    what determines its types (:func:`_type_key`), not by Numba's typing of every argument (some 15 us an
    array). A plain function (Numba's JIT disabled) is itself."""
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
    """What fixes ``argument``'s Numba type in layout ``A``: an array's dtype, dimensions, writability and
    alignment; a bool's, float's or NumPy scalar's Python type; else its Numba type."""
    if isinstance(argument, np.ndarray):
        return argument.dtype, argument.ndim, argument.flags.writeable, argument.flags.aligned
    if isinstance(argument, (bool, float, np.generic)):
        return type(argument)
    return dispatcher.typeof_pyval(argument)  # an int's type depends on its value (int64 or uint64)


def _any_layout(kind: NumbaType) -> NumbaType:
    """An array type as the same type of layout ``A`` (any strides); another type as it is."""
    return kind.copy(layout="A") if isinstance(kind, Array) else kind


def bound(dispatcher: Dispatcher | Callable, *arguments: object) -> Callable[[], object]:
    """``dispatcher`` on ``arguments`` (the same objects every call: buffers read and written in place), as a
    call without arguments, past the dispatcher (:func:`direct`)."""
    return partial(direct(dispatcher, *arguments), *arguments)
