"""The rule for sample times (ftc_mj.online.grid): a stream resampled causally onto the uniform grid gives what
NumPy's interpolation of the whole log gives (the replay's), bit for bit; time that does not increase and values
that are not finite are refused."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.online.grid import GridResampler, SampleError

NAMES = ("position", "torque")


def _stream(times: np.ndarray, values: np.ndarray, dt: float) -> tuple[list[int], np.ndarray]:
    grid = GridResampler(dt, NAMES)
    indices, out = [], []
    for t, v in zip(times, values):
        for k, (position, torque) in grid.push(float(t), v, -v):
            indices.append(k)
            out.append(position)
            np.testing.assert_array_equal(torque, -position)
    return indices, np.array(out)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_irregular_stream_equals_the_replays_interpolation(seed):
    rng = np.random.default_rng(seed)
    dt = 0.01
    # Steps of 4 to 25 ms (some shorter, some longer than the grid's period), three joints, an origin far from 0.
    times = 3017.18 + np.r_[0.0, np.cumsum(rng.uniform(0.004, 0.025, 300))]
    values = rng.standard_normal((len(times), 3))
    indices, streamed = _stream(times, values, dt)
    relative = times - times[0]
    grid = np.arange(len(indices)) * dt
    assert indices == list(range(len(indices)))
    assert grid[-1] <= relative[-1] < grid[-1] + dt  # every instant up to the last sample, none beyond
    expected = np.column_stack([np.interp(grid, relative, values[:, j]) for j in range(3)])
    np.testing.assert_array_equal(streamed, expected)


def test_a_sample_on_the_grid_is_taken_as_it_is_and_a_gap_is_interpolated_across():
    grid = GridResampler(0.5, ("position",))
    assert [k for k, _ in grid.push(10.0, np.array([1.0]))] == [0]
    assert grid.push(10.25, np.array([3.0])) == []  # between two instants: nothing completes yet
    completed = grid.push(11.5, np.array([6.0]))  # instants 1, 2, 3 (at 10.5, 11.0, 11.5)
    assert [k for k, _ in completed] == [1, 2, 3]
    np.testing.assert_allclose([v[0][0] for _, v in completed], [3.6, 4.8, 6.0])  # between (10.25, 3) and (11.5, 6)
    assert completed[-1][1][0][0] == 6.0  # exactly the sample


@pytest.mark.parametrize("t, field", [(10.0, "time"), (9.0, "time"), (np.nan, "time")])
def test_time_that_does_not_increase_is_refused(t, field):
    grid = GridResampler(0.1, ("position",))
    grid.push(10.0, np.zeros(2))
    with pytest.raises(SampleError, match=f"^{field}: "):
        grid.push(t, np.zeros(2))
    assert grid.next == 1  # nothing stepped


def test_values_that_are_not_finite_are_refused_by_name():
    grid = GridResampler(0.1, NAMES)
    with pytest.raises(SampleError, match="^torque: .*not all finite"):
        grid.push(0.0, np.zeros(2), np.array([0.0, np.inf]))
    assert grid.origin is None
