"""The one switch and the one announcement (ftc_mj.fast): FTC_MJ_FAST read at import, set_enabled and switched
for what is built later, what switching off moves (SWITCH_TOLERANCE, on the main job and a scenario per robot),
and the first run's line said once per kernel family, only when it will compile."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

from ftc_mj import fast

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow  # a subprocess
@pytest.mark.parametrize(("value", "expected"), [("0", False), ("off", False), ("no", False), ("1", True),
                                                 ("", True), (None, True)])
def test_the_environment_variable_is_read_at_import(value: str | None, expected: bool) -> None:
    env = {key: item for key, item in os.environ.items() if key != "FTC_MJ_FAST"}
    if value is not None:
        env["FTC_MJ_FAST"] = value
    env["PYTHONPATH"] = str(ROOT)
    done = subprocess.run([sys.executable, "-c", "import ftc_mj.fast as f, os; "
                           "print(f.enabled(), os.environ['NUMBA_DISABLE_INTEL_SVML'])"],
                          env=env, capture_output=True, text=True, timeout=120, check=True)
    assert done.stdout.split() == [str(expected), "1"]


def test_switched_sets_the_switch_inside_and_restores_it() -> None:
    before = fast.enabled()
    with fast.switched(False):
        assert not fast.enabled()
        with fast.switched(True):
            assert fast.enabled()
        assert not fast.enabled()
    assert fast.enabled() == before
    with pytest.raises(RuntimeError), fast.switched(not before):
        raise RuntimeError
    assert fast.enabled() == before


def test_the_announcement_is_said_once_and_only_when_cold(monkeypatch, capsys) -> None:
    monkeypatch.setattr(fast, "_announced", set())
    fast.announce_compilation("the warm kernels", False)
    fast.announce_compilation("the cold kernels", True, "/some/cache")
    fast.announce_compilation("the cold kernels", True, "/some/cache")
    assert capsys.readouterr().err.splitlines() == [
        "compiling the cold kernels (first run on this machine, some seconds; cached in /some/cache)"]


def _switch_off_check():
    """``benchmarks/switch_off.py`` as a module (its comparison is what the test asserts)."""
    spec = importlib.util.spec_from_file_location("switch_off", ROOT / "benchmarks" / "switch_off.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("switch_off", module)  # its dataclass looks its module up
    spec.loader.exec_module(module)
    return sys.modules["switch_off"]


@pytest.mark.slow  # closed-loop runs, each twice
@pytest.mark.parametrize(("scenario", "duration"), [
    ("puma_fault.yaml", 10.3),  # the main job, every variant, past the fault's onset (10 s)
    ("two_link_tosmo_simple.yaml", 1.0),
    ("robots/ur5e_fault.yaml", 1.0),
    ("robots/panda_fault.yaml", 1.0),
    ("real/ur10e_pushed.yaml", None),  # a log replay: the observers on a real arm's readings
])
def test_switching_the_fast_paths_off_moves_nothing_but_a_metrics_last_bits(scenario: str, duration) -> None:
    """With the fast paths off (in the same process), every series, extras and diagnosis array and detection
    statistic has the same bits and every metric agrees to SWITCH_TOLERANCE: the chattering sliding-mode loops
    amplify any difference in the nominal model (1e-15 in it moved the TOSMO variants' converged errors by 0.8%),
    so this fails at once if an accelerator of the loop stops giving its definition's bits."""
    check = _switch_off_check()
    differences, _, _ = check.compare(ROOT / "scenarios" / scenario, duration)
    assert {d.kind for d in differences} >= {"series", "metric"}
    assert sum(d.kind == "series" for d in differences) > 20
    outside = [f"{d.variant} {d.kind} {d.name}: {d.relative:.3g}" for d in differences if not d.within]
    assert not outside, outside
