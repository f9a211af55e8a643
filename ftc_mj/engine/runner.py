"""Running a compiled scenario: :func:`run_scenario`, the library's one entry point.

The command line (:mod:`ftc_mj.run`), ``studies/`` and ``benchmarks/`` all call it::

    from ftc_mj import load_scenario, run_scenario

    scenario = load_scenario("scenarios/puma_fault.yaml", overrides=["seed=3"])
    results = run_scenario(scenario)  # one VariantResult per variant, each followed by its monitors'

Metrics (:func:`ftc_mj.analysis.metrics.compute_metrics`) and outputs (:mod:`ftc_mj.outputs`) take the results.
"""

from __future__ import annotations

from collections.abc import Callable

from ftc_mj.engine.loop import ProgressCallback, simulate_variant
from ftc_mj.engine.results import VariantResult
from ftc_mj.spec.scenario import Scenario

#: Called with a variant's name when its run starts; returns the callback that the loop then calls with the
#: number of control steps done since the last call (``len(scenario.times)`` in all for a run that finishes).
RunProgress = Callable[[str], ProgressCallback]


def run_scenario(
    scenario: Scenario, *, record_poses: bool = True, progress: RunProgress | None = None
) -> list[VariantResult]:
    """Simulate every variant of ``scenario``, in the scenario's order. Each variant's monitors follow it in
    the list as results of their own (``<variant>.<monitor>``).

    Args:
        scenario: a compiled scenario (:func:`ftc_mj.spec.loading.load_scenario`).
        record_poses: keep the body poses of the first variant, for the recording's 3-D view.
        progress: progress display, e.g. the command line's bars; None: none.
    """
    results = []
    for index, variant in enumerate(scenario.variants):
        advance = None if progress is None else progress(variant.name)
        result = simulate_variant(scenario, variant, record_poses=record_poses and index == 0, progress=advance)
        results.append(result)
        results.extend(result.monitors)  # a column each, beside their host
    return results
