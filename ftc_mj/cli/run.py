"""Run a scenario: ``ftc-mj run SCENARIO [options]`` (also ``python -m ftc_mj.run``).

Runs every controller-observer variant of the scenario, prints their metrics, and writes a Rerun recording
(and optionally a JSON file of the metrics, and every series at float64 for MATLAB or pandas: --export). Exit status: 0 on success, 1 if a variant diverged, 2 on bad
input (one line on stderr naming the file, the field and the problem; nothing is written), 130 when
interrupted (nothing is written).

A thin client of the library: :func:`ftc_mj.load_scenario`, :func:`ftc_mj.run_scenario` (given the progress
bars), :func:`ftc_mj.analysis.metrics.compute_metrics`, :func:`ftc_mj.outputs.recording.write_recording`,
:func:`ftc_mj.outputs.files.write_atomic`.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from ftc_mj.cli.command import Outputs, exit_status
from ftc_mj.cli.parser import ArgumentParser

if TYPE_CHECKING:
    import numpy as np
    from rich.console import Console, Group

    from ftc_mj.engine.loop import ChunkCallback
    from ftc_mj.outputs.live import LiveRecording
    from ftc_mj.results import VariantResult
    from ftc_mj.scenario.definition import Scenario

PROG = "ftc-mj run"
#: Rerun's default viewer address (``rerun`` listens there).
DEFAULT_PORT = 9876
DEFAULT_URL = f"rerun+http://127.0.0.1:{DEFAULT_PORT}/proxy"


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    parser = ArgumentParser(prog=prog, description=__doc__.split("\n\n")[1])
    parser.add_argument("scenario", type=Path, help="scenario YAML file")
    parser.add_argument("--out", type=Path, help="recording path (default: the scenario's output)")
    parser.add_argument("--variant", nargs="+", default=[], metavar="NAME", help="run only these variants")
    parser.add_argument("--duration", type=float, metavar="S", help="override the scenario's duration [s]")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="overrides",
                        help="override a scenario field, e.g. variants.proposed.controller.gains.mu=1.0")
    parser.add_argument("--json", type=Path, metavar="PATH", help="write the metrics as JSON")
    parser.add_argument("--no-record", action="store_true", help="do not write a Rerun recording")
    parser.add_argument("--quiet", action="store_true", help="no progress display and no table")
    parser.add_argument("--export-log", type=Path, metavar="PATH",
                        help="write per variant what a real controller would have logged (PATH.<variant>.csv "
                             "or .mcap, by PATH's extension): time, measured positions and velocities, commanded "
                             "and delivered torques")
    parser.add_argument("--export", type=Path, metavar="FILE",
                        help="write every series of every variant at the run's precision (float64), with units: "
                             "FILE.mat (MATLAB: scipy.io.savemat), .parquet or .csv")
    viewer = parser.add_mutually_exclusive_group()  # Rerun's conventions (rr.script_add_args)
    viewer.add_argument("--spawn", action="store_true", help="start a Rerun viewer and send it the recording")
    viewer.add_argument("--connect", nargs="?", const=DEFAULT_URL, metavar="URL",
                        help=f"send the recording to a running viewer or server (default: {DEFAULT_URL})")
    viewer.add_argument("--serve", action="store_true",
                        help="serve the recording over gRPC for viewers to connect to, until Ctrl-C (on this "
                             "machine only, 127.0.0.1, unless --bind names another address)")
    parser.add_argument("--bind", metavar="HOST[:PORT]",
                        help=f"the address --serve listens on (default 127.0.0.1:{DEFAULT_PORT}; 0.0.0.0 "
                             "serves every network interface: the recording is then open to the network)")
    parser.add_argument("--metrics", default="summary", metavar="WHICH",
                        help="the table's metrics: summary (default: tracking after convergence, estimation "
                             "errors, chattering, detection delay and false alarms), all, or a comma-separated "
                             "list of names")
    return parser


#: A variant whose command is clipped for more than this share of the run (on any joint) is warned about.
SATURATION_WARNING = 0.05


def chosen_metrics(which: str, diagnosis: bool) -> list[str]:
    """The table's metrics for ``--metrics``.

    Raises:
        InputError: an unknown metric name.
    """
    from ftc_mj.analysis.metrics import METRICS
    from ftc_mj.config.errors import InputError
    from ftc_mj.outputs.tables import summary_metrics

    if which == "summary":
        return summary_metrics(diagnosis)
    if which == "all":
        return list(METRICS)
    names = [name.strip() for name in which.split(",") if name.strip()]
    unknown = [name for name in names if name not in METRICS]
    if unknown or not names:
        raise InputError("command line", "--metrics", f"unknown metric {unknown[0] if unknown else which!r} "
                         f"(summary, all, or among: {', '.join(METRICS)})")
    return names


def _load_warnings(scenario: Scenario) -> None:
    """The warnings of ``ftc-mj robot check`` in short, one line each on stderr, before the run."""
    from ftc_mj.cli.robot import scenario_check, short_warning

    # One line per statement: the per-variant forms of a warning are the same statement in short.
    for warning in dict.fromkeys(short_warning(w) for w in scenario_check(scenario).warnings):
        print(f"warning: {warning} (ftc-mj robot check {scenario.path})", file=sys.stderr)


def saturation_warning(scenario: Scenario, results: Sequence[VariantResult], metrics: dict[str, dict]) -> str | None:
    """One line naming each variant and joint whose command was clipped at the torque limit for more than
    :data:`SATURATION_WARNING` of the run; None if none was."""
    import numpy as np

    found = []
    for result in results:
        if result.host is not None:  # a monitor shares its host's commands
            continue
        share = np.asarray(metrics[result.name]["saturation_time"], dtype=float)
        found += [f"{result.name} {scenario.model.joint(j).name or j + 1} {share[j]:.0%}"
                  for j in np.flatnonzero(share > SATURATION_WARNING)]
    if not found:
        return None
    return (f"warning: the command was clipped at the torque limits for more than {SATURATION_WARNING:.0%} of "
            f"the run: {', '.join(found)} (saturation_time)")


def _run_with_progress(scenario: Scenario, console: Console | None,
                       on_chunk: ChunkCallback | None = None) -> list[VariantResult]:
    """:func:`run_scenario` with a progress bar on ``console`` (none when None): the variants step together."""
    from ftc_mj.engine.runner import run_scenario

    if console is None:
        return run_scenario(scenario, on_chunk=on_chunk)
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    steps = len(scenario.times)
    with Progress(
        TextColumn("{task.description:<16}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
        console=console, transient=False,
    ) as display:
        tasks = {}

        def start(variants: str):
            tasks[variants] = task = display.add_task(variants, total=steps)
            return lambda advance: display.advance(task, advance)

        results = run_scenario(scenario, progress=start, on_chunk=on_chunk)
    return results


def metrics_table(scenario: Scenario, results: Sequence[VariantResult], metrics: dict[str, dict],
                  shown: Sequence[str] | None = None) -> Group:
    """Per metric, a heading (its name and unit) and one line per variant, one column per joint, each value
    once (:func:`ftc_mj.outputs.tables.table_rows`), the columns aligned from metric to metric: a 6-joint
    arm fits 80 columns, its joints numbered with a legend where their names do not fit
    (:func:`ftc_mj.outputs.tables.joint_labels`). ``shown``: the metrics (default: all)."""
    from rich.console import Group
    from rich.markup import escape
    from rich.table import Table
    from rich.text import Text

    from ftc_mj.analysis.metrics import METRICS
    from ftc_mj.outputs.tables import joint_labels, table_rows

    n = scenario.n_joints
    shown = list(METRICS if shown is None else shown)
    every = len(shown) == len(METRICS)
    labels, legend = joint_labels([scenario.model.joint(joint).name for joint in range(n)])
    hosts = {r.name: r.host for r in results}
    diverged = {r.name: f" (diverged at {r.diverged_at:.3f} s)" for r in results if r.status != "ok"}
    space = scenario.diagnoser.space if scenario.diagnoser is not None else None
    sections = []
    for metric in shown:
        rows = [(label if label.startswith(".") or label == "all" else label + diverged.get(label, ""),
                 [_format(v) for v in values])
                for label, values in table_rows({r.name: metrics[r.name][metric] for r in results}, hosts,
                                                    shared_plant=scenario.log is not None)]
        sections.append((f"{metric} [{_unit(metric, space)}]", rows))
    # One width per column over every metric, so that the joints line up down the whole table.
    variant_width = max([len("variant")] + [len(label) for _, rows in sections for label, _ in rows])
    widths = [max([len(label)] + [len(cells[j]) for _, rows in sections for _, cells in rows])
              for j, label in enumerate(labels)]
    # Two spaces between columns, one where two would not fit 80 columns (six joints of -1.23e-06).
    gap = 2 if variant_width + sum(width + 2 for width in widths) <= 80 else 1
    parts: list = [Text(f"{scenario.name}: " + ("metrics, one column per joint" if every
                                                 else "summary (--metrics all: every metric)"), style="bold"),
                   Text("")]
    for k, (heading, rows) in enumerate(sections):
        table = Table(title=escape(heading), title_justify="left", title_style="bold", box=None,
                      padding=(0, 0, 0, gap), show_header=k == 0, header_style="bold underline", pad_edge=False)
        table.add_column("variant", no_wrap=True, min_width=variant_width, max_width=variant_width)
        for label, width in zip(labels, widths):
            table.add_column(label, justify="right", no_wrap=True, min_width=width, max_width=width)
        for label, cells in rows:
            table.add_row(Text(label, style="red" if label.endswith(" s)") else ""), *cells)
        parts.append(table)
    if legend:
        parts.append(Text(f"joints: {legend}"))
    if any(host is not None for host in hosts.values()):
        parts.append(Text("a monitor's row (.name) is left out where it equals its variant's (the same closed "
                          "loop)"))
    return Group(*parts)


def _unit(metric: str, space: str | None) -> str:
    from ftc_mj.analysis.metrics import unit
    from ftc_mj.logs.events import EVENT_METRICS

    return EVENT_METRICS[metric] if metric in EVENT_METRICS else unit(metric, space)


def _format(value: float) -> str:
    return "-" if not math.isfinite(value) else f"{value:.3g}"


def metrics_document(scenario: Scenario, results: Sequence[VariantResult], metrics: dict[str, dict]) -> dict:
    """The ``--json`` document; NaN (undefined) values become null."""
    import numpy as np

    def clean(values: np.ndarray) -> list[float | None]:
        return [float(v) if math.isfinite(v) else None for v in values]

    first_onset = min(scenario.fault_onsets, default=math.inf)

    def diagnosis(result: VariantResult) -> dict | None:
        found = result.diagnosis
        if found is None:
            return None
        return {
            "space": found.space,
            "alarms": found.alarm_times(),
            "isolated_joints": [int(j) + 1 for j in np.flatnonzero(found.isolated(first_onset))],
            "baseline_mean": clean(found.mean),
            "baseline_std": clean(found.std),
        }

    velocity = {variant.name: variant.controller_velocity for variant in scenario.variants}
    return {
        "scenario": scenario.name,
        "seed": scenario.spec.seed,
        "variants": {
            r.name: {
                "status": r.status,
                "diverged_at": r.diverged_at,
                "controller_velocity": velocity[r.host or r.name],  # a monitor's: its host's
                "metrics": {name: clean(values) for name, values in metrics[r.name].items()},
                "diagnosis": diagnosis(r),
            }
            for r in results
        },
    }


def _viewer_sinks(args: argparse.Namespace) -> list[object]:
    """The Rerun sinks of ``--spawn``, ``--connect`` and ``--serve`` (none without them)."""
    import rerun as rr

    if args.spawn:
        rr.spawn(port=DEFAULT_PORT, connect=False)
        return [rr.GrpcSink(DEFAULT_URL)]
    if args.connect:
        return [rr.GrpcSink(args.connect)]
    if args.serve:
        host, port = args.address
        return [rr.GrpcServerSink(bind_ip=host, port=port)]
    return []


def start_live(scenario: Scenario, sinks: Sequence[object]) -> tuple[LiveRecording, ChunkCallback]:
    """The stream to a viewer's ``sinks`` opened before the run (blueprint first) and the loop's per-chunk
    hook that feeds it (:class:`ftc_mj.outputs.live.LiveRecording`)."""
    from ftc_mj.outputs.live import LiveRecording

    optional = ["torque_delivered", "fault_torque", "fault_acceleration"]
    if scenario.measures_velocity:
        optional.append("velocity/measured")
    live = LiveRecording.start(
        sinks, scenario=scenario.name, model=scenario.model, variants=[v.name for v in scenario.variants],
        monitors={v.name: [m.name for m in v.monitors] for v in scenario.variants}, times=scenario.times,
        fault_onsets=scenario.fault_onsets, seed=scenario.spec.seed, figures=scenario.figures,
        colours=scenario.colours, optional=optional,
        diagnosis=scenario.diagnoser is not None)

    def on_chunk(stop: int, series, reference) -> None:
        if live.due():  # cheap test first: most chunks send nothing
            live.send(stop, series.rows, series.monitors, reference[0], series.body_xpos, series.body_xquat)

    return live, on_chunk


def _bind_address(text: str) -> tuple[str, int]:
    """``HOST``, ``HOST:PORT`` or ``[IPV6]:PORT`` of ``--bind`` (default port :data:`DEFAULT_PORT`).

    Raises:
        InputError: not such an address.
    """
    from ftc_mj.config.errors import InputError

    if text.startswith("["):
        host, _, rest = text[1:].partition("]")
        port = rest.removeprefix(":")
    elif text.count(":") == 1:
        host, _, port = text.partition(":")
    else:
        host, port = text, ""
    number = int(port) if port.isdigit() else DEFAULT_PORT if not port else -1
    if not host or not 0 < number < 65536:
        raise InputError("command line", "--bind", f"{text!r} is not HOST or HOST:PORT (e.g. 127.0.0.1:9876)")
    return host, number


def _viewer(args: argparse.Namespace) -> str | None:
    """The viewer option given (``--spawn``, ``--connect``, ``--serve``), checked before the run: a viewer
    that does not answer and an address that cannot be listened on are refused at once.

    Raises:
        InputError: a viewer option with --no-record, --bind without --serve, no viewer at --connect's
            address, --serve's address in use.
    """
    from ftc_mj.config.errors import InputError
    from ftc_mj.outputs import live

    viewer = next((o for o, on in (("--spawn", args.spawn), ("--connect", args.connect), ("--serve", args.serve))
                   if on), None)
    if viewer and args.no_record:
        raise InputError("command line", viewer, "sends the recording to a viewer: drop --no-record")
    if args.bind is not None and not args.serve:
        raise InputError("command line", "--bind", "is the address --serve listens on: give --serve too")
    if args.connect:
        live.check_viewer(args.connect)
    if args.serve:
        args.address = _bind_address(args.bind or "127.0.0.1")  # the loopback only, unless the user says
        live.check_bindable(*args.address)
    return viewer


def _declare_outputs(args: argparse.Namespace, scenario: Scenario, outputs: Outputs) -> None:
    """Every output of the run, for :meth:`Outputs.check`: the recording, --json, each variant's exported log
    and --export (its extension checked)."""
    from ftc_mj.config.errors import InputError

    outputs.add("--out", None if args.no_record else (args.out or scenario.output_path))
    outputs.add("--json", args.json)
    if args.export_log is not None:
        from ftc_mj.logs.export import FORMATS, variant_path

        if args.export_log.suffix not in FORMATS:
            raise InputError(outputs.file, "--export-log", f"{str(args.export_log)!r}: the extension must be one "
                             f"of {', '.join(FORMATS)}")
        for variant in scenario.variants:
            outputs.add("--export-log", variant_path(args.export_log, variant.name))
    if args.export is not None:
        from ftc_mj.outputs.series_export import export_path_problem

        problem = export_path_problem(args.export)
        if problem is not None:
            raise InputError(outputs.file, "--export", problem)
        outputs.add("--export", args.export)


def _prepare(args: argparse.Namespace) -> tuple[Scenario, Outputs, list[str]]:
    """The scenario loaded and every output checked against every input and each other, the viewer reached:
    all bad input is refused here, before the run. Also the table's metrics."""
    from ftc_mj.scenario.loading import load_scenario

    outputs = Outputs(str(args.scenario))
    outputs.add("--out", None if args.no_record else args.out)
    outputs.add("--json", args.json)
    outputs.check([args.scenario])  # before loading: the scenario is an input whatever it inherits
    scenario = load_scenario(args.scenario, overrides=args.overrides, duration=args.duration, variants=args.variant)
    shown = chosen_metrics(args.metrics, scenario.diagnoser is not None)
    if not args.quiet and scenario.log is None:
        _load_warnings(scenario)
    outputs.declared.clear()
    _declare_outputs(args, scenario, outputs)
    outputs.check(scenario.inputs)
    _viewer(args)
    return scenario, outputs, shown


def _simulate(args: argparse.Namespace, scenario: Scenario, shown: list[str], live_chunk) -> tuple[list, dict]:
    """The run (with progress bars unless --quiet) and its metrics; the table printed unless --quiet."""
    import numpy as np
    from rich.console import Console

    from ftc_mj.analysis.metrics import compute_metrics  # scipy's signal module: not needed for a bad input

    console = None if args.quiet else Console(stderr=True)
    results = _run_with_progress(scenario, console, live_chunk)
    metrics = {r.name: compute_metrics(r, scenario.spec.metrics, scenario.fault_onsets, scenario.joint_fault_onsets,
                                       scenario.torque_limits)
               for r in results}
    if scenario.log is not None:  # no ground truth: its metrics out, the events' in
        from ftc_mj.logs.events import log_metrics

        shown = log_metrics(scenario.log.events, results, metrics, shown)
    if args.metrics == "summary" and any(np.any(m["saturation_time"] > 0) for m in metrics.values()):
        shown.append("saturation_time")  # in the summary whenever a command was clipped
    if not args.quiet:
        Console().print(metrics_table(scenario, results, metrics, shown))
        note = undefined_note(scenario, results)
        if note is not None:
            print(note, file=sys.stderr)
    return results, metrics


def _write_outputs(args: argparse.Namespace, scenario: Scenario, outputs: Outputs, results: list,
                   metrics: dict) -> None:
    """The recording, the JSON, the series (--export), the exported logs, each whole or not at all; if one cannot be written, those
    written before go too (:func:`~ftc_mj.cli.command.exit_status`)."""
    if not args.no_record:
        from ftc_mj.outputs.recording import write_recording  # rerun is heavy to import; only when recording

        path = args.out or scenario.output_path
        with outputs.writing("--out", path):
            write_recording(path, scenario=scenario.name, model=scenario.model, results=results,
                            fault_onsets=scenario.fault_onsets, seed=scenario.spec.seed, figures=scenario.figures,
                            colours=scenario.colours,
                            replayed=scenario.log.file.name if scenario.log is not None else None)
    if args.json is not None:
        document = metrics_document(scenario, results, metrics)
        outputs.write("--json", args.json, (json.dumps(document, indent=2) + "\n").encode("utf-8"))
    if args.export is not None:
        from ftc_mj.outputs.series_export import export_bytes

        slides = [int(scenario.model.jnt_type[scenario.model.dof_jntid[d]]) == 2 for d in range(scenario.n_joints)]
        outputs.write("--export", args.export, export_bytes(args.export, results, _joint_names(scenario), slides))
    if args.export_log is not None:
        from ftc_mj.logs.export import log_bytes, variant_path
        from ftc_mj.logs.trajectory import joint_names

        joints = joint_names(scenario.model)
        for result in results:
            if result.host is None:  # a monitor shares its host's readings and commands
                target = variant_path(args.export_log, result.name)
                outputs.write("--export-log", target, log_bytes(target, result, joints))


def _joint_names(scenario: Scenario) -> list[str]:
    from ftc_mj.logs.trajectory import joint_names

    return joint_names(scenario.model)


def _serve_until_stopped(args: argparse.Namespace) -> None:
    """Keep the --serve server (it lives in this process) until Ctrl-C."""
    import time

    host, port = args.address
    print(f"serving the recording: rerun --connect rerun+http://{host}:{port}/proxy (Ctrl-C to stop)",
          file=sys.stderr, flush=True)
    try:
        while True:
            time.sleep(3600)
    except KeyboardInterrupt:  # Ctrl-C ends the serving, the run's exit status follows
        print("stopped serving", file=sys.stderr)


@exit_status()
def main(argv: Sequence[str] | None = None, prog: str = PROG) -> int:
    args = build_parser(prog).parse_args(argv)
    scenario, outputs, shown = _prepare(args)
    live, on_chunk = start_live(scenario, _viewer_sinks(args)) if (args.spawn or args.connect or args.serve) \
        else (None, None)
    if args.serve:
        host, port = args.address
        print(f"serving the run as it goes: rerun --connect rerun+http://{host}:{port}/proxy", file=sys.stderr,
              flush=True)
    results, metrics = _simulate(args, scenario, shown, on_chunk)
    _write_outputs(args, scenario, outputs, results, metrics)
    if live is not None:
        live.finish(scenario.model, results, scenario.fault_onsets, scenario.spec.seed, scenario.figures)
    saturated = saturation_warning(scenario, results, metrics)
    if saturated and not args.quiet:
        print(saturated, file=sys.stderr)
    if not args.no_record and not args.quiet:
        recording = args.out or scenario.output_path
        print(f"recording: {recording}  (open with: rerun {recording})", file=sys.stderr)
    if args.serve:
        _serve_until_stopped(args)
        live.close()
    diverged = [r for r in results if r.status != "ok" and r.host is None]  # monitors share their host's run
    for r in diverged:  # said whatever --quiet: an exit 1 explains itself
        print(f"diverged: variant {r.name!r} at t = {r.diverged_at:.6g} s", file=sys.stderr)
    return 1 if diverged else 0


def undefined_note(scenario: Scenario, results: Sequence[VariantResult]) -> str | None:
    """One line naming the metrics that are undefined (``null``, ``-``) because their window starts after the
    run's end, grouped by that window (:func:`ftc_mj.analysis.metrics.windows_after_the_end`); None if none."""
    from ftc_mj.analysis.metrics import METRICS, windows_after_the_end

    reasons: dict[str, str] = {}
    for result in results:
        reasons.update(windows_after_the_end(result, scenario.spec.metrics, scenario.fault_onsets))
    if not reasons:
        return None
    groups: dict[str, list[str]] = {}
    for metric in METRICS:
        if metric in reasons:
            groups.setdefault(reasons[metric], []).append(metric)
    parts = "; ".join(f"{', '.join(names)} ({reason})" for reason, names in groups.items())
    return f"note: the run ends at {scenario.spec.duration:g} s, before these metrics' windows start, so they " \
           f"are undefined (null, -): {parts}"


if __name__ == "__main__":
    sys.exit(main())
