"""The null observer: each run draws a stream of its own (seeded by its readings over the warm-up, not by the
first reading, which most runs share), unit white noise in torque space, and a batch member draws what its
single run draws."""

import numpy as np

from ftc_mj.testing import assert_batch_equals_single
from ftc_mj_white_noise.observer import WhiteNoiseConfig, WhiteNoiseObserver


class Model:
    """M = diag(2) for every member: solve_M halves."""

    def solve_M(self, vector):
        return vector / 2.0


def estimates(readings: np.ndarray, warmup: int = 5) -> np.ndarray:
    config = WhiteNoiseConfig.model_validate({"warmup": warmup}, context={"n_joints": readings.shape[1]})
    observer = WhiteNoiseObserver(config, readings.shape[1], 1e-3)
    out = []
    for q in readings:
        observer.update(0.0, q, Model())
        out.append(observer.luaf_hat.copy())
    return np.array(out)


def test_runs_that_share_their_first_reading_draw_streams_of_their_own():
    steps = np.zeros((400, 3))
    other = steps.copy()
    other[3, 1] = 9.6e-5  # one quantisation step apart, once, inside the warm-up
    a, b = estimates(steps), estimates(other)
    assert not a[:5].any() and not b[:5].any()  # zero during the warm-up
    assert np.corrcoef(a[5:, 0], b[5:, 0])[0, 1] < 0.2
    np.testing.assert_array_equal(a, estimates(steps))  # reproducible from the readings


def test_the_torque_space_estimate_is_unit_white_noise():
    torque = 2.0 * estimates(np.zeros((20_005, 2)))[5:]  # M z_hat
    assert abs(torque.std() - 1.0) < 0.02 and abs(torque.mean()) < 0.02
    assert abs(np.corrcoef(torque[1:, 0], torque[:-1, 0])[0, 1]) < 0.03


def test_a_batch_member_draws_what_its_single_run_draws():
    assert_batch_equals_single(WhiteNoiseObserver, [{"warmup": 3}, {"warmup": 7}, {"warmup": 3}, {"warmup": 1}],
                               n_joints=2)
