"""ftc_mj.methods.plugin.Method: what a plugin receives in its base's ``__init__`` (members, its state shape,
the period as a number and as an array)."""

from __future__ import annotations

import numpy as np

from ftc_mj.methods.controllers import SMC


def make(members=None) -> SMC:
    return SMC(SMC.Config.model_validate({"c": 2.0, "bound": 0.5, "mu": 0.5}, context={"n_joints": 3}), 3, 2e-3,
               members)


def test_members_shape_and_period():
    batch = make(members=4)
    assert batch.members == 4 and batch.n == 3 and batch.shape == (4, 3)
    assert float(batch.dt) == 2e-3 and batch.dt.shape == ()
    assert batch.dt_array.dtype == np.float64
    np.testing.assert_array_equal(batch.dt_array, np.full((4, 3), 2e-3))
    alone = make()
    assert alone.members is None and alone.shape == (3,)
    np.testing.assert_array_equal(alone.dt_array, np.full(3, 2e-3))
