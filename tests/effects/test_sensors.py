"""Sensor effects (ftc_mj.effects.sensors): quantisation, noise, bias, drift, stuck readings and delay, alone and in
their documented order; in the closed loop the controller side reads the corrupted measurement while the
recorded truth stays true; the schema's errors; and every observer's estimation error growing with the noise
level."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from fault_scenarios import ROOT, assert_input_error, puma_model, run, scenario_data

from ftc_mj.analysis.metrics import compute_metrics
from ftc_mj.config.errors import InputError
from ftc_mj.effects import randomness
from ftc_mj.effects.sensors import Channel, ChannelSpec, EncoderSpec, Measurement, compile_channel
from ftc_mj.engine.runner import simulate_variant
from ftc_mj.scenario.loading import load_scenario

N, NJ, DT = 2000, 3, 1e-3
T = np.arange(N) * DT
TRUE = np.stack([np.sin(3 * T + j) * (1 + j) for j in range(NJ)], axis=1)  # moves on every joint


def channel(**kwargs) -> Channel:
    values = {"resolution": np.zeros(NJ), "noise_std": np.zeros(NJ), "bias": np.zeros(NJ), "drift_rate": np.zeros(NJ)}
    values.update({k: np.asarray(v, dtype=float) if k in values else v for k, v in kwargs.items()})
    return Channel(**values)


def read_all(ch: Channel, true: np.ndarray = TRUE, seed: int = 3) -> np.ndarray:
    measurement = Measurement(ch, T, [np.random.default_rng(seed)])
    out = np.empty_like(true)
    for k in range(len(true)):
        measurement.read(k, true[k], out[k])
    return out


def test_perfect_channel_passes_the_truth() -> None:
    np.testing.assert_array_equal(read_all(channel()), TRUE)


def test_a_channel_without_offsets_passes_the_truth_bit_for_bit() -> None:
    """No noise, bias or drift (quantisation on one joint): the readings are the truth's bits, down to the sign
    of a zero (adding a zero offset would turn -0.0 into 0.0), and the channel never draws from its stream."""
    true = TRUE.copy()
    true[::2] = -0.0
    generator = np.random.default_rng(3)
    measurement = Measurement(channel(resolution=[0.0, 1e-3, 0.0]), T, [generator])
    out = np.empty_like(true)
    for k in range(len(true)):
        measurement.read(k, true[k], out[k])
    assert out[:, [0, 2]].tobytes() == true[:, [0, 2]].tobytes()
    assert np.signbit(out[::2]).all()
    assert generator.bit_generator.state == np.random.default_rng(3).bit_generator.state


def test_partial_quantisation_warns_of_nothing() -> None:
    """Encoders on some joints only: no division by the zero resolution of the others (a NumPy warning on every
    run that sets the channel up)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = read_all(channel(resolution=[0.0, 1e-3, 0.0]))
    np.testing.assert_array_equal(out[:, [0, 2]], TRUE[:, [0, 2]])
    np.testing.assert_allclose(out[:, 1], np.round(TRUE[:, 1] / 1e-3) * 1e-3, rtol=0, atol=1e-15)


def test_quantisation_to_the_nearest_count() -> None:
    step = 2 * np.pi / 4096
    out = read_all(channel(resolution=[step, step, 0.0]))
    counts = out[:, :2] / step
    np.testing.assert_allclose(counts, np.round(counts), rtol=0, atol=1e-9)  # whole counts
    assert np.abs(out[:, :2] - TRUE[:, :2]).max() <= step / 2 * (1 + 1e-9)
    assert np.abs(out[:, :2] - TRUE[:, :2]).max() > 0.45 * step  # and not finer than a count
    np.testing.assert_array_equal(out[:, 2], TRUE[:, 2])  # joint 3 not quantised


def test_bias_and_drift() -> None:
    out = read_all(channel(bias=[0.1, -0.2, 0.0], drift_rate=[0.0, 0.05, -0.01]))
    expected = TRUE + np.array([0.1, -0.2, 0.0]) + np.outer(T, [0.0, 0.05, -0.01])
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-15)


def test_gaussian_noise_statistics_and_seed() -> None:
    std = np.array([1e-3, 1e-4, 0.0])
    out = read_all(channel(noise_std=std))
    noise = out - TRUE
    np.testing.assert_allclose(noise[:, :2].std(axis=0), std[:2], rtol=0.05)  # 2000 samples: about 1.6% spread
    assert np.all(np.abs(noise[:, :2].mean(axis=0)) < 4 * std[:2] / np.sqrt(N))
    assert abs(np.corrcoef(noise[:, 0], noise[:, 1])[0, 1]) < 0.1  # independent joints
    np.testing.assert_array_equal(noise[:, 2], 0.0)
    np.testing.assert_array_equal(read_all(channel(noise_std=std)), out)  # same generator seed, same numbers
    assert not np.array_equal(read_all(channel(noise_std=std), seed=4), out)


def test_stuck_holds_the_last_reading() -> None:
    out = read_all(channel(), true=TRUE)
    stuck = read_all(channel(stuck_onset=0.5, stuck_end=1.2, stuck_joints=np.array([False, True, False])))
    k0, k1 = 500, 1200
    np.testing.assert_array_equal(stuck[k0:k1, 1], out[k0 - 1, 1])
    np.testing.assert_array_equal(stuck[:k0], out[:k0])
    np.testing.assert_array_equal(stuck[k1:], out[k1:])
    np.testing.assert_array_equal(stuck[:, [0, 2]], out[:, [0, 2]])
    # Stuck from the first sample: the first reading holds.
    stuck = read_all(channel(stuck_onset=0.0, stuck_joints=np.ones(NJ, dtype=bool)))
    np.testing.assert_array_equal(stuck, np.broadcast_to(TRUE[0], TRUE.shape))


def test_stuck_until_its_end() -> None:
    """Compiled from a section with an end: stuck on its joints from the onset until (not at) the end."""
    spec = ChannelSpec(stuck={"onset": 0.3, "end": 0.5, "joints": [1, "joint3"]})
    ch = compile_channel(spec, "s.yaml", "sensors.position", puma_model())
    assert (ch.stuck_onset, ch.stuck_end) == (0.3, 0.5)
    held = (T >= 0.3) & (T < 0.5)
    np.testing.assert_array_equal(ch.stuck(T), held[:, None] & np.array([True, False, True]))
    out = read_all(ch)
    k0, k1 = np.flatnonzero(held)[[0, -1]]
    np.testing.assert_array_equal(out[k0:k1 + 1, [0, 2]], np.broadcast_to(TRUE[k0 - 1, [0, 2]], (k1 + 1 - k0, 2)))
    np.testing.assert_array_equal(out[k1 + 1:], TRUE[k1 + 1:])


def test_never_stuck_is_a_boolean_mask() -> None:
    stuck = channel().stuck(T)
    assert stuck.dtype == bool and stuck.shape == (N, NJ)
    assert (~stuck).all()


@pytest.mark.parametrize(("field", "spec"), [
    ("resolution", ChannelSpec(resolution=[1e-3, 1e-3])),
    ("noise_std", ChannelSpec(noise_std=[1e-3, 1e-3])),
    ("bias", ChannelSpec(bias=[0.1, 0.2])),
    ("drift_rate", ChannelSpec(drift_rate=[0.1, 0.2])),
    ("counts_per_rev", EncoderSpec(counts_per_rev=[4096, 4096])),
])
def test_a_list_per_joint_must_have_one_per_joint(field: str, spec: ChannelSpec) -> None:
    with pytest.raises(InputError) as info:
        compile_channel(spec, "s.yaml", "sensors.position", puma_model())
    assert (info.value.file, info.value.field) == ("s.yaml", f"sensors.position.{field}")
    assert info.value.problem.startswith("has 2 values"), info.value.problem


def test_counts_per_rev_give_the_resolution() -> None:
    ch = compile_channel(EncoderSpec(counts_per_rev=[4096, 1000, 65536]), "s.yaml", "sensors.position",
                         puma_model())
    np.testing.assert_array_equal(ch.resolution, 2 * np.pi / np.array([4096, 1000, 65536]))


def test_delay_of_whole_samples() -> None:
    out = read_all(channel(delay_samples=7))
    np.testing.assert_array_equal(out[7:], TRUE[:-7])
    np.testing.assert_array_equal(out[:7], np.broadcast_to(TRUE[0], (7, NJ)))


def test_effects_compose_in_the_documented_order() -> None:
    """delay, then bias + drift + noise, then quantisation, then stuck."""
    step, std, delay = 1e-3, 2e-4, 3
    ch = channel(resolution=[step] * NJ, noise_std=[std] * NJ, bias=[0.01] * NJ, drift_rate=[0.02] * NJ,
                 delay_samples=delay, stuck_onset=1.0, stuck_end=1.5, stuck_joints=np.array([True, False, True]))
    out = read_all(ch, seed=11)
    noise = np.random.default_rng(11).standard_normal((N, NJ)) * std
    delayed = TRUE[np.maximum(np.arange(N) - delay, 0)]
    expected = np.round((delayed + 0.01 + 0.02 * T[:, None] + noise) / step) * step
    held = (T >= 1.0) & (T < 1.5)
    expected[np.ix_(held, [0, 2])] = expected[np.flatnonzero(held)[0] - 1, [0, 2]]
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-12)


# ------------------------------------------------------------------------------------------ closed loop


def sensor_data(sensors: dict, duration: float = 0.5) -> dict:
    data = scenario_data()
    data.update(duration=duration, sensors=sensors, actuator_faults=[])
    data.pop("diagnosis")
    return data


def test_closed_loop_measurement_is_corrupted_truth_stays_true(tmp_path: Path) -> None:
    sensors = {"position": {"counts_per_rev": 65536, "noise_std": 1e-5, "bias": [0.0, 2e-4, 0.0],
                            "delay_samples": 2}}
    scenario, result = run(tmp_path, sensor_data(sensors))
    rng = randomness.generator(scenario.spec.seed, randomness.POSITION_NOISE)
    noise = rng.standard_normal(result.q_true.shape) * 1e-5
    step = 2 * np.pi / 65536
    delayed = result.q_true[np.maximum(np.arange(len(result.t)) - 2, 0)]
    expected = np.round((delayed + [0.0, 2e-4, 0.0] + noise) / step) * step
    np.testing.assert_allclose(result.q_meas, expected, rtol=0, atol=1e-12)
    # The truth is the simulation's: q_true[k + 1] follows from q_true[k] with the recorded velocity.
    assert np.abs(result.q_true - result.q_meas).max() > 1e-4
    assert result.qd_meas is None


def test_closed_loop_controller_follows_the_biased_measurement(tmp_path: Path) -> None:
    """With a 0.01 rad encoder bias on joint 1 the controller makes the *measured* position track the reference:
    the true position ends up 0.01 rad off, which shows the controller saw the corrupted reading."""
    _, result = run(tmp_path, sensor_data({"position": {"bias": [0.01, 0.0, 0.0]}}, duration=3.0))
    late = result.t >= 2.0
    np.testing.assert_allclose(result.tracking_error[late, 0], -0.01, atol=1e-4)
    np.testing.assert_allclose((result.q_meas - result.q_ref)[late], 0.0, atol=1e-4)


def test_closed_loop_tachometers(tmp_path: Path) -> None:
    data = sensor_data({"velocity": {"resolution": 0.01, "bias": 0.2, "stuck": {"onset": 0.3, "joints": [3]}}})
    data["robot"]["sensors"] = ["position", "velocity"]
    _, result = run(tmp_path, data)
    expected = np.round((result.qd_true + 0.2) / 0.01) * 0.01
    held = result.t >= 0.3
    expected[held, 2] = expected[np.flatnonzero(held)[0] - 1, 2]
    np.testing.assert_allclose(result.qd_meas, expected, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(result.q_meas, result.q_true)  # the encoders are perfect here


INVALID = [
    ({"position": {"counts_per_rev": 4096, "resolution": 0.001}}, "sensors.position", "not both"),
    ({"position": {"counts_per_rev": 0}}, "sensors.position.counts_per_rev", "greater than 0"),
    ({"position": {"counts_per_rev": 1.5}}, "sensors.position.counts_per_rev", "integer"),
    ({"position": {"noise_std": -1e-3}}, "sensors.position.noise_std", "greater than or equal to 0"),
    ({"position": {"bias": [0.1, 0.2]}}, "sensors.position.bias", "has 2 values, the robot has 3 joints"),
    ({"position": {"drift_rate": float("nan")}}, "sensors.position.drift_rate", "finite"),
    ({"position": {"delay_samples": -1}}, "sensors.position.delay_samples", "greater than or equal to 0"),
    ({"position": {"delay_samples": 0.5}}, "sensors.position.delay_samples", "integer"),
    ({"position": {"stuck": {"onset": 2.0, "end": 1.0}}}, "sensors.position.stuck", "must be after the onset"),
    ({"position": {"stuck": {"onset": 2.0, "joints": ["wrist"]}}}, "sensors.position.stuck.joints.0", "unknown joint"),
    ({"position": {"gain": 2.0}}, "sensors.position.gain", "unknown key"),
    ({"velocity": {"counts_per_rev": 100}}, "sensors.velocity.counts_per_rev", "unknown key"),
    ({"velocity": {"noise_std": 0.01}}, "sensors.velocity", "no velocity sensors"),
    ({"torque": {}}, "sensors.torque", "unknown key"),
]


@pytest.mark.parametrize(("sensors", "field", "fragment"), INVALID, ids=[f"{i}" for i in range(len(INVALID))])
def test_invalid_sensors(tmp_path: Path, sensors: dict, field: str, fragment: str) -> None:
    assert_input_error(tmp_path, sensor_data(sensors), field, fragment)


# ------------------------------------------------------------------------------------------ estimation vs noise


def estimation_errors(noise_std: float) -> dict[str, tuple[float, float]]:
    """Per observer (each in its Chapter 5 loop): joint-RMS velocity and LUaF errors over 2-4 s."""
    overrides = [f"sensors.position.noise_std={noise_std}", "diagnosis=null"]
    scenario = load_scenario(ROOT / "scenarios" / "puma_fault.yaml", overrides=overrides, duration=4.0,
                             variants=["nftsmc_sosmo", "nftsmc_tosmo", "proposed"])
    out = {}
    for variant in scenario.variants:
        result = simulate_variant(scenario, variant)
        assert result.status == "ok", (variant.name, noise_std)
        metrics = compute_metrics(result, scenario.spec.metrics, scenario.fault_onsets)
        out[variant.name] = (float(np.sqrt(np.mean(metrics["rms_velocity_error"] ** 2))),
                             float(np.sqrt(np.mean(metrics["rms_luaf_error"] ** 2))))
    return out


@pytest.mark.slow  # a closed-loop run of seconds
def test_estimation_error_grows_with_noise_for_every_observer() -> None:
    """Noise 0, 1e-4 and 1e-3 rad, 4 s runs. Measured: velocity error 0.014 / 0.027 / 0.046 rad/s (SOSMO),
    2.7e-4 / 2.3e-3 / 7.6e-3 (TOSMO and HS-TOSMO); LUaF error 1.31 / 2.52 / 3.88 rad/s^2 (SOSMO), 0.051 /
    0.078 / 0.12-0.13 (TOSMOs): every step costs at least 50%. The test asks for 20% per step."""
    levels = [0.0, 1e-4, 1e-3]
    errors = [estimation_errors(level) for level in levels]
    for observer in errors[0]:
        for quantity in (0, 1):
            values = [e[observer][quantity] for e in errors]
            assert all(b > 1.2 * a for a, b in zip(values, values[1:])), (observer, quantity, values)


def test_noise_drawn_in_chunks_is_one_draw_for_the_whole_run() -> None:
    """The measurement draws each member's noise NOISE_CHUNK periods at a time (memory that does not grow with
    the run); the numbers are those of one draw for the whole run, offset for offset."""
    from ftc_mj.effects.sensors import NOISE_CHUNK

    assert N > NOISE_CHUNK  # the run spans more than one chunk
    std, bias = np.array([1e-3, 2e-3, 0.0]), np.array([0.1, 0.0, -0.2])
    out = read_all(channel(noise_std=std, bias=bias), seed=11)
    expected = TRUE + (bias + np.random.default_rng(11).standard_normal((N, NJ)) * std)
    np.testing.assert_array_equal(out, expected)


def test_members_draw_their_own_noise_and_every_variant_reads_it() -> None:
    """Rows are variant blocks of the same members: member m's noise comes from its own generator and is the
    same in every variant's block (a paired comparison)."""
    members, blocks = 3, 2
    measurement = Measurement(channel(noise_std=[1e-3] * NJ), T, [np.random.default_rng(s) for s in (1, 2, 3)],
                              blocks)
    true = np.zeros((blocks * members, NJ))
    out = np.empty_like(true)
    measurement.read(0, true, out)
    np.testing.assert_array_equal(out[:members], out[members:])
    for m, seed in enumerate((1, 2, 3)):
        np.testing.assert_array_equal(out[m], np.random.default_rng(seed).standard_normal((N, NJ))[0] * 1e-3)


def test_the_compiled_pass_is_numpys_sequence_bit_for_bit() -> None:
    """Offsets, quantisation (part of the joints), stuck (part of the joints) over variant blocks of several
    members, NaN and a tie of the rounding included: each sample is what NumPy's operations give in the
    module's order (add the member's offset, ``round(x * (1 / step)) * step`` where quantised, the last
    reading where stuck)."""
    members, blocks = 4, 3
    step = np.array([1e-3, 0.0, 2.5e-4])
    ch = channel(resolution=step, noise_std=[1e-3, 2e-3, 0.0], bias=[0.01, 0.0, -0.2], drift_rate=[0.02, 0.0, 0.0],
                 stuck_onset=0.5, stuck_end=0.9, stuck_joints=np.array([False, True, True]))
    measurement = Measurement(ch, T, [np.random.default_rng(s) for s in range(members)], blocks)
    mirror = Measurement(ch, T, [np.random.default_rng(s) for s in range(members)], blocks)  # draws the same noise
    rng = np.random.default_rng(5)
    rows = blocks * members
    last = np.zeros((rows, NJ))
    quantised = step > 0
    inverse = np.divide(1.0, step, out=np.zeros(NJ), where=quantised)
    for k in range(N):
        true = np.repeat(TRUE[k][None], rows, axis=0) + rng.normal(0, 1e-3, (rows, NJ))
        if k == 7:
            true[2, 0], true[5, 2] = np.nan, 0.5 * 2.5e-4 - 0.0  # NaN, and x / step = 0.5 (a tie)
        got = np.empty((rows, NJ))
        measurement.read(k, true, got)
        index = k % len(mirror._offsets)
        if index == 0:
            mirror._draw(k)
        expected = np.empty((rows, NJ))
        np.add(true.reshape(blocks, members, NJ), mirror._offsets[index], out=expected.reshape(blocks, members, NJ))
        scratch = expected * inverse
        np.round(scratch, out=scratch)
        np.multiply(scratch, step, out=scratch)
        np.copyto(expected, scratch, where=quantised)
        if ch.stuck(T[k:k + 1]).any() and k:
            np.copyto(expected, last, where=ch.stuck(T[k:k + 1])[0])
        last = expected.copy()
        assert np.array_equal(got.view(np.int64), expected.view(np.int64)), k


def test_one_block_by_default_rows_are_the_members() -> None:
    """Without ``blocks`` the rows are the members themselves (one variant): three members' readings, delayed
    by a sample, each from its own row."""
    measurement = Measurement(channel(delay_samples=1), T, [np.random.default_rng(s) for s in range(3)])
    first, second = TRUE[:3], TRUE[3:6]
    out = np.empty((3, NJ))
    measurement.read(0, first, out)
    np.testing.assert_array_equal(out, first)
    measurement.read(1, second, out)
    np.testing.assert_array_equal(out, first)  # a sample ago
