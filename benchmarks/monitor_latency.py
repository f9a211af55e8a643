"""The ROS 2 monitor node's latency: from a JointState message's arrival to its residual published, for a
6-joint arm at 500 Hz (the goal: under 1 ms), with the publisher in another process as a robot's driver is.

    PYTHONPATH=. python benchmarks/monitor_latency.py                     # the DO, 500 Hz, 10 s
    PYTHONPATH=. python benchmarks/monitor_latency.py --variant tosmo --rate 1000 --seconds 5

The real UR10's free-motion log (scenarios/real/ur10e_free_motion.yaml, its grid set to the rate) is published
row after row at the rate, each message stamped on the grid (the rows replayed faster than they were logged:
the numbers are not the point, their cost is). The node runs in this process on one executor thread; the
publisher is a child process. Printed: the latency (the middleware's receive stamp to the residual's
``publish`` returning) and the callback's own time, median and 99th percentile, over the messages after the
first second (start-up). Needs the extra ``ftc_mj[ros]``.
"""

from __future__ import annotations

import argparse
import os
import random
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios/real/ur10e_free_motion.yaml"

PUBLISHER = textwrap.dedent("""
    import sys, time
    import numpy as np
    import rclpy
    from sensor_msgs.msg import JointState
    topic, rate, seconds, names = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), sys.argv[4].split(",")
    rows = np.loadtxt(sys.argv[5], delimiter=",")
    rclpy.init()
    node = rclpy.create_node("latency_publisher")
    publisher = node.create_publisher(JointState, topic, 1000)
    while publisher.get_subscription_count() < 1:
        time.sleep(0.01)
    time.sleep(0.5)
    period, start = 1.0 / rate, time.monotonic()
    for i in range(int(seconds * rate)):
        row = rows[i % len(rows)]
        message = JointState()
        stamp = 1000.0 + i * period
        message.header.stamp.sec, message.header.stamp.nanosec = int(stamp), int(round((stamp % 1) * 1e9))
        message.name = names
        message.position, message.velocity, message.effort = row[1:7].tolist(), row[7:13].tolist(), row[13:19].tolist()
        delay = start + i * period - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        publisher.publish(message)
    time.sleep(0.5)
    rclpy.shutdown()
""")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--variant", default="do")
    parser.add_argument("--rate", type=float, default=500.0, help="messages per second")
    parser.add_argument("--seconds", type=float, default=10.0)
    args = parser.parse_args()
    import rclpy

    from ftc_mj.online import InputMap, Monitor
    from ftc_mj.online.ros import MonitorNode, Topics, spin
    from ftc_mj.scenario.loading import load_scenario

    os.environ["ROS_DOMAIN_ID"] = str(random.randrange(1, 100))
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    scenario = load_scenario(SCENARIO, overrides=[f"log.steps.resample={1.0 / args.rate!r}"], variants=[args.variant])
    monitor, inputs = Monitor(scenario, args.variant), InputMap.of(scenario)
    rclpy.init()
    node = MonitorNode(monitor, inputs, Topics("/latency/joint_states", "/latency/ftc_mj", "/latency/diagnostics"))
    child = subprocess.Popen([sys.executable, "-c", PUBLISHER, "/latency/joint_states", str(args.rate),
                              str(args.seconds), ",".join(inputs.source_joints), str(scenario.log.file)])
    start = time.monotonic()
    while child.poll() is None and node.error is None:
        spin(node, duration=0.5)
    spin(node, duration=0.5)
    elapsed = time.monotonic() - start
    rclpy.shutdown()
    if node.error is not None:
        sys.exit(f"error: {node.error}")
    skip = int(args.rate)  # the first second: discovery, first calls
    kept = min(node.messages, len(node.latencies))
    latency, callback = node.latencies[skip:kept], node.callback_times[skip:kept]
    published = np.isfinite(latency)
    latency, callback = latency[published] * 1e3, callback[published] * 1e3
    print(f"{scenario.name}, {args.variant}, {inputs.robot_joints.__len__()} joints, {args.rate:g} Hz: "
          f"{node.messages} of {int(args.seconds * args.rate)} messages taken (the rest lost in the queue), "
          f"{node.periods} periods in {elapsed:.1f} s; load average {os.getloadavg()[0]:.1f}; after the first second "
          f"{len(latency)} messages")
    print(f"latency, arrival to residual published: median {np.median(latency):.3f} ms, "
          f"99th percentile {np.percentile(latency, 99):.3f} ms, max {latency.max():.3f} ms")
    print(f"callback: median {np.median(callback):.3f} ms, 99th percentile {np.percentile(callback, 99):.3f} ms")
    print(f"share under 1 ms: {np.mean(latency < 1.0):.4f}")


if __name__ == "__main__":
    main()
