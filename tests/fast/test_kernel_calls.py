"""How kernels are called (ftc_mj.fast.kernels): a bound call checks its buffers at its boundary and reads any
layout right; one compiled version serves every layout of a dtype; a plain function is called as it is."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from ftc_mj.fast.kernels import WITHOUT_RUNTIME, bound, for_any_layout


@numba.njit(cache=False)
def scaled_sum(a: np.ndarray, b: np.ndarray, out: np.ndarray, factor: float) -> None:
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            out[i, j] = a[i, j] * factor + b[i, j]


@numba.njit(cache=False)
def total(values: np.ndarray) -> float:
    result = 0.0
    for i in range(values.shape[0]):
        for j in range(values.shape[1]):
            result += values[i, j]
    return result


def arrays(rows: int, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(rows * 10 + n)
    return rng.normal(size=(rows, n)), rng.normal(size=(rows, n)), np.zeros((rows, n))


def test_a_bound_call_runs_the_kernel_on_its_buffers_with_the_free_scalars() -> None:
    a, b, out = arrays(4, 3)
    call = bound(scaled_sum, a, b, out, free=(0.0,))
    call(0.3)
    assert np.array_equal(out, a * 0.3 + b)
    a += 1.0  # in place: the bound call reads the buffers as they are now
    call(-2.0)
    assert np.array_equal(out, a * -2.0 + b)


@pytest.mark.parametrize("layout", ["strided", "fortran", "reversed", "broadcast"])
def test_a_bound_call_reads_any_layout_as_numpy_does(layout: str) -> None:
    """The kernel is compiled for each buffer's own layout: a strided view's sum is its elements' sum (a call
    compiled for a contiguous array and handed this view would read 6.0 where the sum is 12.0)."""
    block = np.ones((4, 6))
    values = {"strided": block[:, ::2], "fortran": np.asfortranarray(block[:, :3]), "reversed": block[::-1, :3],
              "broadcast": np.broadcast_to(np.ones(3), (4, 3))}[layout]
    assert bound(total, values)() == 12.0 == values.sum()


class Subclass(np.ndarray):
    pass


@pytest.mark.parametrize("argument", [np.ma.masked_array(np.ones((2, 2))), np.ones((2, 2)).view(Subclass)],
                         ids=["masked", "subclass"])
def test_a_bound_call_refuses_an_array_subclass(argument: np.ndarray) -> None:
    with pytest.raises(TypeError, match="argument 0"):
        bound(total, argument)


def test_a_bound_call_refuses_a_free_argument_that_is_neither_a_scalar_nor_an_array() -> None:
    a, b, out = arrays(2, 2)
    with pytest.raises(TypeError, match="free argument 0"):
        bound(scaled_sum, a, b, out, free=([1.0],))


def test_a_bound_call_refuses_a_free_array() -> None:
    """An array is bound (checked once, compiled for its type), never left to the call: a caller handed another
    array binds again (the fused laws' identity check)."""
    a, b, out = arrays(2, 2)
    with pytest.raises(TypeError, match="free argument 0 must be a number or a flag"):
        bound(scaled_sum, a, b, free=(out, 1.0))


def test_a_bound_call_of_a_plain_function_is_that_function_on_the_buffers() -> None:
    def plain(a: np.ndarray, b: np.ndarray, out: np.ndarray, factor: float) -> None:
        out[...] = a * factor + b

    a, b, out = arrays(3, 2)
    bound(plain, a, b, out, free=(1.0,))(2.0)
    assert np.array_equal(out, a * 2.0 + b)


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


def test_a_kernel_without_numbas_runtime_may_not_allocate() -> None:
    """What ``WITHOUT_RUNTIME`` promises its kernels: Numba refuses at compile time one that allocates."""
    def allocate(n: int) -> np.ndarray:
        return np.zeros(n)

    assert numba.njit(cache=False)(allocate)(3).tolist() == [0.0, 0.0, 0.0]  # with the runtime it compiles
    with pytest.raises(numba.core.errors.NumbaError):
        numba.njit(cache=False, **WITHOUT_RUNTIME)(allocate)(3)
