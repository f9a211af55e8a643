"""The tests mirror the package (tests/spec, tests/robot, tests/effects, tests/methods, tests/engine,
tests/analysis, tests/outputs; the command line in tests/test_run.py); whole-scenario experiments are in
tests/experiments.

Helpers are imported by bare module name: one used by a single folder sits in it (e.g.
``methods/observers/double_integrator.py``), pytest putting a test file's folder on ``sys.path``; the helper
shared across folders, ``fault_scenarios.py``, sits here, and this folder is put on ``sys.path`` below so it
is importable whichever tests run.
"""

import sys
from pathlib import Path

_TESTS = str(Path(__file__).resolve().parent)
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)


import pytest  # noqa: E402


@pytest.fixture(scope="session", autouse=True)
def compiled_kernels() -> None:
    """Every kernel the shipped scenarios use, compiled (or loaded from Numba's cache) once before any test: the
    tests that start ``ftc-mj`` in a subprocess and read its stderr then see a warm cache, as a user's second
    run does (the first run's one-line announcements have tests of their own, with a fresh cache)."""
    from ftc_mj import load_scenario
    from ftc_mj.engine.loop import simulate
    from ftc_mj.engine.members import single

    scenario = load_scenario(Path(__file__).resolve().parents[1] / "scenarios" / "puma_fault.yaml", duration=0.01)
    simulate(scenario, single(scenario))


@pytest.fixture
def fast_paths():
    """The fast paths on whatever ``FTC_MJ_FAST`` says: for a test of an accelerator's own behaviour (which
    kernel runs, its call sites, the compiled nominal model), not of a result."""
    from ftc_mj import fast

    with fast.switched(True):
        yield
