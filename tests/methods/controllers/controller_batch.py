"""Batch against single for one controller law, without the engine: B members of an n-joint law (B != n) with
per-member gains, stacked as the engine stacks them, fed random per-member inputs for a number of periods, give
member by member the bits of B single-member controllers fed the same rows.

Named ``controller_batch`` (not ``batch``): the test folders have no ``__init__.py``, so helper modules are
imported by their bare name and must not collide with another folder's."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from ftc_mj.engine.batching import stack
from ftc_mj.robot.nominal import matvec


def step_model(M: np.ndarray, psi: np.ndarray) -> SimpleNamespace:
    """What a controller reads from a StepModel (estimated velocity), for rows ``(rows, n)``."""
    return SimpleNamespace(M=M, psi_hat=psi, psi_control=psi, control_velocity=lambda qd_hat: qd_hat,
                           apply_M=lambda v, out: matvec(M, v, out))


def assert_batch_equals_single(cls, member_gains: list[dict], n: int = 3, periods: int = 200, seed: int = 0,
                               scale: float = 1.0) -> None:
    """``member_gains``: one gain dict per member. Inputs are random, ``scale`` times a unit spread (errors of
    that size reach the saturations and sign changes of a law)."""
    rng = np.random.default_rng(seed)
    members, dt = len(member_gains), 1e-3
    assert members != n
    configs = [cls.Config.model_validate(g, context={"n_joints": n}) for g in member_gains]
    batch = cls(stack(configs, n), n, dt, members)
    singles = [cls(stack([config], n), n, dt, 1) for config in configs]
    for controller in (batch, *singles):
        controller.reset()
    observer = SimpleNamespace(qd_hat=np.zeros((members, n)), luaf_hat=np.zeros((members, n)),
                               injection=np.zeros((members, n)))
    for k in range(periods):
        t = k * dt
        q_ref, qd_ref, qdd_ref = rng.normal(size=(3, n))
        q = q_ref + scale * rng.normal(size=(members, n))
        observer.qd_hat[:], observer.luaf_hat[:], observer.injection[:] = scale * rng.normal(size=(3, members, n))
        A = rng.normal(size=(members, n, n))
        M, psi = A @ A.transpose(0, 2, 1) + n * np.eye(n), rng.normal(size=(members, n))
        tau = batch.compute(t, q_ref, qd_ref, qdd_ref, q, observer, step_model(M, psi)).copy()
        for m, single in enumerate(singles):
            rows = slice(m, m + 1)
            alone = SimpleNamespace(qd_hat=observer.qd_hat[rows], luaf_hat=observer.luaf_hat[rows],
                                    injection=observer.injection[rows])
            tau_m = single.compute(t, q_ref, qd_ref, qdd_ref, q[rows], alone, step_model(M[rows], psi[rows]))
            np.testing.assert_array_equal(tau[rows], tau_m, err_msg=f"tau, member {m}, period {k}")
            np.testing.assert_array_equal(batch.sliding[rows], single.sliding, err_msg=f"sliding, member {m}")
            for name, signal in batch.signals.items():
                np.testing.assert_array_equal(signal[rows], single.signals[name], err_msg=f"{name}, member {m}")
