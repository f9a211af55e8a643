"""The bench file: which methods to score, by name, with their gains per robot of the suite. Example::

    suite: v2                      # a shipped suite's version, or a suite file relative to this one
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

import yaml
from pydantic import Field, StrictStr

from ftc_mj.ranking.suite import SUITES, Name, Suite, load_suite
from ftc_mj.campaign.population import digest
from ftc_mj.config.errors import InputError, validate
from ftc_mj.config.types import Strict
from ftc_mj.config.yaml import read_yaml_mapping
from ftc_mj.methods.registry import PluginError, controller_types, observer_types

#: The bench file scored when none is given: every built-in observer and pair on suite v2.
DEFAULT_ENTRIES = Path(__file__).resolve().parent / "suites" / "v2-entries.yaml"
Text = Annotated[StrictStr, Field(min_length=1)]


#: What an observer may read: encoder positions, tachometer velocities, the commanded torque.
Reading = Literal["encoders", "tachometers", "torque"]


class ObserverEntrySpec(Strict):
    #: The observer's registered name: a built-in or an ``ftc_mj.observers`` entry point (default: the entry's
    #: name).
    type: StrictStr | None = None
    #: What it reads (the leaderboard's "reads" column); default: encoders and torque, and tachometers for an
    #: observer that takes the raw readings (overrides ``measure``).
    reads: list[Reading] | None = None
    #: The tuning its gains come from, relative to this file: a tuning file (``ftc-mj tune``'s) or a bench tuning's
    #: record (its ``tuned.yaml``), or a list of them; their runs' seeds may not be ones the suite scores or
    #: calibrates on (suite v2: they are the ``tune`` population's).
    tuned_with: StrictStr | list[StrictStr] | None = None
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
    #: As an observer entry's: the tuning (or tunings) its gains come from (their seeds are checked).
    tuned_with: StrictStr | list[StrictStr] | None = None
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
    suite: StrictStr = "v2"
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
    #: What it reads (diagnosis entries): encoders, tachometers, torque.
    reads: tuple[str, ...] = ()

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


def method_section(file: str, type_field: str, gains_field: str, kind: str, name: str, gains: dict[str, Any],
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


#: What a bench tuning's record (``tuned.yaml`` of :mod:`ftc_mj.ranking.tune`) says it is, in its ``kind``.
TUNING_RECORD = "bench tuning"


def recorded_seeds(path: Path, file: str, field: str) -> set[int] | None:
    """The seeds a bench tuning's record lists; None when ``path`` is no such record.

    Raises:
        InputError: a record without its list of seeds (naming the bench file and ``field``).
    """
    try:
        raw = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError):
        return None
    if not isinstance(raw, dict) or raw.get("kind") != TUNING_RECORD:
        return None
    seeds = raw.get("seeds")
    if not isinstance(seeds, list) or not seeds or not all(type(seed) is int for seed in seeds):
        raise InputError(file, field, f"the tuning record {path.name} lists no seeds (seeds: a list of the "
                         "integers its runs used)")
    return set(seeds)


def tuning_seeds(tuning_file: Path, file: str = "", field: str = "") -> set[int]:
    """Every seed a tuning's runs use: a bench tuning's record lists them (:func:`recorded_seeds`); a campaign
    tuning's are its training conditions' and its held-out check's."""
    from ftc_mj.campaign.population import population
    from ftc_mj.campaign.schema import load_campaign
    from ftc_mj.tuning.schema import load_tuning

    recorded = recorded_seeds(tuning_file, file or str(tuning_file), field or "seeds")
    if recorded is not None:
        return recorded
    tuning = load_tuning(tuning_file)
    campaign = load_campaign(tuning_file.parent / tuning.campaign, tuning.conditions + tuning.held_out)
    seed = campaign.seed if campaign.seed is not None else 0
    return {run.seed for run in population(campaign, seed)[: tuning.conditions + tuning.held_out]}


def check_tuning_seeds(tuning_file: Path, suite: Suite, file: str, field: str) -> None:
    """Refuse a tuning that used a seed the suite scores or calibrates on (suite v2's disjoint populations).

    Raises:
        InputError: naming the bench file, the field and the first shared seed.
    """
    from ftc_mj.ranking.suite import seed_ranges

    if not tuning_file.is_file():
        raise InputError(file, field, f"no such file: {tuning_file}")
    scored = {name: span for name, span in seed_ranges(suite.spec).items() if name != "tune"}
    used = tuning_seeds(tuning_file, file, field)
    for name, span in scored.items():
        shared = sorted(seed for seed in used if seed in span)
        if shared:
            raise InputError(file, field, f"the tuning {tuning_file.name} used seed {shared[0]}, one of the suite "
                             f"{suite.version}'s {name} seeds ({span.start}-{span.stop - 1}): tune on the suite's "
                             "tune seeds, never on scored ones")


def _reads(kind: str) -> tuple[str, ...]:
    """What an observer reads by default: encoders and the command, and the tachometers when it takes the raw
    readings (its class overrides :meth:`~ftc_mj.methods.observers.base.Observer.measure`)."""
    from ftc_mj.methods.observers.base import Observer

    plugin = observer_types()[kind]
    takes_readings = getattr(plugin, "measure", Observer.measure) is not Observer.measure
    return ("encoders", "tachometers", "torque") if takes_readings else ("encoders", "torque")


def builtin_entries(suite: Suite) -> Path:
    """The bench file of the built-in entries of ``suite``: its shipped ``<version>-entries.yaml``, else
    :data:`DEFAULT_ENTRIES` (a suite of one's own on suite v2's robots)."""
    shipped = SUITES / f"{suite.version}-entries.yaml"
    return shipped if shipped.is_file() else DEFAULT_ENTRIES


def _with_builtins(raw: dict[str, Any], spec: BenchSpec, suite: Suite, file: str) -> dict[str, Any]:
    """The bench file's entries and, for each task it scores, every built-in entry of its suite
    (:func:`builtin_entries`), their gains on the suite's robots; a built-in entry's name that the file uses too
    is refused."""
    builtins_path = builtin_entries(suite)
    builtins = read_yaml_mapping(builtins_path, "a bench file")
    merged = dict(raw)
    for task, named in (("diagnosis", spec.diagnosis), ("tracking", spec.tracking)):
        if not named:
            continue
        combined = dict(raw[task])
        for name, entry in (builtins.get(task) or {}).items():
            if name in named:
                raise InputError(file, f"{task}.{name}", f"is also a built-in entry's name ({builtins_path.name}, "
                                 "which --with-builtins adds): rename yours")
            gains = entry["gains"]
            missing = [robot for robot in suite.spec.robots if robot not in gains]
            if missing:
                raise InputError(file, "suite", f"the built-in entries have no gains for robot {missing[0]!r} "
                                 f"(--with-builtins scores {builtins_path.name}'s entries, on the robots "
                                 f"{', '.join(gains)})")
            entry = {**entry, "gains": {robot: gains[robot] for robot in suite.spec.robots}}
            tunings = entry.get("tuned_with")
            if tunings:  # relative to the built-in file, not to this one
                absolute = [str((builtins_path.parent / t).resolve()) for t in
                            ([tunings] if isinstance(tunings, str) else tunings)]
                entry["tuned_with"] = absolute[0] if isinstance(tunings, str) else absolute
            combined[name] = entry
        merged[task] = combined
    return merged


def load_bench(path: str | Path | None = None, with_builtins: bool = False) -> Bench:
    """Read and check a bench file (default: :data:`DEFAULT_ENTRIES`) and its suite; ``with_builtins``: its
    entries and, for each task it scores, every built-in entry of its suite beside them (:func:`_with_builtins`).

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
    if with_builtins:
        raw = _with_builtins(raw, spec, suite, file)
        spec = validate(BenchSpec, raw, file)
    entries = []
    for task, named in (("diagnosis", spec.diagnosis), ("tracking", spec.tracking)):
        for name in named:
            if name.startswith("oracle") or name == "null":
                raise InputError(file, f"{task}.{name}", "oracle* and null are the benchmark's sanity rows (they "
                                 "read the engine's truth): choose another name")
    for task, named in (("diagnosis", spec.diagnosis), ("tracking", spec.tracking)):
        for name, entry in named.items():
            tunings = [entry.tuned_with] if isinstance(entry.tuned_with, str) else entry.tuned_with or []
            for index, tuned_with in enumerate(tunings):
                field = f"{task}.{name}.tuned_with" + (f".{index}" if isinstance(entry.tuned_with, list) else "")
                check_tuning_seeds(path.parent / tuned_with, suite, file, field)
    for name, entry in spec.diagnosis.items():
        field = f"diagnosis.{name}"
        _robots_covered(file, f"{field}.gains", entry.gains, suite)
        kind = entry.type or name
        sections = {robot: method_section(file, f"{field}.type", f"{field}.gains.{robot}", "observer", kind,
                                   entry.gains[robot], suite.joints(robot))
                    for robot in suite.spec.robots}
        entries.append(Entry("diagnosis", name, kind, entry.gains_from, sections,
                             tuple(entry.reads) if entry.reads is not None else _reads(kind)))
    for name, entry in spec.tracking.items():
        field = f"tracking.{name}"
        _robots_covered(file, f"{field}.gains", entry.gains, suite)
        sections = {}
        for robot in suite.spec.robots:
            gains, n = entry.gains[robot], suite.joints(robot)
            section = {role: method_section(file, f"{field}.{role}", f"{field}.gains.{robot}.{role}", role, method,
                                     getattr(gains, role), n)
                       for role, method in (("observer", entry.observer), ("controller", entry.controller))}
            if entry.controller_velocity is not None:
                section["controller_velocity"] = entry.controller_velocity
            sections[robot] = section
        entries.append(Entry("tracking", name, f"{entry.observer} + {entry.controller}", entry.gains_from, sections))
    return Bench(path=path, spec=spec, suite=suite, entries=entries)
