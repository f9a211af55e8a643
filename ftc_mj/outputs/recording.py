"""Write the variants of one scenario into a single Rerun recording (``.rrd``), laid out like the figures.

Every quantity is stored per joint, one column per variant (all variants of the run, monitors included, in
order; NaN where a variant has no value, e.g. after it diverged), so one plot overlays the variants of one
joint as in the dissertation's comparison figures::

    /q/joint<k>   /tracking_error/joint<k>   /velocity/true/joint<k>   /velocity/estimate/joint<k>
    /velocity_error/joint<k>   /luaf/true/joint<k>   /luaf/estimate/joint<k>   /luaf_error/joint<k>
    /torque/joint<k>   /sliding/joint<k>   /fault/joint<k>
    /velocity/measured/joint<k>   /torque_delivered/joint<k>   /fault_torque/joint<k>
    /fault_acceleration/joint<k>   (when recorded)
    /diagnosis/residual/joint<k>   /diagnosis/threshold/joint<k>   /diagnosis/alarm/joint<k>
    /diagnosis/fault_estimate/joint<k>   (with a diagnosis section; the injected fault is /fault_torque or
                                          /fault_acceleration, by the diagnosis space)
    /extras/<name>/joint<k>
    /q_ref/joint<k>   /fault_active   (the same for every variant: one column)
    /events (fault onsets, alarms raised and cleared, divergences)   /info (scenario, seed, variants, status)
    /world/<body>   /world/<body>/geoms/<geom>   (robot of the first variant that recorded body poses)

Each series entity holds an (N, V) ``Scalars`` column on the ``sim_time`` timeline (a duration, seconds) with
static line names and colours: each variant one colour (:func:`ftc_mj.outputs.layout.variant_styles`), its
ground truth in a wide pale line of the same colour. Values are float32 (7 significant digits: errors are
stored as errors, computed in float64, so nothing a figure or a ground-truth comparison shows is lost; half
the size of float64). Time series are sent column-wise (``send_columns``): per-sample ``rr.log`` is about 1000x
slower.

The figures (:class:`ftc_mj.outputs.layout.Layout`) are stored as a recording property
(``/__properties/ftc_mj_layout``), from which ``ftc-mj figures`` draws them; a blueprint stored in
the file opens the viewer on the same figures, one tab each, per-joint plots stacked, the zoom panels beside.
"""

from __future__ import annotations

import contextlib
import uuid
from collections.abc import Mapping, Sequence
from pathlib import Path

import mujoco
import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from ftc_mj.results import VariantResult
from ftc_mj.outputs.files import atomic_path
from ftc_mj.outputs.layout import (Figure, Layout, MAX_TICK_INTERVALS, VariantStyle, generic_figures, tick_range,
                                   variant_styles, zoom_span)
from ftc_mj.outputs.palette import colour_name

TIMELINE = "sim_time"
LAYOUT_PROPERTY = "ftc_mj_layout"

# (entity prefix, VariantResult attribute or property, line kind). The kind names a variant's lines where two
# entities share a plot: "" the variant's name, else "<variant> <kind>" (truth drawn wide and pale).
SERIES: tuple[tuple[str, str, str], ...] = (
    ("q", "q_meas", ""),
    ("tracking_error", "tracking_error", ""),
    ("velocity/true", "qd_true", "true"),
    ("velocity/estimate", "qd_hat", ""),
    ("velocity_error", "velocity_error", ""),
    ("luaf/true", "luaf_true", "true"),
    ("luaf/estimate", "luaf_hat", ""),
    ("luaf_error", "luaf_error", ""),
    ("torque", "tau", ""),
    ("sliding", "sliding", ""),
    ("fault", "fault", ""),
)
#: Ground truth a result may lack (results built without it): logged when a variant has it.
OPTIONAL_SERIES: tuple[tuple[str, str, str], ...] = (
    ("velocity/measured", "qd_meas", "measured"),
    ("torque_delivered", "tau_delivered", ""),
    ("fault_torque", "fault_torque", ""),
    ("fault_acceleration", "fault_acceleration", ""),
)
#: The diagnoser's output (attributes of ftc_mj.results.Diagnosis), under /diagnosis. Its injected
#: fault is fault_torque or fault_acceleration, already recorded.
DIAGNOSIS_SERIES: tuple[tuple[str, str, str], ...] = (
    ("diagnosis/residual", "residual", ""),
    ("diagnosis/threshold", "threshold", "threshold"),
    ("diagnosis/alarm", "alarm", ""),
    ("diagnosis/fault_estimate", "fault_estimate", ""),
)
#: Series the same for every variant, logged once: (entity prefix, attribute, line name).
SHARED_SERIES: tuple[tuple[str, str, str], ...] = (("q_ref", "q_ref", "reference"),
                                                    ("fault_active", "fault_active", "fault active"))
#: Quantities in the "Other signals" tab, when no figure shows them: (title, entity prefixes).
OTHER_VIEWS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("Joint position q and reference", ("q", "q_ref")),
    ("Tracking error q - q_ref [rad]", ("tracking_error",)),
    ("Velocity: true and estimate [rad/s]", ("velocity",)),
    ("Velocity estimation error [rad/s]", ("velocity_error",)),
    ("LUaF: true and estimate [rad/s^2]", ("luaf",)),
    ("LUaF estimation error [rad/s^2]", ("luaf_error",)),
    ("Torque: commanded and delivered [N m]", ("torque", "torque_delivered")),
    ("Sliding variable", ("sliding",)),
    ("Fault signal and fault active", ("fault", "fault_active")),
    ("Generalized fault force [N m]", ("fault_torque",)),
    ("Fault acceleration M^-1 force [rad/s^2]", ("fault_acceleration",)),
    ("Diagnosis: residual and threshold", ("diagnosis/residual", "diagnosis/threshold")),
    ("Diagnosis: alarms", ("diagnosis/alarm",)),
    ("Fault estimate", ("diagnosis/fault_estimate",)),
)
#: Quantities a recording without scenario figures shows as figures.
GENERIC_QUANTITIES = ("tracking_error", "velocity_error", "luaf", "luaf_error", "torque")
#: Line widths [points]: a variant's own line, its ground truth underneath.
LINE_WIDTH, TRUTH_WIDTH = 1.5, 3.0

# MuJoCo's viewer hides geom groups 3..5 by default (where collision duplicates usually live); do the same.
_MAX_VISIBLE_GROUP = 2
#: The primitive shapes :func:`_geom_shape` draws (meshes too, when they have data).
_SOLIDS = frozenset(int(kind) for kind in (mujoco.mjtGeom.mjGEOM_CAPSULE, mujoco.mjtGeom.mjGEOM_CYLINDER,
                                           mujoco.mjtGeom.mjGEOM_BOX, mujoco.mjtGeom.mjGEOM_SPHERE,
                                           mujoco.mjtGeom.mjGEOM_ELLIPSOID))
#: The robot camera's distance from the centre of what it frames, in half diagonals of its bounding box: the
#: box's bounding sphere fits in a field of view of 60 degrees (1 / sin 30 degrees).
EYE_DISTANCE = 2.0


def write_recording(
    path: Path,
    *,
    scenario: str,
    model: mujoco.MjModel,
    results: Sequence[VariantResult],
    fault_onsets: Sequence[float] = (),
    seed: int | None = None,
    pose_stride: int = 10,
    figures: Sequence[Figure] | None = None,
    colours: Mapping[str, str] | None = None,
    sinks: Sequence[object] = (),
    replayed: str | None = None,
) -> None:
    """Write all ``results`` of ``scenario`` into one ``.rrd`` at ``path``, atomically.

    ``replayed``: the name of the log a replay reads (a scenario with a ``log`` section); the 3-D panel then
    shows the logged arm (its logged positions), not a simulated variant's robot.

    ``figures`` (a scenario's, :attr:`ftc_mj.scenario.definition.Scenario.figures`) lay out the viewer and are stored
    for ``ftc-mj figures``; without them, one figure per core quantity. ``colours`` (a scenario's,
    :func:`ftc_mj.outputs.palette.declared_colours`) colour the variants, the same whichever of them ran;
    without them, the palette's order over ``results``. ``sinks`` (``rr.GrpcSink``, ``rr.GrpcServerSink``: a
    viewer's) get the same stream as the file, the blueprint first. The file is written beside
    ``path`` under a temporary name and moved onto ``path`` only once complete, so ``path`` never holds a
    half-written recording; on any error the temporary file is removed and the error re-raised. Body poses (of
    the first variant that has them) are kept every ``pose_stride`` samples plus the last one.
    """
    if pose_stride < 1:
        raise ValueError(f"pose_stride must be >= 1, got {pose_stride}")
    if not results:
        raise ValueError("no results to record")
    path = Path(path)
    posed = next((r for r in results if r.body_xpos.size > 0), None)
    t = _common_time(results)
    layout = _layout(scenario, model, results, t, fault_onsets, figures, colours)
    with atomic_path(path) as tmp:
        # A fresh stream per call (never the global one), so several recordings in one process do not mix.
        rec = rr.RecordingStream("ftc_mj", recording_id=str(uuid.uuid4()))
        try:
            series = _series(results, len(t), layout.variants)
            blueprint = _blueprint(layout, series, t, _robot_title(posed.name, replayed) if posed else None, model,
                                   *((posed.body_xpos, posed.body_xquat) if posed else ()))
            if sinks:
                rec.set_sinks(rr.FileSink(tmp), *sinks, default_blueprint=blueprint)
            else:
                rec.save(tmp, default_blueprint=blueprint)
            rec.send_recording_name(scenario)
            rec.send_property(LAYOUT_PROPERTY, rr.AnyValues(json=layout.to_json()))
            info = _info_markdown(scenario, seed, results, fault_onsets, layout.variants)
            rec.log("/info", rr.TextDocument(info, media_type=rr.MediaType.MARKDOWN), static=True)
            _log_events(rec, results, fault_onsets)
            time = _time_column(t)
            for entity, (values, names, colors, widths) in series.items():
                rec.log(entity, rr.SeriesLines(names=names, colors=colors, widths=widths), static=True)
                rec.send_columns(entity, indexes=[time], columns=rr.Scalars.columns(scalars=values))
            if posed is not None:
                _log_geometry(rec, model)
                _log_poses(rec, model, posed, pose_stride)
        except BaseException:
            with contextlib.suppress(Exception):
                rec.disconnect()  # release the file before it is removed
            raise
        rec.disconnect()  # writes the footer; flush() alone would not


def read_layout(path: Path) -> Layout:
    """The figure layout a recording was written with."""
    from rerun.chunk import RrdReader

    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.entity_path == f"/__properties/{LAYOUT_PROPERTY}":
            return Layout.from_json(chunk.to_record_batch().column("json").to_pylist()[0][0])
    raise KeyError(f"{path} holds no ftc_mj figure layout (written by another program or version)")


def read_entities(path: Path, entities: set[str] | None = None) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Time series of a recording in one pass: entity -> (times [s], values (N, k) float64), in time order.
    All scalar series when ``entities`` is None."""
    import pyarrow as pa
    from rerun.chunk import RrdReader

    batches: dict[str, list] = {}
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.is_static or (entities is not None and chunk.entity_path not in entities):
            continue
        batch = chunk.to_record_batch()
        if "Scalars:scalars" in batch.schema.names:
            batches.setdefault(chunk.entity_path, []).append(batch)
    found = {}
    for entity, parts in batches.items():
        table = pa.Table.from_batches(parts, schema=parts[0].schema).sort_by(TIMELINE)
        nanoseconds = table.column(TIMELINE).to_numpy().astype("timedelta64[ns]").astype(np.int64)
        values = table.column("Scalars:scalars").combine_chunks().flatten().to_numpy(zero_copy_only=False)
        found[entity] = (nanoseconds * 1e-9, values.astype(np.float64).reshape(len(nanoseconds), -1))
    return found


def read_series(path: Path, entity: str) -> tuple[np.ndarray, np.ndarray]:
    """Read one time series back from a recording: times [s] and values ``(N, k)``, in time order.

    ``entity`` is a stored entity (``/luaf/estimate/joint2``: one column per variant) or a variant's quantity
    (``/luaf/estimate/proposed``: one column per joint, that variant's samples only). For analysis scripts and
    tests.

    Precision: the values are the recording's, float32 (about 7 significant digits), not the run's float64;
    the times are exact to the nanosecond. For the run's own float64 series, every one of every variant with
    its unit, export them with the run: ``ftc-mj run SCENARIO --export run.mat`` (or ``.parquet``, ``.csv``;
    :mod:`ftc_mj.outputs.series_export`).
    """
    layout = read_layout(path)
    prefix, _, last = entity.rpartition("/")
    names = [s.name for s in layout.variants]
    if last not in names:
        series = read_entities(path, {entity})
        if entity not in series:
            raise KeyError(f"no time series at {entity} in {path}")
        return series[entity]
    joints = [_ep(*prefix.strip("/").split("/"), f"joint{k + 1}") for k in range(len(layout.joints))]
    series = read_entities(path, set(joints))
    if not series:
        raise KeyError(f"no time series at {prefix} in {path}")
    column, samples = names.index(last), layout.samples[last]
    times = series[joints[0]][0][:samples]
    return times, np.stack([series[j][1][:samples, column] for j in joints], axis=1)


def _ep(*parts: str) -> str:
    """Entity path from raw parts (variant, body and geom names may hold '/', spaces, '+')."""
    return "/" + "/".join(rr.escape_entity_path_part(p) for p in parts)


def _time_column(t: np.ndarray) -> rr.TimeColumn:
    # Round to whole ns ourselves: TimeColumn truncates float seconds, so 1.025 s would become 1024999999 ns.
    with np.errstate(invalid="ignore"):
        ns = np.round(np.asarray(t, dtype=np.float64) * 1e9).astype("timedelta64[ns]")
    return rr.TimeColumn(TIMELINE, duration=ns)


def _common_time(results: Sequence[VariantResult]) -> np.ndarray:
    """The longest variant's time axis; every variant's must be a prefix of it (a diverged one stops early)."""
    t = np.asarray(max((r.t for r in results), key=len), dtype=np.float64)
    for r in results:
        if not np.array_equal(r.t, t[:len(r.t)]):
            raise ValueError(f"variant {r.name!r}: its time axis is not the other variants'")
    return t


def _monitors(results: Sequence[VariantResult]) -> set[str]:
    """The names of the results that are monitors (an estimator beside a variant's loop)."""
    return {r.name for r in results if r.host is not None}


def _layout(scenario: str, model: mujoco.MjModel, results: Sequence[VariantResult], t: np.ndarray,
            fault_onsets: Sequence[float], figures: Sequence[Figure] | None,
            colours: Mapping[str, str] | None = None) -> Layout:
    names = [r.name for r in results]
    dt = float(t[1] - t[0]) if len(t) > 1 else 0.0
    joints = [_dof_name(model, dof) for dof in range(model.nv)]
    if figures is None:
        chosen = generic_figures(model.nv, names, GENERIC_QUANTITIES)
    else:  # a figure's variants that did not run are left out
        chosen = [f for f in (_with_variants(f, names) for f in figures) if f.variants]
    return Layout(scenario=scenario, duration=float(t[-1]) + dt if len(t) else 0.0,
                  fault_onsets=[float(x) for x in fault_onsets], joints=joints, variants=variant_styles(names, _monitors(results), colours),
                  samples={r.name: len(r.t) for r in results}, figures=chosen)


def _with_variants(figure: Figure, names: Sequence[str]) -> Figure:
    from dataclasses import replace

    return replace(figure, variants=tuple(v for v in figure.variants if v in names))


def _dof_name(model: mujoco.MjModel, dof: int) -> str:
    joint = int(model.dof_jntid[dof])
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, joint) or f"joint{dof + 1}"


def _rows(result: VariantResult, label: str, value: np.ndarray) -> np.ndarray:
    """``value`` as an (N, k) array, checked against the variant's time axis."""
    arr = np.asarray(value, dtype=np.float64)
    arr = arr.reshape(len(arr), int(np.prod(arr.shape[1:])))  # (N,) -> (N, 1); reshape(-1) fails for N = 0
    if len(arr) != len(result.t):
        raise ValueError(f"variant {result.name!r}: {label} has {len(arr)} rows, t has {len(result.t)}")
    return arr


def _hex_rgb(color: str) -> list[int]:
    return [int(color[i:i + 2], 16) for i in (1, 3, 5)]


def _pale(rgb: list[int]) -> list[int]:
    """The colour blended 60 % toward white: a variant's ground truth, drawn under its estimate."""
    return [round(c + 0.6 * (255 - c)) for c in rgb]


Series = dict[str, tuple[np.ndarray, list[str], list[list[int]], list[float]]]


def _series(results: Sequence[VariantResult], n_samples: int, styles: Sequence[VariantStyle]) -> Series:
    """Every entity to log: (N, V) float32 values (NaN where a variant has none), line names, colours (one
    style per result, in order), widths."""
    rgb = [_hex_rgb(s.color) for s in styles]
    sources: list[tuple[str, str, str, list]] = []  # (prefix, attribute, kind, per-variant source or None)
    for prefix, attr, kind in SERIES:
        sources.append((prefix, attr, kind, list(results)))
    for prefix, attr, kind in OPTIONAL_SERIES:
        if any(getattr(r, attr) is not None for r in results):
            sources.append((prefix, attr, kind, [r if getattr(r, attr) is not None else None for r in results]))
    if any(r.diagnosis is not None for r in results):
        for prefix, attr, kind in DIAGNOSIS_SERIES:
            sources.append((prefix, attr, kind, [r.diagnosis for r in results]))
    for extra in sorted({name for r in results for name in r.extras}):
        sources.append((f"extras/{extra}", extra, "", [r if extra in r.extras else None for r in results]))

    series: Series = {}
    for prefix, attr, kind, owners in sources:
        columns = []
        for result, owner in zip(results, owners):
            value = None if owner is None else (owner.extras[attr] if prefix.startswith("extras/") else getattr(owner, attr))
            columns.append(None if value is None else _rows(result, f"{prefix} ({attr})", value))
        width = max(c.shape[1] for c in columns if c is not None)
        names = [r.name if not kind else f"{r.name} {kind}" for r in results]
        colors = [_pale(c) if kind == "true" else c for c in rgb]
        widths = [TRUTH_WIDTH if kind == "true" else LINE_WIDTH] * len(results)
        for joint in range(width):
            values = np.full((n_samples, len(results)), np.nan, dtype=np.float32)
            for v, column in enumerate(columns):
                if column is not None:
                    values[:len(column), v] = column[:, min(joint, column.shape[1] - 1)]
            series[_ep(*prefix.split("/"), f"joint{joint + 1}")] = (values, names, colors, widths)
    longest = max(results, key=lambda r: len(r.t))
    for prefix, attr, name in SHARED_SERIES:
        value = _rows(longest, attr, getattr(longest, attr)).astype(np.float32)
        color = [[90, 90, 90]]
        if prefix == "fault_active":
            series[_ep(prefix)] = (np.ascontiguousarray(value[:, :1]), [name], color, [LINE_WIDTH])
            continue
        for joint in range(value.shape[1]):
            series[_ep(prefix, f"joint{joint + 1}")] = (np.ascontiguousarray(value[:, joint:joint + 1]), [name],
                                                        color, [LINE_WIDTH])
    return series


def _log_events(rec: rr.RecordingStream, results: Sequence[VariantResult], fault_onsets: Sequence[float]) -> None:
    """Fault onsets, alarms (raised and cleared) and divergences as text-log events on the timeline. The text
    leaves the time out: the events view shows it in its own column, and the text must fit the side panel."""
    events = [(float(t), "fault onset", "WARN") for t in fault_onsets]
    for r in results:
        if r.diagnosis is None:
            continue
        for edges, what, level in ((r.diagnosis.raised, "raised", "WARN"), (r.diagnosis.cleared, "cleared", "INFO")):
            for k, joint in zip(*np.nonzero(edges)):
                t = float(r.diagnosis.t[k])
                events.append((t, f"{r.name}: alarm {what} on joint {joint + 1}", level))
    events += [(float(r.diverged_at), f"{r.name} diverged", "ERROR")
               for r in results if r.diverged_at is not None]
    if not events:
        return
    events.sort(key=lambda e: e[0])
    times, texts, levels = zip(*events)
    rec.send_columns("/events", indexes=[_time_column(np.array(times))],
                     columns=rr.TextLog.columns(text=list(texts), level=list(levels)))


def _info_markdown(scenario: str, seed: int | None, results: Sequence[VariantResult],
                   fault_onsets: Sequence[float], styles: Sequence[VariantStyle]) -> str:
    """The info panel: one heading line and a narrow table that reads whole in the side panel (a quarter of a
    1600-pixel screen): at most three columns, the variant with its colour ("proposed (red)"), its controller
    and observer in one ("nftsmc / tosmo") and its status. A value every variant shares (the status of runs
    that all ended "ok", the controller of a host and its monitors) is said once in the heading instead of
    repeated on every row."""
    rows = [{"observer": r.observer, "controller": r.controller,
             "status": r.status if r.diverged_at is None else f"diverged at {r.diverged_at:g} s"} for r in results]
    shared = {key: rows[0][key] for key in ("observer", "controller", "status")
              if len(rows) > 1 and all(row[key] == rows[0][key] for row in rows)}
    kept = [key for key in ("controller", "observer") if key not in shared]
    columns = {" / ".join(kept): [" / ".join(row[key] for key in kept) for row in rows]} if kept else {}
    if "status" not in shared:
        columns["status"] = [row["status"] for row in rows]
    heading = (f"**{scenario}** · seed {seed if seed is not None else 'not set'} · fault onsets [s]: "
               f"{', '.join(f'{t:g}' for t in fault_onsets) or 'none'} · {len(results[0].t) if results else 0} "
               "samples" + "".join(f" · {key}: {value}" for key, value in shared.items()))
    lines = [heading, "", "| " + " | ".join(["variant (colour)", *columns]) + " |", "|" + "---|" * (1 + len(columns))]
    for k, (r, style) in enumerate(zip(results, styles)):
        cells = [f"{r.name} ({colour_name(style.color)})", *(values[k] for values in columns.values())]
        lines.append("| " + " | ".join(cells) + " |")
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


def _rgba(model: mujoco.MjModel, g: int) -> np.ndarray:
    """The geom's colour: its material's, else its own."""
    mat = model.geom_matid[g]
    return model.mat_rgba[mat] if mat >= 0 else model.geom_rgba[g]


def _drawn(model: mujoco.MjModel, g: int) -> bool:
    """Whether the geom is drawn: visible (not transparent, in a group MuJoCo's viewer shows) and of a shape
    Rerun draws (planes, height fields and SDFs are not)."""
    kind = int(model.geom_type[g])
    return bool(_rgba(model, g)[3] > 0 and model.geom_group[g] <= _MAX_VISIBLE_GROUP
                and (kind in _SOLIDS or (kind == int(mujoco.mjtGeom.mjGEOM_MESH) and model.geom_dataid[g] >= 0)))


def _log_geometry(rec: rr.RecordingStream, model: mujoco.MjModel) -> None:
    """Every visible geom once, static, at /world/<body>/geoms/<geom>, placed by its pose in the body frame."""
    for g in range(model.ngeom):
        if not _drawn(model, g):
            continue
        shape = _geom_shape(model, g, np.round(np.clip(_rgba(model, g), 0, 1) * 255).astype(np.uint8))
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


#: The viewer's layout is sized for a laptop screen (1600 x 1000): the side panel (robot, info, events) and the
#: tabs share the width in this ratio, the side panel wide enough for an event's text ("nftsmc_tosmo: alarm
#: raised on joint 2") beside its time; the right pane, where the tabs are, is about TABS_WIDTH pixels wide;
#: a tab label takes about TAB_CHARACTER pixels per character plus TAB_MARGIN.
SIDE_SHARE, TABS_SHARE = 2.5, 6.5
TABS_WIDTH, TAB_CHARACTER, TAB_MARGIN = 1060, 7.5, 44
#: Short tab labels of the figures without a "Fig. N.M:" title, when the full titles do not fit.
SHORT_TABS = {"position": "position", "tracking_error": "tracking error", "velocity": "velocity",
              "velocity_error": "velocity error", "luaf": "LUaF", "luaf_error": "LUaF error", "torque": "torque",
              "torque_delivered": "delivered torque", "sliding": "sliding", "fault": "fault",
              "fault_torque": "fault force", "fault_acceleration": "fault accel.", "residual": "residual",
              "fault_estimate": "fault estimate", "alarm": "alarms"}
OTHER_TAB = "Other signals"
#: The other signals' tab: its plots in this many columns.
OTHER_COLUMNS = 2
#: The tabs' height [pixels] on a 1000-pixel screen, a plot's title bar and time axis, and the least distance
#: between two y-axis tick labels the viewer shows.
TABS_HEIGHT, PLOT_CHROME, TICK_SPACING = 720, 45, 20


def tab_labels(figures: Sequence[Figure], other: bool) -> list[str]:
    """The figures' tab labels (and the other signals' last): their titles where all fit in the tab strip
    (:data:`TABS_WIDTH`), else short ones ("Fig. 5.3", or the quantity), so that no tab is hidden."""
    def width(labels: Sequence[str]) -> float:
        return sum(len(label) * TAB_CHARACTER + TAB_MARGIN for label in labels)

    tail = [OTHER_TAB] if other else []
    labels = [f.title for f in figures]
    if width(labels + tail) <= TABS_WIDTH:
        return labels + tail
    short = []
    for f in figures:
        head, colon, _ = f.title.partition(":")
        short.append(head if colon and len(head) <= 16 else SHORT_TABS.get(f.quantity, f.name.replace("_", " ")))
    # Two figures of one quantity (e.g. two residual figures) would share a label: those take their names.
    short = [f.name.replace("_", " ") if short.count(label) > 1 else label for f, label in zip(figures, short)]
    return short + (["other"] if other else [])


def _robot_title(variant: str, replayed: str | None = None) -> str:
    """The 3-D panel's title: the variant whose simulated robot it shows, or, in a log replay (where every
    variant reads the same logged positions), the logged arm."""
    return f"Logged arm: {replayed}" if replayed is not None else f"Robot: variant {variant}"


def _blueprint(layout: Layout, series: Series, t: np.ndarray, posed: str | None,
               model: mujoco.MjModel | None = None, body_xpos: np.ndarray | None = None,
               body_xquat: np.ndarray | None = None) -> rrb.Blueprint:
    """The robot (``posed``: the 3-D panel's title, :func:`_robot_title`), info and events on the left; on the
    right one tab per figure (per-joint plots stacked, each with its zoom panel beside it), then a tab of the
    other recorded signals. Sized for 1600 x 1000: every
    tab label visible (:func:`tab_labels`), the info table whole (its share grows with the variants), the robot
    framed over the poses ``body_xpos``, ``body_xquat`` of the variant ``posed`` (:func:`_eye`)."""
    shown = {figure.entity for figure in layout.figures}
    other_views = [(title, tuple(f"/{p}" for p in prefixes)) for title, prefixes in OTHER_VIEWS
                   if any(e.startswith(tuple(f"/{p}" for p in prefixes)) for e in series)
                   and not shown.issuperset(prefixes)]
    other_views += [(f"extra: {e.split('/')[2]}", (e.rsplit("/", 1)[0],))
                    for e in sorted({e.rsplit("/", 1)[0] + "/joint1" for e in series if e.startswith("/extras/")})
                    if e.split("/")[2] not in {f.quantity.removeprefix("extras.") for f in layout.figures}]
    intervals = tick_intervals(-(-len(other_views) // OTHER_COLUMNS))
    others = [rrb.TimeSeriesView(name=title, origin="/", contents=[f"{p}/**" for p in prefixes] + list(prefixes),
                                 plot_legend=rrb.PlotLegend(visible=False),
                                 axis_y=_ticked_axis(series, prefixes, intervals))
              for title, prefixes in other_views]
    labels = tab_labels(layout.figures, bool(others))
    tabs: list[rrb.Container] = [_figure_tab(figure, layout, series, t, label, label != figure.title)
                                 for figure, label in zip(layout.figures, labels)]
    if others:
        tabs.append(rrb.Grid(*others, grid_columns=OTHER_COLUMNS, name=labels[-1]))
    events = rrb.TextLogView(name="Events", origin="/events", columns=rrb.archetypes.TextLogColumns(
        text_log_columns=[rrb.encodings.TextLogColumn("EntityPath", visible=False),
                          rrb.encodings.TextLogColumn("LogLevel", visible=False),
                          rrb.encodings.TextLogColumn("Body", visible=True)]))
    side: list[rrb.View] = [rrb.TextDocumentView(name="Info", origin="/info"), events]
    # The info table reads whole up to six variants (rows); beyond, each takes room from the events, and
    # beyond eight from the robot too.
    rows = len(layout.variants)
    shares = [2.0 + 0.3 * max(0, rows - 6), max(1.0, 1.6 - 0.3 * max(0, rows - 6))]
    if posed is not None:
        side.insert(0, rrb.Spatial3DView(name=posed, origin="/world",
                                         eye_controls=None if model is None else _eye(model, body_xpos, body_xquat)))
        shares.insert(0, max(1.6, 2.4 - 0.25 * max(0, rows - 8)))
    return rrb.Blueprint(
        rrb.Horizontal(rrb.Vertical(*side, row_shares=shares), rrb.Tabs(*tabs, active_tab=0),
                       column_shares=[SIDE_SHARE, TABS_SHARE]),
        collapse_panels=True,
    )


def _eye(model: mujoco.MjModel, body_xpos: np.ndarray | None = None,
         body_xquat: np.ndarray | None = None) -> rrb.archetypes.EyeControls3D:
    """A camera that frames the robot over the whole run: looking from the front-left and above at the centre
    of the box that holds every drawn geom's bounding sphere (its centre placed by the body poses
    ``body_xpos`` (N, nbody, 3) and ``body_xquat`` (N, nbody, 4, wxyz), radius ``geom_rbound``) at every
    recorded pose, from :data:`EYE_DISTANCE` times that box's half diagonal. Without poses (a live view before
    the first period), MuJoCo's ``stat.center`` and ``stat.extent`` of the initial pose, which miss an arm
    that moves away from it."""
    drawn = [g for g in range(model.ngeom) if _drawn(model, g)]
    if body_xpos is None or body_xquat is None or body_xpos.size == 0 or not drawn:
        centre, radius = np.asarray(model.stat.center, dtype=np.float64), 0.5 * float(model.stat.extent)
    else:
        rows = slice(None, None, max(1, len(body_xpos) // 500))  # a few hundred poses frame the run as well
        bodies = model.geom_bodyid[drawn]
        xpos = np.asarray(body_xpos, dtype=np.float64)[rows][:, bodies]  # (n, geoms, 3)
        quat = np.asarray(body_xquat, dtype=np.float64)[rows][:, bodies]
        offset = np.broadcast_to(model.geom_pos[drawn], xpos.shape)
        # v' = v + w t + u x t with t = 2 u x v: the geom's offset turned by its body's quaternion (w, u)
        w, u = quat[..., :1], quat[..., 1:]
        turn = 2.0 * np.cross(u, offset)
        centres = xpos + offset + w * turn + np.cross(u, turn)
        reach = model.geom_rbound[drawn][None, :, None]
        low, high = (centres - reach).min(axis=(0, 1)), (centres + reach).max(axis=(0, 1))
        centre, radius = 0.5 * (low + high), 0.5 * float(np.linalg.norm(high - low))
    direction = np.array([1.0, -1.4, 0.8])
    position = centre + direction / np.linalg.norm(direction) * EYE_DISTANCE * max(radius, 1e-3)
    return rrb.archetypes.EyeControls3D(kind="Orbital", position=position, look_target=centre, eye_up=[0, 0, 1])


def _figure_tab(figure: Figure, layout: Layout, series: Series, t: np.ndarray, tab: str,
                titled: bool = False) -> rrb.Container:
    """One figure: a row per joint, the overview plot and, with a zoom, the zoomed plot beside it. The colour
    key is in a plot title; with a short ``tab`` label, the figure's title heads the top plot (``titled``)."""
    companion, kind = figure.companion
    shown = np.array([s.name in figure.variants for s in layout.variants])
    in_zoom = np.array([s.name in figure.shown_in_zoom() for s in layout.variants])
    zoom = zoom_span(figure, layout.duration)
    rows: list[rrb.View | rrb.Container] = []
    for row, joint in enumerate(figure.joints):
        entities = [_ep(*figure.entity.split("/"), f"joint{joint + 1}")]
        if companion is not None:
            entities.append(_ep(*companion.split("/"), f"joint{joint + 1}"))
        entities = [e for e in entities if e in series]
        overrides = {e: rr.SeriesLines(visible_series=shown) for e in entities
                     if series[e][0].shape[1] == len(shown) and not shown.all()}
        label = f"{layout.joints[joint]} [{figure.unit}]" if figure.unit else layout.joints[joint]
        main = entities[0] if entities else None
        # No legend box over the data: the top plot's title is the key (a legend would also list the columns
        # this figure hides); every plot has the same colours, and hovering a line names it.
        key = _colour_key(layout, figure.variants, kind)
        if titled and row == 0:  # the title first; the key in the next title (or here, with one plot)
            title = f"{figure.title} · {label}" if len(figure.joints) > 1 else f"{figure.title} · {label}   {key}"
        elif row == (1 if titled else 0):
            title = f"{label}   {key}"
        else:
            title = label
        legend = rrb.PlotLegend(visible=False)
        window = figure.window
        # A vertical range with two labelled ticks at least (:func:`tick_range`): left to the viewer, a plot
        # whose data fall between its coarse ticks shows a lone 0.
        span = (t >= window[0]) & (t <= window[1]) if window else np.ones(len(t), dtype=bool)
        overview_range = tick_range(np.concatenate(
            [np.ravel(_shown(series[e][0][span], shown)) for e in entities] or [np.zeros(0)]),
            tick_intervals(len(figure.joints)))
        overview = rrb.TimeSeriesView(
            name=title, origin="/", contents=entities, overrides=overrides, plot_legend=legend,
            axis_x=rrb.TimeAxis(link="Independent", view_range=_time_range(*window)) if window else None,
            axis_y=rrb.ScalarAxis(range=overview_range) if overview_range is not None else None)
        if zoom is None:
            rows.append(overview)
            continue
        limits = figure.zoom_range
        if limits is None and main is not None:
            inside = (t >= zoom[0]) & (t <= zoom[1])
            limits = tick_range(_shown(series[main][0][inside], in_zoom), tick_intervals(len(figure.joints)))
        zoom_overrides = {e: rr.SeriesLines(visible_series=in_zoom) for e in entities
                          if series[e][0].shape[1] == len(in_zoom) and not in_zoom.all()}
        zoomed = rrb.TimeSeriesView(
            name=f"{label}, zoom {zoom[0]:g}-{zoom[1]:g} s", origin="/", contents=entities, overrides=zoom_overrides,
            plot_legend=rrb.PlotLegend(visible=False),
            axis_x=rrb.TimeAxis(link="Independent", view_range=_time_range(*zoom)),
            axis_y=rrb.ScalarAxis(range=limits) if limits is not None else None)
        rows.append(rrb.Horizontal(overview, zoomed, column_shares=[3, 2]))
    return rrb.Vertical(*rows, name=tab)


def tick_intervals(rows: int) -> int:
    """How many intervals between labelled ticks a plot in a column of ``rows`` shows: its height on a
    1600 x 1000 screen (:data:`TABS_HEIGHT` shared, less :data:`PLOT_CHROME` each) over :data:`TICK_SPACING`,
    from 1 to :data:`ftc_mj.outputs.layout.MAX_TICK_INTERVALS`."""
    return int(np.clip((TABS_HEIGHT / max(rows, 1) - PLOT_CHROME) // TICK_SPACING, 1, MAX_TICK_INTERVALS))


def _ticked_axis(series: Series, prefixes: tuple[str, ...], intervals: int) -> rrb.ScalarAxis | None:
    """A vertical axis with two labelled ticks at least (:func:`tick_range`) over every series at or under
    the entities ``prefixes``; None (the viewer's own) without finite values."""
    limits = tick_range(np.concatenate([np.ravel(values) for e, (values, *_) in series.items()
                                        if e in prefixes or e.startswith(tuple(f"{p}/" for p in prefixes))]
                                       or [np.zeros(0)]), intervals)
    return rrb.ScalarAxis(range=limits) if limits is not None else None


def _shown(values: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """The ``columns`` (a mask over the variants) of an (N, V) series; a shared series (one column) whole."""
    return values[:, columns] if values.shape[1] == len(columns) else values


def _time_range(start: float, end: float) -> rrb.TimeRange:
    return rrb.TimeRange(start=rrb.TimeRangeBoundary.absolute(seconds=start),
                         end=rrb.TimeRangeBoundary.absolute(seconds=end))


def _colour_key(layout: Layout, variants: Sequence[str], kind: str | None) -> str:
    """'red: proposed · blue: nftsmc_tosmo · ...' for a figure's variants, and what its second lines are."""
    key = " · ".join(f"{colour_name(layout.style(v).color)}: {v}" for v in variants)
    companion = {"truth": "wide pale: truth", "reference": "grey: reference", "threshold": "second line: threshold",
                 "injected": "second line: injected fault"}.get(kind or "")
    return f"{key} · {companion}" if companion else key
