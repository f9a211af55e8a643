"""Scenario files to a validated, compiled scenario: the top-level schema that assembles every concept's own
section, its compilation, and :func:`~ftc_mj.scenario.loading.load_scenario`."""
