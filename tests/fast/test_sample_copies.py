"""SampleCopies: each entry is NumPy's assignment of it, bit for bit, whether the kernel or NumPy copies it."""

from __future__ import annotations

import gc

import numpy as np
import pytest

from ftc_mj.fast.copies import SampleCopies, _copyable

STEPS, ROWS, N = 7, 5, 3  # rows != joints, so that a mixed-up axis shows


def _random(shape: tuple[int, ...], seed: int) -> np.ndarray:
    return np.random.default_rng(seed).standard_normal(shape)


def test_every_kind_of_entry_is_numpys_assignment() -> None:
    """Contiguous pairs (a whole series, a block of its rows, a pose array, a buffer) and pairs NumPy must copy
    (a strided source, float32, a row broadcast over the rows) end with the bytes NumPy's assignments leave."""
    series = {name: np.zeros((STEPS, ROWS, N)) for name in ("whole", "block", "strided", "float32", "broadcast")}
    poses, ctrl = np.zeros((STEPS, ROWS, 8, 4)), np.zeros((ROWS, N))
    sources = {"whole": _random((ROWS, N), 0), "block": _random((2, N), 1), "poses": _random((ROWS, 8, 4), 2),
               "strided": _random((ROWS, 2 * N), 3)[:, ::2], "float32": _random((ROWS, N), 4).astype(np.float32),
               "broadcast": _random((N,), 5), "ctrl": _random((ROWS, N), 6)}
    copies = SampleCopies()
    copies.sample(sources["whole"], series["whole"])
    copies.sample(sources["block"], series["block"][:, 1:3])
    copies.sample(sources["poses"], poses)
    for name in ("strided", "float32", "broadcast"):
        copies.sample(sources[name], series[name])
    copies.into(sources["ctrl"], ctrl)
    expected = {name: np.zeros_like(values) for name, values in series.items()}
    expected_poses = np.zeros_like(poses)
    for k in (0, 3, STEPS - 1):
        for source in sources.values():
            source[...] += 1.0  # new values every sample
        copies(k)
        expected["whole"][k] = sources["whole"]
        expected["block"][k, 1:3] = sources["block"]
        expected_poses[k] = sources["poses"]
        for name in ("strided", "float32", "broadcast"):
            expected[name][k] = sources[name]
        np.testing.assert_array_equal(ctrl, sources["ctrl"])
    for name, values in series.items():
        assert values.tobytes() == expected[name].tobytes(), name
    assert poses.tobytes() == expected_poses.tobytes()
    assert copies.kernel_entries == 4  # whole, block, poses, ctrl; the other three by NumPy


def test_a_row_entry_copies_sample_k_into_its_buffer() -> None:
    """``buffer[...] = series[k]``: a whole series' sample, a per-member reference's, and a strided series' (by
    NumPy), each the bytes NumPy's assignment leaves."""
    series = {"row": _random((STEPS, N), 7), "members": _random((STEPS, ROWS, N), 8),
              "strided": _random((STEPS, 2 * N), 9)[:, ::2]}
    buffers = {name: np.zeros(values.shape[1:]) for name, values in series.items()}
    copies = SampleCopies()
    for name, values in series.items():
        copies.row(values, buffers[name])
    for k in (0, 4, STEPS - 1):
        copies(k)
        for name, values in series.items():
            assert buffers[name].tobytes() == np.ascontiguousarray(values[k]).tobytes(), (name, k)
    assert copies.kernel_entries == 2


def test_entries_are_copied_in_the_order_they_were_added() -> None:
    """An entry reads what an earlier one wrote, whichever copies each: a command into a block of ``tau``, by the
    kernel or (a broadcast row) by NumPy, then ``tau`` into ``ctrl`` and into the series."""
    tau, ctrl, series = np.zeros((ROWS, N)), np.zeros((ROWS, N)), np.zeros((STEPS, ROWS, N))
    command, row = _random((2, N), 10), _random((N,), 11)
    copies = SampleCopies()
    copies.into(command, tau[:2])
    copies.into(row, tau[2:])  # NumPy broadcasts it: not the kernel's
    copies.into(tau, ctrl)
    copies.sample(tau, series)
    for k in (1, 5):
        command += 1.0
        row -= 1.0
        copies(k)
        expected = np.vstack([command, np.broadcast_to(row, (ROWS - 2, N))])
        for values in (tau, ctrl, series[k]):
            assert values.tobytes() == expected.tobytes()
    assert copies.kernel_entries == 3


def test_only_contiguous_float64_pairs_of_one_shape_go_to_the_kernel() -> None:
    a = np.zeros((ROWS, N))
    assert _copyable(a, np.zeros((ROWS, N)))
    assert not _copyable(a[:, :2], np.zeros((ROWS, 2)))  # strided source
    assert not _copyable(a, np.zeros((ROWS, 2 * N))[:, ::2])  # strided target
    assert not _copyable(a.astype(np.float32), np.zeros((ROWS, N)))
    assert not _copyable(a, np.zeros((ROWS, N), dtype=np.float32))
    assert not _copyable(a[0], np.zeros((ROWS, N)))  # NumPy would broadcast it
    read_only = np.zeros((ROWS, N))
    read_only.flags.writeable = False
    assert not _copyable(a, read_only)


def test_a_rebound_group_copies_the_arrays_its_owner_now_holds() -> None:
    """After rebind the group's entries copy the new arrays (by NumPy), the other entries still theirs."""
    series, other = np.zeros((STEPS, ROWS, N)), np.zeros((STEPS, ROWS, N))
    owner, fixed = _random((ROWS, N), 0), _random((ROWS, N), 1)
    copies = SampleCopies()
    group = object()
    copies.sample(owner, series, group=group)
    copies.sample(fixed, other)
    copies(0)
    assert copies.kernel_entries == 2
    replacement = owner + 10.0
    owner[...] = -1.0  # the old array changes too: it must no longer be read
    copies.rebind(group, [replacement])
    copies(1)
    np.testing.assert_array_equal(series[1], replacement)
    np.testing.assert_array_equal(other[1], fixed)
    replacement[...] = 3.0
    copies(2)
    np.testing.assert_array_equal(series[2], 3.0)
    assert copies.kernel_entries == 1  # the rebound group by NumPy from now on, the other still compiled
    call = copies._call
    for k in range(3, STEPS):  # rebound every period: the same table, the new arrays copied
        latest = np.full((ROWS, N), float(k))
        copies.rebind(group, [latest])
        copies(k)
        np.testing.assert_array_equal(series[k], latest)
    assert copies._call is call


def test_a_rebound_buffer_entry_and_the_other_groups() -> None:
    """rebind moves only its own group's entries, a buffer's (``into``) as a sample's; the engine's entries
    (no group) stay in the table."""
    ctrl, series = np.zeros((ROWS, N)), np.zeros((STEPS, ROWS, N))
    first, second, fixed = (_random((ROWS, N), seed) for seed in range(3))
    copies = SampleCopies()
    group, other = object(), object()
    copies.into(first, ctrl, group=group)
    copies.sample(second, series, group=other)
    copies.into(fixed, np.zeros((ROWS, N)))
    copies.into(second, np.zeros((ROWS, N)))
    copies(0)
    assert copies.kernel_entries == 4
    copies.rebind(group, [fixed])
    copies(1)
    assert copies.kernel_entries == 3
    np.testing.assert_array_equal(ctrl, fixed)
    np.testing.assert_array_equal(series[1], second)


@pytest.mark.slow  # a closed-loop run of seconds
def test_the_table_keeps_its_arrays_alive() -> None:
    """The kernel reads addresses: the arrays behind them stay alive while the copies do, whoever else drops
    them (the first call compiles the table from an array nobody else holds)."""
    series = np.zeros((STEPS, ROWS, N))
    copies = SampleCopies()
    copies.sample(_random((ROWS, N), 0), series)
    gc.collect()
    copies(0)
    gc.collect()
    for _ in range(50):  # memory freed and reused would show as other numbers
        np.full((ROWS, N), 7.0)
    copies(1)
    np.testing.assert_array_equal(series[1], _random((ROWS, N), 0))


def test_the_table_is_built_once_and_again_only_for_new_entries() -> None:
    """Nothing is compiled before the first call; later calls reuse its table until an entry is added."""
    first, second = np.zeros((STEPS, ROWS, N)), np.zeros((STEPS, ROWS, N))
    copies = SampleCopies()
    copies.sample(np.ones((ROWS, N)), first)
    assert copies.kernel_entries == 0
    copies(0)
    call = copies._call
    copies(1)
    assert copies._call is call and copies.kernel_entries == 1
    copies.sample(np.full((ROWS, N), 2.0), second)
    copies(2)
    assert copies._call is not call and copies.kernel_entries == 2
    assert np.all(first[:3] == 1.0) and np.all(second[2] == 2.0) and np.all(second[:2] == 0.0)


@pytest.mark.parametrize("count", [0, 1])
def test_no_entry_or_one(count: int) -> None:
    series = np.zeros((STEPS, 1, 1))
    copies = SampleCopies()
    if count:
        copies.sample(np.full((1, 1), 4.0), series)
    copies(STEPS - 1)
    assert series[STEPS - 1, 0, 0] == (4.0 if count else 0.0)
