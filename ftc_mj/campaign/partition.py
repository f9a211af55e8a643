"""How a campaign's runs are cut into batches: one group per batch, as large as a worker's memory allows, the
same share of the work for every worker.

A batch's Python work per control period is shared by its rows, so the larger the batch, the closer the
campaign is to its bare physics; but a batch holds one group (one structure of the scenario), and the workers
should finish together. :func:`partition` does both: the runs, group after group, are cut into ``workers``
contiguous shares of equal size; each share's part of a group is one piece, cut into the fewest batches of
at most ``cap`` members, of equal sizes (within one). The batches are then handed out largest first, so that
a pool that gives each free worker the next batch ends with the small ones (longest processing time first).

Example: 100 runs in three groups of 33, 33 and 34 on two workers: shares of 50, pieces 33 + 17 and 16 + 34,
batches of 34, 33, 17 and 16 members; each worker steps 50 members. Cutting each group alone would give
three batches of 33 or 34 (one worker steps twice as many as the other) or, halved, six batches of 16 or 17.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass


@dataclass(frozen=True)
class Batch:
    """Members ``start:stop`` of group ``group`` (indices into the group's members, in their order)."""

    group: int
    start: int
    stop: int

    @property
    def size(self) -> int:
        return self.stop - self.start


def partition(group_sizes: Sequence[int], workers: int, cap: int) -> list[Batch]:
    """The batches of groups of ``group_sizes`` members for ``workers`` workers, each of at most ``cap``
    members (the module docstring), largest first (ties in group and member order).

    Every member is in exactly one batch; every batch is of one group."""
    if workers < 1 or cap < 1:
        raise ValueError(f"workers and cap must be positive (got {workers}, {cap})")
    total = sum(group_sizes)
    shares = min(workers, total) or 1
    # Share boundaries over the runs laid end to end: share w holds members [bounds[w], bounds[w + 1]).
    bounds = [total * w // shares for w in range(shares + 1)]
    batches = []
    first = 0  # the group's first member in that end-to-end order
    for group, size in enumerate(group_sizes):
        cuts = sorted({first, first + size, *(b for b in bounds if first < b < first + size)})
        for start, stop in zip(cuts, cuts[1:]):  # one piece: a share's part of the group
            count = math.ceil((stop - start) / cap)
            edges = [start + (stop - start) * k // count for k in range(count + 1)]
            batches += [Batch(group, a - first, b - first) for a, b in zip(edges, edges[1:])]
        first += size
    return sorted(batches, key=lambda batch: -batch.size)  # stable: ties keep group and member order
