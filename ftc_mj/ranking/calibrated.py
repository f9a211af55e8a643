"""Suite v2's diagnosis scores: one statistic for healthy and faulty windows, thresholds calibrated per entry on
healthy runs the scoring never sees, intervals clustered by draw. Plain NumPy on the envelopes of
:mod:`ftc_mj.ranking.windows`.

A **stratum** is (robot, faulty joint j, onset o, window length L): a faulty run's window [o, o + L) on joint j
after its fault's onset, and every healthy run's window at the same nominal onset on the same joint. A window's
**peak** is its largest held residual (an alarm at c held for the persistence is raised in it iff peak > c).

* **Threshold** c(s, k) of an entry for stratum s and joint k: the population quantile (NumPy's ``higher``) at
  1 - alpha of the peaks of the ``calibrate`` runs' windows, alpha the suite's common false-alarm probability
  per window and joint; the scored runs never enter it.
* ``auc``: the Mann-Whitney area of the faulty against the healthy windows' z = peak / c(s, j), pooled over the
  strata (per stratum: the raw peaks); 1 perfect, 1/2 useless.
* ``pd``: the share of faulty windows with z > 1 (P_d at the common false-alarm probability); ``false_alarm``:
  the share of the scored healthy windows with z > 1, the realised rate beside the nominal alpha, and
  ``specificity`` = 1 - ``false_alarm``.
* ``isolation``: among detected faulty windows, the share whose alarmed joints (peak > c(s, k), every joint k)
  are exactly the faulty one (the DX competition's convention).
* ``delay_median``: of the first block over c after the onset [s], over the detected windows whose alarm was not
  already on at the onset; ``on_at_onset``: the detected windows whose alarm was on in the block before the onset
  (a false alarm still on, not a detection with delay 0).
* ``alarms_per_hour``: alarms raised (rising edges: alarms re-arm) in the scored healthy windows per hour of them;
  ``latched``: the share of healthy windows whose alarm is on in every block (a latched alarm, not a rate).

Intervals: 95% percentile bootstrap, clustered by draw: a healthy run's windows share its run, and fault cases
that share a draw (a campaign's common random numbers) are resampled together; suite v2 gives each fault case
its own draws (seeds and mass scales), so there its runs are the clusters. The thresholds are held at their
calibrated values. Runs whose reference loop diverged are counted apart and never scored.

Paired comparisons (:func:`paired_differences`): every entry of a robot is a monitor of the same simulated runs,
so two entries' windows are the same windows; the difference of a score between them is resampled with the same
clusters for both (a paired cluster bootstrap), its p-value the percentile interval's inversion, and a family of
such tests adjusted by Holm's step-down (:func:`holm`).
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterator, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from ftc_mj.ranking.score import BOOTSTRAP_SEED, Score, mann_whitney

#: Score -> (label, unit, higher is better): the v2 leaderboard's columns, in order.
SCORES: dict[str, tuple[str, str, bool]] = {
    "auc": ("AUC (pooled windows)", "", True),
    "pd": ("P_d at the common FA", "", True),
    "false_alarm": ("realised FA per window", "", False),
    "specificity": ("specificity", "", True),
    "isolation": ("isolation accuracy", "", True),
    "delay_median": ("delay median", "s", False),
    "on_at_onset": ("alarm on at onset", "", False),
    "alarms_per_hour": ("false alarms per hour", "1/h", False),
    "latched": ("latched healthy windows", "", False),
}
RESAMPLES = 1000
#: The false-alarm probabilities of the delay-against-false-alarm front.
FRONT = (0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.3)


@dataclass(frozen=True)
class Population:
    """One population's windows reduction (a ``windows.npz``), its diverged runs left out."""

    #: ``(runs, blocks, n)`` held-residual envelope per estimator.
    envelopes: dict[str, np.ndarray]
    draw: np.ndarray
    kind: np.ndarray
    size: np.ndarray
    joint: np.ndarray
    onset: np.ndarray
    fault_effect: np.ndarray
    #: Runs left out because the reference loop diverged (by case label where faulty).
    diverged: int
    block_seconds: float
    diverged_cases: dict[str, int] = field(default_factory=dict)

    @classmethod
    def of(cls, data: dict[str, np.ndarray]) -> "Population":
        ok = ~np.isfinite(data["diverged_at"])
        dt, steps = data["times"]
        envelopes = {name.split("/", 1)[1]: values[ok] for name, values in data.items() if name.startswith("envelope/")}
        blocks = next(iter(envelopes.values())).shape[1]
        count = int(ok.size)

        def case(name: str, fill: object) -> np.ndarray:
            values = data.get(f"case/{name}")
            return (values if values is not None else np.full(count, fill))[ok]

        diverged_cases: dict[str, int] = {}
        if "case/kind" in data:
            for kind, size in zip(data["case/kind"][~ok], data["case/fault_size"][~ok]):
                label = f"{kind} {float(size):g}"
                diverged_cases[label] = diverged_cases.get(label, 0) + 1
        return cls(envelopes, data["draw"][ok], case("kind", ""), case("fault_size", np.nan).astype(float),
                   case("fault_joint", 0).astype(int), case("onset", np.nan).astype(float), data["fault_effect"][ok],
                   int((~ok).sum()), float(dt * steps / blocks), diverged_cases)


@dataclass(frozen=True)
class Stratum:
    joint: int  # 1-based
    onset: float
    length: float

    @property
    def label(self) -> str:
        return f"j{self.joint} t{self.onset:g} L{self.length:g}"


def strata(onsets: list[float], joints: list[int], lengths: list[float]) -> list[Stratum]:
    return [Stratum(j, o, L) for o, j in zip(onsets, joints) for L in lengths]


def _blocks(stratum: Stratum, block_seconds: float) -> slice:
    first = int(round(stratum.onset / block_seconds))
    return slice(first, first + max(1, int(round(stratum.length / block_seconds))))


def peaks(envelope: np.ndarray, stratum: Stratum, block_seconds: float) -> np.ndarray:
    """Each run's window peak on every joint, ``(runs, n)`` (0 where a window holds nothing finite)."""
    window = envelope[:, _blocks(stratum, block_seconds)]
    finite = np.isfinite(window)
    return np.where(finite.any(axis=1), np.max(np.where(finite, window, -np.inf), axis=1), 0.0).astype(float)


def quantile_threshold(values: np.ndarray, alpha: float) -> np.ndarray:
    """The population quantile at 1 - alpha along axis 0 (NumPy's ``higher``: an observed peak, the
    :func:`threshold_rank`-th smallest of the n values).

    A fresh healthy peak exceeds the k-th smallest of n exchangeable continuous peaks with probability
    (n + 1 - k) / (n + 1) on average over the calibration draws (:func:`expected_false_alarm`), whatever their
    law. At the suite's alpha = 0.05 that is 2/33 = 0.061 for n = 32 (the quick tier) and 13/257 = 0.051 for
    n = 256 (the full tier); the distribution-free conformal rank k = ceil((n + 1)(1 - alpha)), which keeps the
    rate at or below alpha, gives 1/33 = 0.030 and 12/257 = 0.047: further from the nominal at both, so the
    rule stays NumPy's ``higher``."""
    if values.shape[0] == 0:
        return np.full(values.shape[1:], np.inf)
    return np.quantile(values, 1.0 - alpha, axis=0, method="higher")


def threshold_rank(n: int, alpha: float) -> int:
    """The rank k (1-based, of n ascending values) that :func:`quantile_threshold` returns."""
    return int(np.quantile(np.arange(n), 1.0 - alpha, method="higher")) + 1


def expected_false_alarm(n: int, alpha: float) -> float:
    """The false-alarm probability a threshold calibrated on n peaks gives on average: (n + 1 - k) / (n + 1),
    k = :func:`threshold_rank` (exact for exchangeable continuous peaks)."""
    return (n + 1 - threshold_rank(n, alpha)) / (n + 1)


def threshold_spread(n: int, alpha: float) -> float:
    """The standard deviation, from one calibration to another, of the false-alarm probability a threshold from
    n peaks gives: that of Beta(n + 1 - k, k), k = :func:`threshold_rank` (the spread no scored run removes)."""
    a, b = n + 1 - threshold_rank(n, alpha), threshold_rank(n, alpha)
    return float(np.sqrt(a * b / ((a + b) ** 2 * (a + b + 1))))


def false_alarm_law(windows_per_stratum: list[int], n: int, alpha: float) -> np.ndarray:
    """The law of an entry's count of false alarms on its scored healthy windows, its thresholds calibrated on
    n peaks per stratum: per stratum the count over m windows beyond the k-th smallest of n is beta-binomial
    (m, n + 1 - k, k) (the threshold's own spread on top of the binomial's; exact for independent exchangeable
    peaks), the strata independent. Its pmf over 0 .. sum(m)."""
    from scipy.stats import betabinom

    k = threshold_rank(n, alpha)
    pmf = np.ones(1)
    for m in windows_per_stratum:
        pmf = np.convolve(pmf, betabinom.pmf(np.arange(m + 1), m, n + 1 - k, k))
    return pmf


def _two_sided(pmf: np.ndarray, observed: int) -> float:
    """The probability of a count no more likely than the observed one (as SciPy's exact binomial test)."""
    return float(min(1.0, pmf[pmf <= pmf[observed] * (1 + 1e-7)].sum()))


def _off(m: int, alpha: float) -> np.ndarray:
    """Per count 0 .. m of m windows, whether its rate lies beyond two binomial standard errors of alpha."""
    return np.abs(np.arange(m + 1) / m - alpha) > 2 * np.sqrt(alpha * (1 - alpha) / m)


@dataclass(frozen=True)
class FalseAlarmCheck:
    """The realised false-alarm rates of several rows against what calibrated thresholds give by chance."""

    rows: int
    #: Rows whose realised rate lies beyond two binomial standard errors of the nominal one.
    off: int
    #: The off rows chance predicts: with an exact threshold (the binomial alone), and with thresholds estimated
    #: from the calibration's n peaks (:func:`false_alarm_law`).
    expected_exact: float
    expected_calibrated: float
    #: P(at least ``off`` off rows) under the calibrated law, the rows independent (they are not quite: every
    #: entry reads the same runs).
    p_value: float
    #: Rows whose count differs from the calibrated law at 5% family-wise (Holm's step-down).
    holm_rejected: tuple[str, ...]


def false_alarm_check(rows: dict[str, tuple[int, list[int], int]], alpha: float) -> FalseAlarmCheck:
    """``rows``: name -> (its false alarms, its scored healthy windows per stratum, the calibration peaks per
    stratum n); alpha the nominal rate."""
    from scipy.stats import binom

    off, p_exact, p_calibrated, p_rows = 0, [], [], {}
    for name, (count, per_stratum, n) in rows.items():
        m = int(sum(per_stratum))
        if m == 0:
            continue
        flags = _off(m, alpha)
        law = false_alarm_law(per_stratum, n, alpha)
        off += int(flags[count])
        p_exact.append(float(binom.pmf(np.arange(m + 1), m, alpha)[flags].sum()))
        p_calibrated.append(float(law[flags].sum()))
        p_rows[name] = _two_sided(law, count)
    count_law = np.ones(1)  # the number of off rows: a Poisson-binomial
    for p in p_calibrated:
        count_law = np.convolve(count_law, [1 - p, p])
    adjusted = dict(zip(p_rows, holm(list(p_rows.values()))))
    rejected = tuple(name for name, _ in sorted(p_rows.items(), key=lambda item: item[1]) if adjusted[name] <= 0.05)
    return FalseAlarmCheck(len(p_rows), off, float(sum(p_exact)), float(sum(p_calibrated)),
                           float(count_law[off:].sum()), rejected)


def pooled_false_alarm(windows: list[Windows], clusters: list[str], resamples: int = RESAMPLES
                       ) -> Score:
    """The realised false-alarm rate over every row's scored healthy windows, with its 95% interval resampling
    the healthy runs (each ``clusters[i]``'s runs shared by its rows: one robot's entries read the same runs)."""
    sums: dict[tuple[str, int], list[float]] = {}
    for w, cluster in zip(windows, clusters):
        for run in np.unique(w.healthy_cluster):
            mine = w.healthy_cluster == run
            total = sums.setdefault((cluster, int(run)), [0.0, 0.0])
            total[0] += float((w.healthy_z[mine] > 1.0).sum())
            total[1] += float(mine.sum())
    if not sums:
        return Score.missing()
    table = np.array(list(sums.values()))
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    picks = rng.integers(0, len(table), (resamples, len(table)))
    rates = table[picks, 0].sum(axis=1) / table[picks, 1].sum(axis=1)
    return Score(float(table[:, 0].sum() / table[:, 1].sum()), float(np.percentile(rates, 2.5)),
                 float(np.percentile(rates, 97.5)), int(table[:, 1].sum()))


@dataclass
class Windows:
    """One entry's scored windows on one robot, pooled over the strata (one element per window)."""

    #: Healthy windows: z = peak / c on the stratum's joint, the run (cluster) and the stratum index.
    healthy_z: np.ndarray
    healthy_cluster: np.ndarray
    healthy_stratum: np.ndarray
    #: Rising edges over c inside the window, and whether the alarm is on in every block.
    healthy_alarms: np.ndarray
    healthy_latched: np.ndarray
    #: Faulty windows: z, the draw (cluster), the stratum, kind and size, isolated right, delay [s] (NaN: not
    #: detected or on at the onset), alarm on at the onset, acts (the fault put torque on the plant).
    fault_z: np.ndarray
    fault_cluster: np.ndarray
    fault_stratum: np.ndarray
    fault_kind: np.ndarray
    fault_size: np.ndarray
    isolated: np.ndarray
    delay: np.ndarray
    on_at_onset: np.ndarray
    acts: np.ndarray
    window_seconds: np.ndarray = field(default_factory=lambda: np.zeros(0))


def _rising(over: np.ndarray, before: np.ndarray) -> np.ndarray:
    """Rising edges of ``over`` ``(runs, blocks)`` given the state of the block before each window."""
    previous = np.concatenate([before[:, None], over[:, :-1]], axis=1)
    return (over & ~previous).sum(axis=1)


def windows(name: str, calibrate: Population, healthy: Population, faults: Population, layers: list[Stratum],
            alpha: float, acts_at: float) -> tuple[Windows, np.ndarray]:
    """An entry's scored windows (see the module docstring) and its thresholds ``(strata, n)``."""
    bs = healthy.block_seconds
    parts: dict[str, list] = {key: [] for key in Windows.__dataclass_fields__}
    thresholds = []
    for index, stratum in enumerate(layers):
        j = stratum.joint - 1
        c = quantile_threshold(peaks(calibrate.envelopes[name], stratum, bs), alpha)
        thresholds.append(c)
        blocks = _blocks(stratum, bs)
        before = slice(blocks.start - 1, blocks.start)
        # healthy
        env = healthy.envelopes[name][:, :, j]
        z = peaks(healthy.envelopes[name], stratum, bs)[:, j] / c[j]
        over = np.nan_to_num(env[:, blocks], nan=-np.inf) > c[j]
        on_before = (np.nan_to_num(env[:, before], nan=-np.inf) > c[j])[:, 0]
        parts["healthy_z"].append(z)
        parts["healthy_cluster"].append(np.arange(len(z)))
        parts["healthy_stratum"].append(np.full(len(z), index))
        parts["healthy_alarms"].append(_rising(over, on_before))
        parts["healthy_latched"].append(over.all(axis=1))
        parts["window_seconds"].append(np.full(len(z), stratum.length))
        # faulty
        mine = (faults.joint == stratum.joint) & np.isclose(faults.onset, stratum.onset)
        fenv = faults.envelopes[name][mine]
        fpeaks = peaks(fenv, stratum, bs)
        fz = fpeaks[:, j] / c[j]
        detected = fz > 1.0
        alarmed = fpeaks > c[None, :]
        right = alarmed[:, j] & (alarmed.sum(axis=1) == 1)
        fover = np.nan_to_num(fenv[:, blocks, j], nan=-np.inf) > c[j]
        on_onset = (np.nan_to_num(fenv[:, before, j], nan=-np.inf) > c[j])[:, 0] & fover[:, 0]
        first = np.argmax(fover, axis=1)
        delay = np.where(detected & ~on_onset, (blocks.start + first + 1) * bs - stratum.onset, np.nan)
        parts["fault_z"].append(fz)
        parts["fault_cluster"].append(faults.draw[mine])
        parts["fault_stratum"].append(np.full(len(fz), index))
        parts["fault_kind"].append(faults.kind[mine])
        parts["fault_size"].append(faults.size[mine])
        parts["isolated"].append(right)
        parts["delay"].append(delay)
        parts["on_at_onset"].append(on_onset)
        parts["acts"].append(faults.fault_effect[mine, j] >= acts_at)
    return Windows(**{key: np.concatenate(values) if values else np.zeros(0) for key, values in parts.items()}), \
        np.array(thresholds)


# ------------------------------------------------------------------------------------------------ scores


def _point(w: Windows, hours_per_window: np.ndarray) -> dict[str, float]:
    """Every score's value on one (re)sample of windows."""
    out = {name: np.nan for name in SCORES}
    if w.healthy_z.size and w.fault_z.size:
        out["auc"] = mann_whitney(w.healthy_z, w.fault_z)
    if w.fault_z.size:
        detected = w.fault_z > 1.0
        out["pd"] = float(detected.mean())
        if detected.any():
            out["isolation"] = float(w.isolated[detected].mean())
            out["on_at_onset"] = float(w.on_at_onset[detected].mean())
            delays = w.delay[detected & np.isfinite(w.delay)]
            if delays.size:
                out["delay_median"] = float(np.median(delays))
    if w.healthy_z.size:
        out["false_alarm"] = float(np.mean(w.healthy_z > 1.0))
        out["specificity"] = 1.0 - out["false_alarm"]
        out["alarms_per_hour"] = float(w.healthy_alarms.sum() / hours_per_window.sum())
        out["latched"] = float(w.healthy_latched.mean())
    return out


def _take(w: Windows, healthy: np.ndarray, fault: np.ndarray) -> Windows:
    return Windows(**{key: (getattr(w, key)[healthy] if key.startswith("healthy") or key == "window_seconds"
                            else getattr(w, key)[fault]) for key in Windows.__dataclass_fields__})


def _cluster_draws(w: Windows, resamples: int) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """The clustered bootstrap's resamples of ``w``: per resample, the indices of its healthy and of its faulty
    windows, healthy runs and fault draws drawn with replacement as clusters, from :data:`BOOTSTRAP_SEED`. Every
    entry of one robot has the same clusters (its runs), so it is resampled alike: the draws of a pair of entries
    (:func:`paired_differences`) are those of each one's own interval."""
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    h_ids, h_inverse = np.unique(w.healthy_cluster, return_inverse=True)
    f_ids, f_inverse = np.unique(w.fault_cluster, return_inverse=True)
    h_members = [np.flatnonzero(h_inverse == i) for i in range(h_ids.size)]
    f_members = [np.flatnonzero(f_inverse == i) for i in range(f_ids.size)]
    for _ in range(resamples):
        h = np.concatenate([h_members[i] for i in rng.integers(0, len(h_members), len(h_members))]) \
            if h_members else np.zeros(0, int)
        f = np.concatenate([f_members[i] for i in rng.integers(0, len(f_members), len(f_members))]) \
            if f_members else np.zeros(0, int)
        yield h, f


def _percentiles(values: list[float], alpha: float = 0.05) -> tuple[float, float]:
    """The percentile interval at 1 - ``alpha`` of a bootstrap's finite values (NaN, NaN when none is)."""
    finite = np.asarray(values, dtype=float)
    finite = finite[np.isfinite(finite)]
    tail = 50.0 * alpha
    return (float(np.percentile(finite, tail)), float(np.percentile(finite, 100.0 - tail))) if finite.size \
        else (np.nan, np.nan)


def clustered(w: Windows, statistic: Callable[[Windows], dict[str, float]], resamples: int = RESAMPLES
              ) -> dict[str, tuple[float, float]]:
    """Each statistic's 95% percentile interval, healthy runs and fault draws resampled as clusters."""
    draws: dict[str, list[float]] = {}
    for h, f in _cluster_draws(w, resamples):
        for name, value in statistic(_take(w, h, f)).items():
            draws.setdefault(name, []).append(value)
    return {name: _percentiles(values) for name, values in draws.items()}


def scores(w: Windows, resamples: int = RESAMPLES) -> dict[str, Score]:
    """Every v2 diagnosis score with its clustered interval."""
    def statistic(sample: Windows) -> dict[str, float]:
        return _point(sample, sample.window_seconds / 3600.0)

    values = statistic(w)
    intervals = clustered(w, statistic, resamples)
    counts = {"auc": w.healthy_z.size + w.fault_z.size, "pd": w.fault_z.size, "isolation": int((w.fault_z > 1).sum()),
              "on_at_onset": int((w.fault_z > 1).sum()), "delay_median": int(np.isfinite(w.delay).sum())}
    return {name: Score(values[name], *intervals.get(name, (np.nan, np.nan)), counts.get(name, w.healthy_z.size))
            if np.isfinite(values[name]) else Score.missing() for name in SCORES}


def per_stratum(w: Windows, count: int) -> list[dict[str, float]]:
    """Per stratum: AUC on the raw peaks (z of one stratum is the peak over one threshold), P_d and the realised
    false-alarm rate, with the windows' numbers."""
    out = []
    for s in range(count):
        h, f = w.healthy_z[w.healthy_stratum == s], w.fault_z[w.fault_stratum == s]
        out.append({"auc": mann_whitney(h, f) if h.size and f.size else np.nan,
                    "pd": float(np.mean(f > 1)) if f.size else np.nan,
                    "false_alarm": float(np.mean(h > 1)) if h.size else np.nan, "healthy": h.size, "faulty": f.size})
    return out


def detectability(w: Windows, kind: str = "bias") -> list[tuple[float, float, float, float, int]]:
    """P_d at the common false-alarm probability against the fault size of one kind: (size, P_d, low, high,
    windows), Wilson intervals."""
    from ftc_mj.campaign import statistics as st

    out = []
    mine = w.fault_kind == kind
    for size in np.unique(w.fault_size[mine]):
        chosen = mine & (w.fault_size == size)
        estimate = st.proportion(float((w.fault_z[chosen] > 1).sum()), int(chosen.sum()))
        out.append((float(size), float(estimate.value), float(estimate.low), float(estimate.high), int(chosen.sum())))
    return out


def front(name: str, calibrate: Population, healthy: Population, faults: Population, layers: list[Stratum],
          acts_at: float, levels: tuple[float, ...] = FRONT) -> list[tuple[float, float, float, float]]:
    """The delay-against-false-alarm front: per nominal false-alarm probability, (nominal, realised FA on the
    scored healthy windows, P_d, median delay [s] of the detected windows)."""
    out = []
    for alpha in levels:
        w, _ = windows(name, calibrate, healthy, faults, layers, alpha, acts_at)
        point = _point(w, w.window_seconds / 3600.0)
        out.append((alpha, point["false_alarm"], point["pd"], point["delay_median"]))
    return out


def per_kind(w: Windows) -> dict[str, float]:
    """P_d at the common false-alarm probability per fault kind (all sizes)."""
    return {str(kind): float(np.mean(w.fault_z[w.fault_kind == kind] > 1)) for kind in np.unique(w.fault_kind)}


#: A tuned entry's name: its design-rule entry's and this suffix (the leaderboard pairs them).
TUNED_SUFFIX = "_tuned"


def design_row(name: str, names: Collection[str]) -> str | None:
    """The design-rule row a tuned row ``<name>_tuned`` is compared with, where that row is among ``names``;
    None for any other row."""
    design = name.removesuffix(TUNED_SUFFIX)
    return design if design != name and design in names else None


def apart(tuned: Score, design: Score, higher_is_better: bool = True) -> str:
    """A tuned row against its design-rule row on one score: ``better`` only when the tuned row's interval lies
    wholly on the better side of the design row's (its low end above the other's high end, strictly, where
    higher is better), ``worse`` when wholly on the other side, ``not apart`` otherwise (overlapping or touching
    intervals, or a missing one)."""
    if not all(np.isfinite(v) for v in (tuned.low, tuned.high, design.low, design.high)):
        return "not apart"
    above, below = tuned.low > design.high, tuned.high < design.low
    if above or below:
        return "better" if above == higher_is_better else "worse"
    return "not apart"


def same_windows(a: Windows, b: Windows) -> bool:
    """Whether two entries' windows are the same windows, element by element: the same runs (healthy clusters)
    and draws (fault clusters), strata, fault cases and acting faults. So are any two entries of one robot's
    board: monitors of the same simulated runs (the reference loop's, which no monitor changes; seeds and run ids
    depend on the run alone, :mod:`ftc_mj.ranking.execute`), their windows in the same order."""
    keys = ("healthy_cluster", "healthy_stratum", "window_seconds", "fault_cluster", "fault_stratum", "fault_kind",
            "fault_size", "acts")
    return all(np.array_equal(getattr(a, key), getattr(b, key)) for key in keys)


@dataclass(frozen=True)
class Difference:
    """One score's paired difference between two entries scored on the same windows (first less second)."""

    value: float
    #: 95% percentile interval of the difference, both entries resampled with the same clusters.
    low: float
    high: float
    #: Two-sided bootstrap p-value of no difference (:func:`bootstrap_p_value`).
    p_value: float
    resamples: int

    def as_dict(self) -> dict[str, float]:
        return {"difference": self.value, "low": self.low, "high": self.high, "p_value": self.p_value,
                "resamples": self.resamples}


def bootstrap_p_value(differences: np.ndarray) -> float:
    """The two-sided p-value of no difference from a bootstrap's differences: twice the smaller share of them on
    either side of 0 (ties count on both sides), the inversion of the percentile interval (the smallest alpha
    whose 1 - alpha interval excludes 0; Davison and Hinkley 1997, Bootstrap Methods and their Application,
    ch. 4), with the Monte Carlo correction (k + 1) / (B + 1) so that B draws never claim p = 0 (North, Curtis and
    Sham 2002, Am. J. Hum. Genet. 71(2), 439-441). 1 where every difference is 0 (an entry against itself) or
    none is finite."""
    finite = differences[np.isfinite(differences)]
    if finite.size == 0:
        return 1.0
    beyond = min(int((finite <= 0).sum()), int((finite >= 0).sum()))
    return float(min(1.0, 2.0 * (beyond + 1) / (finite.size + 1)))


def paired_differences(a: Windows, b: Windows, names: Sequence[str] = ("auc", "pd"), resamples: int = RESAMPLES
                       ) -> dict[str, Difference]:
    """Each score of ``names`` (:data:`SCORES`): entry a's less entry b's on the same windows, with its 95%
    paired clustered percentile interval and bootstrap p-value.

    A paired cluster bootstrap: each resample draws the healthy runs and fault draws once (:func:`_cluster_draws`,
    the seed of every interval) and scores both entries on the same resampled windows, so that what the two
    entries share (the run's trajectory, its mass scale, its fault) cancels in the difference as it does in the
    data; the marginal intervals' overlap ignores that pairing and calls apart only differences far larger than
    either interval's half-width. Chosen over DeLong et al. (1988, Biometrics 44(3), 837-845: the paired AUCs'
    covariance from their placement values) because it keeps the windows' clustering (DeLong's treats windows as
    independent, and windows of one run are not: tests/ranking/test_clustered_coverage.py) and because one
    resampling serves every score (P_d too), the thresholds held at their calibrated values as in
    :func:`clustered`.

    Raises:
        ValueError: the two entries' windows are not the same (:func:`same_windows`): nothing to pair.
    """
    if not same_windows(a, b):
        raise ValueError("the two entries were not scored on the same windows (runs, draws, strata): not paired")
    hours = a.window_seconds / 3600.0
    first, second = _point(a, hours), _point(b, hours)
    draws: dict[str, list[float]] = {name: [] for name in names}
    for h, f in _cluster_draws(a, resamples):
        first_draw, second_draw = _point(_take(a, h, f), hours[h]), _point(_take(b, h, f), hours[h])
        for name in names:
            draws[name].append(first_draw[name] - second_draw[name])
    out = {}
    for name in names:
        values = np.asarray(draws[name], dtype=float)
        out[name] = Difference(float(first[name] - second[name]), *_percentiles(draws[name]),
                               bootstrap_p_value(values), resamples)
    return out


def holm(p_values: Sequence[float]) -> np.ndarray:
    """Holm's (1979) step-down adjusted p-values, in the order given: the i-th smallest p times (m + 1 - i), made
    non-decreasing, capped at 1. A hypothesis is rejected at family-wise level alpha iff its adjusted p-value is
    at most alpha, whatever the dependence between the tests (Holm, Scand. J. Statist. 6(2), 65-70)."""
    p = np.asarray(p_values, dtype=float)
    order = np.argsort(p, kind="stable")
    adjusted = np.empty_like(p)
    adjusted[order] = np.minimum(1.0, np.maximum.accumulate((p.size - np.arange(p.size)) * p[order]))
    return adjusted


def paired_resamples(tests: int, alpha: float = 0.05) -> int:
    """The paired bootstrap's resamples for a family of ``tests``: its smallest p-value, 2 / (B + 1), a fifth of
    Holm's first threshold alpha / tests at most (so that a difference no resample crosses 0 is called apart),
    and never fewer than the intervals' :data:`RESAMPLES`."""
    return max(RESAMPLES, int(np.ceil(10.0 * tests / alpha)) - 1)


def paired_verdict(difference: Difference, adjusted_p: float, higher_is_better: bool = True,
                   alpha: float = 0.05) -> str:
    """``better`` or ``worse`` when the family-wise adjusted p-value is at most alpha (the difference's side and
    the score's direction say which), ``not apart`` otherwise."""
    if not (np.isfinite(difference.value) and adjusted_p <= alpha) or difference.value == 0:
        return "not apart"
    return "better" if (difference.value > 0) == higher_is_better else "worse"


def tuned_verdict(verdicts: list[str]) -> str:
    """One verdict from each score's (:func:`apart`): better when some interval is apart above and none below."""
    if "better" in verdicts and "worse" not in verdicts:
        return "better"
    if "worse" in verdicts and "better" not in verdicts:
        return "worse"
    return "mixed" if "better" in verdicts else "not apart"


def chance_interval(healthy: int, faulty: int, level: float = 0.95) -> tuple[float, float]:
    """The ``level`` range of a useless detector's AUC: 1/2 +- z sd, sd = sqrt((n_h + n_f + 1) / (12 n_h n_f)) the
    Mann-Whitney statistic's under no difference between the healthy and the faulty windows (z = 1.96 at 95%).
    An AUC outside the 95% range is one that chance alone gives in 5% of samples; the bootstrap's percentile
    interval, on a dozen faulty windows, is narrower than that (it missed 1/2 for a noise row at AUC 0.35,
    z = -1.5). A claim over several robots at once takes the family-wise level (Bonferroni: 1 - 0.05 / robots)."""
    sd = np.sqrt((healthy + faulty + 1) / (12.0 * max(healthy, 1) * max(faulty, 1)))
    z = float(stats.norm.ppf(0.5 + level / 2.0))
    return 0.5 - z * sd, 0.5 + z * sd


def consistent_with_chance(auc: float, healthy: int, faulty: int, level: float = 0.95) -> bool:
    low, high = chance_interval(healthy, faulty, level)
    return bool(low <= auc <= high)


@dataclass(frozen=True)
class Gate:
    """The sanity rows' verdict on one robot: each condition and whether it holds."""

    oracle_fault_auc: float
    oracle_fault_pd: float
    null_auc: tuple[float, float, float]
    #: Entries whose AUC interval lies above oracle_luaf's (none where the pipeline is sound).
    beating_oracle_luaf: tuple[str, ...]
    #: The range of AUC chance gives null's windows (:func:`chance_interval`).
    chance: tuple[float, float] = (0.0, 1.0)

    @property
    def null_at_chance(self) -> bool:
        """null's AUC is 1/2 within its interval: the bootstrap's, or the range chance gives its windows."""
        return bool(self.null_auc[1] <= 0.5 <= self.null_auc[2]
                    or self.chance[0] <= self.null_auc[0] <= self.chance[1])

    @property
    def passed(self) -> bool:
        return bool(self.oracle_fault_auc >= 0.99 and self.oracle_fault_pd >= 0.95 and self.null_at_chance
                    and not self.beating_oracle_luaf)

    def conditions(self) -> list[tuple[str, bool]]:
        return [(f"oracle_fault AUC {self.oracle_fault_auc:.3f} >= 0.99", bool(self.oracle_fault_auc >= 0.99)),
                (f"oracle_fault P_d {self.oracle_fault_pd:.3f} >= 0.95 on faults that act",
                 bool(self.oracle_fault_pd >= 0.95)),
                (f"null AUC {self.null_auc[0]:.3f} [{self.null_auc[1]:.3f}, {self.null_auc[2]:.3f}] at chance "
                 f"(1/2 in its interval, or the AUC in chance's range [{self.chance[0]:.3f}, {self.chance[1]:.3f}])",
                 self.null_at_chance),
                ("no entry's AUC interval above oracle_luaf's" + (f" (above: {', '.join(self.beating_oracle_luaf)})"
                                                                   if self.beating_oracle_luaf else ""),
                 not self.beating_oracle_luaf)]


def gate(by_entry: dict[str, dict[str, Score]], acting: dict[str, Windows]) -> Gate:
    """The sanity gate from every row's scores (sanity rows included) and the rows' windows (oracle_fault's,
    and null's for the range chance gives)."""
    oracle = acting["oracle_fault"]
    acts = oracle.acts
    fault_only = _take(oracle, np.arange(oracle.healthy_z.size), np.flatnonzero(acts))
    point = _point(fault_only, fault_only.window_seconds / 3600.0)
    null = by_entry["null"]["auc"]
    ceiling = by_entry["oracle_luaf"]["auc"].high
    beating = tuple(name for name, s in by_entry.items() if name not in ("oracle_luaf", "oracle_fault", "null")
                    and np.isfinite(s["auc"].low) and s["auc"].low > ceiling)
    windows = acting["null"] if "null" in acting else oracle
    return Gate(point["auc"], point["pd"], (null.value, null.low, null.high), beating,
                chance_interval(windows.healthy_z.size, windows.fault_z.size))
