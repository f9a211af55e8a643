"""ftc_mj: a physics-in-the-loop testbed for fault diagnosis and fault-tolerant control of robot manipulators.

Run a scenario with ``python -m ftc_mj.run scenarios/puma_fault.yaml``; see README.md.
"""

__version__ = "0.1.0"
