"""Figure 12: the ROS 2 face's cost, and its ``joint_states`` as a ROS 2 client gets them.

    python -m motocell.tools.bench.run --only 12 [--quick]

The four-group cell of ``bench_cell`` with a ``[ros2]`` table (a ROS domain and a namespace of
this run's, discovery on this host only, the default 10 ms ``controller_status_monitor_period``:
100 Hz), and one ROS 2 client (``tools.bench.ros2_client``): a lean rclpy subscriber in a
process of its own, subscribed to ``joint_states`` with MotoROS2's sensor_data QoS, garbage
collector off, recording each message's header stamp and CLOCK_REALTIME when its callback began
into arrays allocated up front. Windows of 20 s (quick: 3 s), 3 per case, the subscriber
connected 3 s (quick 2 s) before the first:

- idle: one cell with the face, 3 windows;
- moving: the four groups swinging as figure 10's moving case (``tools.bench.swinging``: 2016
  points streamed like motoman_driver, every axis 0.2 rad either side of its start), the
  cell's default 10 ms state period and no state client (a ROS 2 user reads the face), in cells
  started for each window, alternating: without the face, with it (A B A B A B). The stream's
  record shows the robot took points in every window; a window whose stream the cell refused
  (an alarm: on a loaded machine, a stall) is measured again in a new cell, at most twice, and
  counted with the cell's alarms.

Rows, medians of the windows:

(a) the face's whole cost: every thread of the ``ros2`` process (rclpy, FastDDS, Zenoh), in %
    of one core from ``/proc/<pid>/task/<tid>/schedstat`` as figure 10 measures; goal <= 5 %
    moving. As a diagnosis, the same per period (five messages: ``joint_states`` and each
    group's), its wake-ups and PSS;
(b) the ``joint_states`` rate at the subscriber: (messages - 1) / (last - first) within the
    window; goal within 1 % of 100 Hz, idle (the newest state held) and moving;
(c) age = the callback's CLOCK_REALTIME - the header stamp (one machine, one clock): the whole
    path from the executor's tick to a ROS 2 client's callback. Only the messages stamped with
    a tick count: while moving, a message whose positions differ from the previous one's (the
    face follows the cell's samples and stamps each with its tick's time); a message that
    repeats them is the face holding its newest sample, stamped as it publishes, whose age is
    the transport alone (shown idle as a diagnosis). p50, p99, max; goal p99 <= 5 ms;
(d) diagnosis: the rest of the cell with the face (every process but the face) against the same
    cell without it (every process), the ratio of each pair of alternating windows: what the
    face's subscription to ``state`` costs the broadcaster and the router.

The subscriber is not the cell's: its own CPU is shown as a diagnosis.
"""

from __future__ import annotations

import os
import random
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from motocell.shared.ros2.extra import missing_ros2
from motocell.testing.running_cell import RunningCell
from motocell.tools.bench.bench_cost import (
    deviation_percent,
    main_thread_ns,
    rate_hz,
    took_points,
)
from motocell.tools.bench.clients import RETRIES, ChildProcess, StreamRefusedError, load
from motocell.tools.bench.measuring import (
    GROUP_MODELS,
    PROCESS_KINDS,
    Window,
    bench_cell,
    cost_by_kind,
    cost_window,
    figure_result,
    percentiles,
    process_kinds,
    refusal_text,
    total,
    without_timestamp,
    workdir,
)
from motocell.tools.bench.swinging import SwingingCell

FIGURE = 12
WINDOWS = 3
WINDOW_S = 20.0
QUICK_WINDOW_S = 3.0
SETTLE_S = 3.0
QUICK_SETTLE_S = 2.0
PERIOD_MS = 10
"""MotoROS2's default ``controller_status_monitor_period``."""
TOPICS = 1 + len(GROUP_MODELS)
"""What the face publishes each period: ``joint_states`` and each group's."""
FACE = "ros2"
"""The face's process, as ``process_kinds`` names it (its module)."""
CLIENT = "ROS 2 subscriber"
FACE_GOAL_PERCENT = 5.0
RATE_GOAL_PERCENT = 1.0
AGE_P99_GOAL_MS = 5.0
IDLE = "idle, 1 subscriber"
MOVING = "4 groups moving, 1 subscriber"


def ros2_table(domain: int, namespace: str) -> str:
    return f'[ros2]\nros_domain_id = {domain}\nnode_namespace = "{namespace}"\n'


class Ros2ClientProcess:
    """``python -m motocell.tools.bench.ros2_client``: records ``joint_states`` for ``seconds``;
    started once the face publishes (it says ``ready`` at its first message)."""

    def __init__(self, domain: int, namespace: str, out: Path, seconds: float) -> None:
        self.out = out
        arguments = [
            *("--domain", str(domain), "--namespace", namespace),
            *("--period-ms", str(PERIOD_MS), "--seconds", f"{seconds:g}", "--out", str(out)),
        ]
        self.child = ChildProcess("motocell.tools.bench.ros2_client", arguments)

    @property
    def pid(self) -> int:
        return self.child.process.pid

    def stop(self, timeout: float = 30.0) -> dict[str, np.ndarray]:
        """The columns of ``tools.bench.ros2_client``, and ``dropped``."""
        self.child.close(timeout)
        return load(self.out)

    def kill(self) -> None:
        self.child.kill()


# -- analysis (pure) ---------------------------------------------------------------------------
@dataclass(frozen=True)
class Received:
    """What the subscriber got within one window."""

    rate_hz: float
    deviation_percent: float
    fresh_percent: float
    """Of the messages, those stamped with a tick (their positions new)."""
    age_ms: tuple[float, float, float]
    """p50, p99, max over the fresh messages (nan without any)."""
    held_age_ms: tuple[float, float]
    """p50, p99 over the messages that repeat the previous positions (stamped at publication)."""


def received_within(record: dict[str, np.ndarray], start_ns: int, end_ns: int) -> Received:
    """``record``: the subscriber's columns; ``start_ns``, ``end_ns``: a window on
    CLOCK_MONOTONIC."""
    mono = record["received_mono_ns"]
    inside = (mono >= start_ns) & (mono <= end_ns)
    age = (record["received_ns"][inside] - record["stamp_ns"][inside]) / 1e6
    fresh = record["fresh"][inside].astype(bool)
    rate = rate_hz(mono, start_ns, end_ns)
    p50, p99, pmax = percentiles(age[fresh], (50, 99, 100))
    h50, h99 = percentiles(age[~fresh], (50, 99))
    return Received(
        rate,
        deviation_percent(rate, PERIOD_MS * 1_000_000),
        100.0 * float(fresh.mean()) if fresh.size else 0.0,
        (p50, p99, pmax),
        (h50, h99),
    )


def pair_ratios(with_face: Sequence[Window], without: Sequence[Window]) -> list[float]:
    """Per pair of alternating windows: the cell's CPU but the face's with it, over the cell's
    CPU without it."""
    ratios = []
    for on, off in zip(with_face, without, strict=True):
        rest = total("rest", [r for r in on.rows if r.kind != FACE]).cpu_percent
        ratios.append(rest / off.cpu if off.cpu > 0 else float("nan"))
    return ratios


# -- measuring ---------------------------------------------------------------------------------
@dataclass
class Measured:
    idle: list[Window] = field(default_factory=list)
    """The cell's processes and the subscriber (kind ``CLIENT``)."""
    idle_received: list[Received] = field(default_factory=list)
    moving: list[Window] = field(default_factory=list)
    moving_received: list[Received] = field(default_factory=list)
    without: list[Window] = field(default_factory=list)
    refusals: list[str] = field(default_factory=list)
    """Moving windows measured again: which cell, and why."""
    loop_share: dict[str, list[float]] = field(default_factory=dict)
    """Per case, per window: the face's main thread's CPU time over the window's length."""
    dropped: int = 0


def cell_only(window: Window) -> Window:
    return Window([r for r in window.rows if r.kind != CLIENT], window.start_ns, window.end_ns)


def face_window(kinds: dict[int, str], seconds: float, shares: list[float]) -> Window:
    """``cost_window``, and the share of it the face's main thread ran (its loop: the state
    sample in, the messages built and published) appended to ``shares``."""
    face = next(pid for pid, kind in kinds.items() if kind == FACE)
    before = main_thread_ns(face)
    window = cost_window(kinds, seconds)
    shares.append((main_thread_ns(face) - before) / (window.end_ns - window.start_ns))
    return window


def log_lines(path: Path) -> list[str]:
    try:
        return path.read_text(errors="replace").splitlines()
    except OSError:
        return []


def with_face_kinds(cell: RunningCell) -> dict[int, str]:
    kinds = process_kinds(cell)
    if FACE not in kinds.values():
        raise RuntimeError(f"the cell has no {FACE} process: {sorted(kinds.values())}")
    return kinds


class Run:
    """One run of the figure: its ROS domain, a namespace per cell, its directory."""

    def __init__(self, directory: Path, seconds: float, settle: float) -> None:
        self.directory = directory
        self.seconds = seconds
        self.settle = settle
        self.domain = random.randrange(1, 101)
        """A domain of this run's; the namespaces keep names apart if another run shares it."""
        self.found = Measured()

    def namespace(self, name: str) -> str:
        return f"/bench{os.getpid()}_{name}"

    def client(self, name: str, seconds: float) -> Ros2ClientProcess:
        out = self.directory / f"{name}-joint-states.npz"
        return Ros2ClientProcess(self.domain, self.namespace(name), out, seconds)

    def idle(self, count: int) -> None:
        name = "ros2_idle"
        table = ros2_table(self.domain, self.namespace(name))
        length = count * self.seconds + 2 * self.settle + 30.0
        with bench_cell(self.directory, name, tables=table) as cell:
            client = self.client(name, length)
            try:
                kinds = {**with_face_kinds(cell), client.pid: CLIENT}
                time.sleep(self.settle)
                shares = self.found.loop_share.setdefault(IDLE, [])
                windows = [face_window(kinds, self.seconds, shares) for _ in range(count)]
                record = client.stop()
            except BaseException:
                client.kill()
                raise
        self.found.idle = windows
        self.found.idle_received = [received_within(record, w.start_ns, w.end_ns) for w in windows]
        self.found.dropped += int(record["dropped"])

    def moving_again(self, index: int, face: bool) -> None:
        """``moving_window``; a window whose stream the cell refused (an alarm: on a loaded
        machine a stall of the executor or of the controller's status) is measured again in a
        new cell, at most ``RETRIES`` times, and the refusal noted."""
        for attempt in range(RETRIES + 1):
            name = f"ros2_{'on' if face else 'off'}{index}" + (f"_{attempt}" if attempt else "")
            try:
                self.moving_window(name, face)
                return
            except StreamRefusedError as refused:
                if attempt == RETRIES:
                    raise
                log = self.directory / f"{name}.log"
                alarms = [without_timestamp(line) for line in log_lines(log) if "alarm" in line]
                self.found.refusals.append(f"{name}: {refusal_text(refused, alarms)}")

    def moving_window(self, name: str, face: bool) -> None:
        table = ros2_table(self.domain, self.namespace(name)) if face else ""
        length = self.seconds + 2 * self.settle + 60.0
        cell = SwingingCell(
            self.directory, name, length, state_clients=0, observe=False, tables=table
        )
        client: Ros2ClientProcess | None = None
        record: dict[str, np.ndarray] = {}
        try:
            kinds = process_kinds(cell.cell)
            if face:
                client = self.client(name, length)
                kinds = {**with_face_kinds(cell.cell), client.pid: CLIENT}
            time.sleep(self.settle)
            if face:
                shares = self.found.loop_share.setdefault(MOVING, [])
                window = face_window(kinds, self.seconds, shares)
            else:
                window = cost_window(kinds, self.seconds)
            if client is not None:
                record = client.stop()
        except BaseException:
            if client is not None:
                client.kill()
            raise
        finally:
            stream = cell.close()
        if stream is None:
            raise RuntimeError(f"the moving cell {name}'s stream left no record")
        stream.check()
        if not took_points(stream, [window])[0]:
            raise RuntimeError(f"the moving cell {name} stopped taking points")
        if face:
            self.found.moving.append(window)
            self.found.moving_received.append(
                received_within(record, window.start_ns, window.end_ns)
            )
            self.found.dropped += int(record["dropped"])
        else:
            self.found.without.append(window)


def measure(quick: bool) -> Measured:
    seconds = QUICK_WINDOW_S if quick else WINDOW_S
    settle = QUICK_SETTLE_S if quick else SETTLE_S
    with workdir() as directory:
        run = Run(directory, seconds, settle)
        run.idle(WINDOWS)
        for index in range(WINDOWS):
            run.moving_again(index, face=False)
            run.moving_again(index, face=True)
    return run.found


# -- results -----------------------------------------------------------------------------------
def face_results(
    case: str, windows: Sequence[Window], loop_share: Sequence[float], goal: float | None, note: str
) -> list[dict[str, Any]]:
    faces = [total(FACE, [r for r in w.rows if r.kind == FACE]) for w in windows]
    clients = [total(CLIENT, [r for r in w.rows if r.kind == CLIENT]) for w in windows]
    return [
        figure_result(
            FIGURE,
            f"[{case}] the face's CPU (ros2, all its threads)",
            "% of 1 core",
            [f.cpu_percent for f in faces],
            goal=None if goal is None else ("<=", goal),
            note=note,
        ),
        figure_result(
            FIGURE,
            f"[{case}]   its CPU per period ({TOPICS} messages)",
            "us",
            [f.cpu_percent / 100 * PERIOD_MS * 1000 for f in faces],
        ),
        figure_result(
            FIGURE,
            f"[{case}]     its main thread's (the loop, rclpy's publish)",
            "us",
            [share * PERIOD_MS * 1000 for share in loop_share],
        ),
        figure_result(FIGURE, f"[{case}]   its wake-ups", "1/s", [f.wakeups_per_s for f in faces]),
        figure_result(FIGURE, f"[{case}]   its PSS", "MiB", [f.pss_mib for f in faces]),
        figure_result(
            FIGURE,
            f"[{case}]   diagnosis: the subscriber's own CPU",
            "% of 1 core",
            [c.cpu_percent for c in clients],
        ),
    ]


def received_results(case: str, received: Sequence[Received]) -> list[dict[str, Any]]:
    return [
        figure_result(
            FIGURE,
            f"[{case}] joint_states rate at the subscriber",
            "Hz",
            [r.rate_hz for r in received],
        ),
        figure_result(
            FIGURE,
            f"[{case}]   its deviation from {1000 // PERIOD_MS} Hz",
            "%",
            [r.deviation_percent for r in received],
            goal=("<=", RATE_GOAL_PERCENT),
        ),
    ]


def age_results(received: Sequence[Received]) -> list[dict[str, Any]]:
    tag = f"[{MOVING}]"
    names = ("p50", "p99", "max")
    results = [
        figure_result(
            FIGURE,
            f"{tag} age tick -> callback {name} (tick-stamped messages)",
            "ms",
            [r.age_ms[i] for r in received],
            goal=("<=", AGE_P99_GOAL_MS) if name == "p99" else None,
        )
        for i, name in enumerate(names)
    ]
    results.append(
        figure_result(
            FIGURE,
            f"{tag}   messages stamped with a tick",
            "%",
            [r.fresh_percent for r in received],
        )
    )
    return results


def rest_results(with_face: Sequence[Window], without: Sequence[Window]) -> list[dict[str, Any]]:
    """(d): the cell without the face against the rest of it with the face (``with_face``: the
    cell's processes only)."""
    tag = f"[{MOVING}]   diagnosis:"
    rest = [Window([r for r in w.rows if r.kind != FACE], w.start_ns, w.end_ns) for w in with_face]
    results = [
        figure_result(
            FIGURE, f"{tag} the cell without the face, all", "% of 1 core", [w.cpu for w in without]
        ),
        figure_result(
            FIGURE,
            f"{tag} the cell with it, all but the face",
            "% of 1 core",
            [w.cpu for w in rest],
        ),
        figure_result(
            FIGURE,
            f"{tag} with / without, pairs of alternating cells",
            "x",
            pair_ratios(with_face, without),
        ),
    ]
    off, on = [cost_by_kind(w.rows) for w in without], [cost_by_kind(w.rows) for w in rest]
    for kind in PROCESS_KINDS:
        if all(kind in k for k in off + on):
            results.append(
                figure_result(
                    FIGURE,
                    f"{tag}   {kind}, with / without",
                    "x",
                    [
                        b[kind].cpu_percent / a[kind].cpu_percent
                        if a[kind].cpu_percent > 0
                        else float("nan")
                        for a, b in zip(off, on, strict=True)
                    ],
                )
            )
    return results


def run(quick: bool) -> list[dict[str, Any]]:
    missing = missing_ros2()
    if missing is not None:  # an extra not installed: not a failure of the suite
        return [figure_result(FIGURE, f"not measured: {missing}", "", [])]
    found = measure(quick)
    seconds = QUICK_WINDOW_S if quick else WINDOW_S
    results = face_results(
        IDLE, found.idle, found.loop_share[IDLE], None, f"{WINDOWS} windows of {seconds:g} s"
    )
    results += received_results(IDLE, found.idle_received)
    results.append(
        figure_result(
            FIGURE,
            f"[{IDLE}]   diagnosis: age publication -> callback p50 (held messages)",
            "ms",
            [r.held_age_ms[0] for r in found.idle_received],
        )
    )
    results += face_results(
        MOVING,
        found.moving,
        found.loop_share[MOVING],
        FACE_GOAL_PERCENT,
        "alternating cells without and with the face",
    )
    results += received_results(MOVING, found.moving_received)
    results += age_results(found.moving_received)
    results += rest_results([cell_only(w) for w in found.moving], found.without)
    results.append(
        figure_result(
            FIGURE,
            "  diagnosis: records dropped (past the subscriber's bound)",
            "",
            [found.dropped],
        )
    )
    results.append(
        figure_result(
            FIGURE,
            "  diagnosis: moving windows measured again (a stream refused)",
            "",
            [len(found.refusals)],
            note=" | ".join(found.refusals),
        )
    )
    return results
