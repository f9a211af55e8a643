"""ftc_mj.methods.registry: built-in methods by name, third-party methods through entry points.

Third-party plugins are simulated: ``ftc_mj.methods.registry.entry_points`` is replaced by a function returning
``importlib.metadata.EntryPoint`` objects whose ``value`` points into a module object put in ``sys.modules``
(a real installed distribution is not needed). ``registry._discover`` is cached, so every test clears the
cache before and after.
"""

from __future__ import annotations

import sys
import types
from importlib.metadata import EntryPoint
from pathlib import Path
from typing import ClassVar

import numpy as np
import pytest
import yaml

from ftc_mj.engine.runner import simulate_variant
from ftc_mj.methods import controllers, observers, registry
from ftc_mj.methods.controllers.nftsmc import NFTSMC, NFTSMCConfig
from ftc_mj.methods.gains import GainConfig, PositiveFloat
from ftc_mj.methods.observers.base import Observer
from ftc_mj.methods.observers.tosmo import TOSMO
from ftc_mj.config.errors import InputError
from ftc_mj.scenario.loading import load_scenario

ROOT = Path(__file__).resolve().parents[2]
TWO_LINK = ROOT / "models" / "two_link.xml"
PLUGIN_MODULE = "ftc_mj_test_thirdparty_plugins"


# ------------------------------------------------------------------------------------------ a third party


class FrozenConfig(GainConfig):
    """Gains of the third-party observer."""

    decay: PositiveFloat


class FrozenObserver(Observer):
    """A minimal third-party observer: q_hat follows the measurement, velocity from a first difference."""

    name: ClassVar[str] = "frozen"
    Config: ClassVar[type[GainConfig]] = FrozenConfig

    def update(self, t, q_meas, model):
        self.qd_hat[:] = (q_meas - self.q_hat) / self.dt
        self.q_hat[:] = q_meas

    def advance(self, tau, model):
        self.luaf_hat *= self.config.decay


class ThirdPartyNFTSMC(NFTSMC):
    """A third-party controller (here: the NFTSMC under another name and class)."""

    name: ClassVar[str] = "third_party_nftsmc"
    Config: ClassVar[type[GainConfig]] = NFTSMCConfig


class ImpostorTOSMO(TOSMO):
    """Declared under a built-in name by a third party; must not replace the built-in."""

    name: ClassVar[str] = "tosmo"


class ImpostorNFTSMC(NFTSMC):
    name: ClassVar[str] = "nftsmc"


@pytest.fixture
def thirdparty(monkeypatch: pytest.MonkeyPatch):
    """Install a plugin module and a fake entry_points(); yields the list of declared entry points to extend."""
    module = types.ModuleType(PLUGIN_MODULE)
    for cls in (FrozenObserver, ThirdPartyNFTSMC, ImpostorTOSMO, ImpostorNFTSMC):
        setattr(module, cls.__name__, cls)
    monkeypatch.setitem(sys.modules, PLUGIN_MODULE, module)
    declared: list[EntryPoint] = []
    groups_asked: list[str] = []

    def fake_entry_points(*, group: str):
        groups_asked.append(group)
        return [entry for entry in declared if entry.group == group]

    monkeypatch.setattr(registry, "entry_points", fake_entry_points)
    registry._discover.cache_clear()
    try:
        yield declared, groups_asked
    finally:
        registry._discover.cache_clear()


@pytest.fixture(autouse=True)
def _fresh_registry():
    registry._discover.cache_clear()
    yield
    registry._discover.cache_clear()


def entry(name: str, cls: type, group: str) -> EntryPoint:
    return EntryPoint(name=name, value=f"{PLUGIN_MODULE}:{cls.__name__}", group=group)


def write_scenario(tmp_path: Path, observer: dict, controller: dict) -> Path:
    spec = {
        "name": "registry_test",
        "robot": {"model": str(TWO_LINK)},
        "duration": 0.1,
        "initial": {"q": [0.1, -0.2]},
        "reference": ["0.1*cos(t)", "-0.2 + 0.1*sin(t)"],
        "variants": {"third_party": {"observer": observer, "controller": controller}},
        "metrics": {"window_start": 0.05, "estimation_window_start": 0.05},
    }
    path = tmp_path / "scenario.yaml"
    path.write_text(yaml.safe_dump(spec, sort_keys=False), encoding="utf-8")
    return path


NFTSMC_GAINS = {"beta1": 15.0, "beta2": 10.0, "beta3": 10.0, "beta4": 5.0, "gamma1": 0.5, "bound": 0.5, "mu": 0.5}


# ------------------------------------------------------------------------------------------ built-ins


def test_builtin_names_are_found() -> None:
    found_observers = registry.observer_types()
    found_controllers = registry.controller_types()
    assert {"sosmo", "tosmo", "hs_tosmo"} <= set(found_observers)
    assert "nftsmc" in found_controllers
    for name, cls in found_observers.items():
        if name in observers.BUILTIN:
            assert cls.name == name and issubclass(cls, Observer)
    assert found_controllers["nftsmc"] is NFTSMC


def test_builtins_are_found_without_any_entry_point(thirdparty) -> None:
    _, groups_asked = thirdparty
    assert set(registry.observer_types()) == set(observers.BUILTIN) == {
        "do", "eso", "sosmo", "tosmo", "hs_tosmo", "levant", "ndob", "ndob_levant", "kalman", "momentum",
        "momentum_levant"}
    assert set(registry.controller_types()) == set(controllers.BUILTIN) == {
        "smc", "ntsmc", "nftsmc", "a_nftsmc", "sigmoid_nftsmc", "computed_torque", "super_twisting", "pid",
        "event_nftsmc", "supervisor", "loe_accommodation"}
    assert set(groups_asked) == {registry.OBSERVER_GROUP, registry.CONTROLLER_GROUP}
    assert registry.OBSERVER_GROUP == "ftc_mj.observers" and registry.CONTROLLER_GROUP == "ftc_mj.controllers"


def test_unknown_name_is_an_input_error(tmp_path: Path) -> None:
    path = write_scenario(tmp_path, {"type": "no_such_observer"}, {"type": "nftsmc", "gains": NFTSMC_GAINS})
    with pytest.raises(InputError) as info:
        load_scenario(path)
    message = str(info.value)
    assert "no_such_observer" in message and "hs_tosmo" in message  # lists the known names


# ------------------------------------------------------------------------------------------ entry points


def test_entry_point_plugins_are_discovered(thirdparty) -> None:
    declared, _ = thirdparty
    declared.append(entry("frozen", FrozenObserver, registry.OBSERVER_GROUP))
    declared.append(entry("third_party_nftsmc", ThirdPartyNFTSMC, registry.CONTROLLER_GROUP))
    found_observers = registry.observer_types()
    found_controllers = registry.controller_types()
    assert found_observers["frozen"] is FrozenObserver
    assert found_controllers["third_party_nftsmc"] is ThirdPartyNFTSMC
    # The built-ins are still there, and a plugin stays in its own group.
    assert {"sosmo", "tosmo", "hs_tosmo"} <= set(found_observers)
    assert "frozen" not in found_controllers and "third_party_nftsmc" not in found_observers


def test_entry_point_plugin_is_usable_in_a_scenario(tmp_path: Path, thirdparty) -> None:
    declared, _ = thirdparty
    declared.append(entry("frozen", FrozenObserver, registry.OBSERVER_GROUP))
    declared.append(entry("third_party_nftsmc", ThirdPartyNFTSMC, registry.CONTROLLER_GROUP))
    path = write_scenario(
        tmp_path,
        {"type": "frozen", "gains": {"decay": 0.5}},
        {"type": "third_party_nftsmc", "gains": {**NFTSMC_GAINS, "compensation": "none"}},
    )
    scenario = load_scenario(path)
    variant = scenario.variants[0]
    assert variant.observer_type is FrozenObserver and variant.controller_type is ThirdPartyNFTSMC
    assert isinstance(variant.observer_config, FrozenConfig) and variant.observer_config.decay == 0.5
    result = simulate_variant(scenario, variant)
    assert result.status == "ok"
    assert (result.observer, result.controller) == ("frozen", "third_party_nftsmc")
    # The observer really ran: after the first sample its velocity is the first difference of the measurement.
    np.testing.assert_allclose(result.qd_hat[1:], np.diff(result.q_meas, axis=0) / scenario.spec.control_dt,
                               rtol=1e-9, atol=1e-12)


def test_entry_point_plugin_gains_are_validated(tmp_path: Path, thirdparty) -> None:
    declared, _ = thirdparty
    declared.append(entry("frozen", FrozenObserver, registry.OBSERVER_GROUP))
    path = write_scenario(tmp_path, {"type": "frozen", "gains": {"decay": -1.0}},
                          {"type": "nftsmc", "gains": NFTSMC_GAINS})
    with pytest.raises(InputError) as info:
        load_scenario(path)
    assert "variants.third_party.observer.gains.decay" in str(info.value)


def test_builtin_name_is_not_overridden_by_an_entry_point(tmp_path: Path, thirdparty) -> None:
    declared, _ = thirdparty
    declared.append(entry("tosmo", ImpostorTOSMO, registry.OBSERVER_GROUP))
    declared.append(entry("nftsmc", ImpostorNFTSMC, registry.CONTROLLER_GROUP))
    assert registry.observer_types()["tosmo"] is observers.BUILTIN["tosmo"]
    assert registry.observer_types()["tosmo"] is not ImpostorTOSMO
    assert registry.controller_types()["nftsmc"] is NFTSMC
    path = write_scenario(tmp_path, {"type": "tosmo", "gains": {"D": 22.0}}, {"type": "nftsmc", "gains": NFTSMC_GAINS})
    variant = load_scenario(path).variants[0]
    assert variant.observer_type is observers.BUILTIN["tosmo"]
    assert variant.controller_type is NFTSMC


def test_discovery_is_cached_until_cleared(thirdparty) -> None:
    declared, groups_asked = thirdparty
    first = registry.observer_types()
    registry.observer_types()
    assert groups_asked.count(registry.OBSERVER_GROUP) == 1
    declared.append(entry("frozen", FrozenObserver, registry.OBSERVER_GROUP))
    assert "frozen" not in registry.observer_types() and "frozen" not in first
    registry._discover.cache_clear()
    assert "frozen" in registry.observer_types()


# A broken third-party plugin must not stop scenarios that do not use it (entry points load on first use).
def test_broken_entry_point_does_not_break_builtin_scenarios(tmp_path: Path, thirdparty) -> None:
    declared, _ = thirdparty
    declared.append(EntryPoint(name="broken", value="ftc_mj_no_such_module:Observer", group=registry.OBSERVER_GROUP))
    path = write_scenario(tmp_path, {"type": "tosmo", "gains": {"D": 22.0}}, {"type": "nftsmc", "gains": NFTSMC_GAINS})
    scenario = load_scenario(path)
    assert scenario.variants[0].observer_type is observers.BUILTIN["tosmo"]
    broken = write_scenario(tmp_path, {"type": "broken", "gains": {}}, {"type": "nftsmc", "gains": NFTSMC_GAINS})
    with pytest.raises(InputError, match=r"observer\.type: plugin 'broken' .*cannot be imported"):
        load_scenario(broken)
