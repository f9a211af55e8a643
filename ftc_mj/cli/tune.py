"""Robust gain tuning: ``ftc-mj tune TUNING.yaml [options]`` (also ``python -m ftc_mj.tune``).

CMA-ES over a variant's gains on a campaign's population of conditions (faults, mismatches, noise), with the
detector's false alarms and delays as constraints; then the tuned gains and the scenario's own on held-out
conditions. Writes into DIR (default ``results/tuning/<name>/``): ``best.yaml``, ``history.parquet``,
``report.md`` with ``convergence.png``, and ``report.json``. The same command on the same DIR resumes.
``--conditions``, ``--held-out``, ``--population``, ``--generations``, ``--duration`` and ``--set`` (a
scenario field in every run) shrink a tuning to a smoke test of the same file; the command line is recorded
in ``best.yaml`` (a comment), ``report.json`` and ``report.md``.

A bench tuning file (one that names a bench's ``entries``, :mod:`ftc_mj.ranking.tune`) tunes diagnosis entries
on their suite's tune population instead: P_d at the common false-alarm probability, every candidate a monitor
of the same reference-loop runs; it writes ``tuned.yaml`` (the gains and the seeds used, for a bench entry's
``tuned_with``) and ``history.yaml`` into DIR, and takes ``--out``, ``--generations``, ``--population``,
``--workers`` and ``--quiet``.

Exit status: 0 on success, 2 on bad input (one line naming the file, the field and the problem), 130 when
interrupted (finished generations are kept).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from ftc_mj.cli.command import Outputs, exit_status
from ftc_mj.cli.parser import ArgumentParser

PROG = "ftc-mj tune"


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    parser = ArgumentParser(prog=prog, description=__doc__.split("\n\n")[1])
    parser.add_argument("tuning", type=Path, help="tuning YAML file")
    parser.add_argument("--out", type=Path, metavar="DIR", help="results directory (default: results/tuning/<name>/)")
    parser.add_argument("--generations", type=int, metavar="G", help="override the optimizer's generations")
    parser.add_argument("--population", type=int, metavar="P", help="override the candidates per generation")
    parser.add_argument("--conditions", type=int, metavar="N", help="override the training conditions")
    parser.add_argument("--held-out", type=int, metavar="N", help="override the held-out conditions")
    parser.add_argument("--duration", type=float, metavar="S", help="override the runs' duration [s]")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="overrides",
                        help="set a scenario field in every run (joins the campaign's set)")
    parser.add_argument("--workers", type=int, metavar="N", help="worker processes (default: all cores)")
    parser.add_argument("--scheduler", metavar="ADDRESS", help="a Dask scheduler, e.g. tcp://127.0.0.1:8786")
    parser.add_argument("--quiet", action="store_true", help="no progress and no summary")
    return parser


@exit_status("interrupted: finished generations are saved; run the same command again to go on")
def main(argv: Sequence[str] | None = None, prog: str = PROG) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser(prog).parse_args(argv)
    from ftc_mj.cli.campaign import assignments, command_line
    from ftc_mj.config.errors import InputError

    from ftc_mj.campaign import execute
    from ftc_mj.tuning import optimise, outcome

    file = str(args.tuning)
    if args.workers is not None and args.workers < 1:
        raise InputError(file, "--workers", f"must be at least 1, not {args.workers}")
    from ftc_mj.config.yaml import read_yaml_mapping
    from ftc_mj.ranking.tune import is_bench_tuning

    if args.tuning.is_file() and is_bench_tuning(read_yaml_mapping(args.tuning, "a tuning")):
        return _bench_tuning(args, argv, prog)
    outputs = Outputs(file)
    outputs.add("--out", args.out, directory=True)
    outputs.check([args.tuning])
    if args.scheduler is not None:
        execute.check_scheduler_address(args.scheduler, file)
    fields = {}
    for option, field, value in (("--population", "optimizer.population", args.population),
                                 ("--conditions", "conditions", args.conditions),
                                 ("--held-out", "held_out", args.held_out)):
        if value is not None:
            if value < 1:
                raise InputError("command line", option, f"must be at least 1, not {value}")
            fields[field] = value
    if args.duration is not None:
        if not args.duration > 0:
            raise InputError("command line", "--duration", f"must be positive, not {args.duration:g}")
        fields["duration"] = args.duration
    tuning = optimise.prepare(args.tuning, args.generations, fields, assignments(args.overrides))
    out = args.out or Path("results") / "tuning" / tuning.spec.name
    outputs.declared.clear()
    outputs.add("--out", out, directory=True)
    outputs.check([args.tuning, *tuning.campaign.inputs])
    if args.scheduler is not None:
        execute.check_scheduler(args.scheduler, file)

    def progress(generation: int, total: int, best: float) -> None:
        if not args.quiet:
            print(f"generation {generation}/{total}: best cost {best:.4g}", file=sys.stderr, flush=True)

    optimise.check_directory(tuning, out)  # before the lock file is made in it
    with execute.directory_lock(out, file, holder="tuning"):  # a second tuning on DIR is refused
        result = optimise.optimise(tuning, out, workers=args.workers, scheduler=args.scheduler,
                                   progress=progress)
        document = outcome.write(tuning, out, result, command=command_line(prog, argv))
    if not args.quiet:
        held = document["held_out"]
        diff = held["paired_difference"]
        print(f"tuned gains in {out}/best.yaml; held-out cost {held['baseline']['cost']:.4g} -> "
              f"{held['tuned']['cost']:.4g} (paired difference {diff['mean']:.3g} [{diff['ci95'][0]:.3g}, "
              f"{diff['ci95'][1]:.3g}]); report: {out}/report.md")
    return 0


def _bench_tuning(args: argparse.Namespace, argv: list[str], prog: str) -> int:
    """A bench tuning file: a bench's diagnosis entries tuned on its suite's tune population
    (:mod:`ftc_mj.ranking.tune`)."""
    from ftc_mj.campaign import execute
    from ftc_mj.cli.campaign import command_line
    from ftc_mj.config.errors import InputError
    from ftc_mj.ranking import tune

    file = str(args.tuning)
    for option, value in (("--conditions", args.conditions), ("--held-out", args.held_out),
                          ("--duration", args.duration), ("--set", args.overrides or None),
                          ("--scheduler", args.scheduler)):
        if value is not None:
            raise InputError(file, option, "not an option of a bench tuning (its runs are the suite's tune "
                             "population; it takes --out, --generations, --population, --workers, --quiet)")
    tuning = tune.load(args.tuning, args.generations, args.population)
    out = args.out or Path("results") / "tuning" / tuning.spec.name
    outputs = Outputs(file)
    outputs.add("--out", out, directory=True)
    outputs.check([args.tuning, tuning.bench.path])
    if out.is_dir() and any(entry.name != execute.LOCK for entry in out.iterdir()) \
            and not (out / "history.yaml").is_file():
        raise InputError(file, "--out", f"{out} is not empty and holds no bench tuning's results")
    workers = args.workers or execute.default_workers()

    def progress(generation: int, total: int, seconds: float) -> None:
        if not args.quiet:
            print(f"generation {generation}/{total} ({seconds:.0f} s)", file=sys.stderr, flush=True)

    if not args.quiet:
        print(f"{tune.budget_text(tuning)}; entries {', '.join(tuning.spec.entries)} on "
              f"{', '.join(tuning.robots)}", file=sys.stderr, flush=True)
    with execute.directory_lock(out, file, holder="tuning"):
        document = tune.optimise(tuning, out, workers, progress)
        document["command"] = command_line(prog, argv)
        tune.write_record(out, document)
    if not args.quiet:
        for name, entry in document["entries"].items():
            for robot, value in entry["objective"].items():
                print(f"{name} on {robot}: P_d {value['design']['pd']:.3f} -> {value['tuned']['pd']:.3f}, AUC "
                      f"{value['design']['auc']:.3f} -> {value['tuned']['auc']:.3f} (tune population); gains "
                      f"{entry['design'][robot]} -> {entry['tuned'][robot]}")
        print(f"tuned gains in {out}/tuned.yaml")
    return 0


if __name__ == "__main__":
    sys.exit(main())
