"""Scenario files to a validated, compiled scenario: the schema's building blocks, the one-line input errors,
the safe expression language, the YAML loader with ``--set`` overrides, and the compile orchestration."""
