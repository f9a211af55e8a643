"""The benchmark's scores of one entry on one robot, from its runs' rows, each with a 95% interval.

Diagnosis (per run, the threshold-free statistics of :func:`ftc_mj.analysis.diagnosis.detection_statistics`;
z is the diagnoser's residual over its threshold, held for its persistence, so that an alarm is raised at c
times the threshold iff z > c):

* a healthy run's **peak** is its largest z on any joint; a faulty run's is its largest z after the onset on
  the faulty joint. A run whose method diverged alarms on a healthy run (peak +inf) and misses a fault (0);
* ``auc``: the area under the empirical ROC of the healthy against the faulty peaks, every observed peak a
  threshold (the Mann-Whitney statistic: the probability that a faulty run's peak exceeds a healthy run's,
  ties counting half); a perfect detector scores 1, a random one 1/2. Bootstrap interval, healthy and faulty
  runs resampled apart;
* ``pd_at_pfa``: the detection probability at the lowest threshold whose false-alarm probability is at most
  :data:`FALSE_ALARM_PROBABILITY` (Wilson interval over the faulty runs);
* ``detection_rate`` and ``specificity`` (1 - false-alarm rate) at the method's own threshold (c = 1),
  Wilson intervals over the faulty and the healthy runs;
* ``isolation_accuracy``: the DX competition's convention: among the faulty runs detected at c = 1, the share
  whose isolated joints are exactly the faulty ones (Wilson);
* ``delay_median``, ``delay_p95``: of the first alarm after the onset on the faulty joint, over the detected
  runs [s] (order-statistic intervals, :func:`ftc_mj.campaign.statistics.percentile`);
* ``false_alarms_per_hour``: alarms raised at c = 1 per hour of armed healthy operation, the mean over the
  healthy runs of their rates (they last alike; bootstrap).

Tracking (per run, the metrics of :mod:`ftc_mj.analysis.metrics`, joints combined as the arm's RMS):

* ``rms_healthy``, ``rms_faulty``: sqrt(mean over joints of ``rms_error_converged``^2) over the healthy and the
  faulty runs [rad] (bootstrap of the mean); a run that diverged counts at the capped penalty
  :data:`DIVERGED_RMS` (never left out, which would flatter the method that diverges), and so does any RMS
  above it;
* ``rms_faulty_median``: the median of the faulty runs' RMS (the mean is heavy-tailed: one fault kind can make
  it); per fault kind the medians and which entry wins each kind are in the leaderboard
  (:func:`kind_medians`);
* ``fault_peak``: the largest ``fault_peak_error`` of the faulty joints [rad];
* ``chattering``: the mean over joints of ``chattering`` [N m / s] on the healthy runs;
* ``divergence_rate``: the share of runs that diverged (Wilson); ``fault_peak`` and ``chattering`` leave them out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ftc_mj.campaign import statistics as st

#: The false-alarm probability at which the detection probability is read off the ROC.
FALSE_ALARM_PROBABILITY = 0.05
BOOTSTRAP = 2000
#: The AUC's bootstrap draws from this seed, so that a leaderboard is the same each time it is made.
BOOTSTRAP_SEED = 20221130

#: Score -> (label, unit, higher is better); the order of the leaderboard's columns.
DIAGNOSIS_SCORES: dict[str, tuple[str, str, bool]] = {
    "auc": ("AUC", "", True),
    "pd_at_pfa": (f"P_d at P_fa <= {FALSE_ALARM_PROBABILITY:g}", "", True),
    "detection_rate": ("detection rate (c = 1)", "", True),
    "specificity": ("specificity (c = 1)", "", True),
    "isolation_accuracy": ("isolation accuracy", "", True),
    "delay_median": ("delay median", "s", False),
    "delay_p95": ("delay p95", "s", False),
    "false_alarms_per_hour": ("false alarms per hour", "1/h", False),
}
TRACKING_SCORES: dict[str, tuple[str, str, bool]] = {
    "rms_healthy": ("RMS error, healthy", "rad", False),
    "rms_faulty": ("RMS error, faulty", "rad", False),
    "rms_faulty_median": ("RMS error, faulty, median", "rad", False),
    "fault_peak": ("fault peak error", "rad", False),
    "chattering": ("chattering", "N m/s", False),
    "divergence_rate": ("divergence rate", "", False),
}
#: The RMS error [rad] a diverged run counts at (and the cap of every run's): a tracking error of a radian on
#: every joint is a lost task, whatever larger number the run reached before it stopped.
DIVERGED_RMS = 1.0
#: The score each task's leaderboard is ranked by.
RANKED_BY = {"diagnosis": "auc", "tracking": "rms_faulty"}


@dataclass(frozen=True)
class Score:
    value: float
    low: float
    high: float
    #: The number of runs (or detected faults) it is estimated from.
    count: int

    @classmethod
    def of(cls, estimate: st.Estimate, count: int) -> "Score":
        return cls(float(estimate.value), float(estimate.low), float(estimate.high), int(count))

    @classmethod
    def missing(cls) -> "Score":
        return cls(np.nan, np.nan, np.nan, 0)


@dataclass(frozen=True)
class DiagnosisRuns:
    """One entry's diagnosis runs on one robot, per run (healthy and faulty apart)."""

    #: Largest held level z of each healthy run; +inf where the run diverged.
    healthy_peak: np.ndarray
    #: Alarms raised at c = 1 and armed healthy seconds of each healthy run.
    healthy_alarms: np.ndarray
    healthy_seconds: np.ndarray
    #: Largest held level z after the onset on the faulty joint of each faulty run; 0 where it diverged.
    fault_peak: np.ndarray
    #: Delay of the first alarm at c = 1 on the faulty joint (NaN: missed).
    fault_delay: np.ndarray
    #: Whether the isolated joints at c = 1 are exactly the faulty ones.
    isolated_right: np.ndarray


def roc_curve(healthy: np.ndarray, fault: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The empirical ROC: false-alarm and detection probability (:func:`ftc_mj.campaign.statistics.roc`) at
    every observed peak as threshold and one below them all. An infinite peak (a diverged run) alarms at
    every threshold: it is ranked above every finite peak."""
    peaks = np.concatenate([healthy, fault])
    finite = peaks[np.isfinite(peaks)]
    top = finite.max() + 1.0 if finite.size else 1.0
    healthy, fault = np.where(np.isinf(healthy), top, healthy), np.where(np.isinf(fault), top, fault)
    observed = np.concatenate([healthy, fault])
    thresholds = np.unique(np.concatenate([[observed.min() - 1.0], observed]))
    return st.roc(healthy, fault, thresholds)


def auc(healthy: np.ndarray, fault: np.ndarray) -> float:
    """The area under the empirical ROC (:func:`roc_curve`, :func:`ftc_mj.campaign.statistics.auc`)."""
    if healthy.size == 0 or fault.size == 0:
        return np.nan
    return st.auc(*roc_curve(healthy, fault))


def operating_threshold(healthy: np.ndarray, target: float = FALSE_ALARM_PROBABILITY) -> float:
    """The lowest threshold c (a healthy peak, or 0) at which at most ``target`` of the healthy runs alarm
    (peak > c)."""
    candidates = np.unique(np.concatenate([[0.0], healthy[np.isfinite(healthy)]]))
    for c in candidates:
        if np.mean(healthy > c) <= target:
            return float(c)
    return np.inf  # more than ``target`` of the runs diverged


def mann_whitney(healthy: np.ndarray, fault: np.ndarray) -> float:
    """P(fault peak > healthy peak) + P(equal) / 2: the empirical ROC's area, computed from ranks."""
    h = np.sort(healthy)
    below = np.searchsorted(h, fault, side="left")
    equal = np.searchsorted(h, fault, side="right") - below
    return float((below + 0.5 * equal).sum() / (h.size * fault.size))


def _bootstrap_auc(healthy: np.ndarray, fault: np.ndarray, resamples: int) -> tuple[float, float]:
    """The AUC's percentile interval, healthy and faulty runs resampled apart."""
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    values = np.empty(resamples)
    for b in range(resamples):
        values[b] = mann_whitney(healthy[rng.integers(0, healthy.size, healthy.size)],
                                 fault[rng.integers(0, fault.size, fault.size)])
    tail = (1 - st.CONFIDENCE) / 2 * 100
    low, high = np.percentile(values, [tail, 100 - tail])
    return float(low), float(high)


def diagnosis_scores(runs: DiagnosisRuns, resamples: int = BOOTSTRAP) -> dict[str, Score]:
    """Every diagnosis score (see the module docstring)."""
    healthy, fault = runs.healthy_peak, runs.fault_peak
    out = {name: Score.missing() for name in DIAGNOSIS_SCORES}
    if healthy.size and fault.size:
        value = auc(healthy, fault)
        out["auc"] = Score(value, *_bootstrap_auc(healthy, fault, resamples), int(healthy.size + fault.size))
        c = operating_threshold(healthy)
        out["pd_at_pfa"] = Score.of(st.proportion(float(np.sum(fault > c)), fault.size), fault.size)
    if fault.size:
        detected = fault > 1.0
        out["detection_rate"] = Score.of(st.proportion(float(detected.sum()), fault.size), fault.size)
        if detected.any():
            n = int(detected.sum())
            out["isolation_accuracy"] = Score.of(st.proportion(float(runs.isolated_right[detected].sum()), n), n)
        delays = runs.fault_delay[detected & np.isfinite(runs.fault_delay)]
        if delays.size:
            s = st.summarise(delays, resamples)
            out["delay_median"], out["delay_p95"] = Score.of(s.median, s.count), Score.of(s.p95, s.count)
    if healthy.size:
        out["specificity"] = Score.of(st.proportion(float(np.sum(healthy <= 1.0)), healthy.size), healthy.size)
        armed = runs.healthy_seconds > 0
        if armed.any():
            rates = runs.healthy_alarms[armed] / (runs.healthy_seconds[armed] / 3600.0)
            s = st.summarise(rates, resamples)
            out["false_alarms_per_hour"] = Score.of(s.mean, s.count)
    return out


@dataclass(frozen=True)
class TrackingRuns:
    """One pair's tracking runs on one robot: per-run metrics, NaN where a run diverged."""

    healthy_rms: np.ndarray
    faulty_rms: np.ndarray
    fault_peak: np.ndarray
    chattering: np.ndarray
    diverged: np.ndarray  # every run, healthy and faulty
    #: Each faulty run's fault kind ("" where unknown).
    faulty_kind: np.ndarray | None = None


def tracking_scores(runs: TrackingRuns, resamples: int = BOOTSTRAP) -> dict[str, Score]:
    """Every tracking score (see the module docstring)."""
    out = {}
    healthy, faulty = capped(runs.healthy_rms), capped(runs.faulty_rms)
    for name, values in (("rms_healthy", healthy), ("rms_faulty", faulty),
                         ("fault_peak", runs.fault_peak), ("chattering", runs.chattering)):
        s = st.summarise(values, resamples)
        out[name] = Score.of(s.mean, s.count) if s.count else Score.missing()
    s = st.summarise(faulty, resamples)
    out["rms_faulty_median"] = Score.of(s.median, s.count) if s.count else Score.missing()
    n = int(runs.diverged.size)
    out["divergence_rate"] = Score.of(st.proportion(float(runs.diverged.sum()), n), n) if n else Score.missing()
    return out


def capped(rms: np.ndarray) -> np.ndarray:
    """RMS values with a diverged run (NaN) and any value above it at :data:`DIVERGED_RMS`."""
    values = np.asarray(rms, dtype=float)
    return np.where(np.isnan(values), DIVERGED_RMS, np.minimum(values, DIVERGED_RMS))


def kind_medians(runs: TrackingRuns) -> dict[str, float]:
    """The median capped faulty RMS per fault kind [rad]."""
    if runs.faulty_kind is None:
        return {}
    faulty = capped(runs.faulty_rms)
    return {str(kind): float(np.median(faulty[runs.faulty_kind == kind])) for kind in np.unique(runs.faulty_kind)}


def arm_rms(per_joint: np.ndarray) -> np.ndarray:
    """Per run, the arm's RMS from the joints' RMS values ``(runs, joints)``: sqrt(mean_j rms_j^2)."""
    return np.sqrt(np.mean(np.asarray(per_joint, dtype=float) ** 2, axis=1))
