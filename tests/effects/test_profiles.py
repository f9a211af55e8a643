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
    assert PROFILES["always"].active(T).all()
