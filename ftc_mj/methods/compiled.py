"""Fused laws: a shipped method's element-wise arithmetic in a few compiled kernels, its powers left to NumPy.

A law written in NumPy (the reference: every plugin's ``update``, ``advance`` or ``compute`` as documented)
pays NumPy's cost per call, about half a microsecond whatever the size, some fifteen calls per law and
period; at a campaign's batch sizes that per-call cost is most of the law's cost. The laws the shipped
scenarios run most (the TOSMO and high-speed TOSMO, eqs. (3.11), (5.6); the SOSMO, (4.37); the NFTSMC,
(5.15)-(5.27)) therefore also have a fused path: the same operations, in the same order, in a few Numba
kernels per period.

**The same bits.** Addition, subtraction, multiplication, division, ``sqrt``, ``abs``, ``copysign`` and the
sign are exact IEEE operations: compiled code and NumPy's SIMD loops give the same bits. Numba compiles them
without fast-math (no fused multiply-add, no reassociation). Fractional powers are not exact: NumPy's ``pow``
here is SVML's, Numba's is the C library's, and they differ in the last bit for some values. So a fused law
keeps every ``power`` a NumPy call, on operands of the same types, shapes and strides as the reference's
(:mod:`ftc_mj.methods.primitives` explains why those decide NumPy's kernel), and fuses the arithmetic around
it. ``tests/methods/test_compiled.py`` checks each fused law against its reference bit for bit, member by
member, on random states; the shipped scenarios' series hashes do not move.

**Which objects.** The fused path serves the shipped class itself; a subclass runs the NumPy law, so that its
overrides are honoured. A plugin in plain NumPy needs nothing of this module.

**First run.** The kernels compile on the first run on a machine (about a second per law) and are
cached by Numba as the nominal model's are (:mod:`ftc_mj.robot.rigid`); the first fused law of a module built in a
process says so in one line on stderr when its kernels will compile.

**The switch.** :func:`reference_laws` makes the methods built inside it use their NumPy law (the tests, and
the benchmarks that measure what fusing saves, in one run).
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_DISABLE_INTEL_SVML", "1")  # before Numba is imported: ftc_mj.robot.rigid says why

import inspect  # noqa: E402
import sys  # noqa: E402
from collections.abc import Callable, Iterator  # noqa: E402
from contextlib import contextmanager  # noqa: E402

import numba  # noqa: E402
import numpy as np  # noqa: E402
from numba.extending import overload  # noqa: E402

from ftc_mj.config.kernels import WITHOUT_RUNTIME, direct  # noqa: E402
from ftc_mj.methods.plugin import Method  # noqa: E402
from ftc_mj.robot.rigid import cache_is_cold  # noqa: E402

_reference = False
#: The fused kernels of each plugin module, for the first run's announcement; the modules announced.
_KERNELS: dict[str, list[numba.core.registry.CPUDispatcher]] = {}
_announced: set[str] = set()


@contextmanager
def reference_laws() -> Iterator[None]:
    """Methods built inside use their NumPy law (the reference), not the fused one."""
    global _reference
    previous, _reference = _reference, True
    try:
        yield
    finally:
        _reference = previous


def fused(method: Method, classes: tuple[type, ...], *operands: object) -> bool:
    """Whether ``method`` takes its fused path: it is an instance of one of ``classes`` exactly (not of a
    subclass), runs members (state ``(members, n)``, as in the engine) with every gain in ``operands`` an
    array of that shape, and is not built inside :func:`reference_laws`."""
    chosen = (not _reference and type(method) in classes and len(method.shape) == 2
              and all(type(operand) is np.ndarray and operand.shape == method.shape for operand in operands))
    if chosen and type(method).__module__ not in _announced:
        announce_compilation(type(method).__module__)
    return chosen


def kernel(function: Callable) -> numba.core.registry.CPUDispatcher:
    """The decorator of every fused kernel: compiled without fast-math, NumPy's semantics for division, cached
    on disk, without Numba's runtime (:data:`~ftc_mj.config.kernels.WITHOUT_RUNTIME`: a fused kernel allocates
    nothing)."""
    dispatcher = numba.njit(cache=True, nogil=True, fastmath=False, error_model="numpy", **WITHOUT_RUNTIME)(function)
    _KERNELS.setdefault(function.__module__, []).append(dispatcher)
    return dispatcher


def call_site(owner: Method, attribute: str, dispatcher: numba.core.registry.CPUDispatcher) -> Callable:
    """What ``owner.<attribute>`` calls ``dispatcher`` through: the first call runs the dispatcher and puts in
    the attribute's place the compiled function for that call's argument types
    (:func:`~ftc_mj.config.kernels.direct`), which the later calls run without the dispatcher's resolution of
    the types. A fused law's arguments have the same types every period (its own buffers; the engine's readings,
    reference rows and model views, each made the same way every period), the condition of that function."""
    def first(*arguments: object) -> object:
        setattr(owner, attribute, direct(dispatcher, *arguments))
        return dispatcher(*arguments)

    return first


def announce_compilation(module: str) -> None:
    """One line on stderr, once per plugin module and process, when its fused kernels will compile (the first
    run on a machine, or after an update)."""
    _announced.add(module)
    source = inspect.getsourcefile(sys.modules[module])
    cold = [dispatcher for dispatcher in _KERNELS.get(module, []) if cache_is_cold(dispatcher, source)]
    if cold:
        where = getattr(cold[0]._cache, "_cache_path", "Numba's cache")
        law = module.rsplit(".", 1)[-1]
        print(f"compiling the fused {law} law (first run on this machine, a second; cached in {where})",
              file=sys.stderr, flush=True)


def entry(values: np.ndarray, member: int, joint: int) -> float:
    """``values[member, joint]`` as NumPy broadcasting reads it: a row ``(n,)`` (the reference shared by every
    member), a row per member ``(members, n)``, or a single row ``(1, n)`` for every member. In a kernel its
    compiled form (below) is used, one per number of dimensions."""
    if values.ndim == 1:
        return float(values[joint])
    return float(values[min(member, values.shape[0] - 1), joint])


@overload(entry, inline="always")
def _entry(values, member, joint):  # noqa: ANN001, ANN202 (Numba's typing)
    """:func:`entry` compiled for the array type at hand."""
    if values.ndim == 1:
        return lambda values, member, joint: values[joint]
    return lambda values, member, joint: values[min(member, values.shape[0] - 1), joint]


@numba.njit(cache=True, inline="always")
def sign(x: float) -> float:
    """``np.sign``: -1, 0 or 1, zero (positive) for both zeros, NaN for NaN."""
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return 0.0 if x == 0.0 else x


@numba.njit(cache=True, inline="always")
def euler_state(psi_hat: np.ndarray, command: np.ndarray, injection: np.ndarray, q_hat_rate: np.ndarray,
                dt: float, q_hat: np.ndarray, qd_hat: np.ndarray, i: int, j: int) -> None:
    """One Euler period of an observer's x1_hat, x2_hat at member i, joint j: x1_hat += dt x1_hat' and
    x2_hat += dt ((Psi + M^-1 u) + injection), in the NumPy laws' order of operations."""
    qdd_hat = (psi_hat[i, j] + command[i, j]) + injection[i, j]
    q_hat[i, j] += dt * q_hat_rate[i, j]
    qd_hat[i, j] += dt * qdd_hat
