"""The sizes at which one way of doing a thing becomes cheaper than another: every machine-measured crossover
of the package, in one table, each with how it was measured (``benchmarks/`` prints the measurements).

A crossover changes only which of two equivalent forms runs (the same numbers either way, or the same to
the tolerance of their conformance tests), never a result; a machine with other caches or another core count
may have its crossovers elsewhere, at some cost in speed and none in results.
"""

from __future__ import annotations

#: Up to this many rows a state function (a scenario's plant terms, where they are not a compiled program) is
#: evaluated row by row on Python floats, beyond it on whole columns by NumPy (one call per operation).
#: Measured by timing both forms of the shipped scenarios' terms at 1 to 64 rows (``tests/fast`` checks that
#: they agree); the crossover of this evaluation's own costs, not of the engine's.
SCALAR_ROWS = 16

#: Up to this many rows the plant's ``mujoco.batch.Batch`` keeps one MjData per row (``persistent``: a step
#: continues from the stages the last one computed); beyond it one MjData per thread that loads each row's
#: state. A persistent row's MjData is some 25 KB on the PUMA560: a few dozen fit in a core's cache and save
#: the stages computed again, but a campaign batch's hundreds evict the loop's own arrays between two steps.
#: Measured by ``benchmarks/loop_phases.py`` (the physics phase of a 336-row batch, both kinds) and
#: ``benchmarks/step_cost.py`` (a single row, both kinds).
PERSISTENT_ROWS = 32

#: Fewest points per thread for the compiled nominal model to split its points over threads: below it,
#: handing a slice to another thread costs more than evaluating it. Measured by ``benchmarks/loop_phases.py``'s
#: nominal-model phase at batch sizes around it, one and two threads.
POINTS_PER_THREAD = 64

#: From this many rows (members x variants) a chunk on two or more threads is run as two interleaved halves;
#: below it the Python of the two halves contends for the GIL more than their physics overlaps. Measured by
#: ``benchmarks/batch_cost.py`` and ``benchmarks/campaign_cost.py`` on both sides of it.
INTERLEAVED_ROWS = 96

#: Rows whose metrics are computed together, side by side in one compiled pass: few enough that the pass's
#: state per column (some thirty numbers) stays in a core's cache. Measured by ``benchmarks/loop_phases.py``'s
#: metrics phase.
METRICS_ROWS = 64

#: Up to this many joints the nominal model's matrix-vector products (M(q) times a vector, row by row) run as
#: the compiled two-lane sum; beyond it by ``numpy.einsum``, whose SIMD loop is then as cheap. Measured by
#: ``benchmarks/step_phases.py`` (the controller's M(q) product of a single run).
PAIRED_COLUMNS = 7
