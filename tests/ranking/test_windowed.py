"""The v2 leaderboard's boards: an entry whose runs on a robot are another entry's (the same method and gains,
e.g. a tuning that kept its design gains) is scored from those runs, found under the name they were made
under."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ftc_mj.ranking import calibrated as cal
from ftc_mj.ranking import windowed
from ftc_mj.ranking.execute import Found


def _population() -> cal.Population:
    empty = np.zeros(2)
    return cal.Population(envelopes={"momentum": np.ones((2, 3, 1))}, draw=empty, kind=empty, size=empty,
                          joint=empty, onset=empty, fault_effect=np.zeros((2, 1)), diverged=0, block_seconds=0.005)


def test_an_entry_simulated_under_another_name_is_scored_from_its_runs(monkeypatch):
    population = _population()
    monkeypatch.setattr(windowed, "_population", lambda path: population)
    shared = windowed._entry_population(Found(Path("chunk"), "momentum"), "momentum_tuned")
    assert shared.envelopes["momentum_tuned"] is population.envelopes["momentum"]
    assert shared.envelopes["momentum"] is population.envelopes["momentum"]
    assert windowed._entry_population(Found(Path("chunk"), "momentum"), "momentum") is population
