"""Monitor a robot with a scenario's observer and diagnosis, sample by sample: ``ftc-mj monitor SCENARIO [options]``.

Without ``--ros`` the scenario's log is streamed through the monitor row by row, as a robot would send it,
and each alarm is printed when it is raised or cleared (the same numbers as ``ftc-mj run`` on the log: see
:mod:`ftc_mj.online`). With ``--ros`` (the extra ``ftc_mj[ros]``) a ROS 2 node monitors a
``sensor_msgs/JointState`` topic and publishes the residual, the thresholds and the alarms
(:mod:`ftc_mj.online.ros`). Exit status: 0, 2 on bad input (a scenario the monitor cannot run, or a message it
cannot take: one line on stderr, nothing published of it), 130 when interrupted.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from ftc_mj.cli.command import exit_status
from ftc_mj.cli.parser import ArgumentParser

PROG = "ftc-mj monitor"


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    parser = ArgumentParser(prog=prog, description=__doc__.split("\n\n")[1])
    parser.add_argument("scenario", type=Path, help="scenario YAML file with a diagnosis section")
    parser.add_argument("--variant", metavar="NAME", help="the variant whose observer runs (default: the first)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="overrides",
                        help="override a scenario field, e.g. log.steps.resample=0.002")
    parser.add_argument("--ros", action="store_true", help="run as a ROS 2 node (pip install ftc_mj[ros])")
    ros = parser.add_argument_group("ROS 2 node")
    ros.add_argument("--joint-states", default="/joint_states", metavar="TOPIC", help="the JointState topic read")
    ros.add_argument("--prefix", default="/ftc_mj", metavar="PREFIX",
                     help="publish PREFIX/residual and PREFIX/alarm/JOINT (default: /ftc_mj)")
    ros.add_argument("--diagnostics", default="/diagnostics", metavar="TOPIC", help="the DiagnosticArray topic")
    ros.add_argument("--clock", choices=("header", "received"),
                     help="a message's time: its header stamp or its arrival (default: the log section's, else header)")
    ros.add_argument("--lost-after", type=float, default=1.0, metavar="S",
                     help="say once when no message came for S seconds (default 1)")
    ros.add_argument("--heartbeat", type=float, default=1.0, metavar="S",
                     help="republish the alarms and diagnostics every S seconds (default 1)")
    ros.add_argument("--duration", type=float, metavar="S", help="stop after S seconds (default: until Ctrl-C)")
    ros.add_argument("--latency", action="store_true",
                     help="at the end, print the message-to-residual latency (median, 99th percentile)")
    return parser


@exit_status(interrupted="interrupted: the monitor stopped")
def main(argv: Sequence[str] | None = None, prog: str = PROG) -> int:
    args = build_parser(prog).parse_args(argv)
    from ftc_mj.config.errors import InputError
    from ftc_mj.online import InputMap, Monitor
    from ftc_mj.scenario.loading import load_scenario

    for option in ("lost_after", "heartbeat", "duration"):
        value = getattr(args, option)
        if value is not None and not value > 0:
            raise InputError("command line", f"--{option.replace('_', '-')}", f"must be positive, not {value}")
    scenario = load_scenario(args.scenario, overrides=args.overrides)
    monitor = Monitor(scenario, args.variant)
    inputs = InputMap.of(scenario)
    if args.ros:
        return _ros(args, monitor, inputs)
    if scenario.log is None:
        raise InputError(str(args.scenario), "log", "without --ros the monitor streams the scenario's log: "
                         "give a log section, or --ros")
    return _stream_log(scenario, monitor, inputs)


def _stream_log(scenario, monitor, inputs) -> int:
    """The scenario's log row by row through ``monitor``; each alarm printed as it is raised or cleared."""
    import numpy as np

    from ftc_mj.config.errors import InputError
    from ftc_mj.logs.readers import read_csv, read_joint_states
    from ftc_mj.online import SampleError

    spec, file = scenario.spec.log, scenario.log.file
    if spec.format == "csv":
        recording = read_csv(file, spec.columns, spec.delimiter)
    else:
        recording = read_joint_states(file, spec.format, spec.topic, inputs.source_joints, spec.clock)
    order, joints = inputs.source_order, inputs.robot_joints
    print(f"{scenario.name}: variant {monitor.variant}, {len(recording.times)} samples of {file}")
    state = np.zeros(len(joints), dtype=bool)
    periods, spent = 0, []
    for i in range(len(recording.times)):
        velocity = None if recording.velocity is None else inputs.to_robot("velocity", recording.velocity[i], order)
        start = time.perf_counter()
        try:
            completed = monitor.push(recording.times[i] * inputs.time_scale,
                                     inputs.to_robot("position", recording.position[i], order), velocity,
                                     inputs.to_robot("torque", recording.torque[i], order))
        except SampleError as error:
            raise InputError(str(file), f"{recording.sample} {i + recording.first} {error.field}", error.problem) from None
        spent.append(time.perf_counter() - start)
        for period in completed:
            for j in np.flatnonzero(period.alarm != state):
                what = "raised" if period.alarm[j] else "cleared"
                print(f"{period.time:9.3f} s  {joints[j]}: alarm {what} (residual {period.residual[j]:.4g}, "
                      f"threshold {period.threshold[j]:.4g})")
            state[:] = period.alarm
            periods += 1
    isolated = [joints[j] for j in np.flatnonzero(monitor.diagnoser.isolated[0])]
    print(f"{periods} periods of {monitor.dt:g} s; isolated: {', '.join(isolated) or 'none'}; per sample "
          f"{np.median(spent) * 1e6:.0f} us median, {np.percentile(spent, 99) * 1e6:.0f} us 99th percentile")
    return 0


def _ros(args, monitor, inputs) -> int:
    from ftc_mj.config.errors import InputError

    try:
        import rclpy

        from ftc_mj.online.ros import MonitorNode, Topics, spin
    except ImportError as error:
        raise InputError("command line", "--ros", f"needs ROS 2's Python client: pip install ftc_mj[ros] ({error})") \
            from None
    spec = monitor.scenario.spec.log
    clock = args.clock or (spec.clock if spec is not None else "header")
    rclpy.init(args=None)
    try:
        node = MonitorNode(monitor, inputs, Topics(args.joint_states, args.prefix, args.diagnostics), clock=clock,
                           lost_after=args.lost_after, heartbeat=args.heartbeat)
        print(f"{monitor.scenario.name}: variant {monitor.variant} on {args.joint_states}; publishing "
              f"{args.prefix.rstrip('/')}/residual, {args.prefix.rstrip('/')}/alarm/JOINT, {args.diagnostics}",
              file=sys.stderr, flush=True)
        spin(node, duration=args.duration)
        if node.error is not None:
            raise node.error
        for when, joint, raised in node.events:
            print(f"{when:9.3f} s  {joint}: alarm {'raised' if raised else 'cleared'}")
        if args.latency:
            summary = node.latency_summary()
            if summary["messages"]:
                print(f"latency, message to residual published: {summary['latency_median'] * 1e3:.3f} ms median, "
                      f"{summary['latency_p99'] * 1e3:.3f} ms 99th percentile over {summary['messages']} messages "
                      f"(callback {summary['callback_median'] * 1e3:.3f} / {summary['callback_p99'] * 1e3:.3f} ms)")
        return 0
    finally:
        rclpy.try_shutdown()
