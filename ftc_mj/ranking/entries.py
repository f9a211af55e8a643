"""The bench file: which methods to score, by name, with their gains per robot of the suite. Example::

    suite: v1                      # a shipped suite's version, or a suite file relative to this one
    diagnosis:                     # observers, scored in the suite's reference loop
      levant:
        type: levant               # a built-in or a third-party entry point (default: the entry's name)
        gains_from: "Levant 2003's lambdas; L below the switching (scenarios/baselines/...)"
        gains:
          puma560: {order: 2, L: 100.0, use_model: true}
          ...                      # every robot of the suite
    tracking:                      # observer-controller pairs, scored for tracking under faults
      proposed:
        observer: hs_tosmo
        controller: nftsmc
        gains_from: "the shipped scenarios' proposed variant"
        gains:
          puma560: {observer: {D: 22.0, gamma: 5.0}, controller: {beta1: 15.0, ...}}

Untrusted input, as a scenario: unknown fields, an unknown method, a method without gains for a robot (or
with gains for a robot the suite does not have), gains its method refuses: each one line ``FILE: FIELD:
PROBLEM`` (:class:`~ftc_mj.config.errors.InputError`), before anything is written.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import Field, StrictStr

from ftc_mj.ranking.suite import Name, Suite, load_suite
from ftc_mj.campaign.population import digest
from ftc_mj.config.errors import InputError, validate
from ftc_mj.config.types import Strict
from ftc_mj.config.yaml import read_yaml_mapping
from ftc_mj.methods.registry import PluginError, controller_types, observer_types

#: The bench file scored when none is given: every built-in observer and pair on suite v1.
DEFAULT_ENTRIES = Path(__file__).resolve().parent / "suites" / "v1-entries.yaml"
Text = Annotated[StrictStr, Field(min_length=1)]


class ObserverEntrySpec(Strict):
    #: The observer's registered name: a built-in or an ``ftc_mj.observers`` entry point (default: the entry's
    #: name).
    type: StrictStr | None = None
    #: Where the gains come from: the source's design rule, a shipped scenario, or a tuning.
    gains_from: Text
    #: Robot of the suite -> the observer's gains on it; every robot needs its gains.
    gains: dict[StrictStr, dict[str, Any]]


class PairGains(Strict):
    #: The observer's gains.
    observer: dict[str, Any] = {}
    #: The controller's gains.
    controller: dict[str, Any] = {}


class PairEntrySpec(Strict):
    #: The observer's registered name (built-in or ``ftc_mj.observers`` entry point).
    observer: StrictStr
    #: The controller's registered name (built-in or ``ftc_mj.controllers`` entry point).
    controller: StrictStr
    #: Where the gains come from: the source's design rule, a shipped scenario, or a tuning.
    gains_from: Text
    #: The controller's velocity: its observer's estimate (default) or the tachometers'.
    controller_velocity: Literal["estimated", "measured"] | None = None
    #: Robot of the suite -> the pair's gains on it; every robot needs its gains.
    gains: dict[StrictStr, PairGains]


class BenchSpec(Strict):
    #: The versioned suite the entries are scored on (``ftc_mj/ranking/suites/<suite>.yaml``).
    suite: StrictStr = "v1"
    #: Free text.
    description: str = ""
    #: Observers scored on fault diagnosis, by entry name.
    diagnosis: dict[Name, ObserverEntrySpec] = {}
    #: Observer-controller pairs scored on tracking under faults, by entry name.
    tracking: dict[Name, PairEntrySpec] = {}


@dataclass(frozen=True)
class Entry:
    """One method to score on one task: its name, where its gains come from, and per robot the scenario
    section it is (a monitor for diagnosis, a variant for tracking)."""

    task: str
    name: str
    label: str
    gains_from: str
    sections: dict[str, dict[str, Any]]

    def identity(self, robot: str) -> str:
        """What its runs on ``robot`` are made of (its name aside): the key its results are found by."""
        return digest({"task": self.task, "section": self.sections[robot]}, 16)


@dataclass
class Bench:
    path: Path
    spec: BenchSpec
    suite: Suite
    entries: list[Entry]

    def of(self, task: str) -> list[Entry]:
        return [entry for entry in self.entries if entry.task == task]


def _robots_covered(file: str, field: str, gains: dict[str, Any], suite: Suite) -> None:
    robots = list(suite.spec.robots)
    for robot in robots:
        if robot not in gains:
            raise InputError(file, field, f"no gains for robot {robot!r} (the suite {suite.version}'s robots: "
                             f"{', '.join(robots)})")
    for robot in gains:
        if robot not in robots:
            raise InputError(file, f"{field}.{robot}", f"not a robot of the suite {suite.version} (its robots: "
                             f"{', '.join(robots)})")


def _method(file: str, type_field: str, gains_field: str, kind: str, name: str, gains: dict[str, Any],
            n: int) -> dict[str, Any]:
    """A scenario's method section, its plugin found and its gains validated for ``n`` joints."""
    known = observer_types() if kind == "observer" else controller_types()
    if name not in known:
        raise InputError(file, type_field, f"unknown {kind} {name!r} (known: {', '.join(sorted(known))})")
    try:
        plugin = known[name]
    except PluginError as exc:
        raise InputError(file, type_field, str(exc)) from None
    validate(plugin.Config, gains, file, gains_field, context={"n_joints": n})
    return {"type": name, "gains": gains}


def load_bench(path: str | Path | None = None) -> Bench:
    """Read and check a bench file (default: :data:`DEFAULT_ENTRIES`) and its suite.

    Raises:
        InputError: naming the file and the field.
    """
    path = Path(path) if path is not None else DEFAULT_ENTRIES
    file = str(path)
    raw = read_yaml_mapping(path, "a bench file")
    spec = validate(BenchSpec, raw, file)
    if not spec.diagnosis and not spec.tracking:
        raise InputError(file, "diagnosis", "no entries: give diagnosis or tracking entries")
    suite_ref = spec.suite
    if suite_ref.endswith((".yaml", ".yml")):
        suite_ref = str((path.parent / suite_ref).resolve())
    suite = load_suite(suite_ref, file)
    entries = []
    for name, entry in spec.diagnosis.items():
        field = f"diagnosis.{name}"
        _robots_covered(file, f"{field}.gains", entry.gains, suite)
        kind = entry.type or name
        sections = {robot: _method(file, f"{field}.type", f"{field}.gains.{robot}", "observer", kind,
                                   entry.gains[robot], suite.joints(robot))
                    for robot in suite.spec.robots}
        entries.append(Entry("diagnosis", name, kind, entry.gains_from, sections))
    for name, entry in spec.tracking.items():
        field = f"tracking.{name}"
        _robots_covered(file, f"{field}.gains", entry.gains, suite)
        sections = {}
        for robot in suite.spec.robots:
            gains, n = entry.gains[robot], suite.joints(robot)
            section = {role: _method(file, f"{field}.{role}", f"{field}.gains.{robot}.{role}", role, method,
                                     getattr(gains, role), n)
                       for role, method in (("observer", entry.observer), ("controller", entry.controller))}
            if entry.controller_velocity is not None:
                section["controller_velocity"] = entry.controller_velocity
            sections[robot] = section
        entries.append(Entry("tracking", name, f"{entry.observer} + {entry.controller}", entry.gains_from, sections))
    return Bench(path=path, spec=spec, suite=suite, entries=entries)
