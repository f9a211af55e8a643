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
