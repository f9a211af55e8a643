"""Cost of first writing a batch's series: NumPy's allocation (huge pages advised from 4 MiB on) against the
engine's buffers (:func:`ftc_mj.engine.series.buffer`: ordinary pages), in one run.

    python benchmarks/series_memory.py [--mib 384] [--rounds 3]

Each round allocates ``--mib`` MiB as 16 series of ``(steps, rows, 3)`` float64 both ways, in alternation, and
writes them one period (``[k]``) at a time as the loop does, then reads each once with a stride as the metrics
do; the memory is freed and the process waits a few seconds between allocations, so that each starts from
memory the kernel has to provide again (a VM may have handed freed memory back to its host). Prints seconds
per way and round and the ratio of the medians; the kernel's transparent huge page settings beside them.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

from ftc_mj.engine.series import buffer

SERIES, ROWS, N = 16, 500, 3


def one_way(allocate, steps: int) -> tuple[float, float]:
    """Seconds to write every series period by period, and to read them once with a stride."""
    series = [allocate((steps, ROWS, N)) for _ in range(SERIES)]
    row = np.random.default_rng(0).standard_normal((ROWS, N))
    start = time.perf_counter()
    for values in series:
        for k in range(steps):
            values[k] = row
    written = time.perf_counter()
    total = sum(float(values[:, ::7].sum()) for values in series)
    read = time.perf_counter()
    assert np.isfinite(total)
    return written - start, read - written


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--mib", type=int, default=384, help="memory of the series per way and round")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--pause", type=float, default=6.0, help="seconds between allocations")
    args = parser.parse_args()
    steps = args.mib * 2**20 // (SERIES * ROWS * N * 8)
    ways = {"numpy (np.empty)": np.empty, "engine (buffer)": buffer}
    results: dict[str, list[tuple[float, float]]] = {name: [] for name in ways}
    for _ in range(args.rounds):
        for name, allocate in ways.items():
            time.sleep(args.pause)
            results[name].append(one_way(allocate, steps))
    for setting in ("enabled", "defrag"):
        path = Path("/sys/kernel/mm/transparent_hugepage") / setting
        if path.exists():
            print(f"transparent huge pages {setting}: {path.read_text().strip()}")
    print(f"{SERIES} series of ({steps}, {ROWS}, {N}) float64: {args.mib} MiB per way and round")
    for name, rounds in results.items():
        print(f"{name:18s} write " + ", ".join(f"{w:.3f}" for w, _ in rounds) + " s; strided read "
              + ", ".join(f"{r:.3f}" for _, r in rounds) + " s")
    numpy_write, engine_write = (statistics.median(w for w, _ in rounds) for rounds in results.values())
    numpy_read, engine_read = (statistics.median(r for _, r in rounds) for rounds in results.values())
    print(f"ratio numpy / engine, first writes: {numpy_write / engine_write:.2f}")
    print(f"ratio numpy / engine, strided read: {numpy_read / engine_read:.2f}")


if __name__ == "__main__":
    main()
