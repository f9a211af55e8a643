"""Where speed lives: every compiled (Numba) kernel of the package, behind one boundary and one switch.

**The guarantee.** Every function here is an accelerator of a NumPy definition that lives with its concept
(a method's law in ``ftc_mj.methods``, a metric or a diagnosis step in ``ftc_mj.analysis``, a plant term in
``ftc_mj.effects``, the rigid-body algorithms in ``ftc_mj.robot.nominal.algorithms``): called on the same inputs it
returns what the definition returns to the tolerance its conformance test states, and it checks what it
trusts (dtype, contiguity, shape) at its boundary instead of trusting types. Each accelerator has one
conformance test against its definition (random and edge-case inputs) in ``tests/fast/``.

**The switch.** ``FTC_MJ_FAST=0`` in the environment (read once, at import), or :func:`set_enabled` (False)
before a run is built, runs everything on the NumPy definitions: the fast paths are never compiled or called.
What the switch moves is stated in :data:`SWITCH_TOLERANCE`: nothing in the simulation (every series, extras
and diagnosis array and every campaign detection statistic of a run has the same bits either way), and a
metric by at most 1e-12 of itself (its compiled pass sums in another order than NumPy's). The closed loop
needs no tolerance because every accelerator it calls gives its definition's bits: the rigid-body kernel
(:mod:`ftc_mj.fast.rigid`) equals its NumPy definition (:mod:`ftc_mj.robot.nominal.algorithms`, the same
operations in the same order) bit for bit, so the chattering sliding-mode loops, which amplify a difference of
1e-15 in the nominal model to percents of a converged error, have none to amplify. The one condition is the
platform's: NumPy's float64 ``sin`` and ``cos`` must be the C library's (tested; a NumPy build with SIMD
versions of its own would fail that test first). ``benchmarks/switch_off.py`` checks every shipped scenario
and prints the worst difference per metric; a slow test checks the main job and a scenario per robot.

This module is the only one that sets Numba's process options: importing it sets ``NUMBA_DISABLE_INTEL_SVML=1``
(unless already set) before Numba is imported anywhere in the package, so that compiled loops round as the
scalar C library does (Intel's SVML, where installed, differs in the last bit for some values). A program that
imports Numba before ftc_mj must set the variable itself.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager

os.environ.setdefault("NUMBA_DISABLE_INTEL_SVML", "1")  # before Numba is imported: the module docstring

#: What switching the fast paths off may move, relative to each value, by kind of result: the series, extras
#: and diagnosis arrays of a run and the campaign detection statistics not at all (the same bits), a metric by
#: 1e-12 of itself (a compiled metric pass sums in its own order; its conformance test's tolerance).
SWITCH_TOLERANCE: dict[str, float] = {"series": 0.0, "diagnosis": 0.0, "detection": 0.0, "metric": 1e-12}

_enabled = os.environ.get("FTC_MJ_FAST", "1").strip().lower() not in {"0", "false", "no", "off"}
_announced: set[str] = set()


def enabled() -> bool:
    """Whether the fast paths are used (``FTC_MJ_FAST`` unset or not ``0``; :func:`set_enabled`)."""
    return _enabled


def set_enabled(value: bool) -> None:
    """Use the fast paths (True) or the NumPy definitions only (False) in what is built from now on."""
    global _enabled
    _enabled = bool(value)


@contextmanager
def switched(value: bool) -> Iterator[None]:
    """What is built inside uses the fast paths (True) or the NumPy definitions only (False); the switch as it
    was afterwards (a test or a benchmark comparing the two in one process)."""
    previous = _enabled
    set_enabled(value)
    try:
        yield
    finally:
        set_enabled(previous)


def announce_compilation(what: str, cold: bool, where: str = "Numba's cache") -> None:
    """One line on stderr, once per ``what`` and process, when ``what``'s kernels are about to compile
    (``cold``: the first run on a machine, or after an update), so that the wait is explained and happens once."""
    if what in _announced:
        return
    _announced.add(what)
    if cold:
        print(f"compiling {what} (first run on this machine, some seconds; cached in {where})",
              file=sys.stderr, flush=True)
