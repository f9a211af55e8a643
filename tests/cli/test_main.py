"""The ``ftc-mj`` command family (:mod:`ftc_mj.cli.main`): the installed script's entry, every command's help,
a short run through the dispatcher, the older ``python -m ftc_mj.<command>`` forms, and a bad option as one
line with exit status 2."""

from __future__ import annotations

import importlib
import json
import os
import re
import subprocess
import sys
import tomllib
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from ftc_mj.cli.main import COMMANDS, main

ROOT = Path(__file__).resolve().parents[2]
SHORT_RUN = [str(ROOT / "scenarios" / "two_link_do.yaml"), "--duration", "0.05", "--no-record", "--quiet"]
#: The older command lines and the command each one is.
OLD_FORMS = {"ftc_mj.run": "run", "ftc_mj.figures": "figures", "ftc_mj.report": "report", "ftc_mj.tune": "tune",
             "ftc_mj.campaign": "campaign"}


def python(*args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, cwd=cwd, timeout=300,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})


def script_entry() -> tuple[str, str]:
    """The module and function of pyproject.toml's ``ftc-mj`` script."""
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    module, function = scripts["ftc-mj"].split(":")
    return module, function


@pytest.fixture(scope="module")
def processes() -> dict[str, subprocess.CompletedProcess]:
    """Every subprocess of this file, started together (each spends most of its second importing)."""
    module, function = script_entry()
    script = f"import sys; from {module} import {function}; sys.exit({function}())"  # what the installed script runs
    jobs = {"script --help": ("-c", script, "--help"),
            "script run": ("-c", script, "run", *SHORT_RUN),
            "python -m ftc_mj.run": ("-m", "ftc_mj.run", *SHORT_RUN),
            "python -m ftc_mj.cli --bogus": ("-m", "ftc_mj.cli", "--bogus"),
            "python -m ftc_mj.campaign --bogus": ("-m", "ftc_mj.campaign", "run", "x", "--bogus")}
    for old in OLD_FORMS:
        jobs[f"{old} --help"] = ("-m", old, "--help")
    with ThreadPoolExecutor(max_workers=4) as pool:
        futures = {name: pool.submit(python, *args) for name, args in jobs.items()}
    return {name: future.result() for name, future in futures.items()}


@pytest.mark.slow  # a subprocess
def test_the_script_entry_lists_every_command(processes):
    done = processes["script --help"]
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("usage: ftc-mj ")
    for command, summary in COMMANDS.items():
        assert command in done.stdout and summary.split(":")[0] in done.stdout


def test_every_command_has_a_module_and_help(capsys):
    for command in COMMANDS:
        with pytest.raises(SystemExit) as exit_:
            main([command, "--help"])
        assert exit_.value.code == 0
        out = capsys.readouterr().out
        assert out.startswith(f"usage: ftc-mj {command} "), out


@pytest.mark.slow  # a subprocess
def test_help_loads_no_engine():
    """``--help`` reads no scenario machinery: MuJoCo, the engine and Rerun stay unimported (the figures
    command's help names the formats of :mod:`ftc_mj.outputs.figures`, which loads matplotlib)."""
    code = ("import io, contextlib, json, sys\nfrom ftc_mj.cli.main import main\nloaded = {}\n"
            "for command in sys.argv[1:]:\n"
            "    with contextlib.redirect_stdout(io.StringIO()):\n"
            "        try:\n            main([command, '--help'])\n        except SystemExit:\n            pass\n"
            "    loaded[command] = sorted(m for m in ('mujoco', 'rerun', 'ftc_mj.engine', 'ftc_mj.scenario', 'numpy',"
            " 'matplotlib') if m in sys.modules)\nprint(json.dumps(loaded))")
    light = [c for c in COMMANDS if c != "figures"]
    done = python("-c", code, *light, "figures")
    assert done.returncode == 0, done.stderr
    loaded = json.loads(done.stdout)
    assert all(loaded[c] == [] for c in light), loaded
    assert not {"rerun", "ftc_mj.engine", "ftc_mj.scenario"} & set(loaded["figures"]), loaded


def test_a_short_run_through_the_dispatcher(capsys):
    assert main(["run", *SHORT_RUN]) == 0
    assert capsys.readouterr().out == ""  # --quiet: no table


@pytest.mark.slow  # a subprocess
def test_a_short_run_through_the_script_and_the_old_form(processes):
    for name in ("script run", "python -m ftc_mj.run"):
        done = processes[name]
        assert done.returncode == 0, (name, done.stderr)
        assert done.stdout == "" and done.stderr == "", name


@pytest.mark.slow  # a subprocess
def test_the_old_forms_are_the_same_commands(processes):
    for old, command in OLD_FORMS.items():
        done = processes[f"{old} --help"]
        assert done.returncode == 0, (old, done.stderr)
        assert done.stdout.startswith(f"usage: python -m {old} "), done.stdout
        module = importlib.import_module(f"ftc_mj.cli.{command}")
        options = set(re.findall(r"--[\w-]+", module.build_parser().format_help()))
        assert options and set(re.findall(r"--[\w-]+", done.stdout)) == options, old


@pytest.mark.parametrize("argv", [["--bogus"], ["bogus"], [], *([c, "x", "--bogus"] for c in COMMANDS)])
def test_a_bad_option_is_one_line_and_exit_2(argv, capsys):
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    assert exit_.value.code == 2
    captured = capsys.readouterr()
    prog = f"ftc-mj {argv[0]}" if argv and argv[0] in COMMANDS else "ftc-mj"
    assert captured.out == "" and captured.err.startswith(f"{prog}: error: ") and captured.err.count("\n") == 1, \
        captured.err


@pytest.mark.slow  # a subprocess
def test_the_old_forms_refuse_a_bad_option_in_one_line(processes):
    for name in ("python -m ftc_mj.cli --bogus", "python -m ftc_mj.campaign --bogus"):
        done = processes[name]
        assert done.returncode == 2, (name, done.stderr)
        assert done.stdout == "" and done.stderr.count("\n") == 1 and ": error: " in done.stderr, (name, done.stderr)
