"""Reproducible randomness (ftc_mj.effects.randomness): one seed per scenario; the same scenario and seed give the
same run bit for bit (in one process and across processes), another seed another run; variants share their
noise; random elements do not disturb each other; the seed is in the JSON and the recording."""

from __future__ import annotations

import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

import numpy as np
from fault_scenarios import FAULTS, ROOT, array_fields, load, scenario_data
from rerun.chunk import RrdReader

from ftc_mj.effects import randomness
from ftc_mj.engine.runner import simulate_variant
from ftc_mj.outputs.recording import read_series

#: The LoE scenario (noise, quantisation, an actuator fault at 8 s, diagnosis) cut to 8.5 s.
SHORT = 8.5


def noisy(seed: int, variants: tuple[str, ...] = ("proposed",)) -> dict:
    data = scenario_data(variants=variants)
    data.update(seed=seed, duration=SHORT)
    return data


@pytest.mark.slow  # a closed-loop run of seconds
def test_same_seed_same_run_bit_for_bit(tmp_path: Path) -> None:
    first = load(tmp_path, noisy(5), "a.yaml")
    second = load(tmp_path, noisy(5), "b.yaml")
    runs = [simulate_variant(first, first.variants[0]), simulate_variant(second, second.variants[0]),
            simulate_variant(first, first.variants[0])]
    reference = array_fields(runs[0])
    assert "diagnosis.alarm" in reference and "tau_delivered" in reference
    assert runs[0].diagnosis.alarm.any()  # the run got as far as the fault and its alarm
    for other in runs[1:]:
        fields = array_fields(other)
        assert fields.keys() == reference.keys()
        for name, value in reference.items():
            np.testing.assert_array_equal(fields[name], value, err_msg=name)


@pytest.mark.slow  # a closed-loop run of seconds
def test_another_seed_another_run(tmp_path: Path) -> None:
    a = load(tmp_path, noisy(5), "a.yaml")
    b = load(tmp_path, noisy(6), "b.yaml")
    ra, rb = simulate_variant(a, a.variants[0]), simulate_variant(b, b.variants[0])
    assert not np.array_equal(ra.q_meas, rb.q_meas)
    assert not np.array_equal(ra.luaf_hat, rb.luaf_hat)
    assert not np.array_equal(ra.q_true, rb.q_true)


def test_variants_share_the_noise(tmp_path: Path) -> None:
    """Paired comparison: each variant's measurement is its own truth plus the same noise sequence."""
    data = noisy(3, variants=("proposed", "nftsmc_tosmo"))
    data["sensors"] = {"position": {"noise_std": 1e-4}}
    data["duration"] = 0.3
    scenario = load(tmp_path, data)
    noise = [r.q_meas - r.q_true for r in (simulate_variant(scenario, v) for v in scenario.variants)]
    np.testing.assert_allclose(noise[0], noise[1], rtol=0, atol=1e-15)
    expected = randomness.generator(3, randomness.POSITION_NOISE).standard_normal(noise[0].shape) * 1e-4
    np.testing.assert_allclose(noise[0], expected, rtol=0, atol=1e-15)


def test_each_random_element_has_its_own_stream_of_the_seed() -> None:
    """Stream k of seed s is the k-th child of SeedSequence(s), as SeedSequence(s).spawn gives it; the encoder
    and the tachometer streams differ (the same numbers on both would be one noise read twice)."""
    children = np.random.SeedSequence(7).spawn(2)
    for stream in (randomness.POSITION_NOISE, randomness.VELOCITY_NOISE):
        np.testing.assert_array_equal(randomness.generator(7, stream).standard_normal(8),
                                      np.random.default_rng(children[stream]).standard_normal(8))
    position = randomness.generator(7, randomness.POSITION_NOISE).standard_normal(8)
    velocity = randomness.generator(7, randomness.VELOCITY_NOISE).standard_normal(8)
    assert not np.array_equal(position, velocity)


def test_random_elements_do_not_disturb_each_other(tmp_path: Path) -> None:
    """Adding tachometer noise leaves the encoder noise as it was."""
    data = noisy(3)
    data.update(duration=0.3, actuator_faults=[], sensors={"position": {"noise_std": 1e-4}})
    data["robot"]["sensors"] = ["position", "velocity"]
    scenario = load(tmp_path, data, "a.yaml")
    without = simulate_variant(scenario, scenario.variants[0])
    data["sensors"]["velocity"] = {"noise_std": 1e-3}
    scenario = load(tmp_path, data, "b.yaml")
    with_velocity_noise = simulate_variant(scenario, scenario.variants[0])
    np.testing.assert_allclose(with_velocity_noise.q_meas - with_velocity_noise.q_true,
                               without.q_meas - without.q_true, rtol=0, atol=1e-15)
    assert np.abs(with_velocity_noise.qd_meas - with_velocity_noise.qd_true).max() > 1e-3


@pytest.mark.slow  # a subprocess
def test_same_seed_same_files_across_processes(tmp_path: Path) -> None:
    """Three processes: two with the scenario's seed write identical JSON (metrics to the last bit, alarm
    times) and recordings holding identical data; one with another seed differs."""
    scenario = FAULTS / "puma_loss_of_effectiveness.yaml"
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}

    def call(name: str, *extra: str) -> subprocess.CompletedProcess:
        args = [sys.executable, "-m", "ftc_mj.run", str(scenario), "--variant", "proposed", "--duration", str(SHORT),
                "--quiet", "--json", str(tmp_path / f"{name}.json"), "--out", str(tmp_path / f"{name}.rrd"), *extra]
        return subprocess.run(args, capture_output=True, text=True, env=env, cwd=tmp_path, timeout=300)

    with ThreadPoolExecutor(max_workers=2) as pool:
        outcomes = list(pool.map(lambda job: call(*job), [("a",), ("b",), ("c", "--set", "seed=2")]))
    assert all(o.returncode == 0 for o in outcomes), [o.stderr for o in outcomes]
    a, b, c = ((tmp_path / f"{name}.json").read_text() for name in "abc")
    assert a == b
    assert a != c and '"seed": 2' in c
    for entity in ("/q/proposed", "/luaf/estimate/proposed", "/diagnosis/residual/proposed"):
        np.testing.assert_array_equal(read_series(tmp_path / "a.rrd", entity)[1],
                                      read_series(tmp_path / "b.rrd", entity)[1], err_msg=entity)
    info = [chunk.to_record_batch().column("TextDocument:text").to_pylist()[0][0]
            for chunk in RrdReader(tmp_path / "c.rrd").stream().to_chunks() if chunk.entity_path == "/info"]
    assert "· seed 2 ·" in info[0]
