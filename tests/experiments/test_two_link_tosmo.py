"""Chapter 3 end to end: scenarios/two_link_tosmo_simple.yaml and _complex.yaml, the claims that hold.

Measured values in the comments ("simple; complex", joint 1 / joint 2); bounds leave about a 3x margin.
"""

from __future__ import annotations

import numpy as np
import pytest

from scenario_runs import Metrics, run_scenario


@pytest.fixture(scope="module", params=["two_link_tosmo_simple", "two_link_tosmo_complex"])
def metrics(request, tmp_path_factory: pytest.TempPathFactory) -> Metrics:
    return run_scenario(request.param, tmp_path_factory.mktemp(request.param))[0]


def test_tosmo_estimates_better_but_converges_slower_than_sosmo(metrics: Metrics) -> None:
    tosmo, sosmo = metrics["proposed"], metrics["proposed_sosmo"]
    # SOSMO with L = 12 (bounds the LUaF). Velocity RMS 1.3e-4 against 0.011 / 9.9e-3; 1.1e-4 against 9.2e-3 /
    # 8.7e-3 rad/s.
    assert np.all(10 * tosmo["rms_velocity_error"] < sosmo["rms_velocity_error"])
    # LUaF RMS 0.027 against 0.76 / 0.76; 0.019 / 0.021 against 0.75 / 0.80 rad/s^2.
    assert np.all(tosmo["rms_luaf_error"] < 0.09)
    assert np.all(7 * tosmo["rms_luaf_error"] < sosmo["rms_luaf_error"])
    # Velocity convergence on joint 1: 0.61 s against 0.05 s (both cases): the TOSMO is slower. On joint 2 the
    # SOSMO's error chatters at about 0.01 rad/s and last leaves the 0.02 rad/s tolerance at 5.8 s (partly).
    assert tosmo["observer_convergence_time"][0] > 3 * sosmo["observer_convergence_time"][0]
    assert sosmo["observer_convergence_time"][1] > 2.0


def test_proposed_law_tracks_better_than_smc_and_ntsmc(metrics: Metrics) -> None:
    proposed = metrics["proposed"]["rms_error_converged"]
    # 8.2e-7 / 1.0e-6; 2.3e-6 / 2.7e-6 rad, against SMC >= 5.1e-5 and NTSMC >= 6.5e-5.
    assert np.all(proposed < 8e-6)
    assert np.all(5 * proposed < metrics["smc"]["rms_error_converged"])
    assert np.all(5 * proposed < metrics["ntsmc"]["rms_error_converged"])


def test_gamma2_term_speeds_up_the_initial_convergence(metrics: Metrics, request) -> None:
    proposed, after = metrics["proposed"], metrics["after_convergence"]
    # Convergence 2.88 / 4.02 s against 2.95 / 5.31 s (both cases); reaching time of joint 2, first and for
    # good: 4.05 s against 5.35 and 7.62 s.
    assert np.all(proposed["convergence_time"] < after["convergence_time"])
    assert proposed["convergence_time"][1] < after["convergence_time"][1] - 0.5
    assert proposed["reaching_time"][1] < after["reaching_time"][1] - 1.0
    assert proposed["first_reaching_time"][1] < after["first_reaching_time"][1] - 0.5
    if request.node.callspec.params["metrics"] == "two_link_tosmo_simple":
        # Peak |e| in the 2 s after the joint-2 fault of Phi_1: 4.4e-5 against 1.9e-4 rad (the one clear case;
        # at the other onsets the laws differ by 1-4e-6 rad, inconclusive).
        assert proposed["fault_peak_error"][1] < after["fault_peak_error"][1] / 2


def test_after_convergence_both_forms_track_alike_from_their_own_convergence(metrics: Metrics) -> None:
    """The window starts per variant and joint at its own convergence + 1 s: (3.35)-(3.37) on joint 2
    converges at 5.31 s. Measured 8.2e-7 / 1.0e-6 against 9.5e-7 / 7.8e-6 (Phi_1; joint 2 after the joint-2
    fault) and 2.3e-6 / 2.7e-6 against 6.5e-6 / 6.3e-6 rad (Phi_2); from the fixed 5 s window it was 2.1e-3."""
    proposed, after = metrics["proposed"], metrics["after_convergence"]
    assert np.all(after["rms_error_converged"] < 2e-5)
    assert np.all(after["rms_error_converged"] < 10 * proposed["rms_error_converged"])


def test_the_sigmoid_laws_are_kicked_off_their_surface(metrics: Metrics) -> None:
    """The singular term |e|^(alpha - 1) kicks s off the surface after it was reached: the proposed law first
    reaches it on joint 1 at 2.92 s, for good at 3.51 s (both cases)."""
    proposed = metrics["proposed"]
    assert proposed["reaching_time"][0] > proposed["first_reaching_time"][0] + 0.2


def test_every_loop_rides_through_the_faults(metrics: Metrics) -> None:
    # The TOSMO loops never leave 0.005 rad at a fault onset (recovery time 0); peak errors in the 2 s after an
    # onset <= 1.9e-4 rad. The SOSMO loop too, with L = 12 (peaks 2.4e-4 / 5.5e-5; with L = 9 it lost joint 2
    # at the Phi_1 joint-2 fault).
    for variant in ("proposed", "after_convergence", "smc", "ntsmc", "proposed_sosmo"):
        assert np.all(metrics[variant]["fault_peak_error"] < 1e-3), variant
        np.testing.assert_array_equal(metrics[variant]["recovery_time"], [0.0, 0.0])
