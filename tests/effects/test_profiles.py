"""Fault time profiles (ftc_mj.effects.profiles): each shape's value, the end time, and the instant (weight) and
grid (evaluate, active) forms agreeing sample by sample."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.effects.profiles import Profile

T = np.arange(4000) * 1e-3
RATE = np.array([1.0, 2.0, 8.0])
PROFILES = {
    "abrupt": Profile("abrupt", onset=1.0),
    "abrupt_end": Profile("abrupt", onset=1.0, end=2.5),
    "incipient": Profile("incipient", onset=1.0, rate=RATE),
    "ramp": Profile("ramp", onset=1.0, ramp_time=0.5, end=3.0),
    "intermittent": Profile("intermittent", onset=1.0, period=0.4, duty=0.25),
    # 2 onset is no multiple of the period here: the cycles count from the onset, not from t = -onset.
    "intermittent_late": Profile("intermittent", onset=0.3, period=0.4, duty=0.25),
    "always": Profile("abrupt"),
}


@pytest.mark.parametrize("name", PROFILES)
def test_instant_and_grid_forms_agree(name: str) -> None:
    profile = PROFILES[name]
    grid, active = profile.evaluate(T, 3), profile.active(T)
    for k, t in enumerate(T):
        weight = profile.weight(float(t))
        assert (weight is not None) == active[k], t
        np.testing.assert_array_equal(grid[k], np.broadcast_to(0.0 if weight is None else weight, 3))


def test_values() -> None:
    after = T >= 1.0
    elapsed = np.maximum(T - 1.0, 0.0)
    np.testing.assert_array_equal(PROFILES["abrupt"].evaluate(T, 3)[:, 1], after * 1.0)
    np.testing.assert_array_equal(PROFILES["abrupt_end"].active(T), after & (T < 2.5))
    np.testing.assert_allclose(PROFILES["incipient"].evaluate(T, 3),
                               np.where(after[:, None], 1 - np.exp(-RATE * elapsed[:, None]), 0.0), rtol=1e-15)
    ramp = PROFILES["ramp"].evaluate(T, 3)[:, 0]
    np.testing.assert_allclose(ramp, np.where(after & (T < 3.0), np.minimum(1.0, elapsed / 0.5), 0.0), rtol=1e-15)
    # Intermittent: on for samples 0..99 of every 400 from the onset, exactly, despite the grid's rounding.
    on = PROFILES["intermittent"].active(T)
    k = np.arange(len(T)) - 1000
    np.testing.assert_array_equal(on, (k >= 0) & (k % 400 < 100))
    k = np.arange(len(T)) - 300
    np.testing.assert_array_equal(PROFILES["intermittent_late"].active(T), (k >= 0) & (k % 400 < 100))
    assert PROFILES["always"].active(T).all()


def test_intermittent_boundary_within_the_tolerance_counts_as_reached() -> None:
    """1e-9 before the end of the on fraction the fault is already off (the boundary counts as reached), and
    just before that it is still on."""
    profile = Profile("intermittent", period=1.0, duty=0.5)
    end = 0.5 - 1e-9
    assert profile.weight(end) is None and profile.weight(end - 1e-12) == 1.0
    np.testing.assert_array_equal(profile.active(np.array([end - 1e-12, end])), [True, False])


def test_a_single_precision_grid_is_worked_in_double_precision() -> None:
    """The values are those of the grid's times, whatever their dtype: a float32 grid gives what the same
    numbers in float64 give, the onset compared in double precision too."""
    grid = T.astype(np.float32)
    # An onset that float32 cannot hold: t - onset in float32 would round where float64 does not.
    for profile in (Profile("incipient", onset=0.35, rate=RATE), Profile("ramp", onset=0.35, ramp_time=0.7),
                    PROFILES["intermittent_late"]):
        np.testing.assert_array_equal(profile.evaluate(grid, 3), profile.evaluate(grid.astype(float), 3))
    onset = float(np.float32(0.1)) + 1e-12  # just after the float32 time 0.1, equal to it in float32
    assert not Profile("abrupt", onset=onset).active(np.float32([0.1]))[0]
