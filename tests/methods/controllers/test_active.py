"""The controllers that read the diagnosis (ftc_mj.methods.controllers.active), without the engine: each one's
defining property on a diagnosis whose decisions the test sets (before a decision the loop it replaces, after it
the loop it switches to; the loss of effectiveness estimated from a fault estimate that holds one), batches of
members (B != n, per-member gains, nested plugins' gains stacked) equal to single members, and what a scenario
may not nest."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from controller_batch import step_model
from pydantic import ValidationError

from ftc_mj.engine.batching import stack
from ftc_mj.methods.controllers import NFTSMC, PID, EffectivenessAccommodation, EventCompensatedNFTSMC, Supervisor

N, DT = 3, 1e-3
SURFACE = {"beta1": 15.0, "beta2": 10.0, "beta3": 10.0, "beta4": 5.0, "gamma1": 0.5, "mu": 0.5}
COMPENSATED = {**SURFACE, "bound": 0.5, "compensation": "injection"}
UNCOMPENSATED = {**SURFACE, "bound": 25.0, "compensation": "none"}
PID_GAINS = {"kp": [1320.0, 1560.0, 282.0], "ki": [4400.0, 5200.0, 940.0], "kd": [132.0, 156.0, 28.2]}


def build(cls, gains: dict | list[dict], members: int = 1):
    configs = [cls.Config.model_validate(g, context={"n_joints": N}) for g in
               (gains if isinstance(gains, list) else [gains] * members)]
    controller = cls(stack(configs, N), N, DT, len(configs))
    controller.reset()
    return controller


def diagnosis(members: int = 1) -> SimpleNamespace:
    """A diagnosis whose decisions the test writes."""
    shape = (members, N)
    return SimpleNamespace(isolated=np.zeros(shape, bool), alarm=np.zeros(shape, bool), fault_estimate=np.zeros(shape),
                           diagnoser=SimpleNamespace(space="torque"))


def inputs(rng: np.random.Generator, members: int = 1):
    q_ref, qd_ref, qdd_ref = rng.normal(size=(3, N))
    q = q_ref + 0.1 * rng.normal(size=(members, N))
    observer = SimpleNamespace(**{name: rng.normal(size=(members, N)) for name in ("qd_hat", "luaf_hat", "injection")})
    a = rng.normal(size=(members, N, N))
    model = step_model(a @ a.transpose(0, 2, 1) + N * np.eye(N), rng.normal(size=(members, N)))
    return q_ref, qd_ref, qdd_ref, q, observer, model


def test_event_nftsmc_is_the_uncompensated_loop_until_detection_then_the_compensated_one():
    rng = np.random.default_rng(0)
    event = build(EventCompensatedNFTSMC, {**COMPENSATED, "bound_healthy": 25.0})
    event.diagnosis = found = diagnosis()
    before, after = build(NFTSMC, UNCOMPENSATED), build(NFTSMC, COMPENSATED)
    for k in range(200):
        if k == 120:
            found.isolated[0, 1] = True  # one joint isolated: every joint engages (engage: any)
        arguments = (k * DT, *inputs(rng))
        expected = (after if k >= 120 else before).compute(*arguments).copy()
        (before if k >= 120 else after).compute(*arguments)  # both integrate their surfaces
        np.testing.assert_allclose(event.compute(*arguments), expected, rtol=1e-12, atol=1e-9)
        assert event.reconfigured.all() == (k >= 120) and event.reconfigured.any() == (k >= 120)


def test_event_nftsmc_engages_each_joint_at_its_own_detection():
    rng = np.random.default_rng(1)
    event = build(EventCompensatedNFTSMC, {**COMPENSATED, "bound_healthy": 25.0, "engage": "joint"})
    event.diagnosis = found = diagnosis()
    found.isolated[0, 2] = True
    before, after = build(NFTSMC, UNCOMPENSATED), build(NFTSMC, COMPENSATED)
    for k in range(50):
        arguments = (k * DT, *inputs(rng))
        M = arguments[-1].M[0]

        def law(tau: np.ndarray) -> np.ndarray:  # -u of tau = M (-u): M couples the joints' commands
            return np.linalg.solve(M, tau[0])

        u = law(event.compute(*arguments))
        np.testing.assert_allclose(u[:2], law(before.compute(*arguments))[:2], rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(u[2], law(after.compute(*arguments))[2], rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(event.reconfigured, [[0, 0, 1]])


def test_warm_supervisor_switches_on_isolation_and_stays_switched():
    rng = np.random.default_rng(2)
    supervisor = build(Supervisor, {"nominal": {"type": "pid", "gains": PID_GAINS},
                                    "reconfigured": {"type": "nftsmc", "gains": COMPENSATED}, "transfer": "warm"},
                       members=2)
    supervisor.diagnosis = found = diagnosis(2)
    pid, nftsmc = build(PID, PID_GAINS, 2), build(NFTSMC, COMPENSATED, 2)
    for k in range(150):
        found.isolated[1, 0] = 50 <= k < 60  # member 1 only, cleared again: the switch is latched
        arguments = (k * DT, *inputs(rng, 2))
        tau = supervisor.compute(*arguments).copy()
        tau_pid, tau_nftsmc = pid.compute(*arguments).copy(), nftsmc.compute(*arguments).copy()
        np.testing.assert_array_equal(tau[0], tau_pid[0])  # both run every period: the same bits as alone
        np.testing.assert_array_equal(tau[1], tau_nftsmc[1] if k >= 50 else tau_pid[1])
        np.testing.assert_array_equal(supervisor.sliding[1], (nftsmc if k >= 50 else pid).sliding[1])


def test_restarting_supervisor_hands_over_to_the_reconfigured_loop_from_its_initial_state():
    rng = np.random.default_rng(5)
    supervisor = build(Supervisor, {"nominal": {"type": "pid", "gains": PID_GAINS},
                                    "reconfigured": {"type": "nftsmc", "gains": COMPENSATED}}, members=2)
    supervisor.diagnosis = found = diagnosis(2)
    pid, fresh = build(PID, PID_GAINS, 2), build(NFTSMC, COMPENSATED, 2)
    for k in range(150):
        found.isolated[1, 2] = k >= 60  # member 1 switches at period 60; its NFTSMC starts then, as if new
        arguments = (k * DT, *inputs(rng, 2))
        tau = supervisor.compute(*arguments).copy()
        tau_pid = pid.compute(*arguments).copy()
        np.testing.assert_array_equal(tau[0], tau_pid[0])
        if k < 60:
            np.testing.assert_array_equal(tau[1], tau_pid[1])
        else:
            np.testing.assert_array_equal(tau[1], fresh.compute(*arguments)[1])


BATCHES = {
    "supervisor": (Supervisor, lambda m: {"nominal": {"type": "pid", "gains": {**PID_GAINS, "kp": 1000.0 + 100 * m}},
                                          "reconfigured": {"type": "nftsmc", "gains": {**COMPENSATED, "mu": 0.5 + 0.1 * m}}}),
    "event_nftsmc": (EventCompensatedNFTSMC, lambda m: {**COMPENSATED, "bound_healthy": 20.0 + m, "mu": 0.5 + 0.1 * m}),
    "loe_accommodation": (EffectivenessAccommodation, lambda m: {
        "controller": {"type": "pid", "gains": {**PID_GAINS, "kd": 100.0 + 10 * m}}, "forgetting": 0.99 + 0.001 * m}),
}


@pytest.mark.parametrize("name", list(BATCHES))
def test_a_batch_equals_its_members_nested_gains_stacked(name):
    cls, gains_of = BATCHES[name]
    rng = np.random.default_rng(3)
    gains = [gains_of(m) for m in range(5)]  # 5 members, 3 joints
    batch = build(cls, gains)
    batch.diagnosis = found = diagnosis(5)
    singles = [build(cls, [g]) for g in gains]
    alone = [diagnosis() for _ in gains]
    for single, own in zip(singles, alone):
        single.diagnosis = own
    for k in range(100):
        found.isolated[k % 5, 1] |= k > 40
        found.fault_estimate[:] = rng.normal(size=(5, N))
        arguments = inputs(rng, 5)
        tau = batch.compute(k * DT, *arguments).copy()
        for m, single in enumerate(singles):
            alone[m].isolated[:] = found.isolated[m]
            alone[m].fault_estimate[:] = found.fault_estimate[m]
            q_ref, qd_ref, qdd_ref, q, observer, model = arguments
            rows = slice(m, m + 1)
            member = SimpleNamespace(**{name: getattr(observer, name)[rows] for name in ("qd_hat", "luaf_hat", "injection")})
            np.testing.assert_array_equal(tau[rows], single.compute(k * DT, q_ref, qd_ref, qdd_ref, q[rows], member,
                                                                    step_model(model.M[rows], model.psi_hat[rows])))
            for signal, values in batch.signals.items():
                np.testing.assert_array_equal(values[rows], single.signals[signal], err_msg=f"{signal}, member {m}")


def test_accommodation_estimates_the_loss_and_divides_the_command_on_the_isolated_joint():
    rng = np.random.default_rng(4)
    accommodation = build(EffectivenessAccommodation, {"controller": {"type": "pid", "gains": PID_GAINS},
                                                       "filter_time_constant": 0.02})
    accommodation.diagnosis = found = diagnosis()
    pid = build(PID, PID_GAINS)
    alpha, applied = 0.4, np.zeros((1, N))
    for k in range(3000):
        found.isolated[0, 1] = k >= 500
        # The actuator of joint 2 delivers (1 - alpha) of the command: the torque-space fault estimate is
        # -alpha times the command applied, plus noise the regression must average out.
        found.fault_estimate[0] = np.where([False, True, False], -alpha * applied[0], 0.0) + 0.5 * rng.normal(size=N)
        arguments = (k * DT, *inputs(rng))
        applied = accommodation.compute(*arguments).copy()
        inner = pid.compute(*arguments)
        estimate = accommodation.loss_estimate[0]
        assert estimate[0] == estimate[2] == 0.0  # healthy joints: never accommodated
        np.testing.assert_allclose(applied[0], inner[0] / (1 - estimate))
    assert abs(accommodation.loss_estimate[0, 1] - alpha) < 0.02, accommodation.loss_estimate


def test_nested_controllers_are_checked_by_their_own_schema():
    with pytest.raises(ValidationError, match="unknown controller type 'lqr'"):
        Supervisor.Config.model_validate({"nominal": {"type": "lqr", "gains": {}},
                                          "reconfigured": {"type": "pid", "gains": PID_GAINS}})
    with pytest.raises(ValidationError, match="kp"):
        Supervisor.Config.model_validate({"nominal": {"type": "pid", "gains": {"ki": 1.0, "kd": 1.0}},
                                          "reconfigured": {"type": "pid", "gains": PID_GAINS}})
    with pytest.raises(ValidationError, match="reads the diagnosis itself"):
        Supervisor.Config.model_validate({"nominal": {"type": "event_nftsmc", "gains": {}},
                                          "reconfigured": {"type": "pid", "gains": PID_GAINS}})
    with pytest.raises(ValidationError, match="forgetting must be in"):
        EffectivenessAccommodation.Config.model_validate({"controller": {"type": "pid", "gains": PID_GAINS},
                                                          "forgetting": 1.5})
