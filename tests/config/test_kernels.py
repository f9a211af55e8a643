"""A compiled kernel taken past its dispatcher (ftc_mj.config.kernels): the same function, the same bits."""

from __future__ import annotations

import numba
import numpy as np

from ftc_mj.config.kernels import bound, direct, for_any_layout
from ftc_mj.methods import compiled


@numba.njit(cache=False)
def scaled_sum(a: np.ndarray, b: np.ndarray, factor: float, out: np.ndarray) -> None:
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            out[i, j] = a[i, j] * factor + b[i, j]


def arrays(rows: int, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(rows * 10 + n)
    return rng.normal(size=(rows, n)), rng.normal(size=(rows, n)), np.zeros((rows, n))


def test_direct_is_the_dispatchers_compiled_function_for_those_types() -> None:
    a, b, out = arrays(4, 3)
    function = direct(scaled_sum, a, b, 0.3, out)
    assert function is not scaled_sum and callable(function)
    expected = np.zeros_like(out)
    scaled_sum(a, b, 0.3, expected)
    function(a, b, 0.3, out)
    assert np.array_equal(out, expected)
    # Other buffers of the same types: the same function serves them.
    a2, b2, out2 = arrays(7, 2)
    function(a2, b2, -1.5, out2)
    assert np.array_equal(out2, a2 * -1.5 + b2)
    # Types the dispatcher had not seen (Fortran order) compile their own function.
    c, d, out3 = np.asfortranarray(a2), np.asfortranarray(b2), np.zeros((7, 2), order="F")
    other = direct(scaled_sum, c, d, 2.0, out3)
    other(c, d, 2.0, out3)
    assert np.array_equal(out3, a2 * 2.0 + b2) and len(scaled_sum.overloads) == 2


@numba.njit(cache=False)
def column_total(values: np.ndarray, out: np.ndarray) -> None:
    for j in range(values.shape[1]):
        out[j] = 0.0
        for i in range(values.shape[0]):
            out[j] += values[i, j]


def test_for_any_layout_serves_every_layout_of_a_dtype_with_one_function() -> None:
    """Contiguous, strided and Fortran-ordered arrays of one dtype get the same compiled function (found again,
    not compiled again); an integer array, or a read-only one, gets its own, which reads its values as they are."""
    values = np.arange(12.0).reshape(4, 3)
    out = np.zeros(3)
    function = for_any_layout(column_total, values, out)
    block = np.zeros((4, 5, 3))
    block[:, 2] = values
    for other in (values, block[:, 2], np.asfortranarray(values)):
        assert for_any_layout(column_total, other, out) is function
        function(other, out)
        assert np.array_equal(out, other.sum(axis=0))
    integers = np.arange(12).reshape(4, 3)
    assert for_any_layout(column_total, integers, out) is not function
    for_any_layout(column_total, integers, out)(integers, out)
    assert np.array_equal(out, [18.0, 22.0, 26.0])
    frozen = values.copy()
    frozen.flags.writeable = False
    assert for_any_layout(column_total, frozen, out) is not function
    assert len(column_total.overloads) == 3


def test_bound_calls_the_same_buffers_without_arguments() -> None:
    a, b, out = arrays(2, 5)
    call = bound(scaled_sum, a, b, 2.0, out)
    call()
    assert np.array_equal(out, a * 2.0 + b)
    a += 1.0  # in place: the bound call reads the buffers as they are now
    call()
    assert np.array_equal(out, a * 2.0 + b)


def test_a_plain_function_is_itself() -> None:
    def plain(x: np.ndarray) -> np.ndarray:
        return x + 1

    assert direct(plain, np.zeros(3)) is plain


def test_a_call_site_runs_the_dispatcher_once_then_the_compiled_function() -> None:
    class Owner:
        pass

    owner = Owner()
    owner.kernel = compiled.call_site(owner, "kernel", scaled_sum)
    first = owner.kernel
    a, b, out = arrays(3, 4)
    owner.kernel(a, b, 0.5, out)
    assert np.array_equal(out, a * 0.5 + b)
    assert owner.kernel is not first and type(owner.kernel).__name__ == "builtin_function_or_method"
    a2, b2, out2 = arrays(3, 4)
    owner.kernel(a2 * 3, b2, 0.25, out2)
    assert np.array_equal(out2, (a2 * 3) * 0.25 + b2)


def test_every_period_kernel_is_compiled_without_numbas_runtime() -> None:
    """The kernels the loop calls every period take their arguments without the runtime's wrappers
    (``WITHOUT_RUNTIME``); a kernel that allocates cannot be one (Numba refuses to compile it)."""
    import pytest

    from ftc_mj.config import programs
    from ftc_mj.config.kernels import WITHOUT_RUNTIME
    from ftc_mj.effects import sensors, terms
    from ftc_mj.engine import plant, truths
    from ftc_mj.robot import nominal, rigid

    period_kernels = [programs._run, sensors._measure, terms._sum_terms, plant._within, truths._record,
                      nominal._matvec_in_pairs, nominal._gather, rigid._evaluate, rigid.solve_factored]
    for kernel in period_kernels:
        assert kernel.targetoptions.get("_nrt") is False, kernel.py_func.__qualname__
    def allocate(n: int) -> np.ndarray:
        return np.zeros(n)

    assert numba.njit(cache=False)(allocate)(3).tolist() == [0.0, 0.0, 0.0]  # with the runtime it compiles
    with pytest.raises(numba.core.errors.NumbaError):  # without it, Numba refuses the allocation
        numba.njit(cache=False, **WITHOUT_RUNTIME)(allocate)(3)
