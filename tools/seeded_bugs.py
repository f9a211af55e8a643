"""Bugs seeded by hand, one at a time, into the baselines, the log plant, the benchmark's scores, a fault's
parameter rate and the detection delay: each must fail the tests of its module. The complement of tools/mutation.py for the bugs a person makes (a sign, a
swapped operand, an exponent, an off-by-one) rather than every operator mutmut can flip.

Usage, from the repository root: ``nice -n 10 python tools/seeded_bugs.py [WORD ...]`` (the bugs whose
description has every WORD; all by default, about half an hour on two busy shared cores); it prints one line per bug and a table. The bugs go into a copy of the repository (a temporary
directory), never into the working tree.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: What the tests need of the repository.
COPIED = ["ftc_mj", "tests", "scenarios", "models", "data", "campaigns", "tuning", "studies", "recordings",
          "pyproject.toml"]


@dataclass(frozen=True)
class Bug:
    what: str
    file: str
    old: str
    new: str
    tests: tuple[str, ...]


M, C = "ftc_mj/methods/observers/", "ftc_mj/methods/controllers/"
A, AT = "ftc_mj/analysis/", ("tests/analysis/test_metrics.py", "tests/analysis/test_metric_edges.py")
DT = ("tests/analysis/test_diagnosis.py", "tests/analysis/test_diagnoser_edges.py",
      "tests/analysis/test_detection_edges.py")
TM, TC = "tests/methods/observers/", "tests/methods/controllers/"
BUGS = [
    Bug("statistics: the bootstrap never draws the last run", "ftc_mj/campaign/statistics.py",
        "integers(0, n, size=(resamples, n))", "integers(0, n - 1, size=(resamples, n))",
        ("tests/campaign/test_statistics_coverage.py",)),
    Bug("statistics: a claim holds on one of its two criteria (and -> or)", "ftc_mj/campaign/statistics.py",
        "if d.high < 0 and w.low > 0.5:", "if d.high < 0 or w.low > 0.5:", ("tests/campaign/test_verdicts.py",)),
    Bug("momentum: C^T qd - G as G - C^T qd", M + "momentum.py",
        "np.subtract(model.coriolis_transpose, model.gravity,", "np.subtract(model.gravity, model.coriolis_transpose,",
        (TM + "test_momentum.py",)),
    Bug("terms: a fault whose rate is a parameter enters with the wrong sign", "ftc_mj/effects/terms.py",
        "                if sign > 0:\n", "                if sign < 0:\n", ("tests/effects/test_terms.py",)),
    Bug("diagnosis: the detection delay from the first fault onset, not the joint's own", A + "diagnosis.py",
        "out[0, j] = t[detected] - onset", "out[0, j] = t[detected] - first_fault", DT),
    Bug("momentum: z integrates tau - r instead of tau + r", M + "momentum.py",
        "rate = np.add(tau, self.residual, out=self._rate)", "rate = np.subtract(tau, self.residual, out=self._rate)",
        (TM + "test_momentum.py",)),
    Bug("ndob: the estimate fed back with the wrong sign", M + "ndob.py",
        "        rate += self.luaf_hat", "        rate -= self.luaf_hat", (TM + "test_ndob.py",)),
    Bug("kalman: P11 += K1 P01 instead of -=", M + "kalman.py",
        "np.subtract(P11, np.multiply(K1, P01, out=term), out=posterior[3])",
        "np.add(P11, np.multiply(K1, P01, out=term), out=posterior[3])", (TM + "test_kalman.py",)),
    Bug("kalman: K2 = P02 / P00 instead of / S", M + "kalman.py",
        "np.divide(P02, S, out=K2)", "np.divide(P02, P00, out=K2)", (TM + "test_kalman.py",)),
    Bug("levant: the correction term added instead of subtracted", M + "levant.py",
        "np.subtract(z[i + 1], term, out=v[i])", "np.add(z[i + 1], term, out=v[i])", (TM + "test_levant.py",)),
    Bug("levant: exponents (r - i) / (r - i + 2)", M + "levant.py",
        "self.exponents = [(r - i) / (r - i + 1) for i in range(r)]",
        "self.exponents = [(r - i) / (r - i + 2) for i in range(r)]", (TM + "test_levant.py",)),
    Bug("computed torque: + K_d e_dot", C + "computed_torque.py",
        "np.multiply(c.kd, e_dot, out=term)\n        v -= term", "np.multiply(c.kd, e_dot, out=term)\n        v += term",
        (TC + "test_computed_torque.py",)),
    Bug("computed torque: K_d = sqrt(K_p) instead of 2 sqrt(K_p)", C + "computed_torque.py",
        '"kd", 2.0 * np.sqrt(self.kp)', '"kd", 1.0 * np.sqrt(self.kp)', (TC + "test_computed_torque.py",)),
    Bug("super-twisting: |s|^1 instead of |s|^(1/2)", C + "super_twisting.py",
        "signed_power(s, 0.5, out=u_sw)", "signed_power(s, 1.0, out=u_sw)", (TC + "test_super_twisting.py",)),
    Bug("super-twisting: dz/dt = -k2 sign(s)", C + "super_twisting.py",
        "self._integral += self._rate", "self._integral -= self._rate", (TC + "test_super_twisting.py",)),
    Bug("pid: integrates -e", C + "pid.py",
        "np.multiply(self.dt, e, out=term)", "np.multiply(-self.dt, e, out=term)", (TC + "test_pid.py",)),
    Bug("pid: anti-windup holds the increment that pulls out of saturation", C + "pid.py",
        "np.less(self._v, 0.0, out=self._pushing)", "np.greater(self._v, 0.0, out=self._pushing)",
        (TC + "test_pid.py",)),
    Bug("log plant: each period reads the sample after its own", "ftc_mj/engine/plant.py",
        "            self._load(self._k + 1)", "            self._load(min(self._k + 2, self._log.steps - 1))",
        ("tests/engine/test_log_plant.py",)),
    Bug("log plant: reset to sample 1", "ftc_mj/engine/plant.py",
        "        self._load(0)", "        self._load(1)", ("tests/engine/test_log_plant.py",)),
    Bug("score: operating threshold with < 5 % instead of <= 5 %", "ftc_mj/ranking/score.py",
        "if np.mean(healthy > c) <= target:", "if np.mean(healthy > c) < target:", ("tests/ranking/test_score.py", "tests/ranking/test_score_edges.py")),
    Bug("score: a fault at exactly the threshold counts as detected", "ftc_mj/ranking/score.py",
        "detected = fault > 1.0", "detected = fault >= 1.0", ("tests/ranking/test_score.py", "tests/ranking/test_score_edges.py")),
    Bug("score: specificity with < 1 instead of <= 1", "ftc_mj/ranking/score.py",
        "np.sum(healthy <= 1.0)", "np.sum(healthy < 1.0)", ("tests/ranking/test_score.py", "tests/ranking/test_score_edges.py")),
    Bug("score: false alarms per minute, not per hour", "ftc_mj/ranking/score.py",
        "(runs.healthy_seconds[armed] / 3600.0)", "(runs.healthy_seconds[armed] / 60.0)",
        ("tests/ranking/test_score.py", "tests/ranking/test_score_edges.py")),
    Bug("score: ties count fully in the Mann-Whitney AUC", "ftc_mj/ranking/score.py",
        "(below + 0.5 * equal)", "(below + 1.0 * equal)", ("tests/ranking/test_score.py", "tests/ranking/test_score_edges.py")),
    # The series metrics are one compiled pass, which mutmut does not mutate (it leaves decorated functions
    # alone): these bugs stand in for its mutants there.
    Bug("metrics: the converged window from the first entry itself, without the settle interval", A + "metrics.py",
        "max(window_start, entry[w, j] + settle)", "max(window_start, entry[w, j])", AT),
    Bug("metrics: a settling time that restarts at every sample within (the last sample, not the run's first)",
        A + "metrics.py", "    if searching:\n        return time, False", "    if True:\n        return time, False", AT),
    Bug("metrics: a NaN sample does not poison a peak", A + "metrics.py",
        "    if peak != peak:\n        return peak\n    if value != value or value > peak:",
        "    if value > peak:", AT),
    Bug("metrics: chattering counts the pair that enters the window", A + "metrics.py",
        "                    if was_inside[w, j]:\n", "                    if i > 0:\n", AT),
    Bug("metrics: the recovery time not from the onset", A + "metrics.py",
        "out[15, w, j] = recovery[w, j] - onsets[j]", "out[15, w, j] = recovery[w, j]", AT),
    Bug("metrics: the overshoot's initial sign from the second transient sample", A + "metrics.py",
        "first_transient = transient and transient_count == 0", "first_transient = transient and transient_count == 1", AT),
    Bug("metrics: the velocity error's RMS over every sample's count", A + "metrics.py",
        "_root_mean(velocity_squares[w, j], estimation_count)", "_root_mean(velocity_squares[w, j], steps)", AT),
    Bug("metrics: the fault window's end sample inside it", A + "metrics.py",
        "if time < onset + fault_window:", "if time <= onset + fault_window:", AT),
    Bug("diagnosis: every scale stepped one sample too few after a reversed order", A + "diagnosis.py",
        "step_all_until = i + samples + 1", "step_all_until = i + samples", DT),
    Bug("diagnosis: the scales not all stepped at the onset", A + "diagnosis.py",
        "            step_all_until = max(step_all_until, i + 1)\n", "            crossed = True\n", DT),
    Bug("diagnosis: the steps off stop at a scale off but not yet settled", A + "diagnosis.py",
        "if state[1, s] >= samples and state[2, s] == 0:", "if state[2, s] == 0:", DT),
    Bug("diagnosis: the steps on stop a sample before a scale settles", A + "diagnosis.py",
        "if state[1, s] >= samples and state[2, s] == 1:", "if state[1, s] >= samples - 1 and state[2, s] == 1:", DT),
    Bug("diagnosis: one joint's baseline summed in time order, not pairwise as NumPy's", A + "diagnosis.py",
        "    if a.shape[1] == 1:\n", "    if a.shape[1] == 0:\n", DT),
    Bug("diagnosis: the pairwise sum's eight partial sums folded in another order", A + "diagnosis.py",
        "total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))",
        "total = (((r0 + r1) + r2) + r3) + (((r4 + r5) + r6) + r7)", DT),
    Bug("diagnosis: the level held over one sample more than the persistence", A + "diagnosis.py",
        "            oldest = i - p + 1\n", "            oldest = i - p\n", DT),
    Bug("diagnosis: the CUSUM not restarted after a NaN", A + "diagnosis.py",
        "        return 0.0, np.nan\n", "        return g, np.nan\n", DT),
]


def run(bug: Bug, copy: Path) -> bool:
    """Whether the bug fails its tests, in the repository's ``copy`` (the file restored after)."""
    path = copy / bug.file
    original = path.read_text()
    if original.count(bug.old) != 1:
        raise SystemExit(f"{bug.file}: the text to replace for {bug.what!r} is not there exactly once")
    try:
        path.write_text(original.replace(bug.old, bug.new))
        result = subprocess.run([sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider", *bug.tests],
                                cwd=copy, capture_output=True, text=True)
    finally:
        path.write_text(original)
    return result.returncode != 0


def main(argv: list[str] | None = None) -> int:
    only = (sys.argv[1:] if argv is None else argv)  # words of the bugs to run (default: all)
    bugs = [bug for bug in BUGS if all(word in bug.what for word in only)]
    rows = ["| seeded bug | file | tests | caught |", "|---|---|---|---|"]
    caught = 0
    copy = Path(tempfile.mkdtemp(prefix="seeded_bugs_"))
    for entry in COPIED:
        source = ROOT / entry
        if source.is_dir():
            shutil.copytree(source, copy / entry, ignore=shutil.ignore_patterns("__pycache__"))
        elif source.exists():
            shutil.copy2(source, copy / entry)
    for bug in bugs:
        failed = run(bug, copy)
        caught += failed
        print(f"{'caught' if failed else 'MISSED'}: {bug.what}", flush=True)
        rows.append(f"| {bug.what} | `{bug.file}` | {', '.join(f'`{t}`' for t in bug.tests)} | "
                    f"{'yes' if failed else '**no**'} |")
    print("\n".join(rows))
    print(f"{caught} of {len(bugs)} caught")
    shutil.rmtree(copy)
    return 0 if caught == len(bugs) else 1


if __name__ == "__main__":
    sys.exit(main())
