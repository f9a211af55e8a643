"""Chapter 3 end to end: scenarios/two_link_tosmo_simple.yaml and _complex.yaml, the claims that hold.

Measured values in the comments ("simple; complex", joint 1 / joint 2); bounds leave about a 3x margin.

The sigmoid laws (``proposed``, ``after_convergence``) have a singular |e|^(alpha - 1) term whose spikes kick
the converged loop at times decided by floating-point rounding (docs/results/reproduction.md, "What rounding decides in
Chapter 3"): their errors after convergence, their fault peaks and their "for good" reaching times moved by
up to 30x (and 8 s) between three roundings of the same physics and methods (two engines, two evaluations of
the nominal model). Those are asserted only through bounds that held under all three; which sigmoid law is
better on them is not asserted at all.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

from scenario_runs import ROOT, Metrics, run_scenario

sys.path.insert(0, str(ROOT / "studies"))
from sigmoid_spikes import spikes  # noqa: E402  (the study docs/results/reproduction.md quotes, run over 12 s)

#: whole-scenario closed-loop experiments
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module", params=["two_link_tosmo_simple", "two_link_tosmo_complex"])
def metrics(request, tmp_path_factory: pytest.TempPathFactory) -> Metrics:
    return run_scenario(request.param, tmp_path_factory.mktemp(request.param))[0]


def test_tosmo_estimates_better_but_converges_slower_than_sosmo(metrics: Metrics) -> None:
    tosmo, sosmo = metrics["proposed"], metrics["proposed_sosmo"]
    # SOSMO with L = 12 (bounds the LUaF). Velocity RMS 1.3e-4 against 0.011 / 9.9e-3; 1.1e-4 against 9.2e-3 /
    # 8.7e-3 rad/s.
    assert np.all(10 * tosmo["rms_velocity_error"] < sosmo["rms_velocity_error"])
    # LUaF RMS 0.028 against 0.76 / 0.76; 0.019 / 0.022 against 0.75 / 0.80 rad/s^2.
    assert np.all(tosmo["rms_luaf_error"] < 0.09)
    assert np.all(7 * tosmo["rms_luaf_error"] < sosmo["rms_luaf_error"])
    # Velocity convergence on joint 1: 0.61 s against 0.05 s (both cases): the TOSMO is slower. On joint 2 the
    # SOSMO's error chatters at about 0.01 rad/s and last leaves the 0.02 rad/s tolerance at 5.8 s (partly).
    assert tosmo["observer_convergence_time"][0] > 3 * sosmo["observer_convergence_time"][0]
    assert sosmo["observer_convergence_time"][1] > 2.0


def test_proposed_law_tracks_better_than_smc_and_ntsmc(metrics: Metrics) -> None:
    proposed = metrics["proposed"]["rms_error_converged"]
    # 1.2e-5 / 5.7e-6; 2.1e-6 / 1.5e-5 rad, against SMC >= 5.1e-5 and NTSMC >= 6.6e-5: 5-31x. The factor is
    # rounding's (11-37x with MuJoCo's nominal model, 3.5e-6 / 7.6e-6; 2.8e-6 / 2.4e-6; 22-97x with the
    # previous engine, 8.2e-7 / 1.0e-6; 2.3e-6 / 2.7e-6); at least 5x in every run of the three roundings (both
    # cases, both initial states). A broken compensation tracks like SMC.
    assert np.all(proposed < 3e-5)  # twice the top of the band over all roundings (1.5e-5); SMC >= 5.1e-5
    assert np.all(3 * proposed < metrics["smc"]["rms_error_converged"])
    assert np.all(3 * proposed < metrics["ntsmc"]["rms_error_converged"])


def test_gamma2_term_speeds_up_the_initial_convergence(metrics: Metrics) -> None:
    """The reaching phase ends before the singular term matters: the same under all three roundings. Convergence
    2.88 / 4.02 s against 2.95 / 5.31 s; surface first reached 2.92 / 4.05 s against 2.99 / 5.35 s (both cases).
    The "for good" reaching times and the fault peaks are rounding's (docs/results/reproduction.md) and not asserted: the
    Phi_1 joint-2 fault peak went from 4.4e-5 against 1.9e-4 rad to 7.8e-5 against 6.4e-6, then 3.2e-5 against
    1.1e-5."""
    proposed, after = metrics["proposed"], metrics["after_convergence"]
    assert np.all(proposed["convergence_time"] < after["convergence_time"])
    assert proposed["convergence_time"][1] < after["convergence_time"][1] - 0.5
    assert proposed["first_reaching_time"][1] < after["first_reaching_time"][1] - 0.5


def test_after_convergence_both_forms_track_alike_from_their_own_convergence(metrics: Metrics) -> None:
    """The window starts per variant and joint at its own convergence + 1 s: (3.35)-(3.37) on joint 2
    converges at 5.31 s (from the fixed 5 s window it was 2.1e-3 rad). Measured 1.2e-5 / 5.7e-6 against 1.2e-5 /
    1.8e-6 (Phi_1) and 2.1e-6 / 1.5e-5 against 3.7e-6 / 3.4e-6 rad (Phi_2); with MuJoCo's nominal model 3.5e-6 /
    7.6e-6 against 1.7e-6 / 1.3e-6 and 2.8e-6 / 2.4e-6 against 2.3e-6 / 2.4e-6; with the previous engine 8.2e-7 /
    1.0e-6 against 9.5e-7 / 7.8e-6 and 2.3e-6 / 2.7e-6 against 6.5e-6 / 6.3e-6. Which one is better flips with
    rounding; both stay in one band (8e-7 to 1.5e-5 over twelve runs), which is what is asserted."""
    for variant in ("proposed", "after_convergence"):
        error = metrics[variant]["rms_error_converged"]
        assert np.all(error < 3e-5), variant  # the band 8e-7 to 1.5e-5, with a 2x margin
        assert np.all(3 * error < metrics["smc"]["rms_error_converged"]), variant


@pytest.mark.parametrize("name", ["two_link_tosmo_simple", "two_link_tosmo_complex"])
def test_the_sigmoid_laws_singular_term_spikes_after_the_surface_is_reached(name: str) -> None:
    """The singular term |e|^(alpha - 1) of (3.27)/(3.36) exceeds the switching gain Delta_d + mu in 73-91 of
    every 1000 periods after the surface is first reached, under all three roundings so far; the largest spike
    of a run is 18-43x the gain with MuJoCo's nominal model, 55-105x now (docs/results/reproduction.md; studies/
    sigmoid_spikes.py). Whether a spike kicks s off its surface for good, and when, is rounding's (the proposed
    law's joint 1: 9.74 s, then 2.92 s, its first reaching): not asserted.
    Over the first 12 s: at least 30 spikes per second on every joint of both laws, the largest above 5x the
    gain. A bounded term (or none) gives no spike."""
    for variant, row in spikes(name, ["duration=12"]).items():
        for j, first in enumerate(row["first_reaching_time"]):
            assert first < 7.0, (variant, j)  # at least 5 s of the converged loop
            assert row["per_second"][j] > 30.0, (variant, j)
            assert row["largest_term"][j] > 5.0 * row["gain"][j], (variant, j)


def test_every_loop_rides_through_the_faults(metrics: Metrics) -> None:
    # The TOSMO loops never leave 0.005 rad at a fault onset (recovery time 0); peak errors in the 2 s after an
    # onset <= 8.7e-5 rad (NTSMC), the sigmoid laws' <= 3.2e-5 (7.8e-5 with MuJoCo's nominal model, 1.9e-4 with
    # the previous engine: their peaks are rounding's). The SOSMO loop
    # too, with L = 12 (peaks 2.4e-4 / 5.5e-5; with L = 9 it lost joint 2 at the Phi_1 joint-2 fault).
    for variant in ("proposed", "after_convergence", "smc", "ntsmc", "proposed_sosmo"):
        assert np.all(metrics[variant]["fault_peak_error"] < 1e-3), variant
        np.testing.assert_array_equal(metrics[variant]["recovery_time"], [0.0, 0.0])
