"""write_recording: entity layout (per joint, one column per variant), float32 values and exact timeline, the
stored figure layout, blueprint and geometry, atomic writes; read_series back."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import mujoco
import numpy as np
import pyarrow as pa
import pytest
import rerun as rr
import rerun.blueprint as rrb
from rerun.chunk import RrdReader

from ftc_mj.results import VariantResult
from ftc_mj.outputs.files import TEMPORARY
from ftc_mj.outputs.layout import MAX_TICK_INTERVALS, TICK_MARGIN, Figure, tick_range, variant_styles
from ftc_mj.outputs.recording import (DIAGNOSIS_SERIES, EYE_DISTANCE, OPTIONAL_SERIES, SERIES, _eye, read_layout,
                                     read_series, tab_labels, write_recording)

N, NJ, STRIDE = 500, 2, 10
VARIANTS = ("nftsmc_sosmo", "nftsmc_tosmo")

# Two links on hinges, with one geom of every drawable kind plus a floor plane (skipped) and a hidden geom.
MJCF = """
<mujoco>
  <asset><mesh name="tet" vertex="0 0 0  0.1 0 0  0 0.1 0  0 0 0.1"/></asset>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <geom name="base" type="box" size="0.1 0.1 0.05" rgba="0.2 0.2 0.2 1"/>
    <body name="link1" pos="0 0 0.1">
      <joint name="j1" type="hinge" axis="0 0 1"/>
      <geom name="upper" type="capsule" fromto="0 0 0 0.5 0 0" size="0.04" rgba="0.8 0.3 0.3 1"/>
      <geom name="hub" type="cylinder" size="0.05 0.05"/>
      <geom name="hidden" type="sphere" size="0.05" group="3"/>
      <body name="link2" pos="0.5 0 0">
        <joint name="j2" type="hinge" axis="0 1 0"/>
        <geom name="lower" type="capsule" fromto="0 0 0 0.4 0 0" size="0.03"/>
        <geom name="elbow" type="sphere" size="0.045"/>
        <geom name="tool" type="ellipsoid" pos="0.4 0 0" size="0.03 0.02 0.01"/>
        <geom name="tag" type="mesh" mesh="tet" pos="0.2 0 0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(MJCF)


def make_result(model: mujoco.MjModel, name: str, k: int) -> VariantResult:
    """Known signals (sin/cos of t, scaled by the variant number k) and body poses from forward kinematics."""
    t = 1.0 + np.arange(N) * 1e-3  # 1.025 s etc. would truncate to ...999 ns: checks the ns rounding too
    phase = np.arange(1, NJ + 1)
    s, c = np.sin(np.outer(t, phase) + k), np.cos(np.outer(t, phase) + k)
    q_ref = 0.5 * s
    data = mujoco.MjData(model)
    xpos, xquat = np.empty((N, model.nbody, 3)), np.empty((N, model.nbody, 4))
    for i in range(N):
        data.qpos[:] = q_ref[i]
        mujoco.mj_kinematics(model, data)
        xpos[i], xquat[i] = data.xpos, data.xquat
    luaf_hat = (k + 1) * c * np.pi / 3  # values with full mantissas, for a bit-exact comparison
    fault = np.where(t[:, None] >= 1.25, 2.0 + 0 * s, 0.0)
    return VariantResult(
        name=name, observer=f"obs{k}", controller="nftsmc", t=t,
        q_ref=q_ref, qd_ref=0.5 * c * phase, qdd_ref=-0.5 * s * phase**2,
        q_meas=q_ref + 1e-3 * k, q_true=q_ref + 2e-3, qd_true=0.5 * c * phase, qdd_true=-0.5 * s * phase**2,
        qd_hat=0.5 * c * phase + 1e-2, luaf_hat=luaf_hat, luaf_true=(k + 1) * c,
        tau=10 * s, sliding=0.1 * c, fault=fault, fault_active=t >= 1.25,
        body_xpos=xpos, body_xquat=xquat,
        extras={"gain": np.full((N, NJ), 3.0 + k)},
    )


@pytest.fixture(scope="module")
def results(model: mujoco.MjModel) -> list[VariantResult]:
    return [make_result(model, name, k) for k, name in enumerate(VARIANTS)]


@pytest.fixture(scope="module")
def rrd(tmp_path_factory: pytest.TempPathFactory, model: mujoco.MjModel, results: list[VariantResult]) -> Path:
    path = tmp_path_factory.mktemp("rec") / "sub" / "demo.rrd"  # parent directory does not exist yet
    write_recording(path, scenario="demo", model=model, results=results, fault_onsets=[1.25], seed=7,
                    pose_stride=STRIDE)
    return path


@pytest.fixture(scope="module")
def chunks(rrd: Path) -> list:
    return RrdReader(rrd).stream().to_chunks()


def column(chunks: list, entity: str, component: str = "Scalars:scalars") -> tuple[np.ndarray, list]:
    """Timeline (int ns) and values of the temporal chunks of ``entity``, in time order."""
    batches = [c.to_record_batch() for c in chunks if c.entity_path == entity and not c.is_static]
    assert batches, f"no temporal data at {entity}"
    table = pa.Table.from_batches(batches, schema=batches[0].schema).sort_by("sim_time")
    times = table.column("sim_time").to_numpy().astype("timedelta64[ns]").astype(np.int64)
    return times, table.column(component).to_pylist()


def static_entities(chunks: list) -> set[str]:
    return {c.entity_path for c in chunks if c.is_static}


def no_temp_files(directory: Path) -> bool:
    return not any(p.name.endswith(TEMPORARY) for p in directory.iterdir())


def test_file_written_atomically(rrd: Path) -> None:
    assert rrd.is_file() and rrd.stat().st_size > 0
    assert no_temp_files(rrd.parent)


def test_entities_per_joint(chunks: list) -> None:
    temporal = {c.entity_path for c in chunks if not c.is_static}
    for joint in range(1, NJ + 1):
        for prefix, _, _ in SERIES:
            assert f"/{prefix}/joint{joint}" in temporal
        assert f"/extras/gain/joint{joint}" in temporal
        assert f"/q_ref/joint{joint}" in temporal
    assert not any(e.endswith(VARIANTS) for e in temporal)  # no entity per variant: variants are columns
    assert {"/events", "/fault_active"} <= temporal
    assert "/info" in static_entities(chunks)


def test_optional_series_only_when_present(chunks: list) -> None:
    """Results without delivered torque, fault ground truth, tachometers or a diagnosis log none of them."""
    entities = {c.entity_path for c in chunks}
    for prefix, _, _ in OPTIONAL_SERIES + DIAGNOSIS_SERIES:
        assert not any(e.startswith(f"/{prefix}/") for e in entities), prefix


@pytest.mark.parametrize("prefix", [p for p, _, _ in SERIES])
def test_series_rows_and_timeline(chunks: list, results: list[VariantResult], prefix: str) -> None:
    for joint in range(1, NJ + 1):
        times, values = column(chunks, f"/{prefix}/joint{joint}")
        assert len(times) == N
        assert np.array_equal(times, np.round(results[0].t * 1e9).astype(np.int64))
        assert all(len(v) == len(VARIANTS) for v in values)


def test_values_are_float32_of_each_variant(rrd: Path, chunks: list, results: list[VariantResult]) -> None:
    """Each variant's column holds its values rounded to float32, exactly; read_series gives them per variant."""
    for v, result in enumerate(results):
        _, values = column(chunks, "/luaf/estimate/joint2")
        assert np.array_equal(np.array(values, dtype=np.float32)[:, v], result.luaf_hat[:, 1].astype(np.float32))
        times, estimate = read_series(rrd, f"/luaf/estimate/{result.name}")
        assert estimate.shape == (N, NJ)
        assert np.array_equal(estimate, result.luaf_hat.astype(np.float32).astype(np.float64))
        np.testing.assert_allclose(times, result.t, atol=1e-9)
    _, active = read_series(rrd, "/fault_active")
    assert np.array_equal(active[:, 0], results[0].fault_active.astype(float))
    _, reference = read_series(rrd, "/q_ref/joint1")
    assert np.array_equal(reference[:, 0], results[0].q_ref[:, 0].astype(np.float32))


def test_line_names_and_colours(chunks: list) -> None:
    """Every entity names its columns by variant (truth: '<variant> true') in the variant's one colour."""
    def lines(entity: str) -> tuple[list, list]:
        batch = next(c.to_record_batch() for c in chunks if c.entity_path == entity and c.is_static)
        return batch.column("SeriesLines:names").to_pylist()[0], batch.column("SeriesLines:colors").to_pylist()[0]

    names, colours = lines("/q/joint1")
    assert names == list(VARIANTS)
    assert len(set(colours)) == len(VARIANTS)
    assert lines("/torque/joint2")[1] == colours
    truth_names, truth_colours = lines("/luaf/true/joint1")
    assert truth_names == [f"{v} true" for v in VARIANTS] and truth_colours != colours


def test_layout_stored(rrd: Path) -> None:
    layout = read_layout(rrd)
    assert layout.scenario == "demo" and layout.fault_onsets == [1.25]
    assert [s.name for s in layout.variants] == list(VARIANTS) == [s.name for s in variant_styles(VARIANTS)]
    assert layout.joints == ["j1", "j2"] and layout.samples == {v: N for v in VARIANTS}
    assert layout.duration == pytest.approx(1.0 + N * 1e-3)
    assert [f.quantity for f in layout.figures] == ["tracking_error", "velocity_error", "luaf", "luaf_error", "torque"]


def test_scenario_figures_kept_for_the_variants_that_ran(tmp_path: Path, model: mujoco.MjModel,
                                                         results: list[VariantResult]) -> None:
    figure = Figure(name="e", title="E", quantity="tracking_error", unit="rad", variants=("gone", VARIANTS[1]),
                    joints=(1,), zoom=(1.2, None))
    empty = Figure(name="none", title="None", quantity="torque", unit="N m", variants=("gone",), joints=(0,))
    path = tmp_path / "figures.rrd"
    write_recording(path, scenario="demo", model=model, results=results, figures=[figure, empty])
    layout = read_layout(path)
    assert [f.name for f in layout.figures] == ["e"] and layout.figures[0].variants == (VARIANTS[1],)
    assert layout.figures[0].zoom == (1.2, None) and layout.figures[0].joints == (1,)


def test_events_and_info(chunks: list) -> None:
    times, texts = column(chunks, "/events", "TextLog:text")
    assert list(times) == [1_250_000_000] and "fault onset" in texts[0][0]
    info = next(c.to_record_batch() for c in chunks if c.entity_path == "/info")
    text = info.column("TextDocument:text").to_pylist()[0][0]
    assert "demo" in text and "7" in text and all(v in text for v in VARIANTS)


def test_blueprint_geometry_and_poses(rrd: Path, chunks: list, model: mujoco.MjModel,
                                      results: list[VariantResult]) -> None:
    assert RrdReader(rrd).blueprints(), "no blueprint stored"
    geoms = {p.rsplit("/", 1)[-1] for p in static_entities(chunks) if "/geoms/" in p}
    assert geoms == {"base", "upper", "hub", "lower", "elbow", "tool", "tag"}  # no plane, no group-3 geom
    assert "/world/link1/geoms/upper" in static_entities(chunks)
    rows = np.append(np.arange(0, N, STRIDE), N - 1)
    for b, body in ((1, "link1"), (2, "link2")):
        times, translation = column(chunks, f"/world/{body}", "Transform3D:translation")
        assert np.array_equal(times, np.round(results[0].t[rows] * 1e9).astype(np.int64))
        # Rerun stores transforms as float32.
        got = np.array(translation, dtype=np.float32).reshape(-1, 3)
        assert np.array_equal(got, results[0].body_xpos[rows, b].astype(np.float32))
        _, quat = column(chunks, f"/world/{body}", "Transform3D:quaternion")
        got = np.array(quat, dtype=np.float32).reshape(-1, 4)
        assert np.array_equal(got, results[0].body_xquat[rows, b][:, [1, 2, 3, 0]].astype(np.float32))
    assert not any(c.entity_path.startswith("/world/world") and not c.is_static for c in chunks)


def test_the_camera_frames_every_pose_of_the_run(model: mujoco.MjModel, results: list[VariantResult]) -> None:
    """The robot camera looks at the centre of what the arm sweeps, not at the initial pose: an arm that swings
    to one side moves the target there, and the camera stands back by the box's half diagonal."""
    xpos, xquat = results[0].body_xpos, results[0].body_xquat
    swung = xpos.copy()
    swung[:, 1:, 1] += 2.0  # the links 2 m to the side all run long
    centre = np.asarray(_eye(model, swung, xquat).look_target.as_arrow_array().to_pylist()[0])
    eye = np.asarray(_eye(model, xpos, xquat).position.as_arrow_array().to_pylist()[0])
    target = np.asarray(_eye(model, xpos, xquat).look_target.as_arrow_array().to_pylist()[0])
    # the base (on the world body) stays at 0 and the box spans base and links: its centre moves, by less
    assert 1.0 < centre[1] - target[1] < 2.0
    # every geom's centre at every pose of the run (MuJoCo's own geom_xpos) is within the framed radius
    radius = np.linalg.norm(eye - target) / EYE_DISTANCE
    data = mujoco.MjData(model)
    for q in results[0].q_ref[::50]:
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        tool = data.geom_xpos[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "tool")]
        assert np.linalg.norm(tool - target) < radius
    assert radius < 1.5  # and not the sphere of the whole reach about every body (the arm is 0.9 m)
    # without poses (a live view before the first period): MuJoCo's statistics of the initial pose
    initial = np.asarray(_eye(model).look_target.as_arrow_array().to_pylist()[0])
    assert np.allclose(initial, model.stat.center, atol=1e-6)


def test_tab_labels_fit_and_are_unique() -> None:
    """Titles that fit stay; otherwise short labels, and two figures of one quantity are told apart."""
    def fig(name: str, title: str, quantity: str) -> Figure:
        return Figure(name=name, title=title, quantity=quantity, unit="", variants=("a",), joints=(0,))

    few = [fig("e", "Tracking error", "tracking_error")]
    assert tab_labels(few, other=True) == ["Tracking error", "Other signals"]
    many = [fig("residual_smooth", "Residual and threshold: DO, ESO, momentum", "residual"),
            fig("residual_sliding", "Residual and threshold: sliding-mode observers", "residual"),
            fig("fig5_6", "Fig. 5.6: tracking error (zoom: the two TOSMO loops after convergence)", "tracking_error"),
            fig("torque", "Control torque (command), every variant, every joint", "torque")]
    labels = tab_labels(many, other=True)
    assert labels == ["residual smooth", "residual sliding", "Fig. 5.6", "torque", "other"]
    assert len(set(labels)) == len(labels)


def test_capsule_is_centred_like_mujoco(chunks: list, model: mujoco.MjModel) -> None:
    g = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "upper")
    half = model.geom_size[g][1]
    batch = next(c.to_record_batch() for c in chunks
                 if c.entity_path == "/world/link1/geoms/upper" and "Capsules3D:translations" in c.to_record_batch().schema.names)
    assert np.allclose(batch.column("Capsules3D:translations").to_pylist()[0][0], [0, 0, -half])
    assert np.isclose(batch.column("Capsules3D:lengths").to_pylist()[0][0], 2 * half)


@pytest.mark.slow  # a subprocess
def test_rerun_cli_verifies(rrd: Path) -> None:
    exe = shutil.which("rerun")
    if exe is None:
        pytest.skip("rerun CLI not on PATH")
    run = subprocess.run([exe, "rrd", "verify", str(rrd)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout + run.stderr


def test_non_finite_and_diverged_variant(tmp_path: Path, model: mujoco.MjModel, results: list[VariantResult]) -> None:
    bad = results[1].truncated(123)
    bad.luaf_hat = bad.luaf_hat.copy()
    bad.luaf_hat[5] = [np.nan, np.inf]
    bad.body_xpos = np.zeros((0, 0, 3))
    bad.status, bad.diverged_at = "diverged", float(bad.t[-1])
    path = tmp_path / "nan.rrd"
    write_recording(path, scenario="nan", model=model, results=[bad], seed=None)
    chunks = RrdReader(path).stream().to_chunks()
    times, values = read_series(path, f"/luaf/estimate/{bad.name}")
    assert len(times) == 123
    assert np.array_equal(values, bad.luaf_hat.astype(np.float32), equal_nan=True)
    assert not any(c.entity_path.startswith("/world") for c in chunks)  # no variant has poses: no 3-D
    _, texts = column(chunks, "/events", "TextLog:text")
    assert "diverged" in texts[0][0]


def test_separate_calls_do_not_mix(tmp_path: Path, model: mujoco.MjModel, results: list[VariantResult]) -> None:
    for result in results:
        write_recording(tmp_path / f"{result.name}.rrd", scenario="one", model=model, results=[result])
    for result in results:
        assert [s.name for s in read_layout(tmp_path / f"{result.name}.rrd").variants] == [result.name]


def test_diverged_variant_is_padded(tmp_path: Path, model: mujoco.MjModel, results: list[VariantResult]) -> None:
    """A variant that stopped early has NaN after its last sample in the shared columns; read_series cuts there."""
    short = results[1].truncated(200)
    path = tmp_path / "padded.rrd"
    write_recording(path, scenario="padded", model=model, results=[results[0], short])
    _, values = read_series(path, "/torque/joint1")
    assert values.shape == (N, 2) and np.isnan(values[200:, 1]).all() and np.isfinite(values[:, 0]).all()
    assert read_series(path, f"/torque/{short.name}")[1].shape == (200, NJ)
    other = results[0].truncated(N)
    other.t = other.t + 0.5
    with pytest.raises(ValueError, match="time axis"):
        write_recording(tmp_path / "bad.rrd", scenario="bad", model=model, results=[results[0], other])


def test_shape_mismatch_leaves_nothing(tmp_path: Path, model: mujoco.MjModel, results: list[VariantResult]) -> None:
    broken = results[0].truncated(N)
    broken.tau = broken.tau[:-1]
    path = tmp_path / "broken.rrd"
    with pytest.raises(ValueError, match="tau"):
        write_recording(path, scenario="broken", model=model, results=[results[1], broken])
    assert not path.exists() and no_temp_files(tmp_path)


def test_failure_midway_keeps_previous_file(tmp_path: Path, model: mujoco.MjModel, results: list[VariantResult],
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "keep.rrd"
    write_recording(path, scenario="first", model=model, results=results[:1])
    before = path.read_bytes()
    calls = {"n": 0}
    original = rr.RecordingStream.send_columns

    def failing(self, *args, **kwargs):  # noqa: ANN001, ANN202
        calls["n"] += 1
        if calls["n"] == 5:
            raise RuntimeError("disk on fire")
        return original(self, *args, **kwargs)

    monkeypatch.setattr(rr.RecordingStream, "send_columns", failing)
    with pytest.raises(RuntimeError, match="disk on fire"):
        write_recording(path, scenario="second", model=model, results=results)
    with pytest.raises(RuntimeError, match="disk on fire"):
        calls["n"] = 0
        write_recording(tmp_path / "fresh.rrd", scenario="second", model=model, results=results)
    assert path.read_bytes() == before
    assert not (tmp_path / "fresh.rrd").exists() and no_temp_files(tmp_path)


def test_the_info_table_says_a_shared_column_once_in_its_heading():
    from types import SimpleNamespace

    from ftc_mj.outputs.recording import _info_markdown

    def result(name: str, observer: str, diverged_at: float | None = None) -> SimpleNamespace:
        return SimpleNamespace(name=name, observer=observer, controller="nftsmc", status="ok",
                               diverged_at=diverged_at, t=np.zeros(4))

    style = SimpleNamespace(color="#d62728")
    host_and_monitor = _info_markdown("s", 1, [result("a", "hs_tosmo"), result("a.m", "momentum")], [10.0],
                                      [style, style])
    assert "· controller: nftsmc · status: ok" in host_and_monitor.splitlines()[0]
    assert "| variant (colour) | observer |" in host_and_monitor and "| a.m (red) | momentum |" in host_and_monitor
    one_diverged = _info_markdown("s", 1, [result("a", "hs_tosmo"), result("b", "sosmo", 2.0)], [10.0],
                                  [style, style])
    assert "| variant (colour) | observer | status |" in one_diverged and "| b (red) | sosmo | diverged at 2 s |" \
        in one_diverged


def test_the_info_table_has_at_most_three_columns():
    """Controllers, observers and statuses that all differ: the controller and observer share a column and the
    colour the variant's, so the table reads whole in a side panel a quarter of 1600 pixels wide."""
    from types import SimpleNamespace

    from ftc_mj.outputs.recording import _info_markdown

    results = [SimpleNamespace(name="proposed", observer="tosmo", controller="sigmoid_nftsmc", status="ok",
                               diverged_at=None, t=np.zeros(4)),
               SimpleNamespace(name="smc_sosmo", observer="sosmo", controller="smc", status="diverged",
                               diverged_at=1.5, t=np.zeros(4))]
    table = [line for line in _info_markdown("s", 1, results, [], [SimpleNamespace(color="#d62728"),
                                             SimpleNamespace(color="#1f77b4")]).splitlines() if line.startswith("|")]
    assert table[0] == "| variant (colour) | controller / observer | status |"
    assert all(line.count("|") == 4 for line in table)
    assert table[2] == "| proposed (red) | sigmoid_nftsmc / tosmo | ok |"
    assert table[3] == "| smc_sosmo (blue) | smc / sosmo | diverged at 1.5 s |"


def _views(container: object) -> list:
    """Every view of a blueprint or container, depth first."""
    if isinstance(container, rrb.Blueprint):
        return _views(container.root_container)
    if isinstance(container, rrb.Container):
        return [view for child in container.contents for view in _views(child)]
    return [container]


def _blueprints(monkeypatch: pytest.MonkeyPatch, tmp_path: Path, model: mujoco.MjModel, results: list[VariantResult],
                **options: object) -> rrb.Blueprint:
    """The blueprint ``write_recording`` stores with these options."""
    from ftc_mj.outputs import recording

    made: list[rrb.Blueprint] = []

    def kept(*args: object, **kwargs: object) -> rrb.Blueprint:
        made.append(original(*args, **kwargs))
        return made[-1]

    original = recording._blueprint
    monkeypatch.setattr(recording, "_blueprint", kept)
    write_recording(tmp_path / "bp.rrd", scenario="bp", model=model, results=results, **options)
    return made[-1]


def _labelled_ticks(low: float, high: float) -> int:
    """The most multiples of one power of ten within [low, high] that are at least a quarter of a 90-pixel plot
    apart less the margins (at most 4.4 steps over the range): the labels the viewer shows on a stacked plot."""
    best = 0
    for k in range(-12, 13):
        step = 10.0 ** k
        if (high - low) / step <= MAX_TICK_INTERVALS * (1 + 2 * TICK_MARGIN) + 1e-9:
            best = max(best, int(np.floor(high / step) - np.ceil(low / step) + 1))
    return best


def test_every_time_series_panel_has_a_scale(monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
                                            model: mujoco.MjModel, results: list[VariantResult]) -> None:
    """Every time-series panel fixes a vertical range with at least two labelled ticks (left to the viewer, a
    stacked plot whose data lie between its coarse ticks shows a lone 0), and the range holds its data."""
    views = [v for v in _views(_blueprints(monkeypatch, tmp_path, model, results)) if isinstance(v, rrb.TimeSeriesView)]
    assert len(views) > 10
    for view in views:
        axis = view.properties.get("ScalarAxis")
        assert axis is not None, view.name
        low, high = axis.range.as_arrow_array().to_pylist()[0]
        assert _labelled_ticks(low, high) >= 2, (view.name, low, high)
    luaf = next(v for v in views if str(v.name).startswith("LUaF: true and estimate"))
    low, high = luaf.properties["ScalarAxis"].range.as_arrow_array().to_pylist()[0]
    values = np.concatenate([r.luaf_hat.ravel() for r in results] + [r.luaf_true.ravel() for r in results])
    assert low <= values.min() and values.max() <= high


@pytest.mark.parametrize("data", [(0.0, 8.7), (0.0, 42.0), (-16.4, 42.0), (0.0, 3.1), (0.2, 0.7), (0.21, 0.29),
                                  (13.6, 13.6), (0.0, 0.0), (-1e-7, 2e-7), (-52.0, 44.0), (980.0, 1004.0)])
def test_tick_range_holds_the_data_and_two_labelled_ticks(data: tuple[float, float]) -> None:
    low, high = tick_range(np.array([*data, np.nan, np.inf]))
    assert low < data[0] and data[1] < high
    assert _labelled_ticks(low, high) >= 2
    assert tick_range(np.array([np.nan])) is None


def test_a_replay_labels_its_3d_panel_the_logged_arm(monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
                                                      model: mujoco.MjModel, results: list[VariantResult]) -> None:
    """A log replay has no simulated robot per variant: its 3-D panel is titled for the logged arm."""
    def robot(**options: object) -> str:
        views = _views(_blueprints(monkeypatch, tmp_path, model, results, **options))
        return str(next(v for v in views if isinstance(v, rrb.Spatial3DView)).name)

    assert robot() == f"Robot: variant {results[0].name}"
    assert robot(replayed="no_torque.csv") == "Logged arm: no_torque.csv"
