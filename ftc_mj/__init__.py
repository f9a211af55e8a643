"""ftc_mj: a physics-in-the-loop testbed for fault diagnosis and fault-tolerant control of robot manipulators.

Run a scenario with ``ftc-mj run scenarios/puma_fault.yaml``; see README.md and docs/. As a library::

    from ftc_mj import load_scenario, run_scenario

    results = run_scenario(load_scenario("scenarios/puma_fault.yaml"))

Bad input raises :class:`InputError` (one line naming the file, the field and the problem).

The names above are imported on first use (PEP 562), so that importing a light part of the package (the
command lines' ``--help``, :mod:`ftc_mj.config`) does not load MuJoCo and the engine.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ftc_mj.config.errors import InputError
    from ftc_mj.engine.runner import run_scenario
    from ftc_mj.scenario.loading import load_scenario

__version__ = "0.1.0"

__all__ = ["InputError", "load_scenario", "run_scenario"]


def __getattr__(name: str) -> Any:
    if name == "InputError":
        from ftc_mj.config.errors import InputError

        return InputError
    if name == "run_scenario":
        from ftc_mj.engine.runner import run_scenario

        return run_scenario
    if name == "load_scenario":
        from ftc_mj.scenario.loading import load_scenario

        return load_scenario
    raise AttributeError(f"module 'ftc_mj' has no attribute {name!r}")
