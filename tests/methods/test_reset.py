"""``reset`` of every built-in observer and controller puts back the state a new instance starts from: after a
run has left every state it writes dirty, reset at q = qd = 0 gives the arrays and flags of a fresh instance
(an integral, a residual, a covariance or a flag that reset forgets carries one run into the next)."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from ftc_mj.methods.observers.base import Observer
from ftc_mj.scenario.loading import load_scenario

ROOT = Path(__file__).resolve().parents[2]
#: Between them, every built-in observer and controller.
SCENARIOS = ["two_link_do.yaml", "two_link_tosmo_simple.yaml", "puma_fault.yaml", "baselines/observers_diagnosis.yaml",
             "baselines/ctc_pd.yaml", "baselines/super_twisting.yaml", "baselines/pid.yaml"]


def _methods():
    seen = {}
    for file in SCENARIOS:
        scenario = load_scenario(ROOT / "scenarios" / file, duration=0.003)
        for variant in scenario.variants:
            pairs = [(variant.observer_type, variant.observer_config),
                     (variant.controller_type, variant.controller_config)]
            pairs += [(monitor.observer_type, monitor.observer_config) for monitor in variant.monitors]
            for plugin, config in pairs:
                seen.setdefault(plugin.name, (plugin, config, scenario.n_joints, scenario.spec.control_dt))
    return seen


METHODS = _methods()


def _state(instance) -> dict[str, object]:
    """Every float array (also inside lists) and every flag or counter of the instance, copied."""
    out = {}
    for name, value in vars(instance).items():
        if isinstance(value, np.ndarray) and value.dtype.kind == "f":
            out[name] = value.copy()
        elif isinstance(value, list) and value and all(isinstance(v, np.ndarray) for v in value):
            out[name] = [v.copy() for v in value]
        elif isinstance(value, (bool, int, float, type(None))):
            out[name] = copy.copy(value)
    return out


def _reset(instance, n: int) -> None:
    if isinstance(instance, Observer):
        instance.reset(np.zeros(n), np.zeros(n))
    else:
        instance.reset()


def _arrays(instance):
    for name, value in vars(instance).items():
        if isinstance(value, np.ndarray) and value.dtype.kind == "f" and value.flags.writeable:
            yield name, value
        elif isinstance(value, list) and value and all(isinstance(v, np.ndarray) for v in value):
            for i, v in enumerate(value):
                yield f"{name}[{i}]", v


@pytest.mark.parametrize("name", sorted(METHODS))
def test_reset_gives_the_state_of_a_new_instance(name):
    plugin, config, n, dt = METHODS[name]
    fresh = _state(plugin(config, n, dt))
    # Which arrays reset writes: those it overwrites when every array starts out NaN.
    probe = plugin(config, n, dt)
    for _, value in _arrays(probe):
        value[...] = np.nan
    _reset(probe, n)
    written = {key for key, value in _arrays(probe) if not np.isnan(value).all()}
    assert written, name
    used = plugin(config, n, dt)
    for key, value in _arrays(used):
        if key in written:
            value[...] = 7.0  # what a run leaves
    _reset(used, n)
    after = _state(used)
    for key, value in fresh.items():
        if isinstance(value, list):
            for i, (a, b) in enumerate(zip(after[key], value)):
                np.testing.assert_array_equal(a, b, err_msg=f"{name}: {key}[{i}]")
        elif isinstance(value, np.ndarray):
            if key in written:
                np.testing.assert_array_equal(after[key], value, err_msg=f"{name}: {key}")
        else:
            assert after[key] == value, f"{name}: {key}"


@pytest.mark.parametrize("name", sorted(METHODS))
def test_a_method_keeps_its_config(name):
    """``config`` is the configuration it was made with (the engine and the recordings read it from there)."""
    plugin, config, n, dt = METHODS[name]
    assert plugin(config, n, dt).config is config


@pytest.mark.parametrize("name", sorted(METHODS))
def test_members_give_a_leading_axis(name):
    """With ``members`` the state is ``(members, n)``: each member its own row."""
    plugin, config, n, dt = METHODS[name]
    instance = plugin(config, n, dt, 3)
    state = instance.q_hat if isinstance(instance, Observer) else instance.tau
    assert state.shape == (3, n), name


@pytest.mark.parametrize("name", sorted(n for n, (plugin, *_) in METHODS.items() if issubclass(plugin, Observer)))
def test_an_observer_starts_at_the_state_it_is_reset_to(name):
    """After reset(q0, qd0): q_hat = q0 and qd_hat = qd0 (not swapped, not zero), and nothing estimated yet."""
    plugin, config, n, dt = METHODS[name]
    observer = plugin(config, n, dt)
    q0, qd0 = np.linspace(0.1, 0.5, n), np.linspace(-0.3, 0.2, n)
    observer.reset(q0, qd0)
    np.testing.assert_array_equal(observer.q_hat, q0)
    np.testing.assert_array_equal(observer.qd_hat, qd0)
    np.testing.assert_array_equal(observer.luaf_hat, 0.0)
    np.testing.assert_array_equal(observer.injection, 0.0)
