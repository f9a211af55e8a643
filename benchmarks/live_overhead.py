"""What streaming a run to a viewer costs the batched loop (``ftc-mj run --connect/--serve/--spawn``).

Runs one scenario's loop (:func:`ftc_mj.run_scenario`) alternately without and with the live stream's
per-chunk hook (:class:`ftc_mj.outputs.live.LiveRecording`, sending to an in-process gRPC server sink with no
viewer attached, so the encoding and sending are all paid here), ``--repeats`` times each, and prints the
best wall and process-CPU time of each and their ratios (streamed / plain), and the share of the loop's
wall time spent inside the hook (robust to other load on the machine, which the ratios are not). The stream's opening (blueprint,
geometry) and its end (the quantities computed after the run) are timed apart: they happen once, outside the
loop.

    PYTHONPATH=. python benchmarks/live_overhead.py [--scenario scenarios/puma_fault.yaml] [--duration 10]
"""

from __future__ import annotations

import argparse
import socket
import time

import rerun as rr

from ftc_mj import load_scenario, run_scenario
from ftc_mj.cli.run import start_live


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenario", default="scenarios/puma_fault.yaml")
    parser.add_argument("--duration", type=float, default=10.0, help="simulated seconds per run")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    scenario = load_scenario(args.scenario, duration=args.duration)
    run_scenario(scenario)  # compile and warm the caches first
    sink = rr.GrpcServerSink(port=_free_port())
    plain, streamed, edges, inside = [], [], [], []
    for _ in range(args.repeats):
        wall, cpu = time.perf_counter(), time.process_time()
        run_scenario(scenario)
        plain.append((time.perf_counter() - wall, time.process_time() - cpu))

        opened = time.perf_counter()
        live, hook = start_live(scenario, [sink])
        opened = time.perf_counter() - opened
        spent = [0.0]

        def on_chunk(*chunk, hook=hook, spent=spent) -> None:
            began = time.perf_counter()
            hook(*chunk)
            spent[0] += time.perf_counter() - began

        wall, cpu = time.perf_counter(), time.process_time()
        results = run_scenario(scenario, on_chunk=on_chunk)
        streamed.append((time.perf_counter() - wall, time.process_time() - cpu))
        inside.append(spent[0] / streamed[-1][0])
        closed = time.perf_counter()
        live.finish(scenario.model, results, scenario.fault_onsets, scenario.spec.seed, scenario.figures)
        edges.append((opened, time.perf_counter() - closed))
    best_plain = [min(p[i] for p in plain) for i in (0, 1)]
    best_streamed = [min(s[i] for s in streamed) for i in (0, 1)]
    print(f"{args.scenario}, {args.duration:g} s simulated ({len(scenario.times)} periods, "
          f"{len(scenario.variants)} variants), best of {args.repeats}")
    print(f"loop without stream: wall {best_plain[0]:.3f} s, cpu {best_plain[1]:.3f} s")
    print(f"loop with stream:    wall {best_streamed[0]:.3f} s, cpu {best_streamed[1]:.3f} s")
    print(f"ratio (streamed / plain): wall {best_streamed[0] / best_plain[0]:.3f}, "
          f"cpu {best_streamed[1] / best_plain[1]:.3f}")
    print(f"time inside the hook: {min(inside):.2%} to {max(inside):.2%} of the streamed loop's wall time "
          f"(the sending thread's share is in the cpu ratio)")
    print(f"once per run: opening the stream {min(e[0] for e in edges):.3f} s, "
          f"sending the rest after the loop {min(e[1] for e in edges):.3f} s")


if __name__ == "__main__":
    main()
