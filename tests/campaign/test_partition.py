"""The campaign's batches: every member once, one group per batch, within the cap, equal shares per worker."""

from __future__ import annotations

import itertools

import pytest

from ftc_mj.campaign.partition import Batch, partition


def _worker_loads(batches: list[Batch], workers: int) -> list[int]:
    """Members each worker steps when a pool hands the next batch to the first free worker (cost = size)."""
    loads = [0] * workers
    for batch in batches:  # in the given order, as the pool starts them
        loads[loads.index(min(loads))] += batch.size
    return loads


CASES = [([33, 33, 34], 2, 46), ([8, 8, 8], 2, 46), ([333, 333, 334], 2, 46), ([10], 3, 4), ([1], 2, 46),
         ([5, 0, 7], 2, 3), ([40, 40, 40], 1, 46), ([7, 11, 2, 30], 4, 5), ([100], 2, 128)]


@pytest.mark.parametrize("sizes, workers, cap", CASES)
def test_every_member_once_one_group_per_batch_within_the_cap(sizes, workers, cap):
    batches = partition(sizes, workers, cap)
    for group, size in enumerate(sizes):
        covered = sorted(itertools.chain.from_iterable(range(b.start, b.stop) for b in batches if b.group == group))
        assert covered == list(range(size))
    assert all(0 < b.size <= cap for b in batches)


@pytest.mark.parametrize("sizes, workers, cap", CASES)
def test_the_workers_step_the_same_share_within_one_batch(sizes, workers, cap):
    batches = partition(sizes, workers, cap)
    loads = _worker_loads(batches, workers)
    assert max(loads) - min(loads) <= max(b.size for b in batches)
    assert [b.size for b in batches] == sorted((b.size for b in batches), reverse=True)  # largest first


def test_the_example_of_the_module():
    batches = partition([33, 33, 34], 2, 46)
    assert [(b.group, b.start, b.stop) for b in batches] == [(2, 0, 34), (0, 0, 33), (1, 0, 17), (1, 17, 33)]
    assert _worker_loads(batches, 2) == [50, 50]


def test_a_piece_beyond_the_cap_is_cut_into_equal_batches():
    batches = partition([100], 1, 46)
    assert sorted(b.size for b in batches) == [33, 33, 34]  # not 46, 46, 8


def test_fewer_members_than_workers():
    assert [(b.group, b.start, b.stop) for b in partition([1, 1], 4, 10)] == [(0, 0, 1), (1, 0, 1)]
    assert partition([], 2, 10) == []


@pytest.mark.parametrize("workers, cap", [(0, 10), (2, 0)])
def test_refuses_no_workers_or_no_room(workers, cap):
    with pytest.raises(ValueError):
        partition([3], workers, cap)
