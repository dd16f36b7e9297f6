"""Figure 4: request -> reply round trip over TCP on the motion port.

    python -m bench.run --only 4 [--quick]

A 4-group cell (default 10 ms state period) with one state client connected, as a ROS driver
has. A ``MotionClient`` times send -> reply read (CLOCK_MONOTONIC) for:

- CHECK_MOTION_READY (a command answered from the gateway's copy of the controller status);
- CHECK_MOTION_READY again while all 4 groups move (sent in each BUSY back-off of a 2016
  stream), to separate the cost of a point from the cost of the load;
- trajectory points while the robot moves: a constant-velocity trajectory with points 4 ms
  apart streamed like motoman_driver (the next point at once after SUCCESS, a BUSY point
  resent after 5 ms). The point sent right after a SUCCESS is nearly always answered BUSY
  (the pending slot frees only once the interpolator has taken the previous point, about
  1 ms later), so SUCCESS and BUSY replies are reported apart. Both JOINT_TRAJ_PT_FULL (14)
  for group 0 and MOTO_JOINT_TRAJ_PT_FULL_EX (2016) for all 4 groups.

Diagnosis rows: the gateway's own reply time (request decoded -> reply written, from
``gateway/metrics``, BUSY and SUCCESS together), to split a round trip into the gateway's
handling and everything around it (wake-ups, the GIL, the loaded CPUs).

Each run: 3000 commands and 2000 accepted points of each kind (quick: 300 and 100), so the
percentiles rest on thousands of samples; the table shows median and [min-max] over the runs.
For comparison, a real FS100 answered points in 0.34 ms median, 1.13 ms worst
(``/work/shared/data``).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from bench.harness import (
    CHECK_MOTION_READY,
    Observer,
    Streamer,
    bench_cell,
    figure_result,
    percentiles,
    positions_of,
    ramp,
    ramps,
    request_rtts,
    start_traj_mode,
    workdir,
)
from shared.bus.schemas import Decoder, GatewayMetrics
from shared.protocol.constants import MsgType, Result
from testkit.client import ex_messages, point_messages

FIGURE = 4
RUNS = 3
COMMANDS = 3000
POINTS = 2000
QUICK_COMMANDS = 300
QUICK_POINTS = 100
POINT_INTERVAL_S = 0.004
SPEED = 0.1
P50_GOAL_MS = 0.35
P99_GOAL_MS = 2.0


def run(quick: bool) -> list[dict[str, Any]]:
    commands = QUICK_COMMANDS if quick else COMMANDS
    points = QUICK_POINTS if quick else POINTS
    series: dict[str, list[list[float]]] = {
        "CHECK_MOTION_READY": [],
        "point 14, SUCCESS": [],
        "point 14, BUSY": [],
        "point 2016 x4 groups, SUCCESS": [],
        "point 2016 x4 groups, BUSY": [],
        "CHECK_MOTION_READY while 4 groups move": [],
    }
    counts: dict[str, list[float]] = {name: [] for name in series}
    with (
        workdir() as directory,
        bench_cell(directory, "bench4") as cell,
        Observer(cell) as observer,
        cell.state(),
        cell.motion() as motion,
    ):
        observer.record_ticks()
        gateway_metrics = observer.record(cell.keys.metrics("gateway"))
        start_traj_mode(motion)
        for index in range(RUNS):
            direction = 1.0 if index % 2 == 0 else -1.0
            rtts = request_rtts(motion, CHECK_MOTION_READY, commands)
            series["CHECK_MOTION_READY"].append([r / 1e6 for r in rtts])
            counts["CHECK_MOTION_READY"].append(float(len(rtts)))
            duration = (points - 1) * POINT_INTERVAL_S
            for kind in ("14", "2016 x4 groups"):
                starts = positions_of(cell.cell, observer.wait_still())
                if kind == "14":
                    plan = ramp(starts[0], direction * SPEED, duration, POINT_INTERVAL_S)
                    messages = point_messages(0, plan)
                else:
                    plans = ramps(starts, direction * SPEED, duration, POINT_INTERVAL_S)
                    messages = ex_messages(plans)
                streamer = Streamer(motion, messages)
                streamer.run()  # in this thread
                if streamer.error is not None:
                    raise RuntimeError(f"streaming failed: {streamer.error}")
                if kind != "14":
                    # The same command, while the 4 groups move: its round trip under the
                    # point stream's load (sent at the start of each BUSY back-off).
                    starts = positions_of(cell.cell, observer.wait_still())
                    count = max(2, points // 2)
                    plans = ramps(
                        starts, -direction * SPEED, (count - 1) * POINT_INTERVAL_S, POINT_INTERVAL_S
                    )
                    prober = Streamer(motion, ex_messages(plans), probe=CHECK_MOTION_READY)
                    prober.run()
                    if prober.error is not None:
                        raise RuntimeError(f"streaming failed: {prober.error}")
                    name = "CHECK_MOTION_READY while 4 groups move"
                    series[name].append([r / 1e6 for r in prober.probes])
                    counts[name].append(float(len(prober.probes)))
                for result, label in ((Result.SUCCESS, "SUCCESS"), (Result.BUSY, "BUSY")):
                    values = [r.rtt_ns / 1e6 for r in streamer.replies if r.result == result]
                    series[f"point {kind}, {label}"].append(values)
                    counts[f"point {kind}, {label}"].append(float(len(values)))
        observer.wait_still()
        time.sleep(1.2)  # the last second's gateway/metrics
    results = []
    internal = gateway_internal(gateway_metrics)
    for name, runs in series.items():
        p50s = [percentiles(r, (50,))[0] for r in runs]
        p99s = [percentiles(r, (99,))[0] for r in runs]
        note = f"{int(np.median(counts[name]))} samples per run"
        results.append(
            figure_result(FIGURE, f"{name} p50", "ms", p50s, goal=("<=", P50_GOAL_MS), note=note)
        )
        results.append(figure_result(FIGURE, f"{name} p99", "ms", p99s, goal=("<=", P99_GOAL_MS)))
    for label, (p50s, p99s) in internal.items():
        results.append(
            figure_result(
                FIGURE,
                f"  diagnosis: gateway-internal reply time, {label}, p50",
                "ms",
                p50s,
                note="request decoded -> reply written, from gateway/metrics (per-second p50s)",
            )
        )
        results.append(
            figure_result(
                FIGURE, f"  diagnosis: gateway-internal reply time, {label}, p99", "ms", p99s
            )
        )
    return results


KINDS = {
    int(MsgType.MOTO_MOTION_CTRL): "commands",
    int(MsgType.JOINT_TRAJ_PT_FULL): "point 14",
    int(MsgType.MOTO_JOINT_TRAJ_PT_FULL_EX): "point 2016",
}


def gateway_internal(
    samples: list[tuple[int, bytes]],
) -> dict[str, tuple[list[float], list[float]]]:
    """The gateway's own measurement (request decoded -> reply written, BUSY and SUCCESS
    together), one p50 and p99 per second in which the type was busy, in ms."""
    decoder = Decoder(GatewayMetrics)
    found: dict[str, tuple[list[float], list[float]]] = {}
    for _, raw in samples:
        for stats in decoder.decode(raw).requests:
            label = KINDS.get(stats.msg_type)
            if label is None or stats.reply.count < 50:
                continue
            p50s, p99s = found.setdefault(label, ([], []))
            p50s.append(stats.reply.p50_us / 1000)
            p99s.append(stats.reply.p99_us / 1000)
    return found
