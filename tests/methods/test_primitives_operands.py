"""The primitives' operands and results: ``out`` is the array written and returned on every path, a number
``x`` with an exponent array, exponents that broadcast to a larger result, and the 0-d arrays ``scalar``
keeps (one per value, read-only, never the cached one for -0.0, NaN or another value).

The caches are module state that outlives a test (another test may have filled them with the shapes and
values used here), so each test that relies on a first look-up starts from empty caches.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ftc_mj.methods import primitives
from ftc_mj.methods.primitives import power, scalar, signed_power

X = np.array([[0.3, 1.7, 4.0], [2.25, 0.01, 9.0]])
SIGNED_X = X * np.array([[1.0, -1.0, 1.0], [-1.0, 1.0, -1.0]])


@pytest.fixture
def empty_caches(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(primitives, "_SCALARS", {})
    monkeypatch.setattr(primitives, "_RESULT_SHAPES", {})


# ------------------------------------------------------------------------------------------ out


@pytest.mark.parametrize("exponent", [0.6, np.full(X.shape, 0.6), np.full((1, 3), 0.6)],
                         ids=["number", "full array", "row"])
def test_power_writes_into_out_and_returns_it(exponent):
    out = np.full(X.shape, np.nan)
    assert power(X, exponent, out=out) is out
    np.testing.assert_allclose(out, X**0.6, rtol=1e-15)


@pytest.mark.parametrize("exponent", [0.6, np.full(X.shape, 0.6), np.full((1, 3), 0.6)],
                         ids=["number", "full array", "row"])
def test_power_in_place(exponent):
    x = X.copy()
    assert power(x, exponent, out=x) is x
    np.testing.assert_allclose(x, X**0.6, rtol=1e-15)


@pytest.mark.parametrize("exponent", [0.6, np.full(X.shape, 0.6), np.full((1, 3), 0.6), np.full(3, 0.6)],
                         ids=["number", "full array", "row", "vector"])
def test_signed_power_writes_the_signed_result_into_out(exponent):
    out = np.full(X.shape, np.nan)
    assert signed_power(SIGNED_X, exponent, out=out) is out
    np.testing.assert_allclose(out, np.sign(SIGNED_X) * X**0.6, rtol=1e-15)


def test_signed_power_refuses_out_x_with_its_message():
    x = SIGNED_X.copy()
    with pytest.raises(ValueError, match=r"^signed_power: out must not be x \(the signs of x are read after "
                                         r"\|x\|\^p is written\)$"):
        signed_power(x, 0.5, out=x)


# ------------------------------------------------------------------------------------------ shapes


def test_a_number_base_with_an_exponent_array():
    """x a Python number, one exponent per element: each element x^p_k."""
    p = np.array([0.5, 2.0, 3.0])
    np.testing.assert_allclose(power(4.0, p), [2.0, 16.0, 64.0], rtol=1e-15)
    np.testing.assert_allclose(signed_power(-4.0, p), [-2.0, -16.0, -64.0], rtol=1e-15)


def test_an_exponent_larger_than_the_base_broadcasts_the_base(empty_caches):
    """x one row ``(n,)``, p one per member and joint ``(members, n)``: the result is ``(members, n)``."""
    x = np.array([4.0, 9.0, 16.0])
    p = np.array([[0.5, 0.5, 0.5], [1.0, 2.0, 0.25]])
    expected = [[2.0, 3.0, 4.0], [4.0, 81.0, 2.0]]
    for _ in range(2):  # the first call fills the shape cache, the second reads it
        np.testing.assert_allclose(power(x, p), expected, rtol=1e-15)
        np.testing.assert_allclose(signed_power(-x, p), -np.array(expected), rtol=1e-15)


def test_an_exponent_column_is_expanded_on_the_first_call_too(empty_caches):
    """A ``(members, 1)`` exponent is pow for every element (not the sqrt NumPy takes for a stride-0 0.5), on
    the call that finds the shape as on later ones."""
    x = np.abs(np.random.default_rng(7).standard_normal((6, 40))) * 10.0
    column = np.full((6, 1), 0.5)
    per_element = np.power(x, np.full(x.shape, 0.5))
    if np.array_equal(per_element, np.sqrt(x)):
        pytest.skip("pow rounds as sqrt on these values with this NumPy: no shortcut to show")
    for _ in range(2):
        np.testing.assert_array_equal(power(x, column), per_element)
    assert primitives._RESULT_SHAPES == {((6, 40), (6, 1)): (6, 40)}


# ------------------------------------------------------------------------------------------ scalar


def test_scalar_keeps_one_read_only_array_per_value(empty_caches):
    first, second = scalar(2.5), scalar(0.75)
    assert float(first) == 2.5 and float(second) == 0.75
    assert scalar(2.5) is first and scalar(0.75) is second and scalar(1.0) is scalar(1.0)
    for value in (first, second, scalar(1.0)):
        assert not value.flags.writeable
        with pytest.raises(ValueError):
            value[...] = 3.0
    assert set(primitives._SCALARS) == {2.5, 0.75, 1.0}


def test_scalar_zero_and_nan_are_never_cached(empty_caches):
    """-0.0 == 0.0 as a key: a cached 0.0 would turn a -0.0 into +0.0."""
    assert math.copysign(1.0, float(scalar(0.0))) == 1.0
    assert math.copysign(1.0, float(scalar(-0.0))) == -1.0
    assert math.isnan(float(scalar(math.nan)))
    assert not scalar(0.0).flags.writeable and not scalar(math.nan).flags.writeable
    assert primitives._SCALARS == {}


def test_scalar_of_a_0d_array_is_its_number(empty_caches):
    value = scalar(np.array(2.5))
    assert value.shape == () and float(value) == 2.5 and value is scalar(2.5)
