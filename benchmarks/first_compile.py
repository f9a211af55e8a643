"""What the first run on a machine costs: the same short single-variant run with an empty Numba cache (every
compiled kernel built) and again with the cache it left (loaded), each in a fresh process.

    python benchmarks/first_compile.py [--scenario scenarios/puma_fault.yaml] [--variant proposed] [--duration 1]

The cache is a temporary folder given as ``NUMBA_CACHE_DIR``, so the machine's own cache is neither used nor
touched. Prints the wall time of each run (import, compilation or loading, the run itself) and their difference,
the compilation's cost; the first run's stderr line that announces it is printed too.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def timed_run(arguments: list[str], cache: str) -> tuple[float, str]:
    """Wall time [s] of ``ftc-mj run ARGUMENTS`` in a fresh process with ``cache`` as Numba's cache, and its
    stderr."""
    env = {**os.environ, "NUMBA_CACHE_DIR": cache, "PYTHONPATH": str(ROOT)}
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "ftc_mj.run", *arguments], capture_output=True, text=True,
                          env=env, check=False)
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"the run failed ({done.returncode}): {done.stderr.strip()}")
    return seconds, done.stderr


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenario", default=str(ROOT / "scenarios" / "puma_fault.yaml"))
    parser.add_argument("--variant", default="proposed")
    parser.add_argument("--duration", type=float, default=1.0)
    args = parser.parse_args()
    arguments = [args.scenario, "--variant", args.variant, "--duration", repr(args.duration), "--no-record",
                 "--quiet"]
    with tempfile.TemporaryDirectory(prefix="ftc_mj-numba-") as cache:
        cold, said = timed_run(arguments, cache)
        warm, _ = timed_run(arguments, cache)
    announced = [line for line in said.splitlines() if line.startswith("compiling")]
    print(f"first run (empty cache):  {cold:.2f} s")
    print(f"second run (cache warm):  {warm:.2f} s")
    print(f"compilation:              {cold - warm:.2f} s")
    print(f"announced: {announced[0] if announced else '(nothing)'}")


if __name__ == "__main__":
    main()
