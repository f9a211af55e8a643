"""Rows and nominal evaluation points of a batch run (ftc_mj.engine.rows)."""

from __future__ import annotations

import numpy as np

from ftc_mj.engine.rows import RowLayout


def test_points_follow_each_variant_observer_monitors_then_readings():
    """Three members; variant 0 with two monitors, variant 1 with none and a controller on the readings,
    variant 2 bare: each variant's points in the order observer, monitors, readings, contiguous, and each
    point on its own variant's rows."""
    layout = RowLayout.of(3, [2, 0, 0], [False, True, False])
    assert layout.rows == 9 and layout.points == 3 * (3 + 2 + 1)
    first, second, third = layout.blocks
    assert (first.rows, first.observer, first.monitors, first.readings) == (
        slice(0, 3), slice(0, 3), (slice(3, 6), slice(6, 9)), None)
    assert (second.rows, second.observer, second.monitors, second.readings) == (
        slice(3, 6), slice(9, 12), (), slice(12, 15))
    assert (third.rows, third.observer, third.readings) == (slice(6, 9), slice(15, 18), None)
    assert first.estimators == (slice(0, 3), slice(3, 6), slice(6, 9))
    np.testing.assert_array_equal(layout.point_rows, [0, 1, 2] * 3 + [3, 4, 5] * 2 + [6, 7, 8])


def test_member_values_repeat_for_every_row_and_every_point():
    layout = RowLayout.of(2, [1, 0], [False, True])
    values = np.array([1.5, 0.5])
    np.testing.assert_array_equal(layout.per_row(values), [1.5, 0.5, 1.5, 0.5])
    np.testing.assert_array_equal(layout.per_point(values), [1.5, 0.5] * 4)
    # A point's member value is its row's.
    np.testing.assert_array_equal(layout.per_point(values), layout.per_row(values)[layout.point_rows])


def test_estimator_points_mark_the_points_of_the_estimators_that_want_them():
    """Variant 0's second monitor and variant 1's observer want a quantity: their points only (not the
    readings' points); none wanted: None, so the nominal batch computes nothing more."""
    layout = RowLayout.of(2, [2, 1], [False, True])
    mask = layout.estimator_points([[False, False, True], [True, False]])
    expected = np.zeros(layout.points, dtype=bool)
    expected[layout.blocks[0].monitors[1]] = True
    expected[layout.blocks[1].observer] = True
    np.testing.assert_array_equal(mask, expected)
    assert layout.estimator_points([[False, False, False], [False, False]]) is None
