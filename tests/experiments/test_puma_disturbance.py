"""Chapter 4 end to end: scenarios/puma_disturbance.yaml, the claims of docs/results/reproduction.md that hold.

Measured values in the comments (joints 1 / 2 / 3); bounds leave about a 3x margin.
"""

from __future__ import annotations

import numpy as np
import pytest

from scenario_runs import Metrics, run_scenario

#: whole-scenario closed-loop experiments
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def metrics(tmp_path_factory: pytest.TempPathFactory) -> Metrics:
    return run_scenario("puma_disturbance", tmp_path_factory.mktemp("puma_disturbance"))[0]


def test_tosmo_estimates_more_accurately_than_sosmo(metrics: Metrics) -> None:
    tosmo, sosmo = metrics["proposed"], metrics["nftsmc_sosmo"]
    # SOSMO with L = 11 (bounds the LUaF). Velocity 2.4e-4 / 3.4e-4 / 0.015 against 7.6e-3 / 7.4e-3 / 9.5e-3
    # rad/s; LUaF 0.032 / 0.032 / 0.23 against 0.67 / 0.68 / 0.70 rad/s^2; velocity convergence 0.86 / 0.61 /
    # 0.75 s against 0.053 / 0.052 / 3.1 s. Joint 3 (where the TOSMO loses its sliding mode during the
    # disturbance) is the exception for velocity: partly.
    arm = slice(0, 2)
    assert np.all(5 * tosmo["rms_velocity_error"][arm] < sosmo["rms_velocity_error"][arm])
    assert sosmo["rms_velocity_error"][2] < tosmo["rms_velocity_error"][2]
    assert np.all(2 * tosmo["rms_luaf_error"] < sosmo["rms_luaf_error"])
    assert np.all(tosmo["observer_convergence_time"][arm] > 3 * sosmo["observer_convergence_time"][arm])


def test_proposed_beats_appendix_b_and_c_and_matches_appendix_d(metrics: Metrics) -> None:
    proposed = metrics["proposed"]
    # Joints 1-2 RMS error after convergence 2.4e-6 / 4.2e-6 rad against B 2.3e-4 / 2.1e-4, C 2.4e-4 / 1.9e-4,
    # D 3.1e-6 / 3.9e-6 (joint 3: C 6.4e-4 beats the proposed 2.9e-3: partly). Chattering 7.8e3 / 1.1e4 / 2.6e3
    # against B 3.0e5 / 4.3e5 / 8.4e4, C 7.7e4 / 1.1e5 / 2.1e4, D 6.9e3 / 9.7e3 / 1.9e3 N m/s.
    arm = slice(0, 2)
    assert np.all(proposed["rms_error_converged"][arm] < 1.5e-5)
    for comparator in ("nftsmc", "nftsmc_sosmo"):
        assert np.all(20 * proposed["rms_error_converged"][arm] < metrics[comparator]["rms_error_converged"][arm])
        assert np.all(3 * proposed["chattering"] < metrics[comparator]["chattering"])
    np.testing.assert_allclose(proposed["rms_error_converged"][arm],
                               metrics["nftsmc_tosmo"]["rms_error_converged"][arm], rtol=0.5)


def test_smaller_switching_gain_chatters_less(metrics: Metrics) -> None:
    # Xi = 1 -> 0.3: proposed 7.8e3 / 1.1e4 / 2.6e3 -> 2.5e3 / 3.4e3 / 562; NFTSMC-TOSMO 6.9e3 / 9.7e3 / 1.9e3 ->
    # 2.0e3 / 2.8e3 / 527 N m/s.
    assert np.all(metrics["proposed_xi03"]["chattering"] < metrics["proposed"]["chattering"] / 2)
    assert np.all(metrics["nftsmc_tosmo_xi03"]["chattering"] < metrics["nftsmc_tosmo"]["chattering"] / 2)


def test_reaching_time_follows_s0_over_the_switching_gain(metrics: Metrics) -> None:
    """Theorem 4.1: with the whole injection compensated, ds/dt = -(Xi + mu) sign(s), so the surface is
    reached after |s(0)| / (Xi + mu), with |s(0)| = 0.5 rad/s (the observer's initial velocity error):
    0.495 s for Xi = 1 (measured 0.486 s) and 1.61 s for Xi = 0.3 (measured 1.58 s) on every joint. The
    Appendix-D law, which leaves the gamma2 term uncompensated, does not follow it (0.81 / 0.59 / 0.98 s)."""
    np.testing.assert_allclose(metrics["proposed"]["reaching_time"], 0.5 / 1.01, atol=0.03)
    np.testing.assert_allclose(metrics["proposed_xi03"]["reaching_time"], 0.5 / 0.31, atol=0.06)
    assert np.all(metrics["nftsmc_tosmo"]["reaching_time"] > metrics["proposed"]["reaching_time"] + 0.05)
