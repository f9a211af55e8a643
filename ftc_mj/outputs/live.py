"""Stream a run to a Rerun viewer while it runs (``ftc-mj run --spawn | --connect URL | --serve``).

The stream carries what :func:`ftc_mj.outputs.recording.write_recording` writes to the file, in three steps:

1. :meth:`LiveRecording.start`, before the first period: the blueprint (the same figures and tabs as the
   file's), the info panel, the robot's geometry and every line's name and colour;
2. :meth:`LiveRecording.send`, from the loop's per-chunk hook (:data:`ftc_mj.engine.loop.ChunkCallback`):
   the samples recorded since the last send of the quantities the loop writes as it goes (:data:`LIVE`:
   positions, reference, tracking error, velocities, the LUaF estimate, torque, sliding variable, fault
   signal) and the robot's poses, as one ``send_columns`` per entity. A send happens at most every
   :data:`SEND_INTERVAL` seconds of wall time, so its cost stays a small share of the loop's whatever the
   number of periods per chunk;
3. :meth:`LiveRecording.finish`, with the run's results: the rest of the streamed quantities, everything the
   run computes after its last period (the true LUaF and its error, the diagnosis, the events, the delivered
   torque, the methods' signals), the final info and the file's blueprint (its zoom ranges are the data's).

The values are those of the file, float32, the same columns (one per variant and monitor, in order). A row
that diverges inside a chunk has sent its samples past the stop (the file has NaN there).
"""

from __future__ import annotations

import time as wall
import uuid
from collections.abc import Mapping, Sequence

import mujoco
import numpy as np
import rerun as rr

from ftc_mj.config.errors import InputError
from ftc_mj.outputs.layout import Figure, Layout, generic_figures, variant_styles
from ftc_mj.outputs.recording import (DIAGNOSIS_SERIES, GENERIC_QUANTITIES, LAYOUT_PROPERTY, LINE_WIDTH,
                                      OPTIONAL_SERIES, SERIES, SHARED_SERIES, TRUTH_WIDTH, _blueprint, _ep,
                                      _common_time, _hex_rgb, _info_markdown, _layout, _log_events, _log_geometry, _name, _pale, _robot_title, _series,
                                      _time_column, _xyzw)
from ftc_mj.results import VariantResult

#: Seconds to wait for a viewer to answer before a run (``--connect``).
CONNECT_TIMEOUT = 3.0
#: Seconds the end of a stream waits for a viewer that stopped reading.
FLUSH_TIMEOUT = 10.0
#: Least wall time between two sends [s]: a send costs about a millisecond per hundred entities.
SEND_INTERVAL = 0.5
#: Body poses kept every this many samples, as in the file.
POSE_STRIDE = 10
#: The quantities streamed during the run: entity prefix -> the loop's series it is computed from. ``-`` is a
#: difference; a monitor's column takes its own estimate (``qd_hat``, ``luaf_hat``), its host's otherwise.
LIVE: dict[str, tuple[str, ...]] = {
    "q": ("q_meas",),
    "tracking_error": ("q_true", "-", "q_ref"),
    "velocity/true": ("qd_true",),
    "velocity/estimate": ("qd_hat",),
    "velocity_error": ("qd_true", "-", "qd_hat"),
    "luaf/estimate": ("luaf_hat",),
    "torque": ("tau",),
    "sliding": ("sliding",),
    "fault": ("fault",),
}
_ESTIMATES = ("qd_hat", "luaf_hat")


class LiveRecording:
    """One run's stream to a viewer's sinks (``rr.GrpcSink``, ``rr.GrpcServerSink``)."""

    def __init__(self, rec: rr.RecordingStream, layout: Layout, variants: Sequence[str],
                 columns: Sequence[tuple[int, str | None]], times: np.ndarray, bodies: Sequence[str] | None):
        self.rec, self.layout, self.times = rec, layout, times
        #: The variants, a row each; per column of the series, its row and monitor (None: the variant's own).
        self.variants, self.columns = list(variants), list(columns)
        #: The entity of every body (the world body first), or None without the robot's poses.
        self.bodies = None if bodies is None else list(bodies)
        #: Samples sent so far, of the quantities and of the poses.
        self.sent = 0
        #: Whether a sink is a server in this process (``--serve``): it serves until :meth:`close`.
        self.serving = False
        self._last = wall.perf_counter()

    @classmethod
    def start(cls, sinks: Sequence[object], *, scenario: str, model: mujoco.MjModel, variants: Sequence[str],
              monitors: Mapping[str, Sequence[str]], times: np.ndarray, fault_onsets: Sequence[float] = (),
              seed: int | None = None, figures: Sequence[Figure] | None = None,
              colours: Mapping[str, str] | None = None, posed: bool = True,
              optional: Sequence[str] = (), diagnosis: bool = False) -> LiveRecording:
        """Open the stream and send what is known before the run: blueprint, info, geometry, line styles.

        ``variants`` in the run's order, ``monitors`` their monitors' names (results ``variant.monitor``);
        ``optional``: the entity prefixes of :data:`~ftc_mj.outputs.recording.OPTIONAL_SERIES` the run will
        have; ``diagnosis``: whether it has a diagnosis section."""
        names, columns = [], []
        for row, variant in enumerate(variants):
            names.append(variant)
            columns.append((row, None))
            for monitor in monitors.get(variant, ()):
                names.append(f"{variant}.{monitor}")
                columns.append((row, monitor))
        styles = variant_styles(names, {n for n in names if "." in n}, colours)
        dt = float(times[1] - times[0]) if len(times) > 1 else 0.0
        chosen = (generic_figures(model.nv, names, GENERIC_QUANTITIES) if figures is None
                  else [f for f in figures if f.variants])
        joints = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, int(model.dof_jntid[d])) or f"joint{d + 1}"
                  for d in range(model.nv)]
        layout = Layout(scenario=scenario, duration=float(times[-1]) + dt if len(times) else 0.0,
                        fault_onsets=[float(t) for t in fault_onsets], joints=joints, variants=styles,
                        samples={n: len(times) for n in names}, figures=chosen)
        rec = rr.RecordingStream("ftc_mj", recording_id=str(uuid.uuid4()))
        skeleton = _skeleton(layout, len(times), optional, diagnosis)
        rec.set_sinks(*sinks, default_blueprint=_blueprint(layout, skeleton, times, _robot_title(names[0]) if posed else None, model))
        rec.send_recording_name(scenario)
        rec.send_property(LAYOUT_PROPERTY, rr.AnyValues(json=layout.to_json()))
        rec.log("/info", rr.TextDocument(f"# {scenario}\n\nrunning: {len(times)} samples of "
                                         f"{', '.join(names)}\n", media_type=rr.MediaType.MARKDOWN), static=True)
        for entity, (_, lines, colors, widths) in skeleton.items():
            rec.log(entity, rr.SeriesLines(names=lines, colors=colors, widths=widths), static=True)
        if posed:
            _log_geometry(rec, model)
        bodies = [_ep("world", _name(model, mujoco.mjtObj.mjOBJ_BODY, b, "body")) for b in range(model.nbody)]
        live = cls(rec, layout, variants, columns, np.asarray(times, dtype=np.float64), bodies if posed else None)
        live.serving = any(isinstance(sink, rr.GrpcServerSink) for sink in sinks)
        return live

    def due(self) -> bool:
        """Whether :data:`SEND_INTERVAL` has passed since the last send."""
        return wall.perf_counter() - self._last >= SEND_INTERVAL

    def send(self, stop: int, series: Mapping[str, np.ndarray], monitors: Mapping[str, Mapping[str, Mapping]],
             reference: np.ndarray, body_xpos: np.ndarray | None = None, body_xquat: np.ndarray | None = None,
             *, force: bool = False) -> None:
        """Samples ``[sent, stop)`` of the loop's series (``(steps, rows, n)``, one member: a row per
        variant), its monitors' (variant -> monitor -> ``(steps, 1, n)``), the reference ``(steps, n)`` and
        the first row's body poses; nothing before :data:`SEND_INTERVAL` unless ``force``."""
        start = self.sent
        if stop <= start or not (force or self.due()):
            return
        rec, rows = self.rec, slice(start, stop)
        time = _time_column(self.times[rows])
        q_ref = reference[rows] if reference.ndim == 2 else reference[rows, 0]
        variants = self.variants

        def column(name: str, row: int, monitor: str | None) -> np.ndarray:
            if name == "q_ref":
                return q_ref
            if monitor is not None and name in _ESTIMATES:
                return monitors[variants[row]][monitor][name][rows, 0]
            return series[name][rows, row]

        for prefix, source in LIVE.items():
            blocks = []
            for row, monitor in self.columns:
                value = column(source[0], row, monitor)
                if len(source) == 3:
                    value = value - column(source[2], row, monitor)
                blocks.append(value)
            values = np.stack(blocks, axis=1).astype(np.float32)  # (samples, columns, n)
            for joint in range(values.shape[2]):
                rec.send_columns(_ep(*prefix.split("/"), f"joint{joint + 1}"), indexes=[time],
                                 columns=rr.Scalars.columns(scalars=np.ascontiguousarray(values[:, :, joint])))
        reference32 = q_ref.astype(np.float32)
        for joint in range(reference32.shape[1]):
            rec.send_columns(_ep("q_ref", f"joint{joint + 1}"), indexes=[time],
                             columns=rr.Scalars.columns(scalars=np.ascontiguousarray(reference32[:, joint:joint + 1])))
        if self.bodies is not None and body_xpos is not None and body_xquat is not None:
            kept = np.arange(-(-start // POSE_STRIDE) * POSE_STRIDE, stop, POSE_STRIDE)
            if len(kept):
                _send_poses(rec, self.bodies, self.times[kept], body_xpos[kept, 0], body_xquat[kept, 0])
        self.sent = stop
        self._last = wall.perf_counter()

    def finish(self, model: mujoco.MjModel, results: Sequence[VariantResult], fault_onsets: Sequence[float] = (),
               seed: int | None = None, figures: Sequence[Figure] | None = None) -> None:
        """What the file has and the stream does not yet: the streamed quantities' last samples, the
        quantities computed after the run, the last pose, events, the final info and blueprint; then the
        stream is closed."""
        rec, start = self.rec, self.sent
        t = _common_time(results)
        layout = _layout(self.layout.scenario, model, results, t, fault_onsets, figures,
                         {s.name: s.color for s in self.layout.variants})
        series = _series(results, len(t), layout.variants)
        streamed = {_ep(*p.split("/"), f"joint{j + 1}") for p in (*LIVE, "q_ref") for j in range(model.nv)}
        rec.send_property(LAYOUT_PROPERTY, rr.AnyValues(json=layout.to_json()))
        rec.log("/info", rr.TextDocument(_info_markdown(layout.scenario, seed, results, fault_onsets,
                                                        layout.variants), media_type=rr.MediaType.MARKDOWN),
                static=True)
        _log_events(rec, results, fault_onsets)
        full, tail = _time_column(t), _time_column(t[start:])
        for entity, (values, names, colors, widths) in series.items():
            if entity in streamed:
                if start < len(t):
                    rec.send_columns(entity, indexes=[tail], columns=rr.Scalars.columns(scalars=values[start:]))
                continue
            rec.log(entity, rr.SeriesLines(names=names, colors=colors, widths=widths), static=True)
            rec.send_columns(entity, indexes=[full], columns=rr.Scalars.columns(scalars=values))
        posed = next((r for r in results if r.body_xpos.size > 0), None)
        if self.bodies is not None and posed is not None and len(posed.t):
            n = len(posed.t)
            kept = np.unique(np.append(np.arange(-(-start // POSE_STRIDE) * POSE_STRIDE, n, POSE_STRIDE), n - 1))
            _send_poses(rec, self.bodies, np.asarray(posed.t)[kept], np.asarray(posed.body_xpos)[kept],
                        np.asarray(posed.body_xquat)[kept])
        rec.send_blueprint(_blueprint(layout, series, t, _robot_title(posed.name) if posed else None, model,
                                      *((posed.body_xpos, posed.body_xquat) if posed else ())), make_active=True)
        rec.flush(timeout_sec=FLUSH_TIMEOUT)  # a viewer closed during the run: give up, never hang
        if not self.serving:  # a server in this process ends with the stream: kept until close()
            rec.disconnect()

    def close(self) -> None:
        """End the stream (and a server's serving)."""
        self.rec.disconnect()


def viewer_address(url: str) -> tuple[str, int]:
    """The host and port of a viewer's gRPC URL (``rerun+http://HOST:PORT/proxy``, Rerun's forms).

    Raises:
        InputError: not such a URL.
    """
    from urllib.parse import urlsplit

    parts = urlsplit(url)
    try:
        port = parts.port
    except ValueError:
        port = None
    if parts.scheme not in ("rerun", "rerun+http", "rerun+https") or not parts.hostname or parts.path != "/proxy":
        raise InputError("command line", "--connect", f"{url!r} is not a viewer's address (rerun+http://HOST:PORT"
                         "/proxy, e.g. rerun+http://127.0.0.1:9876/proxy)")
    return parts.hostname, port or 9876


def check_viewer(url: str) -> None:
    """Refuse a viewer address where nothing answers within :data:`CONNECT_TIMEOUT`, before the run (a stream
    to it would wait for ever at the end).

    Raises:
        InputError: one line saying what to do.
    """
    import socket

    host, port = viewer_address(url)
    try:
        socket.create_connection((host, port), timeout=CONNECT_TIMEOUT).close()
    except OSError as error:
        reason = "no answer" if isinstance(error, TimeoutError) else error.strerror or str(error)
        raise InputError("command line", "--connect", f"no viewer at {url} ({reason}): start one first (rerun), "
                         "or use --spawn to start one, or --serve for viewers to connect to this run") from None


def check_bindable(host: str, port: int, option: str = "--serve") -> None:
    """Refuse an address this process cannot listen on (in use, not this machine's), before the run.

    Raises:
        InputError: one line saying what to do.
    """
    import socket

    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except socket.gaierror as error:
        raise InputError("command line", option, f"{host!r} is not an address of this machine ({error.strerror})"
                         ) from None
    family, kind, _, _, address = infos[0]
    with socket.socket(family, kind) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the server binds
        try:
            probe.bind(address)
        except OSError as error:
            raise InputError("command line", option, f"cannot listen on {host}:{port} ({error.strerror}): stop "
                             f"what listens there, or name another port (--bind {host}:{port + 1})") from None


def _send_poses(rec: rr.RecordingStream, bodies: Sequence[str], times: np.ndarray, xpos: np.ndarray,
                xquat: np.ndarray) -> None:
    """World poses of every body but the world body (``xpos`` ``(samples, bodies, 3)``) at ``times``."""
    time = _time_column(times)
    for b in range(1, xpos.shape[1]):
        rec.send_columns(bodies[b], indexes=[time],
                         columns=rr.Transform3D.columns(translation=np.ascontiguousarray(xpos[:, b], np.float64),
                                                        quaternion=_xyzw(xquat[:, b])))


def _skeleton(layout: Layout, samples: int, optional: Sequence[str], diagnosis: bool) -> dict:
    """The series entities the run will have, with their line styles and no values (NaN views: no memory),
    for the blueprint and the static line styles sent before the run."""
    rgb = [_hex_rgb(s.color) for s in layout.variants]
    prefixes = [(p, kind) for p, _, kind in SERIES]
    prefixes += [(p, kind) for p, _, kind in OPTIONAL_SERIES if p in optional]
    if diagnosis:
        prefixes += [(p, kind) for p, _, kind in DIAGNOSIS_SERIES]
    empty = np.broadcast_to(np.float32(np.nan), (samples, len(rgb)))
    found = {}
    for prefix, kind in prefixes:
        names = [s.name if not kind else f"{s.name} {kind}" for s in layout.variants]
        colors = [_pale(c) if kind == "true" else c for c in rgb]
        widths = [TRUTH_WIDTH if kind == "true" else LINE_WIDTH] * len(rgb)
        for joint in range(len(layout.joints)):
            found[_ep(*prefix.split("/"), f"joint{joint + 1}")] = (empty, names, colors, widths)
    single = np.broadcast_to(np.float32(np.nan), (samples, 1))
    for prefix, _, name in SHARED_SERIES:
        entities = [_ep(prefix)] if prefix == "fault_active" else [_ep(prefix, f"joint{j + 1}")
                                                                   for j in range(len(layout.joints))]
        for entity in entities:
            found[entity] = (single, [name], [[90, 90, 90]], [LINE_WIDTH])
    return found
