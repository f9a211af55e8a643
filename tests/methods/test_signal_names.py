"""``signal_names``, the signals a method declares (:attr:`ftc_mj.methods.plugin.Method.signal_names`): every
built-in plugin declares them, and what it records (``self.signals``) is exactly that."""

from __future__ import annotations

from pathlib import Path

import pytest

from ftc_mj.methods.plugin import Method
from ftc_mj.methods.registry import controller_types, observer_types
from ftc_mj.scenario.loading import load_scenario

ROOT = Path(__file__).resolve().parents[2]
#: Between them, every built-in observer and controller.
SCENARIOS = ["two_link_do.yaml", "two_link_tosmo_simple.yaml", "puma_fault.yaml", "baselines/observers_diagnosis.yaml",
             "baselines/ctc_pd.yaml", "baselines/super_twisting.yaml", "baselines/pid.yaml"]


def test_the_default_is_undeclared():
    assert Method.signal_names is None


def test_every_built_in_plugin_declares_its_signals():
    plugins = {**observer_types(), **controller_types()}
    builtin = {name: cls for name, cls in plugins.items() if cls.__module__.startswith("ftc_mj.")}
    assert builtin
    assert {name for name, cls in builtin.items() if cls.signal_names is None} == set()


@pytest.mark.parametrize("file", SCENARIOS)
def test_what_a_method_records_is_what_it_declares(file):
    scenario = load_scenario(ROOT / "scenarios" / file, duration=0.003)
    for variant in scenario.variants:
        methods = [(variant.observer_type, variant.observer_config), (variant.controller_type, variant.controller_config)]
        methods += [(monitor.observer_type, monitor.observer_config) for monitor in variant.monitors]
        for plugin, config in methods:
            instance = plugin(config, scenario.n_joints, scenario.spec.control_dt)
            assert set(instance.signals) == plugin.signal_names, plugin.name
