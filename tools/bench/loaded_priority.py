"""Does a cell need a priority above ordinary processes to keep moving on a loaded machine?
(the decision and the measured runs are in docs/realtime.md)

    python -m motocell.tools.bench.loaded_priority [--runs 3] [--trajectories 8] [--hogs N]
        [--hog-session same|own] [--variants today,nice,rr] [--out FILE]

Not part of ``motocell bench``: a run takes about a minute per variant and repetition, and it
needs root (or CAP_SYS_NICE) to set the variants' priorities.

Each run starts a fresh four-group cell (``bench_cell``) with one state client at the default
state period, sets the scheduling of every thread of the cell's processes to the variant's
(below), starts ``--hogs`` busy-loop processes at ordinary priority (nice 0; default twice the
CPUs), and streams ``--trajectories`` rest-to-rest moves back to back, every axis of every group
0.2 rad there and back in turn, points 0.1 s apart, as motoman_driver streams them (a BUSY point
resent after 5 ms). The variants are run in turn within each repetition (A/B interleaved: the
machine's other load changes slowly), the order rotating from one repetition to the next.

A variant sets every thread of the processes it names (``Variant.kinds``; Zenoh's threads included)
to one policy, and every other thread of the cell to ordinary scheduling, nice 0; the
executor's clock (SCHED_FIFO 50) is never touched. ``shipped`` touches nothing: the cell runs
with the priorities the services give themselves.

Per run it reports: trajectories aborted (a point refused, NOT_READY or INVALID, or the robot
coming to rest off the last point), the stall alarms the controller raised (4200), the episodes
its status said NOT_READY 5012 (a service missing, a broken increment path), the executor's
missed periods and lateness (p99, max), the motion port's reply times (p50, p99 of every reply,
BUSY included), and the share of the machine the hogs got.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from motocell.shared.bus.schemas import ControllerStatus, Decoder
from motocell.testing.client import ex_messages, smooth_move
from motocell.testing.running_cell import RunningCell
from motocell.tools.bench.clients import StateClientProcess, StreamClientProcess, stream_bound_s
from motocell.tools.bench.measuring import (
    PROCESS_KINDS,
    Observer,
    bench_cell,
    cpu_seconds,
    gc_paused,
    percentiles,
    positions_of,
    process_kinds,
    workdir,
)

CLOCK_PRIORITY = 50
"""The executor's clock thread (``shared.realtime.RT_PRIORITY``): never changed here."""
MOVE_RAD = 0.2
MOVE_S = 4.0
POINT_INTERVAL_S = 0.1
GOAL_TOLERANCE_RAD = 1e-4
STILL_TIMEOUT_S = 60.0
ARRIVAL_S = 5.0
RECOVER_TIMEOUT_S = 60.0
HOG_SETTLE_S = 2.0
OBSERVER_PRIORITY = 20
"""The SCHED_RR priority of this process's threads but the main one (which starts the cell, the
clients and the hogs, at ordinary priority): above the cell's threads, below its clock, so that
the controller's status is stamped when it arrives, not when Zenoh's threads here next get a CPU
among the hogs. Not SCHED_RESET_ON_FORK on the main thread: the kernel resets every thread
started after it too, Zenoh's included."""
STALL_ALARM = 4200
INCMOVE_ERROR = 5012
"""NOT_READY 5012: a service missing, or the increment path broken (a starved ring)."""
STALL_KINDS = frozenset({"controller", "interpolator", "gateway"})
"""The services the stall rules depend on: the controller's status, the increments, the
gateway's view of both."""
ALL_KINDS = frozenset(PROCESS_KINDS)


@dataclass(frozen=True)
class Variant:
    name: str
    policy: str
    """``other`` (with ``value`` the nice value), ``rr`` (``value`` the priority), ``none``
    (touch nothing)."""
    value: int = 0
    kinds: frozenset[str] = ALL_KINDS
    """The processes (``measuring.process_kinds``) set to it; the others get ordinary scheduling."""
    python_only: bool = False
    """Only the threads Python runs (named ``python``), not Zenoh's (``rx-0``, ``tx-0``, ...)."""


VARIANTS = {
    v.name: v
    for v in (
        Variant("today", "other", 0),
        Variant("nice", "other", -10),
        Variant("rr", "rr", 10),
        Variant("rr-stall", "rr", 10, STALL_KINDS),
        Variant("rr-python", "rr", 10, python_only=True),
        Variant("shipped", "none"),
    )
}


def parse_variants(text: str) -> list[Variant]:
    names = [name.strip() for name in text.split(",") if name.strip()]
    unknown = [name for name in names if name not in VARIANTS]
    if unknown or not names:
        raise argparse.ArgumentTypeError(
            f"unknown variant {', '.join(unknown) or '(none)'}; choose from {', '.join(VARIANTS)}"
        )
    return [VARIANTS[name] for name in names]


def rotated(variants: Sequence[Variant], repetition: int) -> list[Variant]:
    """The order of a repetition: each variant takes each place in turn."""
    shift = repetition % len(variants)
    return [*variants[shift:], *variants[:shift]]


# -- scheduling --------------------------------------------------------------------------------
def threads(pid: int) -> list[int]:
    with contextlib.suppress(OSError):
        return [int(tid) for tid in os.listdir(f"/proc/{pid}/task")]
    return []


def thread_name(pid: int, tid: int) -> str:
    with contextlib.suppress(OSError):
        return Path(f"/proc/{pid}/task/{tid}/comm").read_text().strip()
    return ""


def is_clock(tid: int) -> bool:
    with contextlib.suppress(OSError):
        if os.sched_getscheduler(tid) == os.SCHED_FIFO:
            return os.sched_getparam(tid).sched_priority >= CLOCK_PRIORITY
    return False


def set_thread(tid: int, policy: str, value: int) -> None:
    """One thread (Linux: scheduling and nice are per thread) to ``policy``; a thread gone
    meanwhile is skipped."""
    with contextlib.suppress(ProcessLookupError):
        if policy == "other":
            os.sched_setscheduler(tid, os.SCHED_OTHER, os.sched_param(0))
            os.setpriority(os.PRIO_PROCESS, tid, value)
        else:
            os.setpriority(os.PRIO_PROCESS, tid, 0)
            os.sched_setscheduler(tid, os.SCHED_RR, os.sched_param(value))


def apply(variant: Variant, kinds: dict[int, str]) -> int:
    """Every thread of the cell's processes as ``variant`` says; the threads changed."""
    if variant.policy == "none":
        return 0
    changed = 0
    for pid, kind in kinds.items():
        for tid in threads(pid):
            if is_clock(tid):
                continue
            chosen = kind in variant.kinds and (
                not variant.python_only or thread_name(pid, tid) == "python"
            )
            policy, value = (variant.policy, variant.value) if chosen else ("other", 0)
            set_thread(tid, policy, value)
            changed += 1
    return changed


def scheduling(kinds: dict[int, str]) -> dict[str, list[str]]:
    """Per process kind, the distinct policies of its threads (``OTHER/-10``, ``RR/10``)."""
    names = {os.SCHED_OTHER: "OTHER", os.SCHED_FIFO: "FIFO", os.SCHED_RR: "RR"}
    seen: dict[str, set[str]] = {}
    for pid, kind in kinds.items():
        for tid in threads(pid):
            with contextlib.suppress(OSError):
                policy = os.sched_getscheduler(tid)
                if policy == os.SCHED_OTHER:
                    text = f"OTHER/{os.getpriority(os.PRIO_PROCESS, tid)}"
                else:
                    text = f"{names.get(policy, policy)}/{os.sched_getparam(tid).sched_priority}"
                seen.setdefault(kind, set()).add(text)
    return {kind: sorted(texts) for kind, texts in sorted(seen.items())}


def raise_observer() -> None:
    """OBSERVER_PRIORITY for every thread of this process but the main one; where refused, the
    observer runs at ordinary priority (its status gaps then include its own waits)."""
    main = os.getpid()
    for tid in threads(main):
        if tid != main:
            with contextlib.suppress(PermissionError):
                set_thread(tid, "rr", OBSERVER_PRIORITY)


HOG_PROGRAMS = {
    "busy": "while True: pass",
    "bursty": (
        "import random, time\n"
        "while True:\n"
        "    end = time.perf_counter() + 0.02\n"
        "    while time.perf_counter() < end: pass\n"
        "    time.sleep(random.uniform(0, 0.02))"
    ),
}
"""What a hog runs: a busy loop (a compiler, a simulation), or 20 ms bursts 0-20 ms apart (a
process that sleeps as the cell's threads do, and so wakes with the same claim on a CPU)."""


@contextlib.contextmanager
def hogs(count: int, own_session: bool, kind: str = "busy") -> Iterator[list[int]]:
    """``count`` hogs at ordinary priority; in a session of their own (another terminal:
    another autogroup) or in this one."""
    processes = [
        subprocess.Popen(
            [sys.executable, "-c", HOG_PROGRAMS[kind]],
            start_new_session=own_session,
            stdin=subprocess.DEVNULL,
        )
        for _ in range(count)
    ]
    try:
        yield [p.pid for p in processes]
    finally:
        for process in processes:
            process.kill()
        for process in processes:
            process.wait()


# -- one run -----------------------------------------------------------------------------------
@dataclass
class Trajectory:
    seconds: float
    points: int
    busy: int
    refused: str
    """The client's error (``point 7 refused: NOT_READY ...``), empty if every point was taken."""
    off_goal_rad: float
    """The largest difference between where the robot stopped and the last point."""
    reply_ms: list[float] = field(default_factory=list)

    @property
    def aborted(self) -> bool:
        return bool(self.refused) or self.off_goal_rad > GOAL_TOLERANCE_RAD


@dataclass
class Run:
    variant: str
    repetition: int
    trajectories: int
    aborted: int
    refusals: list[str]
    stall_alarms: int
    incmove_episodes: int
    missed_periods: int
    lateness_p99_us: float
    lateness_max_us: float
    reply_p50_ms: float
    reply_p99_ms: float
    status_gap_max_ms: float
    """The longest time without a controller status, as this process received them; the
    executor stops motion after 4 heartbeats (400 ms) without one."""
    hog_cpu_percent: float
    """Of the whole machine (100: every CPU)."""
    loadavg: float
    seconds: float
    scheduling: dict[str, list[str]]


def episodes(statuses: Sequence[ControllerStatus]) -> tuple[int, int]:
    """(stall alarms raised, NOT_READY 5012 episodes begun) over a run's controller statuses:
    each counted when it appears, not for every status that repeats it."""
    alarms = incmove = 0
    had_alarm = had_incmove = False
    for status in statuses:
        alarm = any(a.code == STALL_ALARM for a in status.alarms)
        broken = status.not_ready_subcode == INCMOVE_ERROR
        alarms += alarm and not had_alarm
        incmove += broken and not had_incmove
        had_alarm, had_incmove = alarm, broken
    return alarms, incmove


def _targets(cell: RunningCell, observer: Observer) -> list[dict[int, tuple[float, ...]]]:
    """The two ends of the back-and-forth: where the robot is, and MOVE_RAD further."""
    home = positions_of(cell.cell, observer.wait_still(STILL_TIMEOUT_S))
    away = {g: tuple(p + MOVE_RAD for p in ps) for g, ps in home.items()}
    return [away, home]


def _rests_off(cell: RunningCell, observer: Observer, goal: dict[int, tuple[float, ...]]) -> float:
    """How far from ``goal`` the robot comes to rest. A still tick is not the end yet: the
    ring runs dry while a late client's last points are still on their way (the robot waits,
    as MotoROS does), so it is the end once at the goal, or ARRIVAL_S after the stream."""
    deadline = time.monotonic() + ARRIVAL_S
    while True:
        stopped = positions_of(cell.cell, observer.wait_still(STILL_TIMEOUT_S))
        off = max(abs(a - b) for g in goal for a, b in zip(stopped[g], goal[g], strict=True))
        if off <= GOAL_TOLERANCE_RAD or time.monotonic() > deadline:
            return off
        time.sleep(0.1)


def _trajectory(
    cell: RunningCell,
    observer: Observer,
    streamer: StreamClientProcess,
    goal: dict[int, tuple[float, ...]],
) -> Trajectory:
    start = positions_of(cell.cell, observer.wait_still(STILL_TIMEOUT_S))
    count = round(MOVE_S / POINT_INTERVAL_S) + 1
    plans = {g: smooth_move(start[g], goal[g], MOVE_S, count) for g in start}
    began = time.monotonic()
    record = streamer.stream(ex_messages(plans), stream_bound_s(MOVE_S))
    return Trajectory(
        seconds=time.monotonic() - began,
        points=record.points,
        busy=record.busy,
        refused=record.error,
        off_goal_rad=_rests_off(cell, observer, goal),
        reply_ms=(record.rtt_ns / 1e6).tolist(),
    )


@dataclass(frozen=True)
class Load:
    """The hogs beside the cell."""

    count: int
    own_session: bool = False
    kind: str = "busy"


def measure(variant: Variant, repetition: int, trajectories: int, load: Load) -> Run:
    with contextlib.ExitStack() as stack:
        directory = stack.enter_context(workdir())
        cell = stack.enter_context(bench_cell(directory, f"prio{repetition}"))
        observer = stack.enter_context(Observer(cell))
        observer.record_ticks()
        raw_statuses = observer.record(cell.keys.controller_status)
        raise_observer()
        seconds = trajectories * (MOVE_S + 30.0) + 120.0
        state = StateClientProcess(cell, directory / "state.npz", seconds)
        stack.callback(state.kill)
        streamer = stack.enter_context(StreamClientProcess(cell, directory))
        stack.enter_context(gc_paused())
        kinds = process_kinds(cell)
        apply(variant, kinds)
        streamer.start_traj_mode()
        targets = _targets(cell, observer)
        pids = stack.enter_context(hogs(load.count, load.own_session, load.kind))
        time.sleep(HOG_SETTLE_S)
        mark = observer.mark()
        started = time.monotonic()
        started_ns = time.monotonic_ns()
        hog_before = sum(cpu_seconds(pid) or 0.0 for pid in pids)
        done: list[Trajectory] = []
        for index in range(trajectories):
            apply(variant, kinds)  # threads started since (Zenoh's pool) inherit; in case
            done.append(_trajectory(cell, observer, streamer, targets[index % 2]))
            if done[-1].aborted:
                streamer.recover(RECOVER_TIMEOUT_S)
        elapsed = time.monotonic() - started
        hog_cpu = sum(cpu_seconds(pid) or 0.0 for pid in pids) - hog_before
        loadavg = os.getloadavg()[0]
        ticks = observer.ticks_since(mark - 1)
        sched = scheduling(kinds)
    decoder = Decoder(ControllerStatus)
    alarms, incmove = episodes([decoder.decode(raw) for _, raw in raw_statuses])
    lateness = [t.lateness_ns / 1000 for t in ticks[1:]]
    arrivals = np.array([at for at, _ in raw_statuses if at >= started_ns], dtype=np.int64)
    gap_ms = float(np.diff(arrivals).max()) / 1e6 if arrivals.size > 1 else float("nan")
    replies = [ms for t in done for ms in t.reply_ms]
    late_p99, late_max = percentiles(lateness, (99, 100))
    reply_p50, reply_p99 = percentiles(replies, (50, 99))
    return Run(
        variant=variant.name,
        repetition=repetition,
        trajectories=len(done),
        aborted=sum(t.aborted for t in done),
        refusals=[t.refused or f"stopped {t.off_goal_rad:.4f} rad off" for t in done if t.aborted],
        stall_alarms=alarms,
        incmove_episodes=incmove,
        missed_periods=ticks[-1].missed - ticks[0].missed if ticks else 0,
        lateness_p99_us=late_p99,
        lateness_max_us=late_max,
        reply_p50_ms=reply_p50,
        reply_p99_ms=reply_p99,
        status_gap_max_ms=gap_ms,
        hog_cpu_percent=100.0 * hog_cpu / elapsed / (os.cpu_count() or 1),
        loadavg=loadavg,
        seconds=elapsed,
        scheduling=sched,
    )


# -- report ------------------------------------------------------------------------------------
COLUMNS = (
    ("aborted", "aborted"),
    ("stall_alarms", "4200"),
    ("incmove_episodes", "5012"),
    ("missed_periods", "missed"),
    ("lateness_p99_us", "late p99 us"),
    ("lateness_max_us", "late max us"),
    ("reply_p50_ms", "reply p50 ms"),
    ("reply_p99_ms", "reply p99 ms"),
    ("status_gap_max_ms", "status gap ms"),
    ("hog_cpu_percent", "hogs %"),
    ("loadavg", "load"),
)


def spread(values: Sequence[float]) -> str:
    """Median [min-max], or the one value."""
    if len(values) == 1:
        return f"{values[0]:.3g}"
    return f"{statistics.median(values):.3g} [{min(values):.3g}-{max(values):.3g}]"


def summary(runs: Sequence[Run], variants: Sequence[Variant]) -> list[str]:
    lines = ["| variant | runs | trajectories | " + " | ".join(h for _, h in COLUMNS) + " |"]
    lines.append("|---" * (len(COLUMNS) + 3) + "|")
    for variant in variants:
        mine = [r for r in runs if r.variant == variant.name]
        if not mine:
            continue
        cells = [spread([float(getattr(r, attr)) for r in mine]) for attr, _ in COLUMNS]
        total = sum(r.trajectories for r in mine)
        lines.append(f"| {variant.name} | {len(mine)} | {total} | " + " | ".join(cells) + " |")
    return lines


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=3, help="repetitions of every variant")
    parser.add_argument("--trajectories", type=int, default=8, help="per run")
    parser.add_argument("--hogs", type=int, default=2 * (os.cpu_count() or 1))
    parser.add_argument("--hog-session", choices=("same", "own"), default="same")
    parser.add_argument("--hog-kind", choices=tuple(HOG_PROGRAMS), default="busy")
    parser.add_argument("--variants", type=parse_variants, default=parse_variants("today,rr"))
    parser.add_argument("--out", type=Path, help="every run as JSON")
    args = parser.parse_args(argv)
    if os.geteuid() != 0:
        print("note: not root; a variant the kernel refuses fails the run", file=sys.stderr)
    runs: list[Run] = []
    for repetition in range(args.runs):
        for variant in rotated(args.variants, repetition):
            load = Load(args.hogs, args.hog_session == "own", args.hog_kind)
            run = measure(variant, repetition, args.trajectories, load)
            runs.append(run)
            cells = "  ".join(f"{h} {getattr(run, a):.4g}" for a, h in COLUMNS)
            print(f"{variant.name} #{repetition}: {cells}", flush=True)
            for refusal in run.refusals:
                print(f"    {refusal}", flush=True)
            if args.out:
                args.out.write_text(json.dumps([asdict(r) for r in runs], indent=1))
    print(
        f"\n{args.hogs} {args.hog_kind} hogs ({args.hog_session} session), {os.cpu_count()} CPUs, "
        f"{args.trajectories} trajectories of {MOVE_S:g} s per run; median [min-max]:"
    )
    print("\n".join(summary(runs, args.variants)))
    print("scheduling seen:", json.dumps({r.variant: r.scheduling for r in runs}))


if __name__ == "__main__":
    with np.errstate(all="ignore"):
        main()
