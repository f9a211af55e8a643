"""The momentum observer period by period on one joint (ftc_mj.methods.observers.momentum), without the
engine: the LUaF estimate and the injection are M^-1 r at every period, and a step model lacking C^T qd or G
is refused with the message that names both."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from double_integrator import FakeStepModel

from ftc_mj.methods.observers import MomentumObserver

DT = 1e-3


def test_the_estimate_and_the_injection_are_m_inverse_r_every_period():
    mass = 2.0
    model = FakeStepModel(np.array([[mass]]))
    model.coriolis_transpose, model.gravity = np.zeros(1), np.array([3.0])
    observer = MomentumObserver(MomentumObserver.Config(K=[50.0]), 1, DT)
    observer.reset(np.array([0.3]), np.array([-0.2]))
    q, v = 0.3, -0.2
    for k in range(50):
        observer.measure(np.array([q]), np.array([v]))
        observer.update(k * DT, np.array([q]), model)
        assert observer.luaf_hat[0] == observer.residual[0] / mass
        assert observer.injection[0] == observer.luaf_hat[0]
        a = (1.0 + 2.0) / mass  # tau = 4 against G = 3, with a fault of 1 the observer sees from the start
        q, v = q + v * DT + 0.5 * a * DT**2, v + a * DT
        observer.advance(np.array([4.0]), model)
    assert observer.residual[0] > 0.5  # the residual rises towards the unmodelled 2 N m


@pytest.mark.parametrize("missing", ["coriolis_transpose", "gravity", "both"])
def test_a_model_without_the_terms_it_needs_is_refused(missing):
    terms = {"coriolis_transpose": np.zeros(1), "gravity": np.zeros(1)}
    for name in (["coriolis_transpose", "gravity"] if missing == "both" else [missing]):
        del terms[name]
    model = SimpleNamespace(apply_M=lambda v, out: out, solve_M=lambda v: v, **terms)
    observer = MomentumObserver(MomentumObserver.Config(K=[50.0]), 1, DT)
    observer.reset(np.zeros(1), np.zeros(1))
    observer.measure(np.zeros(1), np.zeros(1))
    with pytest.raises(ValueError, match=r"^momentum needs the nominal model's C\^T qd and G: .*Observer\.needs\)$"):
        observer.update(0.0, np.zeros(1), model)


def test_measured_velocities_are_required():
    observer = MomentumObserver(MomentumObserver.Config(K=[50.0]), 1, DT)
    with pytest.raises(ValueError, match=r"^momentum needs measured velocities \(momentum_levant differentiates "
                                         r"the encoders\)$"):
        observer.measure(np.zeros(1), None)
