"""A plugin written in plain NumPy on the primitives is bit-identical batched (docs/explanation/batching.md):
a small observer defined here, with a fractional power of a gain exponent and of a literal one, an exp of its
state and per-joint gains, registered for these tests only, runs as the host observer of a batch of 5 members
of a 3-joint robot (members != joints, so that a mixed-up axis shows) with per-member gains; each member equals
its own run alone, bit for bit."""

from __future__ import annotations

from pathlib import Path
from typing import ClassVar

import numpy as np
import pytest
import yaml

from ftc_mj.engine.loop import simulate
from ftc_mj.engine.members import members_from_overrides
from ftc_mj.engine.runner import variant_result
from ftc_mj.methods import controllers, observers, registry
from ftc_mj.methods.controllers import NFTSMC
from ftc_mj.methods.gains import Exponent, GainConfig, PositiveFloat, PositiveJoints
from ftc_mj.methods.observers.base import Observer
from ftc_mj.methods.primitives import exp, signed_power
from ftc_mj.scenario.loading import load_scenario

#: closed-loop batches checked member by member against single runs
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]


class FractionalObserverConfig(GainConfig):
    k1: PositiveJoints
    k2: PositiveJoints
    k3: PositiveJoints
    exponent: Exponent  # one number: the engine hands it as a (members, n) array
    width: PositiveFloat


class FractionalObserver(Observer):
    """A third-order sliding-mode observer with a gain exponent and an exp-scheduled gain:

        dx1_hat/dt = x2_hat + k1 |e|^(2/3) sign(e)
        dx2_hat/dt = Psi + M^-1 u + k2 s |e|^p sign(e) + z,   s = 1 + exp(-|e| / w),   dz/dt = k3 sign(e)

    The gain exponent's power is in the injection, which reaches the recorded torque directly (a last-bit
    difference in the position correction would mostly vanish in q_hat's rounding); s is recorded as a signal.
    """

    name: ClassVar[str] = "test_fractional"
    Config: ClassVar[type[FractionalObserverConfig]] = FractionalObserverConfig

    def __init__(self, config: FractionalObserverConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        self._error = np.zeros(self.shape)
        self._rate = np.zeros(self.shape)
        self._sign = np.zeros(self.shape)
        self.schedule = np.zeros(self.shape)
        self.signals["schedule"] = self.schedule

    def update(self, t: float, q_meas: np.ndarray, model) -> None:
        c = self.config
        error = np.subtract(q_meas, self.q_hat, out=self._error)
        np.sign(error, out=self._sign)
        self._rate[:] = self.qd_hat + c.k1 * signed_power(error, 2 / 3)
        self.schedule[:] = 1.0 + exp(-np.abs(error) / c.width)
        self.injection[:] = c.k2 * self.schedule * signed_power(error, c.exponent) + self.luaf_hat

    def advance(self, tau: np.ndarray, model) -> None:
        self.q_hat += self.dt * self._rate
        self.qd_hat += self.dt * (model.psi_hat + model.command_acceleration(tau) + self.injection)
        self.luaf_hat += self.dt * self.config.k3 * self._sign


class RebindingObserver(FractionalObserver):
    """The same law, its estimates new arrays every period (``x = x + ...``, the same bits as ``x += ...``), and
    the engine's copies of them into the series must follow (:class:`ftc_mj.fast.copies.SampleCopies`)."""

    name: ClassVar[str] = "test_rebinding"

    def advance(self, tau: np.ndarray, model) -> None:
        self.q_hat = self.q_hat + self.dt * self._rate
        self.qd_hat = self.qd_hat + self.dt * (model.psi_hat + model.command_acceleration(tau) + self.injection)
        self.luaf_hat = self.luaf_hat + self.dt * self.config.k3 * self._sign


GAINS = {"k1": 5.6, "k2": [16.6, 15.0, 17.0], "k3": 24.0, "exponent": 1 / 3, "width": 0.01}
#: Per member: its own exponent (0.5 among them: sqrt where a number, pow where a gain), gains, seed.
MEMBERS = [
    {"variants.fractional.observer.gains.exponent": 0.5},
    {"variants.fractional.observer.gains.exponent": 0.4, "seed": 11},
    {"variants.fractional.observer.gains.k2": [12.0, 20.0, 14.0], "variants.fractional.observer.gains.width": 0.05},
    {"variants.fractional.observer.gains.exponent": 0.6, "variants.fractional.observer.gains.k1": 8.0},
    {"seed": 7, "variants.fractional.observer.gains.k3": 30.0},
]


def scenario_dict() -> dict:
    return {
        "name": "plugin_batching",
        "robot": {"model": str(ROOT / "models" / "puma560.xml"), "sensors": ["position"]},
        "seed": 3,
        "duration": 0.15,
        "control_dt": 1e-3,
        "timestep": 5e-4,
        "initial": {"q": [-0.5, -0.5, -0.5], "qd": [0.0, 0.0, 0.0]},
        "observer_initial": {"qd_hat": [0.5, 0.5, 0.5]},
        "reference": ["cos(pi*t/5) - 1", "sin(pi*t/5 + pi/2) - 1", "0.3*sin(2*t) - 0.5"],
        "terms": [
            {"kind": "friction", "space": "torque", "sign": -1, "value": ["1.9*sin(qd1)", "2.03*sin(qd2)", "1.76*sin(qd3)"]},
            {"kind": "fault", "space": "acceleration", "sign": 1, "onset": 0.05, "rate": 20.0,
             "value": ["10*sin(q1*q2) + 3.7*cos(qd1*q2)", "15*sin(q1*q2)", "0"]},
        ],
        "sensors": {"position": {"counts_per_rev": 65536, "noise_std": 1e-5}},
        "variants": {"fractional": {
            "observer": {"type": FractionalObserver.name, "gains": GAINS},
            "controller": {"type": "nftsmc", "gains": {"beta1": 15.0, "beta2": 10.0, "gamma1": 0.5, "bound": 0.5,
                                                      "mu": 0.5, "compensation": "injection"}}}},
        "metrics": {"window_start": 0.05, "estimation_window_start": 0.05},
    }


@pytest.fixture(scope="module")
def scenarios(tmp_path_factory):
    """The scenario, and the same with the rebinding observer, the test observers registered as built-ins
    while the module's tests run."""
    with pytest.MonkeyPatch.context() as patch:
        registry._discover.cache_clear()
        for plugin in (FractionalObserver, RebindingObserver):
            patch.setitem(observers.BUILTIN, plugin.name, plugin)
        folder = tmp_path_factory.mktemp("plugin")
        loaded = []
        for plugin in (FractionalObserver, RebindingObserver):
            spec = scenario_dict()
            spec["variants"]["fractional"]["observer"]["type"] = plugin.name
            path = folder / f"{plugin.name}.yaml"
            path.write_text(yaml.safe_dump(spec, sort_keys=False), encoding="utf-8")
            loaded.append(load_scenario(path))
        yield loaded
    registry._discover.cache_clear()


@pytest.fixture(scope="module")
def scenario(scenarios):
    return scenarios[0]


@pytest.fixture(scope="module")
def batch_run(scenario):
    return simulate(scenario, members_from_overrides(scenario, MEMBERS), nthread=2)


SERIES = ("q_meas", "q_true", "qd_true", "qd_hat", "luaf_hat", "luaf_true", "tau", "sliding")


@pytest.mark.parametrize("member", range(len(MEMBERS)))
def test_every_member_of_a_plain_numpy_plugin_equals_its_own_run(scenario, batch_run, member):
    seed = scenario.spec.seed + member  # a member without its own seed has seed + its index
    alone = simulate(scenario, members_from_overrides(scenario, [{"seed": seed, **MEMBERS[member]}]), nthread=1)
    batched, single = variant_result(scenario, batch_run, 0, member), variant_result(scenario, alone, 0, 0)
    assert batched.status == single.status == "ok" and batched.observer == FractionalObserver.name
    for name in SERIES:
        np.testing.assert_array_equal(getattr(batched, name), getattr(single, name), err_msg=name)  # bit for bit
    assert set(batched.extras) == set(single.extras) and batched.extras
    for name, values in batched.extras.items():
        np.testing.assert_array_equal(values, single.extras[name], err_msg=name)


def test_the_members_differ(scenario, batch_run):
    """Each member's gains change its estimate (else the test above proves little)."""
    first = variant_result(scenario, batch_run, 0, 0).luaf_hat
    for member in range(1, len(MEMBERS)):
        assert np.abs(variant_result(scenario, batch_run, 0, member).luaf_hat - first).max() > 1e-6, member


@pytest.mark.parametrize("members", [1, 4])
def test_estimates_rebound_every_period_are_recorded_as_written_in_place(scenarios, members):
    """The series of an observer that makes its estimates new arrays every period are those of the same law
    writing them in place, bit for bit: the engine copies what the plugin holds now, not what it held."""
    runs = [simulate(each, members_from_overrides(each, MEMBERS[:members]), nthread=1) for each in scenarios]
    for member in range(members):
        in_place, rebound = (variant_result(each, run, 0, member) for each, run in zip(scenarios, runs))
        assert np.abs(np.diff(rebound.qd_hat, axis=0)).max() > 0  # the estimate moves
        for name in SERIES:
            np.testing.assert_array_equal(getattr(rebound, name), getattr(in_place, name), err_msg=name)


class NewCommandNFTSMC(NFTSMC):
    """The NFTSMC's law, its command a new array every period: the engine must command and record what it
    returns, not what the controller's ``tau`` held when the copies were set up."""

    name: ClassVar[str] = "test_new_command"

    def compute(self, t, q_ref, qd_ref, qdd_ref, q_meas, observer, model):
        command = super().compute(t, q_ref, qd_ref, qdd_ref, q_meas, observer, model).copy()
        self.tau[...] = np.nan  # what a copy of the old array would command
        return command


@pytest.mark.parametrize("members", [1, 4])
def test_a_command_returned_as_a_new_array_every_period_is_the_one_applied(scenario, tmp_path, members):
    with pytest.MonkeyPatch.context() as patch:
        registry._discover.cache_clear()
        patch.setitem(observers.BUILTIN, FractionalObserver.name, FractionalObserver)
        patch.setitem(controllers.BUILTIN, NewCommandNFTSMC.name, NewCommandNFTSMC)
        spec = scenario_dict()
        spec["variants"]["fractional"]["controller"]["type"] = NewCommandNFTSMC.name
        path = tmp_path / "new_command.yaml"
        path.write_text(yaml.safe_dump(spec, sort_keys=False), encoding="utf-8")
        new_command = load_scenario(path)
        runs = [simulate(each, members_from_overrides(each, MEMBERS[:members]), nthread=1)
                for each in (scenario, new_command)]
    registry._discover.cache_clear()
    for member in range(members):
        in_place, returned = (variant_result(each, run, 0, member) for each, run in zip((scenario, new_command), runs))
        assert np.abs(returned.tau).max() > 0
        for name in SERIES:
            np.testing.assert_array_equal(getattr(returned, name), getattr(in_place, name), err_msg=name)
