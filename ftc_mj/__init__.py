"""ftc_mj: a physics-in-the-loop testbed for fault diagnosis and fault-tolerant control of robot manipulators.

Run a scenario with ``python -m ftc_mj.run scenarios/puma_fault.yaml``; see README.md. As a library::

    from ftc_mj import load_scenario, run_scenario

    results = run_scenario(load_scenario("scenarios/puma_fault.yaml"))

Bad input raises :class:`InputError` (one line naming the file, the field and the problem).
"""

from ftc_mj.engine.runner import run_scenario
from ftc_mj.config.errors import InputError
from ftc_mj.spec.loading import load_scenario

__version__ = "0.1.0"

__all__ = ["InputError", "load_scenario", "run_scenario"]
