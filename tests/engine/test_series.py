"""The run's buffers: zero, writable, of their shape, in mapped memory from MAPPED_BYTES on; tau_delivered shares
tau's buffer where no actuator fault acts, and a cut writes NaN once per buffer."""

from __future__ import annotations

import mmap

import numpy as np
import pytest

from ftc_mj.engine.series import MAPPED_BYTES, SERIES, BlockSeries, Series, buffer


@pytest.mark.parametrize("shape", [(3, 2, 1), (MAPPED_BYTES // 8 // 6 + 1, 2, 3), (1000, 500, 3)])
def test_a_buffer_is_zero_writable_float64_and_mapped_when_large(shape: tuple[int, ...]) -> None:
    values = buffer(shape)
    assert values.shape == shape and values.dtype == np.float64 and values.flags.writeable
    assert values.flags.c_contiguous
    assert not values.any()
    large = np.prod(shape) * 8 >= MAPPED_BYTES
    owner = values
    while isinstance(owner, np.ndarray):  # the chain of views down to the memory
        owner = owner.base
    assert isinstance(getattr(owner, "obj", owner), mmap.mmap) == large  # a memoryview of the mapping
    values[-1] = 1.5  # the whole extent is writable
    assert values[-1].sum() == 1.5 * np.prod(shape[1:])


def allocate(delivered_is_command: bool) -> Series:
    blocks = [BlockSeries("a", slice(0, 2), [], []), BlockSeries("b", slice(2, 4), [], [])]
    return Series.allocate(6, 4, 3, 2, blocks, np.zeros(6, dtype=bool), False, False, None,
                           delivered_is_command=delivered_is_command)


def test_tau_delivered_is_tau_without_actuator_faults() -> None:
    shared, own = allocate(True), allocate(False)
    assert set(shared.rows) == set(own.rows) == set(SERIES)
    assert shared.rows["tau_delivered"] is shared.rows["tau"]
    assert not np.shares_memory(own.rows["tau_delivered"], own.rows["tau"])
    for name in ("fault", "fault_torque", "fault_acceleration"):  # written only while a fault may be on
        assert not shared.rows[name].any()


def test_a_cut_writes_nan_from_each_rows_stop_once_per_buffer() -> None:
    series = allocate(True)
    for values in series.rows.values():
        values[...] = 1.0
    series.cut(np.array([6, 2, 6, 0]))
    tau = series.rows["tau"]
    assert np.isnan(tau[2:, 1]).all() and not np.isnan(tau[:2, 1]).any()
    assert np.isnan(tau[:, 3]).all() and not np.isnan(tau[:, [0, 2]]).any()
    assert np.array_equal(series.rows["q_true"], tau, equal_nan=True)
