"""Diagnosis thresholds calibrated per arm: per-joint fixed thresholds that hold a chosen per-run false-alarm
rate on healthy runs of a scenario.

It runs the engine (healthy members of the scenario, stepped together as one batch), so it sits with the
campaigns, above the engine, and below the command line (``ftc-mj calibrate``).

The healthy scenario is the scenario without its faults: fault terms (``terms`` of kind ``fault``) and
``actuator_faults`` removed; sensor effects (noise, quantisation) kept, since they are part of the healthy
arm. Its members differ in their seed only (seed ``first_seed + k`` for member k), so the population is the
arm's own healthy variability: its noise and whatever the seed draws.

For each joint j, variant v and run, the diagnoser's alarm logic (:mod:`ftc_mj.analysis.diagnosis`) raises an
alarm once the residual r_j stays above the threshold for P consecutive samples (``persistence``) after the
diagnoser is armed. With a threshold fixed_j + bound_j(t) (the scenario's adaptive bound kept, ``k`` set to
0), a run raises a false alarm on joint j exactly when

    S_j = max over armed windows of P samples of  min over the window of (r_j(t) - bound_j(t))

exceeds fixed_j. The calibrated fixed_j is the (1 - p) quantile of S_j over the healthy runs, the threshold
whose per-run false-alarm probability on joint j is p. S_j is a maximum over many samples, so its quantile
is taken from a Gumbel distribution fitted by moments (location mu = mean - 0.5772 beta, scale
beta = sd sqrt(6) / pi; quantile mu - beta ln(-ln(1 - p))), which extrapolates to rates below 1/runs where an
empirical quantile cannot; where the runs resolve the rate (runs p >= 1) the threshold is at least the
empirical quantile too (a tail the fit misses stays covered). The report gives the empirical exceedance on
the calibration runs beside it. A fixed threshold cannot be negative: where the quantile is below 0 (the
residual stays below the adaptive bound by a margin: the bound alone already raises fewer false alarms than
the target, and detects later than a threshold at the target would), the threshold is 0 and the report says
so. One
threshold per joint serves every variant (the ``diagnosis`` section is the scenario's): the largest of the
variants' values, so every variant holds the rate at most.

**On a log** (a scenario with a ``log`` section: :func:`calibrate_log`) there is one healthy run, the log: no
rate can be estimated from it. The threshold of joint j is ``margin`` times S_j of the log (at least the
scenario's ``threshold.floor``): the largest residual the log holds for the persistence, with a margin for
motions it did not show. Set on a log not used to identify the model (``ftc-mj identify``), it says how the
thresholds hold on data the model was not fitted to.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ftc_mj.config.errors import InputError
from ftc_mj.engine.members import members_from_overrides
from ftc_mj.engine.runner import run_batch
from ftc_mj.results import VariantResult
from ftc_mj.scenario.loading import load_scenario
from ftc_mj.scenario.definition import MAX_SEED, Scenario

#: Euler-Mascheroni constant: the mean of the standard Gumbel distribution.
_EULER_GAMMA = 0.5772156649015329
#: The calibration's seeds start this far above the scenario's own, away from the seeds its runs use.
SEED_OFFSET = 1000
#: The most healthy runs of one calibration: they resolve rates down to 1e-4 (the Gumbel fit extrapolates
#: below); more is a typo, and their seeds alone would fill the memory.
MAX_RUNS = 10_000


@dataclass
class Calibration:
    """Per-joint fixed thresholds for a per-run false-alarm rate, and what they were made from."""

    scenario: Path
    false_alarm_rate: float
    seeds: list[int]
    joints: list[str]
    #: Per variant (and monitor), S of every run that finished, ``(runs, n)``.
    statistics: dict[str, np.ndarray]
    #: Per variant, the threshold of each joint.
    per_variant: dict[str, np.ndarray]
    #: The thresholds to use: per joint, the largest over the variants (>= 0).
    thresholds: np.ndarray
    #: Runs that diverged (left out of the statistics), per variant.
    diverged: dict[str, int]
    #: Joints whose quantile is below 0: the scenario's bound alone stays below the target rate there (a
    #: lower bound would detect sooner at the same rate).
    bound_above_target: list[str] = dataclasses.field(default_factory=list)
    #: On a log (:func:`calibrate_log`): the margin on its largest residual, and the log; else None.
    margin: float | None = None
    log: Path | None = None

    def empirical_rate(self) -> dict[str, np.ndarray]:
        """Per variant and joint, the share of the calibration runs whose S exceeds the threshold."""
        return {name: (s > self.thresholds).mean(axis=0) for name, s in self.statistics.items()}


def healthy_scenario(path: Path, overrides: Sequence[str] = (), duration: float | None = None,
                     variants: Sequence[str] = ()) -> Scenario:
    """The scenario without its faults (fault terms and actuator faults), its threshold reduced to its bound
    (``fixed`` 0, ``k`` 0), for the statistics S (module docstring).

    Raises:
        InputError: a scenario without a ``diagnosis`` section, or any problem of the file.
    """
    scenario = load_scenario(path, overrides=list(overrides), duration=duration, variants=list(variants))
    file = str(path)
    if scenario.diagnoser is None:
        raise InputError(file, "diagnosis", "the scenario has no diagnosis section: nothing to calibrate")
    terms = [term for term in scenario.written("terms") or [] if term.get("kind") != "fault"]
    # A log has neither (it refuses the sections): it is healthy as it is.
    assignments: dict[str, Any] = {} if scenario.log is not None else {"actuator_faults": [], "terms": terms}
    healthy = load_scenario(path, overrides=list(overrides), duration=duration, variants=list(variants),
                            assignments=assignments)
    zero = np.zeros(healthy.n_joints)
    return dataclasses.replace(healthy, diagnoser=dataclasses.replace(healthy.diagnoser, fixed=zero, k=0.0))


def exceedance_statistics(scenario: Scenario, seeds: Sequence[int]) -> tuple[dict[str, np.ndarray], dict[str, int]]:
    """S per run, joint and variant (or monitor) on the members of ``seeds`` of a :func:`healthy_scenario`;
    and per variant the number of runs that diverged (left out)."""
    persistence = scenario.diagnoser.persistence
    statistics: dict[str, list[np.ndarray]] = {}
    diverged: dict[str, int] = {}

    def take(member: int, results: list[VariantResult]) -> None:
        for result in results:
            for one in (result, *result.monitors):
                statistics.setdefault(one.name, [])
                diverged.setdefault(one.name, 0)
                if one.status != "ok":
                    diverged[one.name] += 1
                else:
                    statistics[one.name].append(_statistic(one.diagnosis, persistence))

    run_batch(scenario, members_from_overrides(scenario, [{"seed": int(seed)} for seed in seeds]), on_result=take)
    n = scenario.n_joints
    return {name: np.array(values).reshape(-1, n) for name, values in statistics.items()}, diverged


def _statistic(diagnosis, persistence: int) -> np.ndarray:
    """S_j of one run: the largest value the margin r - bound stays above for ``persistence`` samples."""
    armed = diagnosis.armed
    margin = (diagnosis.residual - diagnosis.threshold)[armed]  # the threshold is the bound alone here
    if len(margin) < persistence:
        return np.full(margin.shape[1], -np.inf)
    if persistence > 1:
        margin = np.lib.stride_tricks.sliding_window_view(margin, persistence, axis=0).min(axis=-1)
    return margin.max(axis=0)


def _check_armed_samples(scenario: Scenario, file: str) -> None:
    """Refuse runs that end before the diagnoser has ``persistence`` armed samples: no alarm can be raised,
    so no threshold can be measured (it would be NaN)."""
    diagnoser = scenario.diagnoser
    armed = int(np.count_nonzero(scenario.times >= diagnoser.start))
    if armed < diagnoser.persistence:
        raise InputError(file, "duration", f"the runs end at {scenario.spec.duration:g} s, with {armed} samples "
                         f"after the diagnoser is armed at {diagnoser.start:g} s (diagnosis.baseline.end or "
                         f"diagnosis.start), fewer than its persistence of {diagnoser.persistence}: no false alarm "
                         "can be measured; lengthen the run (--duration)")


def gumbel_quantile(samples: np.ndarray, rate: float) -> np.ndarray:
    """Per column, the value a Gumbel distribution fitted by moments exceeds with probability ``rate``."""
    mean, sd = samples.mean(axis=0), samples.std(axis=0, ddof=1) if len(samples) > 1 else np.zeros(samples.shape[1])
    beta = sd * math.sqrt(6.0) / math.pi
    return mean - _EULER_GAMMA * beta - beta * math.log(-math.log1p(-rate))


def threshold_quantile(samples: np.ndarray, rate: float) -> np.ndarray:
    """Per column, the threshold S exceeds with probability ``rate``: the Gumbel quantile, and where the runs
    resolve it (``runs * rate >= 1``) at least the empirical one, so that a tail the fit misses is not
    under-covered."""
    quantile = gumbel_quantile(samples, rate)
    if len(samples) * rate >= 1:
        quantile = np.maximum(quantile, np.quantile(samples, 1.0 - rate, axis=0, method="higher"))
    return quantile


def calibrate(path: Path, *, runs: int, false_alarm_rate: float, overrides: Sequence[str] = (),
              first_seed: int | None = None, variants: Sequence[str] = (),
              duration: float | None = None) -> Calibration:
    """Thresholds from ``runs`` healthy runs of the scenario at ``path`` (module docstring).

    Raises:
        InputError: bad options or a scenario that cannot be calibrated, naming the file and the field.
    """
    file = str(path)
    if not 2 <= runs <= MAX_RUNS:
        raise InputError(file, "--runs", f"must be 2 to {MAX_RUNS}, not {runs}")
    if not 0 < false_alarm_rate < 1:
        raise InputError(file, "--false-alarm-rate", f"must be in (0, 1), not {false_alarm_rate}")
    scenario = healthy_scenario(path, overrides, duration, variants)
    _check_armed_samples(scenario, file)
    first = scenario.spec.seed + SEED_OFFSET if first_seed is None else first_seed
    if not 0 <= first <= MAX_SEED - (runs - 1):
        raise InputError(file, "--first-seed" if first_seed is not None else "seed",
                         f"the healthy runs' seeds {first} to {first + runs - 1} must lie in 0 to {MAX_SEED}"
                         + ("" if first_seed is not None else f" (the scenario's seed + {SEED_OFFSET} on)"))
    seeds = list(range(first, first + runs))
    statistics, diverged = exceedance_statistics(scenario, seeds)
    per_variant = {}
    for name, values in statistics.items():
        if len(values) < 2:
            raise InputError(file, "variants", f"variant {name!r}: {diverged[name]} of {runs} healthy runs "
                                               "diverged; too few left to calibrate")
        per_variant[name] = np.maximum(threshold_quantile(values, false_alarm_rate), 0.0)
    thresholds = np.max(np.stack(list(per_variant.values())), axis=0)
    if not np.all(np.isfinite(thresholds)):  # a residual that is NaN in every run: no threshold to write
        joint = int(np.flatnonzero(~np.isfinite(thresholds))[0])
        raise InputError(file, "diagnosis", f"the healthy runs give no finite threshold for joint {joint + 1} "
                         "(its residual is not finite after the diagnoser is armed)")
    raw_quantiles = np.max(np.stack([threshold_quantile(v, false_alarm_rate) for v in statistics.values()]), axis=0)
    joints = [scenario.model.joint(j).name for j in range(scenario.n_joints)]
    return Calibration(scenario=path, false_alarm_rate=false_alarm_rate, seeds=seeds, joints=joints,
                       statistics=statistics, per_variant=per_variant, thresholds=thresholds, diverged=diverged,
                       bound_above_target=[joint for joint, q in zip(joints, raw_quantiles) if q < 0])


def calibrate_log(path: Path, *, margin: float, overrides: Sequence[str] = (), variants: Sequence[str] = ()
                  ) -> Calibration:
    """Thresholds from the healthy log the scenario at ``path`` replays: per joint ``margin`` times its S over
    the variants, at least the scenario's ``threshold.floor`` (module docstring).

    Raises:
        InputError: a scenario without a log or a diagnosis, or a margin below 1.
    """
    file = str(path)
    if not margin >= 1.0:
        raise InputError(file, "--margin", f"must be at least 1, not {margin:g}")
    scenario = healthy_scenario(path, overrides, None, variants)
    if scenario.log is None:
        raise InputError(file, "log", "calibrating on a log needs a scenario with a log section")
    statistics, diverged = exceedance_statistics(scenario, [scenario.spec.seed])
    floor = np.asarray(scenario.spec.diagnosis.threshold.floor, dtype=float) * np.ones(scenario.n_joints)
    per_variant = {}
    for name, values in statistics.items():
        if not len(values):
            raise InputError(file, "variants", f"variant {name!r} diverged on the log: nothing to calibrate on")
        per_variant[name] = np.maximum(margin * np.maximum(values[0], 0.0), floor)
    thresholds = np.max(np.stack(list(per_variant.values())), axis=0)
    joints = [scenario.model.joint(j).name for j in range(scenario.n_joints)]
    return Calibration(scenario=path, false_alarm_rate=float("nan"), seeds=[], joints=joints,
                       statistics=statistics, per_variant=per_variant, thresholds=thresholds, diverged=diverged,
                       margin=margin, log=scenario.log.file)


def scenario_fragment(calibration: Calibration, written_to: Path, base: bool = True) -> str:
    """A scenario file (valid YAML, runnable as it is) that is the calibrated scenario with the calibrated
    thresholds: ``base:`` the scenario (relative to ``written_to``'s folder), ``diagnosis.threshold.fixed``
    per joint and ``k`` 0 (the scenario's adaptive ``bound`` kept).

    Without ``base``, the thresholds alone: a fragment a scenario names as its own ``base:``, whose
    ``diagnosis.threshold`` then gives neither ``fixed`` nor ``k`` (its own values would win the merge)."""
    thresholds = [float(f"{value:.6g}") for value in calibration.thresholds]
    if calibration.margin is not None:
        lines = [f"# Per-joint diagnosis thresholds: {calibration.margin:g} times the largest residual of the healthy "
                 f"log {calibration.log.name}",
                 f"# held for the persistence, over the variants {', '.join(calibration.per_variant)} (at least the "
                 "threshold floor), by ftc-mj calibrate."]
    else:
        lines = [f"# Per-joint diagnosis thresholds for a per-run false-alarm rate of "
                 f"{calibration.false_alarm_rate:g} per joint,",
                 f"# calibrated on {len(calibration.seeds)} healthy runs (faults removed; seeds "
                 f"{calibration.seeds[0]}-{calibration.seeds[-1]}) by ftc-mj calibrate."]
    lines += [f"# Joints: {', '.join(calibration.joints)}. The same values on the command line:",
             f"#   --set diagnosis.threshold.fixed=[{', '.join(f'{t:g}' for t in thresholds)}] "
             "--set diagnosis.threshold.k=0"]
    document: dict[str, Any] = {"diagnosis": {"threshold": {"fixed": thresholds, "k": 0.0}}}
    if base:
        document = {"base": os.path.relpath(calibration.scenario.resolve(), written_to.resolve().parent),
                    **document}
    return "\n".join(lines) + "\n" + yaml.safe_dump(document, sort_keys=False, default_flow_style=None)
