"""Mutation testing of the packages whose bugs a user would see: mutmut 3 on each target with the fast tests
that cover it, and the kill ratio per target.

Usage, from the repository root (hours for every target on two busy shared cores: run the targets one at a
time; the measured rates are in docs/results/testing.md)::

    nice -n 10 python tools/mutation.py                 # every target
    nice -n 10 python tools/mutation.py methods effects # some
    nice -n 10 python tools/mutation.py --survivors analysis  # after new tests: the survivors again
    python tools/mutation.py --report [--diffs]         # the table of the last runs (and the survivors' diffs)

Each target runs in its own stage, ``build/mutation/<target>/``: links to the sources, the data the tests read
and a ``pyproject.toml`` whose ``[tool.mutmut]`` section names the files to mutate and the test subset (mutmut
reads its configuration from the working directory's ``pyproject.toml`` only, one section per run). mutmut
copies the stage into ``mutants/``, runs the subset once to learn which tests reach which function, then runs
each mutant against only those tests. A second run of a stage tests again only what changed; ``--fresh``
starts it over (after new tests, for example: mutmut does not re-run survivors on its own).

With ``--diffs`` the open survivors of each target, with their diffs, go to
``build/mutation/<target>/survivors.txt``; those read and
judged equivalent are listed, by mutant name, in ``docs/results/equivalent-mutants.md`` (the first backticked
name of each table row), so the report counts them apart from the survivors still to kill.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STAGES = ROOT / "build" / "mutation"
EQUIVALENTS = ROOT / "docs" / "results" / "equivalent-mutants.md"
#: What the tests read besides the package and the tests (scenarios, robots, logs, ...), copied into mutants/.
DATA = ["scenarios", "models", "data", "campaigns", "tuning", "studies", "recordings"]


@dataclass(frozen=True)
class Target:
    """Files to mutate (globs relative to the root) and the test paths that cover them."""

    mutate: tuple[str, ...]
    tests: tuple[str, ...]


def _without(*tests: str) -> tuple[str, ...]:
    """pytest arguments that leave out the given tests (closed-loop runs of many seconds each: every mutant
    they reach would run them again; what they check is checked by the unit tests of the same module)."""
    return tuple(arg for test in tests for arg in ("--deselect", test))


#: Each target with the fast subset that covers it (seconds unmutated; not the whole suite).
TARGETS: dict[str, Target] = {
    "methods": Target(("ftc_mj/methods/*",), ("tests/methods", *_without(
        "tests/methods/observers/test_tosmo.py::test_converges_with_the_real_step_model",
        "tests/methods/controllers/test_nftsmc.py::test_no_compensation_tracks_only_with_a_large_gain_and_chatters_more",
    ))),
    "effects": Target(("ftc_mj/effects/*",), ("tests/effects", *_without(
        "tests/effects/test_randomness.py::test_same_seed_same_files_across_processes",
        "tests/effects/test_randomness.py::test_same_seed_same_run_bit_for_bit",
        "tests/effects/test_randomness.py::test_another_seed_another_run",
        "tests/effects/test_sensors.py::test_estimation_error_grows_with_noise_for_every_observer",
    ))),
    "analysis": Target(("ftc_mj/analysis/*",), ("tests/analysis", *_without(
        "tests/analysis/test_diagnosis.py::test_torque_space_signal_is_nominal_mass_times_estimate",
        "tests/analysis/test_diagnosis.py::test_no_alarm_without_a_fault",
        "tests/analysis/test_diagnosis.py::test_loss_of_effectiveness_detected_and_isolated",
        "tests/analysis/test_diagnosis.py::test_table_json_and_recording",
        "tests/analysis/test_diagnosis.py::test_staggered_onsets_in_the_closed_loop",
        "tests/analysis/test_diagnosis.py::test_bias_detected_against_the_uncertainty_bound",
    ))),
    "truths": Target(("ftc_mj/engine/truths.py",), ("tests/engine/test_truths.py",)),
    "copies": Target(("ftc_mj/fast/copies.py",), ("tests/fast/test_sample_copies.py",
                                                   "tests/engine/test_plugin_batching.py")),
    "plant": Target(("ftc_mj/engine/plant.py",),
                    ("tests/engine/test_plant.py", "tests/engine/test_log_plant.py", "tests/engine/test_truths.py")),
    "logs": Target(("ftc_mj/logs/*",), ("tests/logs", *_without(
        "tests/logs/test_ur10.py::test_free_motion_command_writes_table_json_recording",
    ))),
    "score": Target(("ftc_mj/ranking/score.py",), ("tests/ranking/test_score.py", "tests/ranking/test_score_edges.py")),
    "statistics": Target(("ftc_mj/campaign/statistics.py",), ("tests/campaign/test_statistics.py",
                                                               "tests/campaign/test_statistics_coverage.py",
                                                               "tests/campaign/test_statistics_edges.py",
                                                               "tests/campaign/test_verdicts.py")),
}


def stage(name: str, target: Target, fresh: bool) -> Path:
    """The target's stage directory, made (or remade with ``fresh``) with its configuration."""
    path = STAGES / name
    if fresh and path.exists():
        shutil.rmtree(path)
    path.mkdir(parents=True, exist_ok=True)
    for entry in ["ftc_mj", "tests", *DATA]:
        link = path / entry
        if not link.exists():
            link.symlink_to(ROOT / entry, target_is_directory=True)
    quoted = lambda items: "[" + ", ".join(json.dumps(item) for item in items) + "]"  # noqa: E731
    (path / "pyproject.toml").write_text(
        "[tool.mutmut]\n"
        'source_paths = ["ftc_mj"]\n'
        f"only_mutate = {quoted(target.mutate)}\n"
        f"also_copy = {quoted(DATA)}\n"
        f"pytest_add_cli_args_test_selection = {quoted(target.tests)}\n"
        'pytest_add_cli_args = ["-p", "no:cacheprovider", "-q"]\n'
        "\n[tool.pytest.ini_options]\n"
        'testpaths = ["tests"]\n'
    )
    return path


def equivalents() -> set[str]:
    """The mutant names listed as equivalent (first backticked name of each table row)."""
    if not EQUIVALENTS.exists():
        return set()
    names = set()
    for line in EQUIVALENTS.read_text().splitlines():
        match = re.match(r"\|\s*`([^`]+)`", line)
        if match:
            names.add(match.group(1))
    return names


def results(path: Path) -> dict[str, str]:
    """Mutant name -> status (killed, survived, timeout, no tests, ...) of the stage's last run."""
    out = subprocess.run(["mutmut", "results", "--all", "true"], cwd=path, capture_output=True, text=True)
    statuses = {}
    for line in out.stdout.splitlines():
        name, _, status = line.strip().rpartition(": ")
        if name:
            statuses[name] = status.strip()
    return statuses


def write_survivors(path: Path, statuses: dict[str, str], known: set[str]) -> list[str]:
    """The survivors not listed as equivalent, their diffs written to ``survivors.txt``."""
    open_ = sorted(name for name, status in statuses.items() if status == "survived" and name not in known)
    with open(path / "survivors.txt", "w") as file:
        for name in open_:
            diff = subprocess.run(["mutmut", "show", name], cwd=path, capture_output=True, text=True).stdout
            file.write(f"# {name}\n{diff}\n")
    return open_


def report(names: list[str], diffs: bool) -> str:
    """The kill ratio per target, a pipe table; with ``diffs``, each target's open survivors to its
    ``survivors.txt`` (one ``mutmut show`` each: seconds per survivor)."""
    known = equivalents()
    rows = ["| target | mutants | killed | survived | equivalent | timeout | no tests | not run | kill ratio |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for name in names:
        path = STAGES / name
        if not (path / "mutants").exists():
            continue
        statuses = results(path)
        equivalent = sum(1 for m, s in statuses.items() if s == "survived" and m in known)
        open_ = [m for m, s in statuses.items() if s == "survived" and m not in known]
        survived = len(write_survivors(path, statuses, known) if diffs else open_)
        killed = sum(1 for s in statuses.values() if s == "killed")
        timeout = sum(1 for s in statuses.values() if s == "timeout")
        untested = sum(1 for s in statuses.values() if s == "no tests")
        unrun = len(statuses) - killed - survived - equivalent - timeout - untested
        judged = killed + timeout + survived
        ratio = f"{(killed + timeout) / judged:.1%}" if judged else "-"
        rows.append(f"| {name} | {len(statuses)} | {killed} | {survived} | {equivalent} | {timeout} | {untested} "
                    f"| {unrun} | {ratio} |")
    return "\n".join(rows)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("targets", nargs="*", help=f"targets (default: all): {', '.join(TARGETS)}")
    parser.add_argument("--fresh", action="store_true", help="start each stage over")
    parser.add_argument("--report", action="store_true", help="only print the table of the last runs")
    parser.add_argument("--survivors", action="store_true",
                        help="test again only the last run's survivors and untested mutants (after new tests)")
    parser.add_argument("--diffs", action="store_true", help="write each open survivor's diff to survivors.txt")
    parser.add_argument("--max-children", type=int, default=2, help="mutants tested at once")
    args = parser.parse_args(argv)
    names = args.targets or list(TARGETS)
    unknown = [name for name in names if name not in TARGETS]
    if unknown:
        parser.error(f"unknown target {unknown[0]!r} (one of {', '.join(TARGETS)})")
    if not args.report:
        for name in names:
            path = stage(name, TARGETS[name], args.fresh)
            print(f"== {name}: {' '.join(TARGETS[name].mutate)} with {' '.join(TARGETS[name].tests)}", flush=True)
            env = dict(os.environ, PYTHONPATH="")  # the staged copy, never an installed ftc_mj
            # The survivors and the mutants no test reached: new tests may reach them now.
            again = [m for m, s in results(path).items() if s in ("survived", "no tests")] if args.survivors else []
            if args.survivors and not again:
                continue
            subprocess.run(["mutmut", "run", "--max-children", str(args.max_children), *again], cwd=path, env=env)
    print(report(names, args.diffs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
