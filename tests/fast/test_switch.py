"""The one switch and the one announcement (ftc_mj.fast): FTC_MJ_FAST read at import, set_enabled and switched
for what is built later, and the first run's line said once per kernel family, only when it will compile."""

from __future__ import annotations

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
