"""The Python half of ``scripts/multihost``: what runs inside its hosts.

- ``failover`` measures a router's death on one machine: a site's two meshed routers
  (``tools.site``), a cell whose services and observer may use either, and the fault run below
  with the router the services use killed and never restarted (docs/site.md).
- ``drive`` is host C: the demo trajectory (``tools.demo.drive``, the same report as
  ``scripts/demo``, with the following error from the observer's bus) while that observer
  records ticks, states and the gateway's metrics; then the reply latency this host sees, the
  state's age here and the empty-queue periods. With ``--fault`` it runs a longer trajectory
  instead, asks the script for the fault in its middle (a file ``begin`` in ``--signals``;
  the script answers ``end`` once the link or the router is back), and reports what the cell
  told the client and whether anything moved after that; then START_TRAJ_MODE until it
  succeeds, and a new trajectory, which must arrive exact.

Host C measures ages with CLOCK_MONOTONIC against the executor's ``tick_ns``: the namespaces
share one kernel, so one clock (real hosts would need a synchronized one).
"""

from __future__ import annotations

import argparse
import contextlib
import itertools
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import zenoh

from motocell.shared.bus.access import Identity
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.credentials import load, write_private
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import ControllerStatus, Decoder, GatewayMetrics, State, Tick
from motocell.shared.bus.session import open_session
from motocell.shared.config import Cell, load_cell
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.ports import free_port, free_port_block
from motocell.shared.protocol.codec import ByteOrder
from motocell.shared.protocol.constants import Command, MsgType, Result, describe_reply
from motocell.shared.protocol.messages import Message
from motocell.testing.client import (
    BUSY_RETRY_S,
    Feedback,
    MotionClient,
    PlannedPoint,
    StateListener,
    ex_messages,
    smooth_move,
)
from motocell.testing.processes import descendants, wait_until
from motocell.testing.running_cell import HOST, LAUNCHER, wait_for_whole_cell
from motocell.tools.bench.bench_streaming import empty_periods
from motocell.tools.demo import drive, goal_within
from motocell.tools.site import SiteCell, site_router_settings

MOTOCELL = (sys.executable, "-m", "motocell.tools.cli")
"""``motocell`` run by this interpreter."""

RECORDED = 65_536
"""Samples the observer keeps per key, the newest: over four minutes of ticks at 250/s, more
than a run lasts before its deadlines end it."""
PROBES = 200
"""CHECK_MOTION_READY requests timed at the client after the demo trajectory."""
FAULT_DURATION_S = 6.0
FAULT_POINTS = 61
"""The fault run's trajectory: long enough that its increments cannot all be in the
executor's rings (200 entries, 0.8 s) when the fault comes."""
NEW_DURATION_S = 2.0
NEW_POINTS = 20
"""The trajectory after the fault: the demo's."""
FAULT_AT_S = 1.5
"""Seconds after the first point when the client asks for the fault."""
SETTLE_S = 3.0
"""How long the robot must stay still after the fault before the report: a TCP connection
whose link was cut retransmits with back-off, well after the cut ends (docs/multihost.md,
Faults)."""
RETRY_S = 0.1
"""Between START_TRAJ_MODE tries after the fault: the recovery's time is known to this."""
WHOLE_WITHIN_S = 3.0
"""``failover``'s goal: the cell whole again this soon after a router of its mesh died."""
FAULT_WAIT_S = 30.0
"""How long the client waits for the script to end the fault, and then for the cell to be
whole again."""


class Samples:
    """The newest RECORDED samples of one key, each with the time it arrived here
    (CLOCK_MONOTONIC). The subscriber's thread only stores bytes: decoding waits for the
    report."""

    def __init__(self) -> None:
        self._samples: deque[tuple[int, bytes]] = deque(maxlen=RECORDED)
        self._lock = threading.Lock()

    def store(self, sample: zenoh.Sample) -> None:
        arrived = time.monotonic_ns()
        with self._lock:
            self._samples.append((arrived, sample.payload.to_bytes()))

    def all(self) -> list[tuple[int, bytes]]:
        with self._lock:
            return list(self._samples)

    def between(self, start_ns: int, end_ns: int) -> list[tuple[int, bytes]]:
        return [(at, raw) for at, raw in self.all() if start_ns <= at <= end_ns]


class Recorder:
    """Ticks, states, gateway metrics and controller statuses from now on."""

    def __init__(self, session: zenoh.Session, keys: CellKeys) -> None:
        self.ticks, self.states, self.gateway, self.statuses = (Samples() for _ in range(4))
        self._subscribers = [
            session.declare_subscriber(key, samples.store)
            for key, samples in (
                (keys.executor_tick, self.ticks),
                (keys.state, self.states),
                (keys.metrics("gateway"), self.gateway),
                (keys.controller_status, self.statuses),
            )
        ]

    def close(self) -> None:
        for subscriber in self._subscribers:
            subscriber.undeclare()

    def ticks_between(self, start_ns: int, end_ns: int) -> list[Tick]:
        decoder = Decoder(Tick)
        return [decoder.decode(raw) for _, raw in self.ticks.between(start_ns, end_ns)]


def percentiles_ms(values_ns: Sequence[float]) -> str:
    if not values_ns:
        return "none measured"
    p50, p99, top = np.percentile(np.asarray(values_ns) / 1e6, [50, 99, 100])
    return f"p50 {p50:.2f} ms, p99 {p99:.2f} ms, max {top:.2f} ms"


def probe_replies(host: str, port_base: int, byte_order: ByteOrder, count: int) -> list[int]:
    """Request -> reply at this host, in ns, for a request the gateway answers from what its
    subscriptions last brought (no Zenoh round trip): what the network adds shows whole."""
    latencies = []
    with MotionClient(host, port_base, byte_order) as motion:
        # The first request waits for the previous client's clean-up (MotoROS closes a motion
        # connection 50 ms after its client left, motoros1 §2.1): not a reply latency.
        motion.command(Command.CHECK_MOTION_READY)
        for _ in range(count):
            sent = time.perf_counter_ns()
            motion.command(Command.CHECK_MOTION_READY)
            latencies.append(time.perf_counter_ns() - sent)
    return latencies


def gateway_reply_times(recorder: Recorder, start_ns: int, end_ns: int) -> str:
    """The gateway's own request -> reply time for trajectory points, worst second."""
    decoder = Decoder(GatewayMetrics)
    p50s, p99s = [], []
    for _, raw in recorder.gateway.between(start_ns, end_ns):
        for stats in decoder.decode(raw).requests:
            if stats.msg_type == MsgType.MOTO_JOINT_TRAJ_PT_FULL_EX and stats.reply.count:
                p50s.append(stats.reply.p50_us)
                p99s.append(stats.reply.p99_us)
    if not p50s:
        return "none reported"
    return f"p50 up to {max(p50s) / 1e3:.2f} ms, p99 up to {max(p99s) / 1e3:.2f} ms"


def state_ages(recorder: Recorder, start_ns: int, end_ns: int) -> list[int]:
    decoder = Decoder(State)
    return [
        at - decoder.decode(raw).tick_ns for at, raw in recorder.states.between(start_ns, end_ns)
    ]


def empty_queue_periods(ticks: list[Tick]) -> str:
    """Ticks inside each group's motion that did not move it (its ring was empty), summed."""
    if not ticks:
        return "no ticks seen"
    numbers = np.array([tick.tick for tick in ticks], dtype=np.int64)
    empty = lost = 0
    for group in range(len(ticks[0].groups)):
        moving = np.array([any(tick.groups[group].increment) for tick in ticks])
        if moving.any():
            group_empty, group_lost = empty_periods(numbers, moving)
            empty, lost = empty + group_empty, lost + group_lost
    return f"{empty} mid-trajectory ({lost} ticks not seen by the observer)"


def report_run(
    cell: Cell,
    host: str,
    port_base: int,
    bus: zenoh.Session,
    recorder: Recorder,
    *,
    points: int,
    duration: float,
) -> int:
    byte_order = ByteOrder(cell.byte_order)
    start = time.monotonic_ns()
    status = drive(
        cell, host, port_base, byte_order=byte_order, points=points, duration=duration, bus=bus
    )
    end = time.monotonic_ns()
    latencies = probe_replies(host, port_base, byte_order, PROBES)
    print(f"reply latency:    {percentiles_ms(latencies)} at host C ({PROBES} CHECK_MOTION_READY)")
    print(f"in the gateway:   {gateway_reply_times(recorder, start, end)} (trajectory points)")
    print(f"state age:        {percentiles_ms(state_ages(recorder, start, end))} at host C")
    print(f"empty queue:      {empty_queue_periods(recorder.ticks_between(start, end))}")
    return status


@dataclass
class Streamed:
    accepted: int = 0
    busy: int = 0
    refusal: str = ""
    refused_ns: int = 0
    first_sent_ns: int = 0


def stream_until_refused(
    motion: MotionClient, messages: Sequence[Message], deadline_s: float
) -> Streamed:
    """As ``testing.client.stream_messages`` (resend after 5 ms on BUSY, stop at any other
    refusal), but remembering when the refusal came, and giving up at ``deadline_s``."""
    result = Streamed(first_sent_ns=time.monotonic_ns())
    deadline = time.monotonic() + deadline_s
    for message in messages:
        reply = motion.motion(message)
        while reply.result == Result.BUSY and time.monotonic() < deadline:
            result.busy += 1
            time.sleep(BUSY_RETRY_S)
            reply = motion.motion(message)
        if reply.result != Result.SUCCESS:
            result.refusal = describe_reply(reply.result, reply.subcode)
            result.refused_ns = time.monotonic_ns()
            return result
        result.accepted += 1
    return result


def told_not_ready(state: StateListener, streamed: Streamed, since_ns: int) -> int | None:
    """When the client was first told the cell cannot move since ``since_ns``: a refused point,
    or a ROBOT_STATUS with motion_possible false on the state port."""
    moments = [streamed.refused_ns] if streamed.refused_ns else []
    for cycle in list(state.cycles):
        status = cycle.status
        if cycle.received_ns >= since_ns and status is not None and status.motion_possible == 0:
            moments.append(cycle.received_ns)
            break
    return min(moments) if moments else None


class FaultRequest:
    """Asks the script for the fault (the file ``begin``) and notes when it answers that the
    fault is over (``end``)."""

    def __init__(self, signals: Path) -> None:
        self.signals = signals
        self.began_ns = 0
        self.ended_ns = 0

    def run(self) -> None:
        self.began_ns = time.monotonic_ns()
        (self.signals / "begin").touch()
        if _appears(self.signals / "end"):
            self.ended_ns = time.monotonic_ns()


def _appears(path: Path) -> bool:
    """Whether ``path`` exists within FAULT_WAIT_S (the script and this process signal each
    other with files)."""
    deadline = time.monotonic() + FAULT_WAIT_S
    while not path.exists():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.005)
    return True


def fault_run(cell: Cell, host: str, port_base: int, recorder: Recorder, signals: Path) -> bool:
    """A trajectory with the fault in its middle; True when the client was told NOT_READY,
    nothing moved after that, and START_TRAJ_MODE succeeded again once the fault was over."""
    byte_order = ByteOrder(cell.byte_order)
    with (
        StateListener(host, port_base + 1, byte_order).start() as state,
        MotionClient(host, port_base, byte_order) as motion,
    ):
        reply = motion.command(Command.START_TRAJ_MODE)
        print(f"fault run:        START_TRAJ_MODE -> {describe_reply(reply.result, reply.subcode)}")
        here = state.wait_for(lambda f: f.status is not None, 10.0)
        messages = ex_messages(_trajectories(cell, here, FAULT_DURATION_S, FAULT_POINTS))
        fault = FaultRequest(signals)
        timer = threading.Timer(FAULT_AT_S, fault.run)
        timer.start()
        try:
            streamed = stream_until_refused(motion, messages, FAULT_WAIT_S)
        finally:
            timer.join()
        wait_until(lambda: fault.ended_ns > 0, 0.1, "the script to end the fault")
        wait_until(lambda: _whole(recorder, fault.ended_ns), FAULT_WAIT_S, "the cell whole again")
        # What was queued before the fault may still move, late: the report must see it all.
        wait_until(lambda: _still_for(state, SETTLE_S), FAULT_WAIT_S, "the robot to stay still")
        told = told_not_ready(state, streamed, fault.began_ns)
        safe = _report_fault(recorder, streamed, fault, told)
        recovered = _recovered(motion, fault.ended_ns) and _arrives_exact(cell, motion, state)
    return safe and recovered


def _trajectories(
    cell: Cell, here: Feedback, duration: float, points: int
) -> dict[int, list[PlannedPoint]]:
    """The demo's trajectories (``tools.demo``) from ``here``."""
    trajectories = {}
    for group in cell.groups:
        start = here.groups[group.index].positions[: group.axes]
        goal = goal_within(start, group.joint_limits)
        trajectories[group.index] = smooth_move(start, goal, duration, points)
    return trajectories


def _arrives_exact(cell: Cell, motion: MotionClient, state: StateListener) -> bool:
    """A new trajectory: True once the feedback is at its goal to the pulse. (Not
    ``tools.demo.drive``: it measures the first state within its goal tolerance, while the
    simulated servo may still be closing the last pulses.)"""
    here = state.latest()
    assert here is not None
    trajectories = _trajectories(cell, here, NEW_DURATION_S, NEW_POINTS)
    streamed = stream_until_refused(motion, ex_messages(trajectories), FAULT_WAIT_S)
    maps = {group.index: AxisMap(group) for group in cell.groups}
    # The goal as the cell gets it: Simple Message carries float32 (motoros1 §1.2), which can
    # round a position to the neighbouring pulse.
    goals = {
        g: maps[g].ros_to_pulses(np.array(plan[-1].positions, dtype=np.float32).astype(float))
        for g, plan in trajectories.items()
    }

    def error(feedback: Feedback) -> int:
        worst = 0
        for g, m in maps.items():
            here = m.ros_to_pulses(np.array(feedback.groups[g].positions[: m.axes]))
            worst = max(worst, int(np.abs(here - goals[g]).max()))
        return worst

    with contextlib.suppress(TimeoutError):
        state.wait_for(lambda feedback: error(feedback) == 0, NEW_DURATION_S + SETTLE_S)
    latest = state.latest()
    assert latest is not None
    off = error(latest)
    axes = sum(group.axes for group in cell.groups)
    refused = f", refused {streamed.refusal}" if streamed.refusal else ""
    print(
        f"new trajectory:   {streamed.accepted} of {NEW_POINTS} points{refused}; "
        f"{off} pulse(s) from the goal (max over {axes} axes)"
    )
    return not streamed.refusal and off == 0


def _still_for(state: StateListener, seconds: float) -> bool:
    cycles = list(state.cycles)
    moved = [c.received_ns for c in cycles if c.status is not None and c.status.in_motion != 0]
    since = moved[-1] if moved else (cycles[0].received_ns if cycles else time.monotonic_ns())
    return time.monotonic_ns() - since >= seconds * 1e9


def _recovered(motion: MotionClient, ended_ns: int) -> bool:
    """START_TRAJ_MODE until it succeeds, as an operator would after a fault."""
    replies = []
    deadline = time.monotonic() + FAULT_WAIT_S
    while time.monotonic() < deadline:
        reply = motion.command(Command.START_TRAJ_MODE)
        replies.append(describe_reply(reply.result, reply.subcode))
        if reply.result == Result.SUCCESS:
            break
        time.sleep(RETRY_S)
    print(
        f"recovery:         START_TRAJ_MODE -> {', '.join(replies)}; "
        f"{(time.monotonic_ns() - ended_ns) / 1e9:.1f} s after the fault was over"
    )
    return replies[-1:] == ["SUCCESS"]


def _whole(recorder: Recorder, since_ns: int) -> bool:
    statuses = recorder.statuses.between(since_ns + 1, time.monotonic_ns())
    if not statuses:
        return False
    status = Decoder(ControllerStatus).decode(statuses[-1][1])
    return not status.missing_services


def _report_fault(
    recorder: Recorder, streamed: Streamed, fault: FaultRequest, told: int | None
) -> bool:
    ticks = recorder.ticks_between(streamed.first_sent_ns, time.monotonic_ns())
    moving = [t.deadline_ns for t in ticks if any(any(g.increment) for g in t.groups)]
    after = _ms_after(fault.began_ns)
    began_s = (fault.began_ns - streamed.first_sent_ns) / 1e9
    print(
        f"fault:            {began_s:.2f} s after the first point (of {FAULT_DURATION_S:.0f} s), "
        f"over {after(fault.ended_ns)} later"
    )
    print(f"points accepted:  {streamed.accepted} of {FAULT_POINTS}, {streamed.busy} BUSY")
    refused = f"{streamed.refusal}, {after(streamed.refused_ns)}" if streamed.refusal else "no"
    print(f"refused:          {refused}")
    print(f"NOT_READY told:   {'never' if told is None else after(told)}")
    if len(moving) > 1:  # an observer that joined late may have seen a single moving tick
        pause = max(itertools.pairwise(moving), key=lambda pair: pair[1] - pair[0])
        print(f"longest pause:    from {after(pause[0])} to {after(pause[1])}")
    if moving:
        late = moving[-1] - (moving[0] + round(FAULT_DURATION_S * 1e9))
        print(f"motion ended:     {after(moving[-1])}, {late / 1e6:+.0f} ms against the plan")
    numbers = [tick.tick for tick in ticks]
    unseen = sum(b - a - 1 for a, b in itertools.pairwise(numbers))
    late_moves = [at for at in moving if told is not None and at > told]
    print(f"moved after told: {len(late_moves)} ticks ({unseen} ticks not seen by the observer)")
    if told is None and not streamed.refusal and streamed.accepted == FAULT_POINTS:
        # A router of a mesh died and the services were back before anything in flight was
        # lost: the executor stops on any gap (docs/motion-safety.md), so none was.
        print("interrupted:      no (every point taken, no gap in the increments)")
        return True
    return told is not None and not late_moves


def _ms_after(origin_ns: int) -> Callable[[int], str]:
    return lambda at_ns: f"{(at_ns - origin_ns) / 1e6:+.0f} ms"


def run_failover(args: argparse.Namespace) -> int:
    """``failover``: ``--runs`` fault runs, each on a fresh site; 0 when every one was safe
    and recovered with no service restarted."""
    cell = load_cell(args.config)
    results = []
    for run in range(1, args.runs + 1):
        print(f"--- run {run} of {args.runs}", flush=True)
        with tempfile.TemporaryDirectory(prefix="motocell-failover-") as directory:
            results.append(_failover_run(cell, args.config, Path(directory)))
    print(f"failover: {sum(results)} of {len(results)} runs safe and recovered")
    return 0 if all(results) else 1


def _failover_run(cell: Cell, config: str, directory: Path) -> bool:
    credentials = directory / "credentials"
    made = subprocess.run(
        [*MOTOCELL, "credentials", str(credentials), "--config", config, "--tls"],
        capture_output=True,
        check=False,
    )
    if made.returncode != 0:
        raise OSError(made.stderr.decode().strip())
    endpoints = [f"tls/{HOST}:{free_port(HOST)}" for _ in range(2)]
    site = [SiteCell(cell.name, len(cell.groups))]
    with contextlib.ExitStack() as stack:
        routers = []
        for index, endpoint in enumerate(endpoints):
            # The second router connects to the first, which the services use until it dies.
            settings = site_router_settings(credentials, site, [endpoint], endpoints[:index])
            config_file = directory / f"router-{index}.json5"
            write_private(config_file, json.dumps(settings))
            routers.append(
                stack.enter_context(_process([*MOTOCELL, "router", "--config", str(config_file)]))
            )
        port_base = free_port_block(3, HOST)
        joined = [option for endpoint in endpoints for option in ("--zenoh-connect", endpoint)]
        launcher = stack.enter_context(
            _process(
                [
                    *LAUNCHER,
                    "--config",
                    config,
                    "--port-base",
                    str(port_base),
                    *joined,
                    "--credentials",
                    str(credentials),
                ]
            )
        )
        wait_for_whole_cell(HOST, port_base, ByteOrder(cell.byte_order), FAULT_WAIT_S)
        services = descendants(launcher.pid)
        observer = load(credentials, cell.name, Identity(Role.OBSERVER))
        session = open_session("client", endpoints[::-1], credentials=observer)
        stack.callback(session.close)
        recorder = Recorder(session, CellKeys(cell.name))
        stack.callback(recorder.close)
        signals = directory / "signals"
        signals.mkdir()
        killed: list[int] = []
        agent = threading.Thread(target=_kill_on_request, args=(routers[0], signals, killed))
        agent.start()
        try:
            safe = fault_run(cell, HOST, port_base, recorder, signals)
        finally:
            agent.join()
        restarted = services - descendants(launcher.pid)
        whole_s = _whole_again_s(recorder, killed[0]) if killed else None
        said = "never" if whole_s is None else f"{whole_s:.2f} s after the router's death"
        print(f"whole again:      {said} (the controller's status: no service missing)")
        print(f"services restarted: {len(restarted)}")
        return safe and not restarted and whole_s is not None and whole_s <= WHOLE_WITHIN_S


def _kill_on_request(router: subprocess.Popen[bytes], signals: Path, killed: list[int]) -> None:
    """The fault: the first router killed (SIGKILL, when) when the client asks, and nothing
    to wait for after: the other router already serves."""
    if not _appears(signals / "begin"):
        return
    router.kill()
    killed.append(time.monotonic_ns())
    (signals / "end").touch()


def _whole_again_s(recorder: Recorder, killed_ns: int) -> float | None:
    """Seconds from ``killed_ns`` to the first controller status, after the last one that
    missed a service, that misses none (as the observer received it); None if none did."""
    decoder = Decoder(ControllerStatus)
    statuses = [
        (at, decoder.decode(raw)) for at, raw in recorder.statuses.between(killed_ns, 2**63)
    ]
    missing = [index for index, (_, status) in enumerate(statuses) if status.missing_services]
    if missing:
        first, last = statuses[missing[0]], statuses[missing[-1]]
        print(
            f"services missing: {len(missing)} statuses, from {(first[0] - killed_ns) / 1e6:+.0f}"
            f" to {(last[0] - killed_ns) / 1e6:+.0f} ms ({', '.join(first[1].missing_services)})"
        )
    after = statuses[missing[-1] + 1 :] if missing else statuses
    return (after[0][0] - killed_ns) / 1e9 if after else None


@contextlib.contextmanager
def _process(command: list[str]) -> Iterator[subprocess.Popen[bytes]]:
    """``command`` running, quiet, and stopped (SIGTERM, then SIGKILL) at the end."""
    env = {**os.environ, "MOTOCELL_LOG": "WARNING"}
    process = subprocess.Popen(command, env=env)
    try:
        yield process
    finally:
        process.terminate()
        try:
            process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def run_drive(args: argparse.Namespace) -> int:
    """``drive``, with what stopped it (the bus, a port, a deadline) said in one line."""
    try:
        return _drive(args)
    except (TimeoutError, OSError) as exc:
        print(f"multihost: {exc}", flush=True)
        return 1


def _drive(args: argparse.Namespace) -> int:
    cell = load_cell(args.config)
    endpoint = f"tls/{args.host}:{args.router_port}"
    observer = load(Path(args.credentials), cell.name, Identity(Role.OBSERVER))
    session = open_session("client", [endpoint], credentials=observer)
    recorder = Recorder(session, CellKeys(cell.name))
    try:
        if args.fault:
            return 0 if fault_run(cell, args.host, args.port_base, recorder, args.signals) else 1
        return report_run(
            cell,
            args.host,
            args.port_base,
            session,
            recorder,
            points=args.points,
            duration=args.duration,
        )
    finally:
        recorder.close()
        session.close()


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m motocell.tools.multihost")
    commands = parser.add_subparsers(dest="command", required=True)
    client = commands.add_parser("drive", help="host C: the demo trajectory, measured")
    client.add_argument("--config", required=True)
    client.add_argument("--host", required=True, help="host A's address")
    client.add_argument("--port-base", type=int, required=True)
    client.add_argument("--router-port", type=int, required=True)
    client.add_argument("--credentials", required=True, metavar="DIR")
    client.add_argument("--points", type=int, default=20)
    client.add_argument("--duration", type=float, default=2.0)
    client.add_argument("--fault", action="store_true", help="a fault run first")
    client.add_argument(
        "--signals", type=Path, metavar="DIR", help="with --fault: begin and end files"
    )
    failover = commands.add_parser("failover", help="a router of a mesh killed, measured")
    failover.add_argument("--config", default="single-arm", help="the cell file")
    failover.add_argument("--runs", type=int, default=3)
    args = parser.parse_args(argv)
    if args.command == "failover":
        return run_failover(args)
    return run_drive(args)


if __name__ == "__main__":
    sys.exit(main())
