"""Chapter 2 end to end: scenarios/two_link_do.yaml, the claims of docs/results/reproduction.md that hold.

Measured values in the comments (joint 1 / joint 2); bounds leave a margin of about 3x (or a factor-of-3
ordering) and sit well away from what a broken observer or compensation gives.
"""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.outputs.recording import read_series
from scenario_runs import Metrics, run_scenario

#: whole-scenario closed-loop experiments
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory):
    return run_scenario("two_link_do", tmp_path_factory.mktemp("two_link_do"))


@pytest.fixture(scope="module")
def metrics(run) -> Metrics:
    return run[0]


def test_do_is_the_most_accurate_observer_before_and_after_the_faults(metrics: Metrics) -> None:
    do, eso, sosmo = (metrics[v] for v in ("a_nftsmc_do", "a_nftsmc_eso", "a_nftsmc_sosmo"))
    # Measured RMS LUaF error: DO 0.011 / 0.012, ESO 0.22 / 0.22, SOSMO (L = 16) 1.35 / 1.36 (after the faults:
    # 0.011 / 0.012, 0.31 / 0.30, 1.33 / 1.33).
    assert np.all(do["rms_luaf_error"] < 0.035)
    for metric in ("rms_luaf_error", "rms_luaf_error_fault"):
        assert np.all(3 * do[metric] < eso[metric]), metric
        assert np.all(3 * eso[metric] < sosmo[metric]), metric


def test_the_ordering_holds_on_one_trajectory_too(metrics: Metrics) -> None:
    """The SOSMO and the ESO as monitors of the proposed variant (same readings and commands as the DO, feeding
    nothing). Measured RMS LUaF error: DO 0.011 / 0.012, ESO 0.22 / 0.22, SOSMO 1.32 / 1.34."""
    do, eso, sosmo = (metrics[v] for v in ("a_nftsmc_do", "a_nftsmc_do.eso", "a_nftsmc_do.sosmo"))
    np.testing.assert_array_equal(eso["rms_error_converged"], do["rms_error_converged"])  # one trajectory
    assert np.all(3 * do["rms_luaf_error"] < eso["rms_luaf_error"])
    assert np.all(3 * eso["rms_luaf_error"] < sosmo["rms_luaf_error"])


def test_do_converges_faster_than_the_sosmo_and_the_eso_overshoots(metrics: Metrics) -> None:
    do, eso, sosmo = (metrics[v] for v in ("a_nftsmc_do", "a_nftsmc_eso", "a_nftsmc_sosmo"))
    # LUaF within 0.5 rad/s^2: DO 0.105 / 0.217 s, ESO 0.17 / 0.17 s, SOSMO never for good (NaN / 15 s).
    assert np.all(do["luaf_convergence_time"] < 0.4)
    assert np.all(np.isnan(sosmo["luaf_convergence_time"]) | (sosmo["luaf_convergence_time"] > 5.0))
    assert np.all(eso["luaf_convergence_time"] < 0.5)
    # Overshoot (luaf_overshoot, one definition for all: how far the estimate goes past the truth). The ESO's
    # joint-1 estimate overshoots by 4.7 rad/s^2, 3.6x its initial error (the true LUaF at t = 0, 1.3); the
    # DO only converges from its initial error (its peak 9.4 / 13.3 is the error at t = 0) and goes past the
    # truth by 0.21 / 0.52, 2-4% of it. On joint 2 the ESO does not cross the truth (0.09).
    assert eso["luaf_overshoot"][0] > 2.0 * 1.3
    assert np.all(do["luaf_overshoot"] < 0.1 * do["peak_luaf_error_transient"])
    assert do["luaf_overshoot"][0] < eso["luaf_overshoot"][0] / 5


def test_smc_is_the_least_accurate_and_slowest_controller(metrics: Metrics) -> None:
    smc, nftsmc, proposed = (metrics[v] for v in ("smc", "nftsmc", "a_nftsmc_do"))
    # Measured RMS error after convergence: SMC 1.6e-3 / 1.4e-3, NFTSMC 3.3e-5 / 2.0e-5, A-NFTSMC-DO 8.8e-8 /
    # 1.6e-7 rad. Convergence: SMC 0.60 / 0.92 s, NFTSMC 0.395 / 0.586 s, A-NFTSMC-DO 0.154 / 0.507 s.
    assert np.all(smc["rms_error_converged"] > 10 * nftsmc["rms_error_converged"])
    assert np.all(nftsmc["rms_error_converged"] > 30 * proposed["rms_error_converged"])
    assert np.all(proposed["rms_error_converged"] < 6e-7)
    assert np.all(smc["convergence_time"] > nftsmc["convergence_time"] + 0.1)
    assert np.all(proposed["convergence_time"] <= nftsmc["convergence_time"])


def test_compensation_with_the_adaptive_gain_reduces_chattering(metrics: Metrics) -> None:
    # Measured: A-NFTSMC-DO 2.1e3 / 600, NFTSMC 1.0e5 / 3.6e4, SMC 1.0e5 / 3.5e4 N m/s.
    proposed = metrics["a_nftsmc_do"]["chattering"]
    assert np.all(15 * proposed < metrics["nftsmc"]["chattering"])
    assert np.all(15 * proposed < metrics["smc"]["chattering"])


def test_adaptive_gain_rises_in_the_transient_then_stays_with_the_dead_zone(run) -> None:
    """Fig. 2.8: K_hat is recorded per joint. It rises while sigma is off the surface (measured 0 -> 0.14 /
    0.14 in 2.6 s); with (2.43) it then stops (constant from 2.6 s to the end, through both faults), while the
    plain law (2.36) keeps drifting (0.1441 / 0.1453 at 30 s)."""
    _, recording = run
    times, gain = read_series(recording, "/extras/switching_gain/a_nftsmc_do")
    _, drift = read_series(recording, "/extras/switching_gain/a_nftsmc_do_drift")
    assert gain.shape == drift.shape and gain.shape[1] == 2
    assert np.all(np.diff(gain, axis=0) >= 0) and np.all(np.diff(drift, axis=0) >= 0)  # rho |s| >= 0
    assert np.all((gain[-1] > 0.05) & (gain[-1] < 0.5))
    after_transient = times >= 5.0
    np.testing.assert_array_equal(gain[after_transient][0], gain[-1])  # frozen by the dead zone
    assert np.all(drift[-1] > gain[-1])


def test_every_chapter_2_controller_runs_on_the_tachometer(metrics: Metrics) -> None:
    """controller_velocity: measured. The SOSMO and ESO variants feed the A-NFTSMC only their LUaF estimate;
    e_dot and Psi come from the tachometer, as for the DO. Measured RMS error after convergence 1.4e-5 /
    1.5e-5 (SOSMO) and 2.2e-4 / 9.5e-5 rad (ESO); on their own velocity estimates (the old behaviour) both
    were about 1e-3 rad, and the ESO needed 1.36 s to recover from the joint-1 fault (now 0)."""
    sosmo, eso = metrics["a_nftsmc_sosmo"], metrics["a_nftsmc_eso"]
    assert np.all(sosmo["rms_error_converged"] < 5e-5)
    assert np.all(eso["rms_error_converged"] < 7e-4)
    np.testing.assert_array_equal(eso["recovery_time"], [0.0, 0.0])
    # The DO's loop still tracks best (8.8e-8 / 1.6e-7 rad).
    assert np.all(metrics["a_nftsmc_do"]["rms_error_converged"] * 10 < sosmo["rms_error_converged"])
