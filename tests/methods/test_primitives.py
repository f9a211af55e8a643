"""The batch-safe primitives (docs/explanation/batching.md): each element's bits are those it has alone, among
many, for odd and even lengths, at every position (the SIMD kernels' full vectors and their tails), in the
engine's ``(members, n)`` layout and in views of larger arrays; and the values are the mathematical ones."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ftc_mj.methods import primitives
from ftc_mj.methods.observers import base
from ftc_mj.methods.primitives import exp, power, scalar, signed_power

RNG = np.random.default_rng(20)


def _rounded_apart(count: int) -> np.ndarray:
    """Values whose pow with exponent 0.5, 2 and -1 differs in the last bit from sqrt, x*x and 1/x on this
    NumPy (if its pow has such values): the shortcuts NumPy takes in some shapes show on them."""
    pool = np.abs(RNG.standard_normal(20000)) * 10.0 ** RNG.uniform(-12, 3, 20000)
    found = []
    for p, shortcut in ((0.5, np.sqrt(pool)), (2.0, pool * pool), (-1.0, 1.0 / pool)):
        apart = np.nonzero(np.power(pool, np.full(pool.shape, p)) != shortcut)[0]
        found.append(pool[apart[:count]])
    return np.concatenate(found)


#: Eight values for each of the exponents 0.5, 2 and -1 where pow and NumPy's shortcut round apart.
APART = _rounded_apart(8)
#: Magnitudes over many decades (where pow, sqrt and exp round differently), with zeros and ones among them.
MAGNITUDES = np.concatenate([APART, np.abs(RNG.standard_normal(37)) * 10.0 ** RNG.uniform(-12, 3, 37),
                             [0.0, 1.0, 4.0]])
RNG.shuffle(MAGNITUDES)
SIGNED = MAGNITUDES * RNG.choice([-1.0, 1.0], MAGNITUDES.size)
ARGUMENTS = RNG.uniform(-30.0, 5.0, MAGNITUDES.size)  # for exp

#: Exponents as a plugin writes them: the exact special values and general ones (NumPy treats them apart).
NUMBERS = [0.5, 2.0, -1.0, 1.0, 2 / 3, 1 / 3, 0.6, 3]


def bits(values) -> np.ndarray:
    return np.ascontiguousarray(values, dtype=float).view(np.int64)


def assert_position_free(function, values: np.ndarray) -> None:
    """``function`` (element-wise) gives every element the bits it has alone: for every length from 1 to 40 and
    every offset into ``values``, for ``(members, n)`` blocks (members != n and equal), and for such blocks as
    views of a larger array."""
    alone = np.concatenate([function(values[k:k + 1]) for k in range(values.size)])
    for length in range(1, 41):
        for offset in range(0, values.size - length + 1, 3):
            got = function(values[offset:offset + length])
            np.testing.assert_array_equal(bits(got), bits(alone[offset:offset + length]),
                                          err_msg=f"length {length} at offset {offset}")
    for members in range(1, 8):
        for n in (1, 2, 3, 7):
            block = values[:members * n].reshape(members, n)
            np.testing.assert_array_equal(bits(function(block)).ravel(), bits(alone[:members * n]),
                                          err_msg=f"({members}, {n})")
            larger = np.zeros((members + 2, n + 3))
            larger[1:-1, 2:-1] = block
            np.testing.assert_array_equal(bits(function(larger[1:-1, 2:-1])).ravel(), bits(alone[:members * n]),
                                          err_msg=f"view ({members}, {n})")
            member = [function(block[k:k + 1]) for k in range(members)]  # each member alone, (1, n)
            np.testing.assert_array_equal(bits(function(block)), bits(np.concatenate(member)),
                                          err_msg=f"members of ({members}, {n})")


def in_place(function):
    """``function(x, out=x)`` on a copy of x."""
    def apply(x):
        copy = x.copy()
        return function(copy, out=copy)
    return apply


@pytest.mark.filterwarnings("ignore:divide by zero")
@pytest.mark.parametrize("exponent", NUMBERS)
def test_power_with_a_number_is_position_free(exponent):
    assert_position_free(lambda x: power(x, exponent), MAGNITUDES)
    assert_position_free(in_place(lambda x, out: power(x, exponent, out=out)), MAGNITUDES)


@pytest.mark.filterwarnings("ignore:divide by zero")
@pytest.mark.parametrize("exponent", NUMBERS)
def test_signed_power_with_a_number_is_position_free(exponent):
    assert_position_free(lambda x: signed_power(x, exponent), SIGNED)
    assert_position_free(lambda x: signed_power(x, exponent, out=np.empty_like(x)), SIGNED)


@pytest.mark.parametrize("exponent", [0.5, 2.0, 2 / 3, 0.3])
def test_powers_with_an_array_exponent_are_position_free(exponent):
    """One exponent per element, as the engine hands gains (``(members, n)``, the shape of the states), also
    in place and into ``out``: NumPy's in-place loop over a single element would see the exponent as a scalar
    and take sqrt or x*x where the batch takes pow."""
    assert_position_free(lambda x: power(x, np.full(x.shape, exponent)), MAGNITUDES)
    assert_position_free(in_place(lambda x, out: power(x, np.full(x.shape, exponent), out=out)), MAGNITUDES)
    assert_position_free(lambda x: signed_power(x, np.full(x.shape, exponent)), SIGNED)
    assert_position_free(lambda x: signed_power(x, np.full(x.shape, exponent), out=np.empty_like(x)), SIGNED)


@pytest.mark.parametrize("exponent", [0.5, 2.0, -1.0])
def test_an_exponent_with_fewer_elements_than_the_result_is_position_free(exponent):
    """One exponent per member broadcast over the joints (a ``(members, 1)`` column): NumPy's loop sees such an
    exponent as a scalar for a member alone and not among several; power expands it, so member k among eight
    has its bits alone."""
    if APART.size < 24:
        pytest.skip("pow rounds as sqrt, x*x and 1/x on this NumPy: no shortcut to show")
    x = APART.reshape(8, 3)
    column = np.full((8, 1), exponent)
    for function in (power, signed_power):
        together = function(x, column)
        for k in range(8):
            np.testing.assert_array_equal(bits(together[k:k + 1]), bits(function(x[k:k + 1], column[k:k + 1])))
        np.testing.assert_array_equal(bits(together), bits(function(x, np.full((8, 3), exponent))))


def test_a_broadcast_base_with_a_full_exponent_is_position_free():
    """x^p with x one value per member (a norm over the joints, ``(members, 1)``) and p one per member and
    joint: every member's row is its row alone."""
    x = MAGNITUDES[MAGNITUDES > 0][:5, None]
    p = RNG.uniform(-0.5, 0.9, (5, 3))
    together = power(x, p)
    assert together.shape == (5, 3)
    for k in range(5):
        np.testing.assert_array_equal(bits(together[k]), bits(power(x[k:k + 1], p[k:k + 1])[0]))
    np.testing.assert_array_equal(bits(signed_power(-x, p)), bits(-together))


def test_exp_is_position_free():
    assert_position_free(exp, ARGUMENTS)
    assert_position_free(in_place(exp), ARGUMENTS)


def test_sums_over_the_joints_do_not_depend_on_the_member_count():
    """What the page promises for plain NumPy: a sum over the joint axis (e^T e of a coupled law) gives each
    member the bits it has alone, for every member count and joint count (short and long rows alike)."""
    for n in (1, 2, 3, 6, 7, 8, 9, 16, 17):
        values = RNG.standard_normal((9, n))
        together = np.sum(values * values, axis=-1, keepdims=True)
        for members in (1, 2, 5, 9):
            part = np.sum(values[:members] * values[:members], axis=-1, keepdims=True)
            np.testing.assert_array_equal(bits(part), bits(together[:members]), err_msg=f"{members} x {n}")
        for k in range(9):
            np.testing.assert_array_equal(bits(np.sum(values[k:k + 1] ** 2, axis=-1)), bits(together[k]))


@pytest.mark.parametrize("exponent", NUMBERS)
def test_power_values(exponent):
    """Within one unit in the last place of the C library's pow; the special exponents exactly as NumPy's own
    ``x ** p`` (sqrt, x*x, 1/x, x)."""
    x = MAGNITUDES[MAGNITUDES > 0]
    np.testing.assert_array_max_ulp(power(x, exponent), np.array([math.pow(v, exponent) for v in x]), maxulp=1)
    np.testing.assert_array_equal(bits(power(x, exponent)), bits(x ** exponent))
    exact = {0.5: np.sqrt(x), 2.0: x * x, -1.0: 1.0 / x, 1.0: x}
    if exponent in exact:
        np.testing.assert_array_equal(bits(power(x, exponent)), bits(exact[exponent]))


def test_an_array_exponent_is_pow_per_element_whatever_its_value():
    """An exponent array is one general power per element, the same bits as pow with one exponent each, not the
    shortcut a number takes (so a gain of 0.5 gives the bits of every other gain's formula)."""
    x = MAGNITUDES.reshape(8, 8)
    p = np.full((8, 8), 0.5)
    expected = np.array([np.power(x.ravel()[k:k + 1], p.ravel()[k:k + 1])[0] for k in range(x.size)])
    np.testing.assert_array_equal(bits(power(x, p)).ravel(), bits(expected))
    np.testing.assert_array_max_ulp(power(x, p), np.sqrt(x), maxulp=1)


def test_signed_power_values():
    x = np.array([[-8.0, 0.0, 27.0], [1.0, -1.0, 0.125]])
    np.testing.assert_allclose(signed_power(x, 1 / 3), [[-2.0, 0.0, 3.0], [1.0, -1.0, 0.5]], rtol=1e-15)
    np.testing.assert_allclose(signed_power(x, 2 / 3), [[-4.0, 0.0, 9.0], [1.0, -1.0, 0.25]], rtol=1e-15)
    np.testing.assert_array_equal(signed_power(x, np.full(x.shape, 1.0)), x)
    np.testing.assert_array_equal(bits(signed_power(SIGNED, 0.5)), bits(np.copysign(np.sqrt(np.abs(SIGNED)), SIGNED)))
    for exponent in (0.5, 2 / 3, np.full(SIGNED.shape, 0.7)):
        np.testing.assert_array_equal(bits(signed_power(SIGNED, exponent)),
                                      bits(np.copysign(np.abs(SIGNED) ** exponent, SIGNED)))
    assert signed_power(-4.0, 0.5) == -2.0 and signed_power(np.array(-8.0), 1 / 3) == pytest.approx(-2.0)


def test_signed_power_writes_into_out_and_refuses_x():
    x = SIGNED[:6].reshape(2, 3).copy()
    out = np.empty_like(x)
    assert signed_power(x, 2 / 3, out=out) is out
    np.testing.assert_array_equal(bits(out), bits(signed_power(x, 2 / 3)))
    with pytest.raises(ValueError, match="out must not be x"):
        signed_power(x, 2 / 3, out=x)


def test_exp_values():
    np.testing.assert_array_max_ulp(exp(ARGUMENTS), np.array([math.exp(v) for v in ARGUMENTS]), maxulp=1)
    out = np.empty(ARGUMENTS.shape)
    assert exp(ARGUMENTS, out=out) is out


def test_scalar_is_the_number_as_an_operand():
    dt = scalar(1e-3)
    assert dt is scalar(1e-3) and dt.shape == () and not dt.flags.writeable
    assert float(dt) == 1e-3 and math.exp(-dt / 0.01) == math.exp(-0.1) and dt < 0.01 and f"{dt:.3f}" == "0.001"
    np.testing.assert_array_equal(bits(dt * SIGNED), bits(1e-3 * SIGNED))  # a product is the float's, bit for bit
    assert (dt * SIGNED).shape == SIGNED.shape
    assert math.copysign(1.0, float(scalar(-0.0))) == -1.0  # not the cached 0.0
    assert math.isnan(float(scalar(float("nan"))))


def test_signed_power_is_importable_from_the_observer_base():
    """Third-party plugins import it there."""
    assert base.signed_power is primitives.signed_power
