"""The nominal model's matrix accelerators (ftc_mj.fast.matrices) against their NumPy definitions: the row-by-row
product against ``numpy.einsum("rij,rj->ri")`` to a few ulps of the row's largest product (equal bits where
einsum's loop sums in two lanes, as on the CPUs the project is measured on: not asserted), on every size, on
contiguous rows, strided slices and a vector broadcast to every row, with NaN and infinities; the gather
against ``numpy.take`` bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.fast.matrices import gather, matvec_in_pairs
from ftc_mj.robot.nominal import matvec

#: The tolerance of the product: ulps of the largest |product| of a row, times the number of products.
ULPS = 4


def einsum(matrices: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    return np.einsum("rij,rj->ri", matrices, vectors)


def assert_close_to_einsum(got: np.ndarray, matrices: np.ndarray, vectors: np.ndarray) -> None:
    expected = einsum(matrices, vectors)
    scale = np.abs(matrices * vectors[:, None, :]).max(axis=2)
    tolerance = ULPS * matrices.shape[-1] * np.spacing(scale)
    same_special = np.isnan(got) == np.isnan(expected)
    assert same_special.all()
    finite = np.isfinite(expected)
    assert np.array_equal(got[~finite & ~np.isnan(got)], expected[~finite & ~np.isnan(expected)])
    assert (np.abs(got - expected)[finite] <= tolerance[finite]).all()


@pytest.mark.parametrize("n", range(1, 10))
def test_the_paired_product_is_einsums_to_a_few_ulps_in_every_layout(n: int) -> None:
    generator = np.random.default_rng(100 + n)
    matrices = generator.standard_normal((40, n, n)) * 10.0 ** generator.integers(-6, 6, (40, n, n))
    vectors = generator.standard_normal((40, n))
    vectors[3, 0] = np.nan
    matrices[5, 0, 0] = np.inf
    cases = [(matrices, vectors), (matrices[::3], vectors[::3]), (matrices[:5], np.broadcast_to(vectors[7], (5, n))),
             (np.zeros((2, n, n)), np.zeros((2, n))), (matrices[:0], vectors[:0])]
    with np.errstate(all="ignore"):
        for m, v in cases:
            out = np.full((len(m), n), -1.0)
            matvec_in_pairs(m, v, out)
            assert_close_to_einsum(out, m, v)
            defined = np.full((len(m), n), -1.0)
            assert matvec(m, v, defined) is defined  # the call the package makes (fast or not)
            assert_close_to_einsum(defined, m, v)


def test_the_paired_product_sums_even_and_odd_products_apart() -> None:
    """Its order for three products, (a0 b0 + a2 b2) + a1 b1: 0 for 1, -1 and 1e-20, where the left-to-right sum
    gives 1e-20 (both within the tolerance of a sum of products of magnitude 1)."""
    matrix, vector = np.array([[[1.0, -1.0, 1e-20]]]), np.ones((1, 3))
    out = np.full((1, 1), np.nan)
    matvec_in_pairs(matrix, vector, out)
    assert out[0, 0] == 0.0 and (1.0 + -1.0) + 1e-20 == 1e-20
    assert_close_to_einsum(out, matrix, vector)


@pytest.mark.parametrize("rows", [1, 5, 0])
def test_the_gather_is_numpys_take(rows: int) -> None:
    generator = np.random.default_rng(rows)
    values = generator.standard_normal((rows, 11))
    values[:, 2] = np.nan
    index = generator.integers(0, 11, 16)
    out, expected = np.full((rows, 16), 7.0), np.empty((rows, 16))
    gather(values, index, out)
    values.take(index, axis=1, out=expected)
    np.testing.assert_array_equal(out, expected)
