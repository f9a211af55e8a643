"""The fused laws (ftc_mj.fast.laws) against their method's NumPy law, member by member.

Each shipped law with an accelerator runs twice on the same random inputs, accelerated and built with the
fast paths off (``fast.switched(False)``): B members (B != n) with their own gains, errors of every scale,
exact zeros (sign(0)), negative and positive values, a member gone NaN (a stopped row of the engine). The
stated tolerance is none: every state and output must have the same bits every period (the accelerator does
the law's IEEE operations in the law's order and leaves the powers to NumPy). Then the rules of the
registration: a subclass, standalone laws and the switch take the NumPy law; and the engine's series of a
shipped scenario are the same either way.
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from ftc_mj import fast, load_scenario
from ftc_mj.engine.batching import stack
from ftc_mj.engine.loop import simulate
from ftc_mj.engine.members import single
from ftc_mj.fast import laws
from ftc_mj.methods.controllers import NFTSMC
from ftc_mj.methods.controllers.nftsmc import AdaptiveNFTSMC
from ftc_mj.methods.observers import SOSMO, HighSpeedTOSMO, TOSMO
from ftc_mj.robot.nominal import matvec

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"
N, MEMBERS, DT, PERIODS = 3, 5, 1e-3, 60
OBSERVERS = {
    TOSMO: [dict(D=22.0), dict(k1=[3.0, 4.0, 5.0], k2=[6.0, 7.0, 8.0], k3=[20.0, 21.0, 22.0])],
    HighSpeedTOSMO: [dict(D=22.0, gamma=5.0), dict(D=10.0, gamma=0.0)],
    SOSMO: [dict(L=22.0, filter_time_constant=0.01), dict(k1=[5.0, 6.0, 7.0], k2=[20.0, 25.0, 30.0],
                                                          filter_time_constant=0.002)],
}
NFTSMC_GAINS = [dict(beta1=15.0, beta2=10.0, beta3=10.0, beta4=5.0, gamma1=0.5, bound=0.5, mu=0.5),
                dict(beta1=[5.0, 6.0, 7.0], beta2=3.0, gamma1=0.6, gamma2=0.65, bound=[1.0, 2.0, 3.0], mu=0.1)]


def build(cls, member_gains: list[dict], reference: bool):
    configs = [cls.Config.model_validate(g, context={"n_joints": N}) for g in member_gains]
    if reference:
        with fast.switched(False):
            return cls(stack(configs, N), N, DT, len(configs))
    return cls(stack(configs, N), N, DT, len(configs))


def member_gains(option: dict) -> list[dict]:
    """MEMBERS gain sets: ``option`` with each member's numbers scaled apart."""
    gains = []
    for m in range(MEMBERS):
        gains.append({name: (value if isinstance(value, str) else
                             (np.asarray(value) * (1 + 0.05 * m)).tolist()) for name, value in option.items()})
    return gains


def random_rows(rng: np.random.Generator, k: int) -> np.ndarray:
    """``(MEMBERS, N)`` values of every scale, with exact zeros, and member 1 NaN from period 40 on."""
    rows = rng.normal(size=(MEMBERS, N)) * 10.0 ** rng.integers(-7, 1, size=(MEMBERS, N))
    rows[rng.random((MEMBERS, N)) < 0.1] = 0.0
    if k >= 40:
        rows[1] = np.nan
    return rows


def assert_same(fused, reference, names: list[str], k: int) -> None:
    for name in names:
        np.testing.assert_array_equal(getattr(fused, name), getattr(reference, name), err_msg=f"{name}, period {k}")


@pytest.mark.parametrize(("cls", "option"), [(cls, option) for cls, options in OBSERVERS.items() for option in options],
                         ids=lambda value: value.name if isinstance(value, type) else "-".join(value))
def test_fused_observer_equals_its_reference(cls, option):
    gains = member_gains(option)
    fused, reference = build(cls, gains, False), build(cls, gains, True)
    assert fused.accelerator is not None and reference.accelerator is None
    rng = np.random.default_rng(0)
    q0 = rng.normal(size=(MEMBERS, N))
    for observer in (fused, reference):
        observer.reset(q0, np.zeros((MEMBERS, N)))
    q = q0.copy()
    for k in range(PERIODS):
        q += random_rows(rng, k)
        model = SimpleNamespace(psi_hat=rng.normal(size=(MEMBERS, N)), command=rng.normal(size=(MEMBERS, N)))
        # M^-1 tau of this period's command: a function of tau, as a model without the engine's solve has it.
        model.command_acceleration = lambda tau, model=model: model.command + 0.5 * tau
        tau = rng.normal(size=(MEMBERS, N))
        # Another object every third period, of another layout: the accelerator binds it and reads it right.
        reading = np.asfortranarray(q) if k % 3 == 1 else np.repeat(q, 2, axis=1)[:, ::2] if k % 3 == 2 else q
        for observer in (fused, reference):
            observer.update(k * DT, reading, model)
        assert_same(fused, reference, ["injection", "qd_hat", "luaf_hat"], k)
        for observer in (fused, reference):
            observer.advance(tau, model)
        assert_same(fused, reference, ["q_hat", "qd_hat", "luaf_hat"], k)
    assert np.isnan(fused.q_hat[1]).all() and np.isfinite(fused.q_hat[[0, 2, 3, 4]]).all()


@pytest.mark.parametrize("option", NFTSMC_GAINS, ids=["chapter-5", "chapter-4"])
@pytest.mark.parametrize("compensation", ["injection", "estimate", "none"])
@pytest.mark.parametrize("shared_reference", [True, False], ids=["reference-row", "reference-per-member"])
def test_fused_nftsmc_equals_its_reference(option, compensation, shared_reference):
    gains = [{**g, "compensation": compensation} for g in member_gains(option)]
    fused, reference = build(NFTSMC, gains, False), build(NFTSMC, gains, True)
    assert fused.accelerator is not None and reference.accelerator is None
    rng = np.random.default_rng(1)
    for controller in (fused, reference):
        controller.reset()
    for k in range(PERIODS):
        shape = (3, N) if shared_reference else (3, MEMBERS, N)
        q_ref, qd_ref, qdd_ref = rng.normal(size=shape)
        q = q_ref + random_rows(rng, k)
        observer = SimpleNamespace(qd_hat=qd_ref + random_rows(rng, k), luaf_hat=rng.normal(size=(MEMBERS, N)),
                                   injection=rng.normal(size=(MEMBERS, N)))
        A = rng.normal(size=(MEMBERS, N, N))
        M, psi = A @ A.transpose(0, 2, 1) + N * np.eye(N), rng.normal(size=(MEMBERS, N))
        model = SimpleNamespace(M=M, psi_control=psi, control_velocity=lambda qd_hat: qd_hat,
                                apply_M=lambda v, out, M=M: matvec(M, v, out))
        taus = [controller.compute(k * DT, q_ref, qd_ref, qdd_ref, q, observer, model).copy()
                for controller in (fused, reference)]
        np.testing.assert_array_equal(taus[0], taus[1], err_msg=f"tau, period {k}")
        assert_same(fused, reference, ["sliding", "integral"], k)


def test_subclasses_standalone_laws_and_the_switch_take_the_reference():
    class DoubledTOSMO(TOSMO):
        """A user's subclass: its override must be honoured, so it runs the NumPy law."""

        def _linear(self, correction, signal):
            return 2.0 * correction

    gains = member_gains(OBSERVERS[TOSMO][0])
    assert build(DoubledTOSMO, gains, False).accelerator is None
    assert build(AdaptiveNFTSMC, [dict(beta1=1.0, beta2=1.0, gamma1=0.5, rho=1.0, mu=0.5)] * 2,
                 False).accelerator is None
    standalone = TOSMO(TOSMO.Config.model_validate(dict(D=22.0), context={"n_joints": N}), N, DT)
    assert standalone.accelerator is None  # (n,) states: the NumPy law
    with fast.switched(False):
        with fast.switched(False):
            pass
        assert build(TOSMO, gains, False).accelerator is None  # still inside the outer one
    assert build(TOSMO, gains, False).accelerator is not None
    doubled, plain = build(DoubledTOSMO, gains, False), build(TOSMO, gains, False)
    q = np.full((MEMBERS, N), 1e-3)
    for observer in (doubled, plain):
        observer.reset(np.zeros((MEMBERS, N)), np.zeros((MEMBERS, N)))
        observer.update(0.0, q, None)
    np.testing.assert_array_equal(doubled.injection, 2.0 * plain.injection)


def test_a_subclass_keeps_the_accelerator_by_registering_it():
    class RenamedTOSMO(TOSMO):
        """A subclass that changes nothing of the law, and says so."""

    laws.register(RenamedTOSMO, lambda method: laws.TOSMOLaw(method, linear=False))
    try:
        assert build(RenamedTOSMO, member_gains(OBSERVERS[TOSMO][0]), False).accelerator is not None
    finally:
        laws.unregister(RenamedTOSMO)


def test_the_tosmo_reads_no_field_of_its_subclass():
    """The base class's construction asks its class's accelerator, which for the TOSMO needs no Gamma."""
    observer = build(TOSMO, member_gains(OBSERVERS[TOSMO][0]), False)
    assert not hasattr(observer.config, "gamma") and not hasattr(observer, "linear_gain")
    assert observer.accelerator.linear is False


@pytest.mark.slow  # closed-loop runs
def test_the_engine_gives_the_same_series_with_the_laws_accelerated_or_not():
    """Only the laws switched (the rest of the fast paths on): the engine's series are the same bits."""
    scenario = load_scenario(SCENARIOS / "puma_fault.yaml", duration=0.5)
    with laws.without_accelerators():
        reference = simulate(scenario, single(scenario))
    fused = simulate(scenario, single(scenario))
    for name, values in fused.series.items():
        np.testing.assert_array_equal(values, reference.series[name], err_msg=name)
    assert np.abs(fused.series["luaf_hat"]).max() > 0.0


@pytest.mark.slow  # closed-loop runs
def test_the_engine_with_every_fast_path_off_agrees_to_rounding():
    """The switch off (MuJoCo's nominal model for the compiled one, NumPy for every kernel): the series agree
    with the accelerated run's to rounding amplified by half a second of a sliding-mode loop."""
    scenario = load_scenario(SCENARIOS / "puma_fault.yaml", duration=0.5)
    fused = simulate(scenario, single(scenario))
    with fast.switched(False):
        scenario = load_scenario(SCENARIOS / "puma_fault.yaml", duration=0.5)
        reference = simulate(scenario, single(scenario))
    for name, values in fused.series.items():
        np.testing.assert_allclose(values, reference.series[name], rtol=1e-6, atol=1e-9, err_msg=name)


FIRST_CALL = """
import numpy as np
from ftc_mj.engine.batching import stack
from ftc_mj.methods.observers import TOSMO
config = stack([TOSMO.Config.model_validate(dict(D=22.0), context={"n_joints": 3})] * 2, 3)
observer = TOSMO(config, 3, 1e-3, 2)
observer.reset(np.zeros((2, 3)), np.zeros((2, 3)))
observer.update(0.0, np.ones((2, 3)), None)
model = type("Model", (), {"psi_hat": np.zeros((2, 3)), "command_acceleration": lambda self, tau: tau})()
observer.advance(np.zeros((2, 3)), model)
"""


@pytest.mark.slow  # a subprocess
def test_the_first_compilation_is_announced_once_per_law_and_cached(tmp_path):
    """An empty cache (a fresh NUMBA_CACHE_DIR): one line on stderr naming the law and the cache; the next
    process loads the cached kernels and says nothing."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path), "PYTHONPATH": str(Path(__file__).resolve().parents[2]),
           "FTC_MJ_FAST": "1"}

    def stderr() -> list[str]:
        done = subprocess.run([sys.executable, "-c", FIRST_CALL], env=env, capture_output=True, text=True,
                              timeout=600)
        assert done.returncode == 0, done.stderr
        return [line for line in done.stderr.splitlines() if line.strip()]

    first = stderr()
    assert len(first) == 1 and first[0].startswith("compiling the fused TOSMO law (first run on this machine")
    assert str(tmp_path) in first[0]
    assert stderr() == []
