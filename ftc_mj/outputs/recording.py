"""Write the variants of one scenario into a single Rerun recording (``.rrd``), side by side.

Every quantity lives under its own top-level entity with one child per variant, so one plot overlays
the same quantity of all variants (as in a paper's comparison figures)::

    /q_ref/<variant>   /q/<variant>   /tracking_error/<variant>
    /velocity/true/<variant>   /velocity/estimate/<variant>   /velocity_error/<variant>
    /luaf/true/<variant>   /luaf/estimate/<variant>   /luaf_error/<variant>
    /torque/<variant>   /sliding/<variant>   /fault/<variant>   /fault_active/<variant>
    /velocity/measured/<variant>   /torque_delivered/<variant>   (when recorded)
    /fault_torque/<variant>   /fault_acceleration/<variant>   (when recorded)
    /diagnosis/residual/<variant>   /diagnosis/threshold/<variant>   /diagnosis/alarm/<variant>
    /diagnosis/fault_estimate/<variant>   /diagnosis/injected/<variant>   (with a diagnosis section)
    /extras/<name>/<variant>
    /events (fault onsets, alarms raised and cleared, divergences)   /info (scenario, seed, variants, status)
    /world/<body>   /world/<body>/geoms/<geom>   (robot of the first variant that recorded body poses)

Each series entity holds an (N, n) ``Scalars`` column on the ``sim_time`` timeline (a duration, seconds)
with n static line names. Time series are sent column-wise (``send_columns``): per-sample ``rr.log`` is
about 1000x slower. A blueprint stored in the file opens the viewer already arranged.
"""

from __future__ import annotations

import contextlib
import os
import uuid
from collections.abc import Sequence
from pathlib import Path

import mujoco
import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from ftc_mj.engine.results import VariantResult

TIMELINE = "sim_time"

# (entity prefix, VariantResult attribute or property, suffix of the line names). The suffixes tell the two
# lines of one joint apart where two entities share a plot (q with its reference, truth with estimate).
SERIES: tuple[tuple[str, str, str], ...] = (
    ("q_ref", "q_ref", " ref"),
    ("q", "q_meas", ""),
    ("tracking_error", "tracking_error", ""),
    ("velocity/true", "qd_true", " true"),
    ("velocity/estimate", "qd_hat", " est"),
    ("velocity_error", "velocity_error", ""),
    ("luaf/true", "luaf_true", " true"),
    ("luaf/estimate", "luaf_hat", " est"),
    ("luaf_error", "luaf_error", ""),
    ("torque", "tau", ""),
    ("sliding", "sliding", ""),
    ("fault", "fault", ""),
    ("fault_active", "fault_active", ""),
)
#: Ground truth a result may lack (results built without it): logged when present.
OPTIONAL_SERIES: tuple[tuple[str, str, str], ...] = (
    ("velocity/measured", "qd_meas", " meas"),
    ("torque_delivered", "tau_delivered", " delivered"),
    ("fault_torque", "fault_torque", ""),
    ("fault_acceleration", "fault_acceleration", ""),
)
#: The diagnoser's output (attributes of ftc_mj.analysis.diagnosis.Diagnosis), under /diagnosis.
DIAGNOSIS_SERIES: tuple[tuple[str, str, str], ...] = (
    ("diagnosis/residual", "residual", " residual"),
    ("diagnosis/threshold", "threshold", " threshold"),
    ("diagnosis/alarm", "alarm", ""),
    ("diagnosis/fault_estimate", "fault_estimate", " est"),
    ("diagnosis/injected", "injected", " injected"),
)

# One time-series view per quantity: (title, entity prefixes shown together).
VIEWS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("Joint position q and reference", ("q", "q_ref")),
    ("Tracking error q - q_ref", ("tracking_error",)),
    ("Velocity: true and estimate", ("velocity",)),
    ("Velocity estimation error", ("velocity_error",)),
    ("LUAF: true and estimate", ("luaf",)),
    ("LUAF estimation error", ("luaf_error",)),
    ("Torque: commanded and delivered", ("torque", "torque_delivered")),
    ("Sliding variable", ("sliding",)),
    ("Fault signal and fault active", ("fault", "fault_active")),
    ("Generalized fault force [N m]", ("fault_torque",)),
    ("Fault acceleration M^-1 force [rad/s^2]", ("fault_acceleration",)),
    ("Diagnosis: residual and threshold", ("diagnosis/residual", "diagnosis/threshold")),
    ("Diagnosis: alarms", ("diagnosis/alarm",)),
    ("Fault estimate and injected fault", ("diagnosis/fault_estimate", "diagnosis/injected")),
)

# MuJoCo's viewer hides geom groups 3..5 by default (where collision duplicates usually live); do the same.
_MAX_VISIBLE_GROUP = 2


def write_recording(
    path: Path,
    *,
    scenario: str,
    model: mujoco.MjModel,
    results: Sequence[VariantResult],
    fault_onsets: Sequence[float] = (),
    seed: int | None = None,
    pose_stride: int = 10,
) -> None:
    """Write all ``results`` of ``scenario`` into one ``.rrd`` at ``path``, atomically.

    The file is written beside ``path`` under a temporary name and moved onto ``path`` only once complete,
    so ``path`` never holds a half-written recording; on any error the temporary file is removed and the
    error re-raised. Body poses (of the first variant that has them) are kept every ``pose_stride`` samples
    plus the last one.
    """
    if pose_stride < 1:
        raise ValueError(f"pose_stride must be >= 1, got {pose_stride}")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f"{path.name}.tmp-{os.getpid()}-{uuid.uuid4().hex[:8]}")
    posed = next((r for r in results if r.body_xpos.size > 0), None)
    extra_names = sorted({name for r in results for name in r.extras})
    logged = {prefix for prefix, _, _ in SERIES}
    logged |= {prefix for prefix, attr, _ in OPTIONAL_SERIES if any(getattr(r, attr) is not None for r in results)}
    if any(r.diagnosis is not None for r in results):
        logged |= {prefix for prefix, _, _ in DIAGNOSIS_SERIES}
    # A fresh stream per call (never the global one), so several recordings in one process do not mix.
    rec = rr.RecordingStream("ftc_mj", recording_id=str(uuid.uuid4()))
    try:
        rec.save(tmp, default_blueprint=_blueprint(posed is not None, extra_names, logged))
        rec.send_recording_name(scenario)
        rec.log("/info", rr.TextDocument(_info_markdown(scenario, seed, results, fault_onsets),
                                         media_type=rr.MediaType.MARKDOWN), static=True)
        _log_events(rec, results, fault_onsets)
        for result in results:
            _log_variant(rec, result)
        if posed is not None:
            _log_geometry(rec, model)
            _log_poses(rec, model, posed, pose_stride)
        rec.disconnect()  # writes the footer; flush() alone would not
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(Exception):
            rec.disconnect()  # release the file before removing it
        tmp.unlink(missing_ok=True)
        raise


def read_series(path: Path, entity: str, component: str = "Scalars:scalars") -> tuple[np.ndarray, np.ndarray]:
    """Read one time series back from a recording: times [s] and values ``(N, k)``, in time order.

    For analysis scripts and tests; e.g. ``read_series(path, "/luaf/estimate/proposed")``.
    """
    import pyarrow as pa
    from rerun.chunk import RrdReader

    batches = [
        chunk.to_record_batch()
        for chunk in RrdReader(path).stream().to_chunks()
        if chunk.entity_path == entity and not chunk.is_static
    ]
    if not batches:
        raise KeyError(f"no time series at {entity} in {path}")
    table = pa.Table.from_batches(batches, schema=batches[0].schema).sort_by("sim_time")
    nanoseconds = table.column("sim_time").to_numpy().astype("timedelta64[ns]").astype(np.int64)
    return nanoseconds * 1e-9, np.array(table.column(component).to_pylist(), dtype=float)


def _ep(*parts: str) -> str:
    """Entity path from raw parts (variant, body and geom names may hold '/', spaces, '+')."""
    return "/" + "/".join(rr.escape_entity_path_part(p) for p in parts)


def _time_column(t: np.ndarray) -> rr.TimeColumn:
    # Round to whole ns ourselves: TimeColumn truncates float seconds, so 1.025 s would become 1024999999 ns.
    with np.errstate(invalid="ignore"):
        ns = np.round(np.asarray(t, dtype=np.float64) * 1e9).astype("timedelta64[ns]")
    return rr.TimeColumn(TIMELINE, duration=ns)


def _rows(result: VariantResult, label: str, value: np.ndarray) -> np.ndarray:
    """``value`` as a float64 (N, k) array, checked against the variant's time axis."""
    arr = np.asarray(value, dtype=np.float64)
    arr = arr.reshape(len(arr), int(np.prod(arr.shape[1:])))  # (N,) -> (N, 1); reshape(-1) fails for N = 0
    if len(arr) != len(result.t):
        raise ValueError(f"variant {result.name!r}: {label} has {len(arr)} rows, t has {len(result.t)}")
    return np.ascontiguousarray(arr)


def _send_series(rec: rr.RecordingStream, entity: str, name: str, values: np.ndarray,
                 time: rr.TimeColumn, suffix: str = "") -> None:
    """One (N, k) Scalars column plus the static names of its k lines."""
    k = values.shape[1]
    names = [f"{name}{suffix}"] if k == 1 else [f"{name} joint{i + 1}{suffix}" for i in range(k)]
    rec.log(entity, rr.SeriesLines(names=names), static=True)
    rec.send_columns(entity, indexes=[time], columns=rr.Scalars.columns(scalars=values))


def _log_variant(rec: rr.RecordingStream, result: VariantResult) -> None:
    time = _time_column(result.t)
    sources = [(result, series) for series in SERIES]
    sources += [(result, series) for series in OPTIONAL_SERIES if getattr(result, series[1]) is not None]
    if result.diagnosis is not None:
        sources += [(result.diagnosis, series) for series in DIAGNOSIS_SERIES]
    for source, (prefix, attr, suffix) in sources:
        values = _rows(result, attr, getattr(source, attr))
        _send_series(rec, _ep(*prefix.split("/"), result.name), result.name, values, time, suffix)
    for extra, value in result.extras.items():
        _send_series(rec, _ep("extras", extra, result.name), result.name,
                     _rows(result, f"extras[{extra!r}]", value), time)


def _log_events(rec: rr.RecordingStream, results: Sequence[VariantResult], fault_onsets: Sequence[float]) -> None:
    """Fault onsets, alarms (raised and cleared) and divergences as text-log events on the timeline."""
    events = [(float(t), f"fault onset at t = {t:g} s", "WARN") for t in fault_onsets]
    for r in results:
        if r.diagnosis is None:
            continue
        for edges, what, level in ((r.diagnosis.raised, "raised", "WARN"), (r.diagnosis.cleared, "cleared", "INFO")):
            for k, joint in zip(*np.nonzero(edges)):
                t = float(r.diagnosis.t[k])
                events.append((t, f"{r.name}: alarm {what} on joint {joint + 1} at t = {t:g} s", level))
    events += [(float(r.diverged_at), f"{r.name} diverged at t = {r.diverged_at:g} s", "ERROR")
               for r in results if r.diverged_at is not None]
    if not events:
        return
    events.sort(key=lambda e: e[0])
    times, texts, levels = zip(*events)
    rec.send_columns("/events", indexes=[_time_column(np.array(times))],
                     columns=rr.TextLog.columns(text=list(texts), level=list(levels)))


def _info_markdown(scenario: str, seed: int | None, results: Sequence[VariantResult],
                   fault_onsets: Sequence[float]) -> str:
    lines = [f"# {scenario}", "", f"- seed: {seed if seed is not None else 'not set'}",
             f"- fault onsets [s]: {', '.join(f'{t:g}' for t in fault_onsets) or 'none'}", "",
             "| variant | observer | controller | samples | status |", "|---|---|---|---|---|"]
    for r in results:
        status = r.status if r.diverged_at is None else f"{r.status} at t = {r.diverged_at:g} s"
        lines.append(f"| {r.name} | {r.observer} | {r.controller} | {len(r.t)} | {status} |")
    return "\n".join(lines) + "\n"


def _xyzw(wxyz: np.ndarray) -> np.ndarray:
    """MuJoCo quaternion order (w, x, y, z) to Rerun's (x, y, z, w)."""
    return np.ascontiguousarray(np.asarray(wxyz, dtype=np.float64)[..., [1, 2, 3, 0]])


def _name(model: mujoco.MjModel, obj: mujoco.mjtObj, i: int, fallback: str) -> str:
    return mujoco.mj_id2name(model, obj, i) or f"{fallback}{i}"


def _geom_shape(model: mujoco.MjModel, g: int, color: np.ndarray) -> rr.AsComponents | None:
    """The geom's shape in its own frame (centred, long axis z, as in MuJoCo); None if not drawable."""
    size, kind = model.geom_size[g], model.geom_type[g]
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        # Rerun capsules start at their origin and run along +z; MuJoCo's are centred: shift by half a length.
        return rr.Capsules3D(lengths=[2 * size[1]], radii=[size[0]], translations=[[0, 0, -size[1]]], colors=[color])
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return rr.Cylinders3D(lengths=[2 * size[1]], radii=[size[0]], colors=[color])
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return rr.Boxes3D(half_sizes=[size], colors=[color], fill_mode="solid")
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return rr.Ellipsoids3D(radii=[size[0]], colors=[color], fill_mode="solid")
    if kind == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
        return rr.Ellipsoids3D(half_sizes=[size], colors=[color], fill_mode="solid")
    if kind == mujoco.mjtGeom.mjGEOM_MESH and model.geom_dataid[g] >= 0:
        mesh = model.geom_dataid[g]
        v0, nv = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        f0, nf = model.mesh_faceadr[mesh], model.mesh_facenum[mesh]
        return rr.Mesh3D(vertex_positions=model.mesh_vert[v0:v0 + nv], triangle_indices=model.mesh_face[f0:f0 + nf],
                         albedo_factor=color)
    return None  # plane, height field, SDF...: skipped


def _log_geometry(rec: rr.RecordingStream, model: mujoco.MjModel) -> None:
    """Every visible geom once, static, at /world/<body>/geoms/<geom>, placed by its pose in the body frame."""
    for g in range(model.ngeom):
        mat = model.geom_matid[g]
        color = model.mat_rgba[mat] if mat >= 0 else model.geom_rgba[g]
        if color[3] == 0 or model.geom_group[g] > _MAX_VISIBLE_GROUP:
            continue
        shape = _geom_shape(model, g, np.round(np.clip(color, 0, 1) * 255).astype(np.uint8))
        if shape is None:
            continue
        body = _name(model, mujoco.mjtObj.mjOBJ_BODY, int(model.geom_bodyid[g]), "body")
        entity = _ep("world", body, "geoms", _name(model, mujoco.mjtObj.mjOBJ_GEOM, g, "geom"))
        rec.log(entity, rr.Transform3D(translation=model.geom_pos[g], quaternion=_xyzw(model.geom_quat[g])),
                static=True)
        rec.log(entity, shape, static=True)


def _log_poses(rec: rr.RecordingStream, model: mujoco.MjModel, result: VariantResult, stride: int) -> None:
    """World pose of every body but the world body, every ``stride`` samples and at the last one."""
    xpos, xquat = np.asarray(result.body_xpos), np.asarray(result.body_xquat)
    if xpos.shape[1:] != (model.nbody, 3) or xquat.shape[1:] != (model.nbody, 4):
        raise ValueError(f"variant {result.name!r}: body poses {xpos.shape} / {xquat.shape} do not match "
                         f"the model's {model.nbody} bodies")
    n = len(result.t)
    if len(xpos) != n or len(xquat) != n:
        raise ValueError(f"variant {result.name!r}: body poses have {len(xpos)} / {len(xquat)} rows, t has {n}")
    rows = np.unique(np.append(np.arange(0, n, stride), n - 1)) if n else np.arange(0)
    time = _time_column(np.asarray(result.t)[rows])
    for b in range(1, model.nbody):
        rec.send_columns(_ep("world", _name(model, mujoco.mjtObj.mjOBJ_BODY, b, "body")), indexes=[time],
                         columns=rr.Transform3D.columns(translation=np.ascontiguousarray(xpos[rows, b], np.float64),
                                                        quaternion=_xyzw(xquat[rows, b])))


def _blueprint(with_3d: bool, extra_names: Sequence[str], logged: set[str]) -> rrb.Blueprint:
    """3-D robot, info and events on the left; a grid of one plot per quantity (all variants overlaid) on the right,
    for the quantities in ``logged`` (entity prefixes)."""
    plots = [rrb.TimeSeriesView(name=title, origin="/", contents=[f"/{p}/**" for p in prefixes])
             for title, prefixes in VIEWS if logged.intersection(prefixes)]
    plots += [rrb.TimeSeriesView(name=f"extra: {name}", origin=_ep("extras", name)) for name in extra_names]
    side: list[rrb.View] = [rrb.TextDocumentView(name="Info", origin="/info"),
                            rrb.TextLogView(name="Events", origin="/events")]
    shares = [1.0, 1.0]
    if with_3d:
        side.insert(0, rrb.Spatial3DView(name="Robot", origin="/world"))
        shares.insert(0, 3.0)
    return rrb.Blueprint(
        rrb.Horizontal(rrb.Vertical(*side, row_shares=shares), rrb.Grid(*plots, grid_columns=3),
                       column_shares=[1, 3]),
        collapse_panels=False,
    )
