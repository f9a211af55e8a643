"""The benchmark: ``ftc-mj bench [BENCH.yaml] [--tier quick|full] [--out DIR] [--with-builtins]`` (also
``python -m ftc_mj.ranking``).

Scores every entry of the bench file (default: every built-in observer and pair,
``ftc_mj/ranking/suites/v2-entries.yaml``) on its suite, simulating only what ``DIR`` does not hold yet (an
entry already scored under the same protocol is not simulated again), and writes the leaderboard into
``DIR`` (default ``results/bench/<suite>-<tier>/``): ``leaderboard.md``, ``.csv``, ``.parquet``, figures and
``bench.json``. With ``--with-builtins`` the file's entries are scored beside every built-in entry of its suite
(on the tasks the file scores): the built-in bench's runs in ``DIR`` (its default is the built-in bench's) are
reused, so that only the file's entries are simulated.

Exit status: 0 on success, 2 on bad input (one line naming the file, the field and the problem; nothing is
written), 1 when a worker process died, 130 when interrupted (what finished is kept).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from ftc_mj.cli.command import Outputs, exit_status
from ftc_mj.cli.parser import ArgumentParser

PROG = "ftc-mj bench"


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    parser = ArgumentParser(prog=prog, description="Score observers (fault diagnosis) and observer-controller "
                            "pairs (tracking under faults) on a versioned benchmark suite.")
    parser.add_argument("bench", type=Path, nargs="?", metavar="BENCH.yaml",
                        help="the entries to score (default: every built-in method on suite v2)")
    parser.add_argument("--tier", choices=("quick", "full"), default="quick",
                        help="quick: fewer runs, the same protocol; full: the reported numbers (default: quick)")
    parser.add_argument("--out", type=Path, metavar="DIR", help="output directory (default: results/bench/"
                        "<suite>-<tier>/)")
    parser.add_argument("--workers", type=int, metavar="N", help="worker processes (default: all cores)")
    parser.add_argument("--with-builtins", action="store_true",
                        help="score the file's entries beside every built-in entry of its suite (ftc_mj/ranking/"
                        "suites/v2-entries.yaml for suite v2) on the tasks the file scores; built-in runs already "
                        "in DIR are reused")
    parser.add_argument("--quiet", action="store_true", help="no progress and no tables")
    return parser


def _check_out(out: Path) -> None:
    """``out`` is a bench's directory, or new, or empty."""
    from ftc_mj.config.errors import InputError

    if out.exists() and not out.is_dir():
        raise InputError("command line", "--out", f"{out} is a file, not a directory")
    if out.is_dir() and any(out.iterdir()) and not (out / "runs").is_dir():
        raise InputError("command line", "--out", f"{out} is not empty and holds no bench's results")


@exit_status("interrupted: what finished is saved; run the same command again to go on")
def main(argv: Sequence[str] | None = None, prog: str = PROG) -> int:
    args = build_parser(prog).parse_args(argv)
    from ftc_mj.config.errors import InputError
    from ftc_mj.ranking import execute, leaderboard
    from ftc_mj.ranking.entries import load_bench

    if args.workers is not None and args.workers < 1:
        raise InputError("command line", "--workers", f"must be at least 1, not {args.workers}")
    if args.with_builtins and args.bench is None:
        raise InputError("command line", "--with-builtins", "needs a bench file (without one, every built-in "
                         "entry is scored already)")
    bench = load_bench(args.bench, with_builtins=args.with_builtins)
    bench.suite.tier(args.tier)
    out = args.out or Path("results") / "bench" / f"{bench.suite.version}-{args.tier}"
    _check_out(out)
    outputs = Outputs(str(args.bench or "command line"))
    outputs.add("--out", out, directory=True)
    outputs.check([] if args.bench is None else [args.bench])
    # The stored results are read before anything is simulated (a damaged file is refused at once); the check
    # that every fault case acts simulates a healthy loop per robot.
    planned = execute.plan(bench, args.tier, out)
    if bench.suite.calibrated and bench.of("diagnosis"):
        from ftc_mj.ranking.sizing import check_faults_act

        check_faults_act(bench.suite, args.tier)  # a fault case that would not act: refused
    start = time.perf_counter()

    def progress(done: int, total: int) -> None:
        if not args.quiet and total:
            print(f"\r{done} / {total} runs simulated ({time.perf_counter() - start:.0f} s)", end="",
                  file=sys.stderr, flush=True)

    info = execute.run(bench, args.tier, out, workers=args.workers, progress=progress, planned=planned)
    if not args.quiet and info["simulated_runs"]:
        print(file=sys.stderr)
    info["workers"] = args.workers or execute.campaign_execute.default_workers()
    written = leaderboard.write(bench, args.tier, out, info.pop("done"), info)
    if not args.quiet:
        print(written[0].read_text())
        print(f"{info['simulated_runs']} runs simulated in {info['wall_time']:.1f} s; wrote {len(written)} files "
              f"in {out}/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
