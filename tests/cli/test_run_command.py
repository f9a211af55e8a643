"""The command line ``ftc-mj run`` (:mod:`ftc_mj.cli.run`), run as a subprocess in tmp_path.

* Bad input (malformed scenario files, bad ``--set``/``--variant``/``--duration``) exits 2 with exactly one
  line on stderr naming the file and the field, no traceback, and nothing written: ``--json out.json
  --out rec.rrd`` are passed so that any write would show in the directory listing.
* A short run writes the JSON (documented structure, all metrics) and the recording and prints the table;
  a diverging variant makes the exit status 1; ``--quiet`` and ``--variant``.

Every subprocess takes about a second (imports), so all of them start together in one module fixture and
the tests only look at the results.

``test_regression_*`` pin bugs found while writing this file, now fixed.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import pytest
import yaml

from ftc_mj.analysis.metrics import METRICS
from ftc_mj.cli.run import main
from ftc_mj.outputs.tables import summary_metrics

#: closed-loop runs and subprocesses of the command line
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
PUMA_YAML = ROOT / "scenarios" / "puma_fault.yaml"
PUMA_MODEL = ROOT / "models" / "puma560.xml"
VARIANTS = ["proposed", "nftsmc_tosmo", "nftsmc_sosmo", "nftsmc"]
OUTPUTS = ["--json", "out.json", "--out", "rec.rrd"]
SHORT = ["--duration", "0.05"]


def reference_data() -> dict:
    """The reference scenario as plain (unshared) data with an absolute model path."""
    data = json.loads(json.dumps(yaml.safe_load(PUMA_YAML.read_text(encoding="utf-8"))))
    data["robot"]["model"] = str(PUMA_MODEL)
    return data


def mutated(dotted: str, value) -> Callable[[], str]:
    def make() -> str:
        data = reference_data()
        parts = dotted.split(".")
        node = data
        for part in parts[:-1]:
            node = node[int(part)] if isinstance(node, list) else node[part]
        node[int(parts[-1]) if isinstance(node, list) else parts[-1]] = value
        return yaml.safe_dump(data, sort_keys=False)

    return make


def text(content: str) -> Callable[[], str]:
    return lambda: content


def appended(extra: str) -> Callable[[], str]:
    return lambda: yaml.safe_dump(reference_data(), sort_keys=False) + extra


REFERENCE = text("")  # marker: use scenarios/puma_fault.yaml itself


@dataclass
class Case:
    scenario: Callable[[], str] | None  # the file's text, REFERENCE for the repository's file, None: no file
    args: list[str]
    field: str | None = None  # expected in the error line
    file_in_message: bool = True
    make_dirs: tuple[str, ...] = ()
    make_files: tuple[str, ...] = ()


@dataclass
class Outcome:
    cwd: Path
    scenario: Path
    returncode: int
    stdout: str
    stderr: str
    before: list[str]
    after: list[str]
    lines: list[str] = field(default_factory=list)

    def json(self) -> dict:
        return json.loads((self.cwd / "out.json").read_text(encoding="utf-8"))


BAD_INPUT = {
    "bad_yaml_syntax": Case(text("name: [unclosed\nduration: 1\n"), OUTPUTS, "line "),
    "unknown_key": Case(mutated("colour", "red"), OUTPUTS, "colour"),
    "wrong_length": Case(mutated("initial.q", [-0.5, -0.5]), OUTPUTS, "initial.q"),
    "duration_negative": Case(mutated("duration", -1), OUTPUTS, "duration"),
    "duration_nan": Case(mutated("duration", float("nan")), OUTPUTS, "duration"),
    "expression_import": Case(mutated("reference.0", "__import__('os').system('touch pwned')"), OUTPUTS,
                              "reference.0"),
    "expression_call": Case(mutated("terms.0.value.0", "open('leak.txt', 'w')"), OUTPUTS, "terms.0.value.0"),
    "expression_attribute": Case(mutated("terms.2.value.1", "q1.real"), OUTPUTS, "terms.2.value.1"),
    "unknown_variant": Case(REFERENCE, ["--variant", "proposed", "kalman", *OUTPUTS], "variants"),
    "set_bad_value": Case(REFERENCE, ["--set", "duration=abc", *OUTPUTS], "duration"),
    "set_bad_index": Case(REFERENCE, ["--set", "initial.q.9=1", *OUTPUTS], "initial.q.9"),
    "duration_option_negative": Case(REFERENCE, ["--duration", "-1", *OUTPUTS], "duration"),
    "duration_option_not_a_number": Case(REFERENCE, ["--duration", "abc", *OUTPUTS], "--duration",
                                         file_in_message=False),
}

#: More bad input, checked in-process through ftc_mj.cli.run.main (the same code path without the second of
#: interpreter start-up per case); an uncaught exception fails the test as a traceback would.
BAD_INPUT_IN_PROCESS = {
    "yaml_is_a_list": Case(text("- name: a\n- name: b\n"), OUTPUTS, None),
    "empty_file": Case(text(""), OUTPUTS, None),
    "duplicate_key": Case(appended("duration: 5.0\n"), OUTPUTS, "duplicate key 'duration'"),
    "unknown_nested_key": Case(mutated("variants.nftsmc.controller.gains.beta9", 1.0), OUTPUTS,
                               "variants.nftsmc.controller.gains.beta9"),
    "wrong_reference_length": Case(mutated("reference", ["0", "0"]), OUTPUTS, "reference"),
    "wrong_gain_length": Case(mutated("variants.nftsmc.controller.gains.beta1", [1.0, 2.0]), OUTPUTS,
                              "variants.nftsmc.controller.gains.beta1"),
    "duration_inf": Case(mutated("duration", float("inf")), OUTPUTS, "duration"),
    "gamma1_out_of_range": Case(mutated("variants.nftsmc.controller.gains.gamma1", 1.5), OUTPUTS,
                                "variants.nftsmc.controller.gains.gamma1"),
    "unknown_observer": Case(mutated("variants.nftsmc.observer.type", "luenberger"), OUTPUTS,
                             "variants.nftsmc.observer.type"),
    "model_not_found": Case(mutated("robot.model", "/nonexistent/puma.xml"), OUTPUTS, "robot.model"),
    "expression_dunder_chain": Case(mutated("terms.2.value.1", "().__class__.__base__.__subclasses__()"),
                                    OUTPUTS, "terms.2.value.1"),
    "expression_eval": Case(mutated("reference.1", "eval('1')"), OUTPUTS, "reference.1"),
    "expression_lambda": Case(mutated("terms.1.value.2", "(lambda: 1)()"), OUTPUTS, "terms.1.value.2"),
    "expression_huge_number": Case(mutated("reference.2", "9**9**9"), OUTPUTS, "reference.2"),
    "set_unknown_key": Case(REFERENCE, ["--set", "variants.proposed.controller.gains.colour=1", *OUTPUTS],
                            "variants.proposed.controller.gains.colour"),
    "set_without_equals": Case(REFERENCE, ["--set", "duration", *OUTPUTS], "--set duration"),
    "set_bad_yaml_value": Case(REFERENCE, ["--set", "duration=[1", *OUTPUTS], "duration"),
    "set_through_a_scalar": Case(REFERENCE, ["--set", "duration.x=1", *OUTPUTS], "duration.x"),
    "set_gain_invalid": Case(REFERENCE, ["--set", "variants.proposed.controller.gains.mu=-1", *OUTPUTS],
                             "variants.proposed.controller.gains.mu"),
    "duration_option_nan": Case(REFERENCE, ["--duration", "nan", *OUTPUTS], "duration"),
    "duration_option_zero": Case(REFERENCE, ["--duration", "0", *OUTPUTS], "duration"),
    "out_is_a_directory": Case(REFERENCE, ["--json", "out.json", "--out", "existing_dir"], "--out",
                               make_dirs=("existing_dir",)),
    "json_is_a_directory": Case(REFERENCE, ["--json", "existing_dir", "--out", "rec.rrd"], "--json",
                                make_dirs=("existing_dir",)),
    "missing_scenario_file": Case(None, OUTPUTS, None),
    # Runs that ask for the impossible: refused before anything is allocated, not a MemoryError or a hang.
    "duration_beyond_memory": Case(REFERENCE, ["--duration", "1e9", *OUTPUTS], "duration"),
    "duration_series_beyond_memory": Case(REFERENCE, ["--duration", "1e5", *OUTPUTS], "duration"),
    "timestep_far_below_control_dt": Case(REFERENCE, ["--set", "timestep=1e-12", *OUTPUTS], "timestep"),
    "control_dt_tiny": Case(REFERENCE, ["--set", "control_dt=1e-12", "--set", "timestep=1e-12", *OUTPUTS],
                            "duration"),
    "delay_longer_than_the_run": Case(REFERENCE, ["--duration", "0.05", "--set",
                                                  "sensors.position.delay_samples=1000000000", *OUTPUTS],
                                      "sensors.position.delay_samples"),
}

GOOD = {
    "short_run": Case(REFERENCE, [*SHORT, *OUTPUTS]),
    "diverging_run": Case(REFERENCE, [*SHORT, "--set", "variants.proposed.controller.gains.mu=1e6", "--json",
                                      "out.json", "--no-record"]),
    "quiet_two_variants": Case(REFERENCE, [*SHORT, "--quiet", "--variant", "proposed", "nftsmc", "--json",
                                           "out.json", "--no-record"]),
}

#: In-process, see BAD_INPUT_IN_PROCESS.
BUGS = {
    # sqrt(q1) parses, but the term is evaluated with math.sqrt at q1 = -0.5
    "runtime_domain_error": Case(mutated("terms.0.value.0", "sqrt(q1)"), [*SHORT, "--variant", "proposed",
                                                                          "--quiet", *OUTPUTS]),
    "division_by_zero_in_reference": Case(mutated("reference.0", "1/0"), OUTPUTS, "reference.0"),
    "recording_fails_after_json": Case(REFERENCE, ["--duration", "0.01", "--variant", "proposed", "--quiet",
                                                   "--json", "out.json", "--out", "a_file/rec.rrd"],
                                       make_files=("a_file",)),
}

SUBPROCESS_CASES = {**BAD_INPUT, **GOOD}


def listing(directory: Path) -> list[str]:
    return sorted(str(p.relative_to(directory)) for p in directory.rglob("*"))


def prepare(directory: Path, case: Case) -> Path:
    """Create the case's files in ``directory``; return the scenario path to pass."""
    for name in case.make_dirs:
        (directory / name).mkdir()
    for name in case.make_files:
        (directory / name).write_text("not a directory\n", encoding="utf-8")
    if case.scenario is REFERENCE:
        return PUMA_YAML
    scenario = directory / "scenario.yaml"
    if case.scenario is not None:
        scenario.write_text(case.scenario(), encoding="utf-8")
    return scenario


def run_case(directory: Path, case: Case) -> Outcome:
    scenario = prepare(directory, case)
    before = listing(directory)
    env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1", "PYTHONPATH": str(ROOT)}  # this checkout's package
    process = subprocess.run(
        [sys.executable, "-m", "ftc_mj.cli", "run", str(scenario), *case.args],
        cwd=directory, capture_output=True, text=True, timeout=180, env=env,
    )
    return Outcome(directory, scenario, process.returncode, process.stdout, process.stderr, before,
                   listing(directory), process.stderr.splitlines())


def run_in_process(directory: Path, case: Case, monkeypatch, capsys) -> Outcome:
    scenario = prepare(directory, case)
    before = listing(directory)
    monkeypatch.chdir(directory)
    capsys.readouterr()
    try:
        returncode = main([str(scenario), *case.args])
    except SystemExit as exit_:  # argparse
        returncode = exit_.code
    captured = capsys.readouterr()
    return Outcome(directory, scenario, returncode, captured.out, captured.err, before, listing(directory),
                   captured.err.splitlines())


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory) -> dict[str, Outcome]:
    directories = {name: tmp_path_factory.mktemp(name) for name in SUBPROCESS_CASES}
    # Slow runs first so they overlap with the many quick bad-input ones.
    order = sorted(SUBPROCESS_CASES, key=lambda name: name not in GOOD)
    with ThreadPoolExecutor(max_workers=max(2, os.cpu_count() or 2)) as pool:
        futures = {name: pool.submit(run_case, directories[name], SUBPROCESS_CASES[name]) for name in order}
        return {name: future.result() for name, future in futures.items()}


# -------------------------------------------------------------------------------------------- bad input


def check_bad_input(case: Case, outcome: Outcome) -> None:
    assert "Traceback" not in outcome.stderr, outcome.stderr
    assert outcome.returncode == 2, outcome.stderr
    assert len(outcome.lines) == 1, outcome.stderr
    line = outcome.lines[0]
    assert line.strip()
    assert "error" in line
    if case.file_in_message:
        assert outcome.scenario.name in line
    if case.field is not None:
        assert case.field in line
    assert outcome.stdout == ""
    assert outcome.after == outcome.before, "bad input wrote something"


@pytest.mark.parametrize("name", list(BAD_INPUT))
def test_bad_input_exits_2_with_one_line_and_writes_nothing(outcomes, name):
    check_bad_input(BAD_INPUT[name], outcomes[name])


@pytest.mark.parametrize("name", list(BAD_INPUT_IN_PROCESS))
def test_more_bad_input_in_process(tmp_path, monkeypatch, capsys, name):
    case = BAD_INPUT_IN_PROCESS[name]
    check_bad_input(case, run_in_process(tmp_path, case, monkeypatch, capsys))


def test_bad_input_messages_have_the_file_field_problem_form(outcomes):
    line = outcomes["wrong_length"].lines[0]
    scenario = outcomes["wrong_length"].scenario
    assert line == f"error: {scenario}: initial.q: has 2 values, the robot has 3 joints"
    line = outcomes["expression_attribute"].lines[0]
    assert line == f"error: {outcomes['expression_attribute'].scenario}: terms.2.value.1: attribute access is not " \
        "allowed in an expression"


def test_expression_import_did_not_run(outcomes):
    outcome = outcomes["expression_import"]
    assert not (outcome.cwd / "pwned").exists()
    assert "not allowed" in outcome.lines[0]


# ------------------------------------------------------------------------------------------ a short run


def test_short_run_writes_json_and_recording(outcomes):
    outcome = outcomes["short_run"]
    assert outcome.returncode == 0, outcome.stderr
    assert "Traceback" not in outcome.stderr
    new_files = sorted(set(outcome.after) - set(outcome.before))
    assert new_files == ["out.json", "rec.rrd"]  # and no temporary files left behind
    recording = (outcome.cwd / "rec.rrd").read_bytes()
    assert recording[:4] == b"RRF2" and len(recording) > 1000
    assert "rec.rrd" in outcome.stderr


def test_short_run_json_structure(outcomes):
    document = outcomes["short_run"].json()
    assert set(document) == {"scenario", "seed", "variants"}
    assert document["scenario"] == "puma_fault"
    assert document["seed"] == yaml.safe_load(PUMA_YAML.read_text(encoding="utf-8")).get("seed", 0)
    assert list(document["variants"]) == VARIANTS
    assert len(METRICS) == 25
    for name, variant in document["variants"].items():
        assert set(variant) == {"status", "diverged_at", "controller_velocity", "metrics", "diagnosis"}, name
        assert variant["controller_velocity"] == "estimated"  # the PUMA of Chapter 5 has no tachometers
        assert variant["status"] == "ok"
        assert variant["diverged_at"] is None
        assert list(variant["metrics"]) == list(METRICS)
        for metric, values in variant["metrics"].items():
            assert isinstance(values, list) and len(values) == 3, (name, metric)
            assert all(v is None or (isinstance(v, float) and math.isfinite(v)) for v in values), (name, metric)


def test_short_run_metric_values_are_plausible(outcomes):
    variants = outcomes["short_run"].json()["variants"]
    for name, variant in variants.items():
        metrics = variant["metrics"]
        # q(0) = -0.5 and q_d(0) = 0: the largest error is at least the initial one; 50 ms is too short to go far.
        assert all(0.5 - 1e-9 <= v < 1.0 for v in metrics["max_error"]), name
        assert all(0.0 < v <= m for v, m in zip(metrics["rms_error"], metrics["max_error"])), name
        assert all(v > 0.0 for v in metrics["rms_torque"]), name
        # The evaluation windows start after 50 ms: undefined, written as null.
        assert metrics["rms_error_converged"] == [None, None, None], name
        assert metrics["chattering"] == [None, None, None], name


def test_short_run_prints_the_summary_on_one_screen(outcomes):
    stdout = outcomes["short_run"].stdout
    for name in VARIANTS:
        assert name in stdout
    for metric in summary_metrics(diagnosis=True):
        assert metric in stdout
    assert "rms_torque" not in stdout  # --metrics all only
    assert "puma_fault" in stdout
    lines = stdout.splitlines()
    assert len(lines) <= 36 and max(len(line) for line in lines) <= 100  # a 100 x 40 terminal, progress beside


def test_metrics_all_prints_every_metric(tmp_path, monkeypatch, capsys):
    case = Case(REFERENCE, ["--duration", "0.01", "--variant", "proposed", "--no-record", "--metrics", "all"])
    outcome = run_in_process(tmp_path, case, monkeypatch, capsys)
    assert outcome.returncode == 0, outcome.stderr
    for metric in METRICS:
        assert metric in outcome.stdout, metric


def test_metrics_names_and_a_bad_name(tmp_path, monkeypatch, capsys):
    case = Case(REFERENCE, ["--duration", "0.01", "--variant", "proposed", "--no-record", "--metrics", "rms_torque"])
    outcome = run_in_process(tmp_path, case, monkeypatch, capsys)
    assert outcome.returncode == 0 and "rms_torque" in outcome.stdout and "chattering" not in outcome.stdout
    case = Case(REFERENCE, ["--duration", "0.01", "--no-record", "--metrics", "rms_torq"])
    outcome = run_in_process(tmp_path, case, monkeypatch, capsys)
    assert outcome.returncode == 2 and outcome.lines == [
        f"error: command line: --metrics: unknown metric 'rms_torq' (summary, all, or among: {', '.join(METRICS)})"]


def test_a_run_ending_before_its_fault_leaves_the_fault_metrics_undefined(tmp_path):
    """A run shortened below its fault's onset: the detection metrics are null in the JSON and ``-`` in the
    table, with one note naming them and the window, never a miss (missed_detection 1, isolation_correct 0)."""
    sys.path.insert(0, str(ROOT / "tests" / "campaign"))
    import small_campaign

    (tmp_path / "s.yaml").write_text(yaml.safe_dump(small_campaign.scenario()))  # fault at 0.3 s
    env = {**os.environ, "PYTHONPATH": str(ROOT), "COLUMNS": "200"}
    done = subprocess.run([sys.executable, "-m", "ftc_mj.run", "s.yaml", "--duration", "0.28", "--no-record",
                           "--json", "out.json", "--metrics", "all", "--variant", "hs"], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    metrics = json.loads((tmp_path / "out.json").read_text())["variants"]["hs"]["metrics"]
    for name in ("missed_detection", "isolation_correct", "detection_delay", "fault_peak_error", "recovery_time"):
        assert metrics[name] == [None, None, None], name
    assert metrics["false_alarms"] == [0.0, 0.0, 0.0] and all(v is not None for v in metrics["rms_error"])
    notes = [line for line in done.stderr.splitlines() if line.startswith("note:")]
    assert len(notes) == 1 and "missed_detection" in notes[0] and "the first fault onset = 0.3 s" in notes[0]
    lines = done.stdout.splitlines()  # the metric's heading, then its row
    row = lines[next(k for k, line in enumerate(lines) if line.startswith("missed_detection")) + 1]
    assert row.split() == ["hs", "-", "-", "-"], row


# --------------------------------------------------------------------------------------------- diverging


def test_diverging_variant_exits_1(outcomes):
    outcome = outcomes["diverging_run"]
    assert outcome.returncode == 1, outcome.stderr
    assert "Traceback" not in outcome.stderr
    variants = outcome.json()["variants"]
    assert list(variants) == VARIANTS
    proposed = variants["proposed"]
    assert proposed["status"] == "diverged"
    assert isinstance(proposed["diverged_at"], float)
    assert 0.0 <= proposed["diverged_at"] < 0.05
    assert list(proposed["metrics"]) == list(METRICS)
    assert all(len(values) == 3 for values in proposed["metrics"].values())
    for name in VARIANTS[1:]:
        assert variants[name]["status"] == "ok", name
        assert variants[name]["diverged_at"] is None, name
    assert "diverged at" in outcome.stdout
    assert not (outcome.cwd / "rec.rrd").exists()  # --no-record
    assert "diverged: variant 'proposed' at t = " in outcome.stderr  # exit 1 says which and when


@pytest.mark.parametrize("override", ["initial.q.0=1e300", "initial.q.0=1e6"])
def test_impossible_initial_state_diverges_at_once_and_says_so_even_quiet(tmp_path, monkeypatch, capsys, override):
    """MuJoCo would reset such a state to the model's and run on; here it is a divergence at t = 0, reported
    on stderr with --quiet too (exit 1 never passes silently)."""
    outcome = run_in_process(tmp_path, Case(REFERENCE, [*SHORT, "--quiet", "--variant", "proposed", "--set",
                                                        override, "--json", "out.json", "--no-record"]),
                             monkeypatch, capsys)
    assert outcome.returncode == 1
    assert outcome.lines == ["diverged: variant 'proposed' at t = 0 s"]
    assert outcome.json()["variants"]["proposed"]["status"] == "diverged"


# ------------------------------------------------------------------------------------ --quiet, --variant


def test_quiet_prints_no_table(outcomes):
    outcome = outcomes["quiet_two_variants"]
    assert outcome.returncode == 0, outcome.stderr
    assert outcome.stdout == ""
    for metric in METRICS:
        assert metric not in outcome.stderr
    assert "proposed" not in outcome.stderr  # no progress display either
    assert outcome.json()["variants"]  # it did run


def test_variant_option_runs_only_those(outcomes):
    outcome = outcomes["quiet_two_variants"]
    assert outcome.returncode == 0, outcome.stderr
    variants = outcome.json()["variants"]
    assert sorted(variants) == ["nftsmc", "proposed"]
    assert all(v["status"] == "ok" for v in variants.values())


def test_variant_option_table_in_process(tmp_path, monkeypatch, capsys):
    case = Case(REFERENCE, ["--duration", "0.01", "--variant", "nftsmc", "proposed", "--no-record"])
    outcome = run_in_process(tmp_path, case, monkeypatch, capsys)
    assert outcome.returncode == 0, outcome.stderr
    assert "proposed" in outcome.stdout and "nftsmc" in outcome.stdout
    assert "nftsmc_tosmo" not in outcome.stdout
    assert "nftsmc_sosmo" not in outcome.stdout
    assert outcome.after == outcome.before  # no --json, --no-record


# ------------------------------------------------------------------------------------------------- BUGs


def run_bug_case(name: str, tmp_path: Path, monkeypatch, capsys) -> Outcome:
    try:
        return run_in_process(tmp_path, BUGS[name], monkeypatch, capsys)
    except Exception as exc:  # what a user sees as a traceback
        pytest.fail(f"BUG: ftc_mj.cli.run.main raised {type(exc).__name__}: {exc}")


def test_regression_runtime_math_error_in_a_term_is_not_a_traceback(tmp_path, monkeypatch, capsys):
    """Was a bug (ftc_mj/engine/loop.py): a term evaluated with the ``math`` module outside its domain
    (sqrt(q1) at q1 = -0.5; likewise 1/(q1 + 0.5), log(q1), exp(1000*qd1)) ended the run in a traceback.
    Now that variant is reported as diverged (exit 1)."""
    outcome = run_bug_case("runtime_domain_error", tmp_path, monkeypatch, capsys)
    assert outcome.returncode == 1


def test_regression_division_by_zero_in_an_expression_is_an_input_error(tmp_path, monkeypatch, capsys):
    """Was a bug (ftc_mj/scenario/expressions.py, parse): "1/0" raised ZeroDivisionError from SymPy, which was not
    turned into an InputError: the command line printed a traceback instead of one line."""
    outcome = run_bug_case("division_by_zero_in_reference", tmp_path, monkeypatch, capsys)
    check_bad_input(BUGS["division_by_zero_in_reference"], outcome)


def test_regression_failed_recording_leaves_no_json(tmp_path, monkeypatch, capsys):
    """Was a bug (ftc_mj/cli/run.py, main): with --out a_file/rec.rrd (a_file a regular file) the exit status was
    2 but out.json had been written. Now the output paths are checked before the run, naming --out."""
    outcome = run_bug_case("recording_fails_after_json", tmp_path, monkeypatch, capsys)
    assert outcome.returncode == 2, outcome.stderr
    assert len(outcome.lines) == 1 and "--out" in outcome.lines[0]
    assert outcome.after == outcome.before, "exit status 2 but files were written"
