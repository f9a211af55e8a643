"""Reproducible randomness: every random element of a run derives from the scenario's one ``seed``.

Each random element has a fixed stream number; its generator is ``default_rng(SeedSequence(seed,
spawn_key=(stream,)))``, the stream-th child of the seed (what ``SeedSequence(seed).spawn`` gives), so
adding a random element never changes the numbers of another, and every variant of a scenario sees the same
numbers (the comparison between methods is paired). In a batch each member has its own seed
(:mod:`ftc_mj.engine.members`); the sensors draw a member's numbers a chunk of periods at a time
(:class:`ftc_mj.effects.sensors.Measurement`), the same numbers as one draw for the whole run, so the same
scenario and seed give the same run bit for bit.
"""

from __future__ import annotations

import numpy as np

#: Stream numbers of the random elements; append new ones, never renumber.
POSITION_NOISE = 0
VELOCITY_NOISE = 1


def generator(seed: int, stream: int) -> np.random.Generator:
    """The generator of random element ``stream`` of a run with scenario seed ``seed`` (>= 0)."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(stream,)))
