"""Running a compiled scenario: the closed loop of one variant, the results it leaves, and ``run_scenario``,
the library's one entry point for running every variant."""
