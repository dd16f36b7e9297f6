"""Figure 4: request -> reply round trip over TCP on the motion port.

    python -m motocell.tools.bench.run --only 4 [--quick]

A 4-group cell (default 10 ms state period) with one state client connected, as a ROS driver
has. The motion client runs in its own process (``bench.stream_client``, garbage collector off)
at the priority of the gateway's thread that answers it (SCHED_RR 20, ``REPLY_PRIORITY``),
standing in for a client on hardware of its own, and times send -> reply read
(CLOCK_MONOTONIC) for:

- CHECK_MOTION_READY and CHECK_QUEUE_CNT, idle (commands answered from the gateway's view of
  the controller and of the queues);
- the same two while all 4 groups move (sent in turn, one in each BUSY back-off of a 2016
  stream), to separate the cost of a point from the cost of the load;
- trajectory points while the robot moves: a constant-velocity trajectory with points 4 ms
  apart streamed like motoman_driver (the next point at once after SUCCESS, a BUSY point
  resent after 5 ms). SUCCESS and BUSY replies are reported apart. Both JOINT_TRAJ_PT_FULL
  (14) for group 0 and MOTO_JOINT_TRAJ_PT_FULL_EX (2016) for all 4 groups.

Goals, for every reply: p50 <= 0.35 ms and p99 <= 2 ms. For comparison, a real FS100 answered
points in 0.34 ms median, 1.13 ms worst (a captured session of a real FS100 running MotoROS).

Diagnosis rows: the gateway's own reply time (request decoded -> reply written, from
``gateway/metrics``, BUSY and SUCCESS together), to split a round trip into the gateway's
handling and everything around it (wake-ups, the GIL, the loaded CPUs); and 2016 points
streamed by a client at the cell's services' priority (SCHED_RR 10) and at ordinary priority,
a driver beside the cell on one machine, whose replies also wait for a CPU the cell holds.

Each run: 3000 of each command and 2000 accepted points of each kind (quick: 300 and 100), so
the percentiles rest on thousands of samples; the table shows median and [min-max] over the runs.
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from motocell.shared.bus.schemas import Decoder, GatewayMetrics
from motocell.shared.protocol.constants import MsgType, Result
from motocell.shared.protocol.messages import Message
from motocell.testing.client import ex_messages, point_messages
from motocell.testing.running_cell import RunningCell
from motocell.tools.bench.clients import (
    StateClientProcess,
    StreamClientProcess,
    measured_again,
    stream_bound_s,
)
from motocell.tools.bench.measuring import (
    CHECK_MOTION_READY,
    CHECK_QUEUE_CNT,
    LogTail,
    Observer,
    bench_cell,
    figure_result,
    gc_paused,
    percentiles,
    positions_of,
    ramp,
    ramps,
    workdir,
)

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
FS100 = "a real FS100: 0.34 ms median, 1.13 ms worst (a captured session)"
COMMAND_MESSAGES = {"CHECK_MOTION_READY": CHECK_MOTION_READY, "CHECK_QUEUE_CNT": CHECK_QUEUE_CNT}
"""Timed idle, and as the probes (in this order) of a stream while 4 groups move."""
MOVING = " while 4 groups move"
RECORDING_S = 600.0
"""Bound of the state client's record (it only loads the cell here)."""

Series = dict[str, list[np.ndarray]]


def _points(
    cell: RunningCell, observer: Observer, kind: str, count: int, direction: float
) -> list[Message]:
    starts = positions_of(cell.cell, observer.wait_still())
    duration = (count - 1) * POINT_INTERVAL_S
    if kind == "14":
        return point_messages(0, ramp(starts[0], direction * SPEED, duration, POINT_INTERVAL_S))
    return ex_messages(ramps(starts, direction * SPEED, duration, POINT_INTERVAL_S))


def _one_run(
    cell: RunningCell,
    observer: Observer,
    streamer: StreamClientProcess,
    *,
    counts: tuple[int, int],
    direction: float,
) -> Series:
    """One run's round trips, by series name."""
    series: Series = {name: [] for name in series_names()}
    commands, points = counts
    for name, message in COMMAND_MESSAGES.items():
        series[name].append(streamer.requests(message, commands)["rtt_ns"] / 1e6)
    bound = stream_bound_s(points * POINT_INTERVAL_S)
    for kind in ("14", "2016 x4 groups"):
        record = streamer.stream(_points(cell, observer, kind, points, direction), bound).check()
        for result in (Result.SUCCESS, Result.BUSY):
            series[f"point {kind}, {result.name}"].append(record.rtts_ms(result))
    # The commands again, while the 4 groups move: their round trips under the point stream's
    # load (sent in turn at the start of each BUSY back-off).
    probing = _points(cell, observer, "2016", max(2, points // 2), -direction)
    probes = list(COMMAND_MESSAGES.values())
    record = streamer.stream(probing, bound, probes=probes).check()
    for index, name in enumerate(COMMAND_MESSAGES):
        series[name + MOVING].append(record.probes_ms(index))
    return series


def run(quick: bool) -> list[dict[str, Any]]:
    counts = (QUICK_COMMANDS, QUICK_POINTS) if quick else (COMMANDS, POINTS)
    series, gateway_metrics = measure(counts, [""] * RUNS, diagnosis_runs=RUNS)
    results = _results(series[""]) + _internal_results(gateway_internal(gateway_metrics))
    for label in DIAGNOSIS_CLIENTS:
        results += _diagnosis_results(series[label], label)
    return results


DIAGNOSIS_CLIENTS = {
    "client at the services' priority": "services",
    "client at ordinary priority": "ordinary",
}
"""The labels of the diagnosis runs, by the priority their motion client runs at
(``recording.CLIENT_PRIORITIES``); the figure's own client runs at the gateway's reply
priority, as a client on hardware of its own waits for nothing in the cell."""
WAITS = {
    "services": "its wait for a CPU behind the cell's threads, at its priority",
    "ordinary": "a driver on the cell's machine: its wait for a CPU the cell's threads hold",
}


def _diagnosis_results(series: Series, label: str) -> list[dict[str, Any]]:
    """A client below the gateway's reply priority waits for a CPU while the cell's threads
    handle the point it just sent (``bench.recording.take_client_priority``)."""
    name = "point 2016 x4 groups, SUCCESS"
    runs = series[name]
    return [
        figure_result(
            FIGURE,
            f"  diagnosis: {name}, {label}, p{q}",
            "ms",
            [percentiles(r, (q,))[0] for r in runs],
            note=WAITS[DIAGNOSIS_CLIENTS[label]] if q == 50 else "",
        )
        for q in (50, 99)
    ]


def series_names() -> list[str]:
    names = [*COMMAND_MESSAGES, *(n + MOVING for n in COMMAND_MESSAGES)]
    for kind in ("14", "2016 x4 groups"):
        names += [f"point {kind}, SUCCESS", f"point {kind}, BUSY"]
    return names


def measure(
    counts: tuple[int, int],
    conditions: Sequence[str],
    before_run: Callable[[int], None] | None = None,
    refusals: list[tuple[int, str]] | None = None,
    diagnosis_runs: int = 0,
) -> tuple[dict[str, Series], list[tuple[int, bytes]]]:
    """One run per entry of ``conditions`` (its label), on one cell, ``before_run(index)``
    called before each (figure 11 starts or stops a neighbour cell there); the round trips per
    label, and the gateway's metrics samples. Runs go up and back in pairs, so every label
    sees both directions when it has two runs or more.

    A stream the cell refuses ends the figure, unless ``refusals`` is given: the refusal is
    noted there (the run's index, why), the cell recovered (START_TRAJ_MODE) and the run measured
    again, at most ``clients.RETRIES`` times.

    Then, for each of ``DIAGNOSIS_CLIENTS``, ``diagnosis_runs`` runs of 2016 points by a motion
    client at that priority, under its label."""
    diagnoses = DIAGNOSIS_CLIENTS if diagnosis_runs else {}
    labels = [*conditions, *diagnoses]
    series: dict[str, Series] = {c: {name: [] for name in series_names()} for c in labels}
    with contextlib.ExitStack() as stack:
        directory = stack.enter_context(workdir())
        cell = stack.enter_context(bench_cell(directory, "bench4"))
        observer = stack.enter_context(Observer(cell))
        observer.record_ticks()
        gateway_metrics = observer.record(cell.keys.metrics("gateway"))
        state = StateClientProcess(cell, directory / "state.npz", RECORDING_S)
        stack.callback(state.kill)
        streamer = StreamClientProcess(cell, directory, priority="reply")
        stack.push(streamer.__exit__)
        stack.enter_context(gc_paused())
        streamer.start_traj_mode()
        log = LogTail(directory / "bench4.log")
        for index, condition in enumerate(conditions):
            if before_run is not None:
                before_run(index)
            direction = 1.0 if direction_index(index, len(set(conditions))) % 2 == 0 else -1.0
            one_run = functools.partial(
                _one_run, cell, observer, streamer, counts=counts, direction=direction
            )
            for name, runs in measured_again(streamer, one_run, log, refusals, index).items():
                series[condition][name] += runs
        # The diagnosis runs alternate directions across clients too, so the robot comes back
        # and stays inside its joint ranges however many clients there are.
        moves = itertools.count()
        for label, priority in diagnoses.items():
            streamer.child.close()  # one motion client at a time, as MotoROS allows
            streamer = StreamClientProcess(cell, directory, priority=priority)
            stack.push(streamer.__exit__)
            streamer.start_traj_mode()
            kind, points = "2016 x4 groups", counts[1]
            for _ in range(diagnosis_runs):
                direction = 1.0 if next(moves) % 2 == 0 else -1.0
                messages = _points(cell, observer, kind, points, direction)
                record = streamer.stream(messages, stream_bound_s(points * POINT_INTERVAL_S))
                series[label][f"point {kind}, SUCCESS"].append(
                    record.check().rtts_ms(Result.SUCCESS)
                )
        observer.wait_still()
        time.sleep(1.2)  # the last second's gateway/metrics
    return series, gateway_metrics


def direction_index(index: int, labels: int) -> int:
    """Runs of ``labels`` interleaved conditions go the same way in each round: A+ B+ A- B- ...;
    one condition alternates run by run (+ - + ...)."""
    return index // max(1, labels)


def _results(series: Series) -> list[dict[str, Any]]:
    results = []
    for name, runs in series.items():
        p50s = [percentiles(r, (50,))[0] for r in runs]
        p99s = [percentiles(r, (99,))[0] for r in runs]
        note = f"{int(np.median([len(r) for r in runs]))} samples per run"
        if name.startswith("point 2016"):
            note += "; " + FS100
        results.append(
            figure_result(FIGURE, f"{name} p50", "ms", p50s, goal=("<=", P50_GOAL_MS), note=note)
        )
        results.append(figure_result(FIGURE, f"{name} p99", "ms", p99s, goal=("<=", P99_GOAL_MS)))
    return results


def _internal_results(internal: dict[str, tuple[list[float], list[float]]]) -> list[dict[str, Any]]:
    results = []
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
