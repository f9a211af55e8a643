"""The plant terms' sums (ftc_mj.fast.terms) against their definition (ftc_mj.effects.terms.sum_terms): bit for
bit (tolerance: none; one product and one sum per element in both), on random values and factors, a term with
a per-row weight read from its slot's block, an inactive term, NaN and infinite values, no active term."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.effects.terms import _SUMS, sum_terms
from ftc_mj.fast import terms as compiled


def inputs(seed: int, rows: int, special: bool) -> tuple:
    generator = np.random.default_rng(seed)
    n, samples = 3, 4
    values = generator.standard_normal((rows, 4 * n)) * 1e3
    if special:
        values[generator.random(values.shape) < 0.2] = np.nan
        values[:1, :1] = np.inf
    factors = generator.standard_normal((4, samples, n))
    weights = generator.standard_normal((2, 3, rows))  # (slots, block, rows): term 2 has slot 1
    active, slots = np.array([0, 2, 3]), np.array([-1, 1, -1])
    targets = np.zeros((3, len(_SUMS)), dtype=bool)
    targets[0, [0, 2, 3]] = targets[1, [1, 2, 4]] = targets[2, 0] = True
    return values, active, slots, targets, factors, weights


@pytest.mark.parametrize("rows", [1, 5, 0])
@pytest.mark.parametrize("special", [False, True], ids=["random", "nan-inf"])
def test_the_compiled_sums_are_the_definitions(rows: int, special: bool) -> None:
    values, active, slots, targets, factors, weights = inputs(rows, rows, special)
    for k, block in ((2, 1), (0, 0), (3, 2)):
        expected = np.full((len(_SUMS), rows, 3), np.nan)
        got = np.full_like(expected, 7.0)
        with np.errstate(all="ignore"):
            sum_terms(values, active, slots, targets, factors, weights, expected, k, block)
            compiled.sum_terms(values, active, slots, targets, factors, weights, got, k, block)
        np.testing.assert_array_equal(got, expected)
    if rows and not special:
        assert np.all(expected[0] != 0.0)


def test_no_active_term_gives_zero_sums() -> None:
    values, _, _, _, factors, weights = inputs(0, 2, False)
    none, no_slots, no_targets = np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros((0, 5), bool)
    for function in (sum_terms, compiled.sum_terms):
        sums = np.full((len(_SUMS), 2, 3), np.nan)
        function(values, none, no_slots, no_targets, factors, weights, sums, 1, 0)
        assert not sums.any()
