"""The metrics registry: every metric a name, a unit, a window and a NumPy definition, found by name.

A metric is one function registered with :func:`metric`::

    from ftc_mj.analysis.registry import metric

    @metric("peak_torque", unit="N m", window="the whole run")
    def peak_torque(run):
        \"\"\"The largest |commanded torque|.\"\"\"
        return np.max(np.abs(run.tau), axis=0)

A ``series`` metric (the default) takes the run's recorded series (:class:`ftc_mj.analysis.metrics.Samples`:
each ``(T, W, n)``, W results side by side) and returns ``(W, n)``; a ``diagnosis`` metric takes a diagnosed run
(:class:`ftc_mj.analysis.diagnosis.DiagnosedRun`) and returns ``(n,)``. Once registered it is in every run's
table and ``--json``, a campaign's rows and statistics, and the docs' metrics page (its docstring is its
definition there). The order of :data:`METRICS` is the registration order, the series metrics first.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

Kind = Literal["series", "diagnosis"]


@dataclass(frozen=True)
class Metric:
    """One registered metric."""

    name: str
    unit: str
    #: The samples it looks at, in words (the docs' metrics page).
    window: str
    #: The NumPy definition (the module docstring).
    definition: Callable
    kind: Kind = "series"

    @property
    def doc(self) -> str:
        """The definition's docstring, on one line."""
        return " ".join((self.definition.__doc__ or "").split())


#: Every metric by name, in registration order.
REGISTRY: dict[str, Metric] = {}


def metric(name: str, unit: str, window: str, kind: Kind = "series") -> Callable[[Callable], Callable]:
    """Register the decorated NumPy function as the metric ``name`` (the module docstring); a name already
    registered is refused."""
    def register(definition: Callable) -> Callable:
        if name in REGISTRY:
            raise ValueError(f"metric {name!r} is registered already")
        REGISTRY[name] = Metric(name, unit, window, definition, kind)
        return definition
    return register


def unregister(name: str) -> None:
    """Remove the metric ``name`` (a plugin's or a test's own)."""
    del REGISTRY[name]


def of_kind(kind: Kind) -> list[Metric]:
    """The registered metrics of one kind, in registration order."""
    return [m for m in REGISTRY.values() if m.kind == kind]


class _Names(Sequence[str]):
    """The registered metrics' names, series then diagnosis, read at every use (a metric registered later is
    in it)."""

    def _names(self) -> list[str]:
        return [m.name for m in of_kind("series")] + [m.name for m in of_kind("diagnosis")]

    def __getitem__(self, index):  # type: ignore[override]
        return self._names()[index]

    def __len__(self) -> int:
        return len(REGISTRY)

    def __contains__(self, name: object) -> bool:
        return name in REGISTRY

    def __iter__(self) -> Iterator[str]:
        return iter(self._names())

    def __repr__(self) -> str:
        return repr(tuple(self._names()))


class _Units(Mapping[str, str]):
    """Each registered metric's unit, read at every use."""

    def __getitem__(self, name: str) -> str:
        return REGISTRY[name].unit

    def __iter__(self) -> Iterator[str]:
        return iter(METRICS)

    def __len__(self) -> int:
        return len(REGISTRY)


#: Every metric's name (a live view of :data:`REGISTRY`).
METRICS: Sequence[str] = _Names()
#: Every metric's unit for display (a live view of :data:`REGISTRY`).
UNITS: Mapping[str, str] = _Units()
