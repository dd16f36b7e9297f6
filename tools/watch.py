"""``motocell watch``: a live view of the cells, for a person at a terminal.

What moves is shown from the keys that carry it live: the controller status (on change, and
at its heartbeat: 10 Hz while motion is possible, 1 Hz while nothing can move), the
broadcaster's ``state`` (positions, velocities: every tick while moving, once a second at rest),
each group's ``queue`` from the executor (every tick while moving, at its heartbeat at rest),
the client counts from the ``connections`` notices (on every change). The 1 Hz metrics (sent
while someone subscribes, as ``watch`` does) only give what they measure over their last second
(lateness, frame ages) and the totals since start. A value that missed several of the
heartbeats its stream announces shows its age (``stale_after_s``), each cell how long ago
anything was heard from it, and the services whose liveliness tokens went away are marked.

A first frame (and the only one, with ``--count 1``) waits, within ``FIRST_FRAME_WAIT_S``,
until it has heard what every service it found alive publishes. With no router to reach
yet, ``watch`` waits for one and says so once.
"""

from __future__ import annotations

import argparse
import contextlib
import datetime
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import Generic, TypeVar

import msgspec
import zenoh

from motocell.shared.bus import catalog
from motocell.shared.bus.access import Identity
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.expiry import warnings
from motocell.shared.bus.keys import ALIVE_ROOT, ROOT, service_of_alive
from motocell.shared.bus.liveness import (
    QUERY_TIMEOUT_S,
    STALE_HEARTBEATS,
    heartbeat_ms,
    silence_bound_s,
)
from motocell.shared.bus.schemas import (
    BroadcasterMetrics,
    CommandRequest,
    ControllerStatus,
    ExecutorMetrics,
    GatewayMetrics,
    LateTicks,
    MotionHolder,
    QueueState,
    State,
)
from motocell.shared.bus.session import Liveness
from motocell.shared.protocol.constants import Result, describe_reply
from motocell.shared.service import StopFlag, stop_on_signals
from motocell.tools import cells
from motocell.tools.bell import Bell
from motocell.tools.cells import CellsError, JoinError, NoRouterError, Target
from motocell.tools.realtime import NOT_REALTIME

OBSERVER = Identity(Role.OBSERVER)
STALE_S = 1.0
"""A live value younger than this is never shown with its age, whatever its heartbeat."""
AT_REST_HEARTBEAT_MS = heartbeat_ms(motion_possible=False)
"""The heartbeat of a stream while nothing can move: the state's while the executor's clock
rests (it follows the ticks), and the longest any stream announces."""
FIRST_FRAME_WAIT_S = 3.0
"""How long the first frame waits for what the services found alive publish (the metrics
come once a second, the controller status and the state at least once a second)."""
RETRY_S = 0.5
"""How often a router not reachable yet is tried again."""
PORTS = ("motion", "state", "io")
"""The order of the counts in a ``controller/cmd/connections`` notice."""
HOLDER_WORDS = {
    MotionHolder.NOBODY: "free",
    MotionHolder.MOTION_PORT: "held by the motion port's client",
    MotionHolder.ROS2_FACE: "held by the ROS 2 face",
}
SUBSCRIBED = (
    "controller/status",
    "state",
    "group/*/queue",
    "controller/cmd/connections",
    "executor/metrics",
    "executor/late",
    "gateway/metrics",
    "broadcaster/metrics",
)
"""The keys ``watch`` shows: not the ticks, increments and points, too fast to matter to a
person."""

T_co = TypeVar("T_co", covariant=True)


@dataclass(frozen=True)
class Seen(Generic[T_co]):
    """A value and when it arrived (CLOCK_MONOTONIC seconds)."""

    value: T_co
    at: float


@dataclass
class CellView:
    """The newest sample of each shown kind for one cell, and its services' liveliness."""

    status: Seen[ControllerStatus] | None = None
    state: Seen[State] | None = None
    queues: dict[int, Seen[QueueState]] = field(default_factory=dict)
    clients: dict[str, Seen[int]] = field(default_factory=dict)
    """Per port (``PORTS``), from the notices of the service that serves it."""
    holder: Seen[MotionHolder] | None = None
    """Which face holds trajectory mode, from the gateway's notices."""
    executor: Seen[ExecutorMetrics] | None = None
    late: Seen[LateTicks] | None = None
    """The executor's newest word on periods its clock missed."""
    gateway: Seen[GatewayMetrics] | None = None
    broadcaster: Seen[BroadcasterMetrics] | None = None
    heard: float | None = None
    """When anything last arrived from the cell."""
    alive: set[str] = field(default_factory=set)
    """``service/instance`` of every liveliness token present."""
    gone: set[str] = field(default_factory=set)
    """Services seen alive whose token went away since."""

    def awaited(self) -> list[str]:
        """What a complete first frame still lacks from the services alive."""
        publishes: dict[str, list[tuple[str, object]]] = {
            "controller/0": [("controller/status", self.status)],
            "broadcaster/0": [
                ("state", self.state),
                ("broadcaster/metrics", self.broadcaster),
                ("state clients", self.clients.get("state")),
            ],
            "executor/0": [("executor/metrics", self.executor)],
            "gateway/0": [
                ("gateway/metrics", self.gateway),
                ("motion clients", self.clients.get("motion")),
            ],
        }
        lacking = [
            what
            for service, kinds in publishes.items()
            if service in self.alive
            for what, value in kinds
            if value is None
        ]
        if "executor/0" in self.alive:
            groups = self.groups()
            lacking += [f"group/{g}/queue" for g in groups if g not in self.queues]
            if not groups:
                lacking.append("group/*/queue")
        return lacking

    def state_heartbeat_ms(self) -> int:
        """How often the state comes at least: it follows the executor's ticks, so as often as
        its queue states (``QueueState.heartbeat_ms``: short while the clock runs, long while it
        rests); at rest's pace while no queue state says."""
        return max(
            (seen.value.heartbeat_ms for seen in self.queues.values()),
            default=AT_REST_HEARTBEAT_MS,
        )

    def groups(self) -> list[int]:
        """The cell's groups as far as known: in its state, queues and interpolators."""
        found = set(self.queues)
        if self.state is not None:
            found |= {group.group_no for group in self.state.value.groups}
        found |= {
            int(instance)
            for kind, _, instance in (name.partition("/") for name in self.alive)
            if kind == "interpolator" and instance.isdigit()
        }
        return sorted(found)


class Watcher:
    """The views of the watched cells. Zenoh's threads decode and store, under ``lock``."""

    def __init__(self) -> None:
        self.cells: dict[str, CellView] = {}
        self.lock = threading.Lock()
        self._liveness: dict[Target, list[Liveness]] = {}
        self._ever: set[str] = set()
        """Every token key seen present."""
        self._news = Bell()
        self._waiting = False
        """Someone waits in ``wait_until_complete``: each sample and token change rings."""

    def view(self, cell: str) -> CellView:
        """``cell``'s view, made empty if new (call with ``lock`` held)."""
        return self.cells.setdefault(cell, CellView())

    def follow(self, session: zenoh.Session, target: Target) -> None:
        """Subscribe to ``target``'s cells and ask which of their services are alive: every
        cell found is known once this returns."""
        with self.lock:
            for cell in target.cells:
                self.view(cell)
        for name in target.names:
            for suffix in SUBSCRIBED:
                session.declare_subscriber(f"{ROOT}/{name}/{suffix}", self._on_sample)
        # Not a liveliness subscriber with history: a query right after one found nothing 29
        # times in 30 (zenoh-python 1.x, a client of a router).
        watched = [
            Liveness(session, f"{ALIVE_ROOT}/{name}/alive/*/*", self._tokens_changed)
            for name in target.names
        ]
        with self.lock:
            self._liveness[target] = watched
        for answered in [liveness.ask() for liveness in watched]:
            answered.wait(QUERY_TIMEOUT_S)
        self._tokens_changed()

    def unfollow(self, target: Target) -> None:
        """``target``'s bus is left (its cells stopped: their launcher left the registry): none
        of their services counts as alive any more."""
        with self.lock:
            self._liveness.pop(target, None)
        self._tokens_changed()

    def _on_sample(self, sample: zenoh.Sample) -> None:
        self.received(str(sample.key_expr), sample.payload.to_bytes(), time.monotonic())

    def _tokens_changed(self) -> None:
        with self.lock:
            watched = [liveness for each in self._liveness.values() for liveness in each]
            self.tokens(frozenset().union(*(liveness.present() for liveness in watched)))
        if self._waiting:
            self._news.ring()

    def received(self, key: str, payload: bytes, now: float) -> None:
        """A sample on ``key`` arrived at ``now`` (CLOCK_MONOTONIC seconds)."""
        try:
            decoded = catalog.decode(key, payload)
        except msgspec.DecodeError:
            return
        with self.lock:
            view = self.view(catalog.cell_of(key))
            view.heard = now
            _store(view, key, decoded, now)
        if self._waiting:
            self._news.ring()

    def tokens(self, present: frozenset[str]) -> None:
        """The liveliness tokens (``@motocell/<cell>/alive/<service>/<instance>``) present now
        on every bus followed (call with ``lock`` held)."""
        self._ever |= present
        for name in {*self.cells, *(catalog.cell_of(key) for key in present)}:
            view = self.view(name)
            view.alive = {service_of_alive(k) for k in present if catalog.cell_of(k) == name}
            ever = {service_of_alive(k) for k in self._ever if catalog.cell_of(k) == name}
            view.gone = ever - view.alive

    def awaited(self) -> dict[str, list[str]]:
        """Per cell, what a complete first frame still lacks (cells lacking nothing left out)."""
        with self.lock:
            lacking = {name: view.awaited() for name, view in self.cells.items()}
        return {name: what for name, what in lacking.items() if what}

    def wait_until_complete(self, stop: StopFlag, timeout: float) -> None:
        """Until every cell found has sent what its live services publish, ``stop``, or
        ``timeout`` seconds; asleep between the samples that could complete it."""
        deadline = time.monotonic() + timeout
        # Set before the first look: whatever arrives after it rings.
        self._waiting = True
        try:
            while self.awaited() and not stop.is_set():
                left = deadline - time.monotonic()
                if left <= 0:
                    return
                self._news.wait(stop, left)
        finally:
            self._waiting = False


def _store(view: CellView, key: str, payload: object, now: float) -> None:
    """Keep ``payload``, which arrived on ``key`` at ``now``, in ``view``."""
    if isinstance(payload, ControllerStatus):
        view.status = Seen(payload, now)
    elif isinstance(payload, State):
        view.state = Seen(payload, now)
    elif isinstance(payload, QueueState):
        view.queues[int(key.split("/")[3])] = Seen(payload, now)
    elif isinstance(payload, CommandRequest):
        # The gateway counts motion and I/O, the broadcaster state; -1 for a port not theirs.
        # The gateway's also say which face holds trajectory mode.
        for port, count in zip(PORTS, payload.args, strict=False):
            if count >= 0:
                view.clients[port] = Seen(count, now)
        holder = payload.args[len(PORTS) : len(PORTS) + 1]
        if holder and holder[0] in HOLDER_WORDS:
            view.holder = Seen(MotionHolder(holder[0]), now)
    elif isinstance(payload, ExecutorMetrics):
        view.executor = Seen(payload, now)
    elif isinstance(payload, LateTicks):
        view.late = Seen(payload, now)
    elif isinstance(payload, GatewayMetrics):
        view.gateway = Seen(payload, now)
    elif isinstance(payload, BroadcasterMetrics):
        view.broadcaster = Seen(payload, now)


# -- rendering ------------------------------------------------------------------------------


def render(watcher: Watcher, waiting: list[str], now: float) -> str:
    """One frame: every cell's view at ``now`` (CLOCK_MONOTONIC), and what is waited for."""
    with watcher.lock:
        lines = [f"motocell watch  {time.strftime('%H:%M:%S')}  {len(watcher.cells)} cell(s)"]
        lines += [f"  {line}" for line in waiting]
        for name in sorted(watcher.cells):
            lines += render_cell(name, watcher.cells[name], now)
    return "\n".join(lines)


def render_cell(name: str, view: CellView, now: float) -> list[str]:
    lines = ["", f"cell {name}   {_heard(view, now)}"]
    lines += _controller(view.status, now)
    lines += _executor(view, now)
    lines += _ports(view, now)
    lines.append(_services(view, now))
    for group in view.groups():
        lines += _group(view, group, now)
    return lines


def _heard(view: CellView, now: float) -> str:
    heard = "nothing heard yet" if view.heard is None else f"last heard {_age(view.heard, now)}"
    if not view.alive and (view.gone or view.heard is not None):
        return f"STOPPED: no service alive; {heard}"
    return heard


def _age(at: float, now: float) -> str:
    return f"{max(0.0, now - at):.1f} s ago"


def stale_after_s(heartbeat: int) -> float:
    """How old a value of a stream that announced ``heartbeat`` ms may be before it is shown
    with its age: ``STALE_HEARTBEATS`` heartbeats, after which the gateway too takes a stream as
    stopped (docs/liveness.md), and never less than ``STALE_S``. At rest a value is a second
    old just before the next one comes."""
    return max(STALE_S, silence_bound_s(heartbeat, STALE_HEARTBEATS))


def _is_stale(seen: Seen[object], heartbeat: int, now: float) -> bool:
    return now - seen.at > stale_after_s(heartbeat)


def _stale(seen: Seen[object] | None, heartbeat: int, now: float) -> str:
    """``   (4.2 s old)`` for a live value that stopped coming, else nothing."""
    if seen is None or not _is_stale(seen, heartbeat, now):
        return ""
    return f"   ({now - seen.at:.1f} s old)"


def _controller(seen: Seen[ControllerStatus] | None, now: float) -> list[str]:
    if seen is None:
        return ["  controller: no status yet"]
    status = seen.value
    ready = (
        "YES"
        if status.motion_ready
        else f"NO: {describe_reply(Result.NOT_READY, status.not_ready_subcode)}"
    )
    alarms = ", ".join(f"{a.code}[{a.subcode}]" for a in status.alarms) or "-"
    job = "at WAIT" if status.job_ready else ("running" if status.operating else "idle")
    return [
        f"  motion-ready {ready}   servo {'ON' if status.servo_on else 'off'}   "
        f"{'PLAY' if status.play else 'TEACH'}   remote {'yes' if status.remote else 'NO'}   "
        f"e-stop {'YES' if status.estop else 'no'}   hold {'YES' if status.hold else 'no'}"
        + _stale(seen, status.heartbeat_ms, now),
        f"  alarms {alarms}   error {status.error or '-'}   job {job}",
    ]


def _executor(view: CellView, now: float) -> list[str]:
    lines = []
    newest = max(view.queues.values(), key=lambda seen: seen.value.tick, default=None)
    metrics = view.executor
    if newest is not None or metrics is not None:
        tick = "?" if newest is None else str(newest.value.tick)
        line = f"  executor: tick {tick}"
        if newest is not None:
            line += _stale(newest, newest.value.heartbeat_ms, now)
        if metrics is not None:
            late = metrics.value.lateness
            line += (
                f"   lateness (last second) p50 {late.p50_us:.0f} us  p99 {late.p99_us:.0f} us  "
                f"max {late.max_us:.0f} us   missed {metrics.value.missed_total}   "
                f"{'SCHED_FIFO' if metrics.value.realtime else 'NO REAL-TIME PRIORITY'}"
            )
        lines.append(line)
    if metrics is not None and not metrics.value.realtime:
        lines.append(f"  !! the executor runs {NOT_REALTIME}; `motocell ps` says what allows it")
    if view.late is not None:
        lines.append(_clock_late(view.late, now))
    return lines


def _clock_late(seen: Seen[LateTicks], now: float) -> str:
    late = seen.value
    return (
        f"  clock late {now - seen.at:.0f} s ago: {late.periods} period(s) missed, "
        f"the worst tick {late.tick} {late.lateness_ns / 1e6:.1f} ms late "
        f"({late.missed_total} since start)"
    )


def _ports(view: CellView, now: float) -> list[str]:
    counts = "  ".join(
        f"{port} {view.clients[port].value if port in view.clients else '?'}" for port in PORTS
    )
    line = f"  clients: {counts}"
    if view.holder is not None:
        line += f"   trajectory mode: {HOLDER_WORDS[view.holder.value]}"
    if view.gateway is not None:
        gateway = view.gateway.value
        line += (
            f"   since start: BUSY {gateway.busy_total}  INVALID {gateway.invalid_total}  "
            f"NOT_READY {gateway.not_ready_total}"
        )
    lines = [line]
    if view.broadcaster is not None:
        broadcaster = view.broadcaster.value
        age = broadcaster.write_age
        lines.append(
            f"  state port (last second): frames out {age.p50_us:.0f} us after the tick (p50), "
            f"p99 {age.p99_us:.0f} us  max {age.max_us:.0f} us   replaced "
            f"{broadcaster.replaced_total}  closed stuck {broadcaster.stuck_closed_total}"
        )
    return lines


def _services(view: CellView, now: float) -> str:
    line = f"  services alive: {' '.join(sorted(view.alive)) or 'none'}"
    missing = set(view.gone)
    status = view.status
    if status is not None and not _is_stale(status, status.value.heartbeat_ms, now):
        missing |= set(status.value.missing_services)
    return line + (f"   MISSING: {' '.join(sorted(missing))}" if missing else "")


def _group(view: CellView, group: int, now: float) -> list[str]:
    queue = view.queues.get(group)
    depth = "?" if queue is None else f"{queue.value.depth}/{queue.value.capacity}"
    lines = [f"  group {group}  queue {depth}"]
    if queue is not None:
        lines[0] += _stale(queue, queue.value.heartbeat_ms, now)
    state = view.state
    shown = [g for g in state.value.groups if g.group_no == group] if state is not None else []
    if state is not None and shown:
        stale = _stale(state, view.state_heartbeat_ms(), now)
        lines.append(f"    position rad  {_joints(shown[0].positions)}{stale}")
        lines.append(f"    velocity rad/s{_joints(shown[0].velocities)}")
    return lines


def _joints(values: list[float]) -> str:
    return " ".join(f"{v:+8.4f}" for v in values)


# -- the buses --------------------------------------------------------------------------------


class Buses:
    """The buses of the watched cells, joined as their routers become reachable; a cell
    started here later is joined too, and one that stopped is left."""

    def __init__(self, args: argparse.Namespace, watcher: Watcher) -> None:
        """TargetError for a ``--cell`` that is not running."""
        self._args = args
        self._watcher = watcher
        self._from_registry = args.zenoh_connect is None
        self._wanted = cells.targets(args)
        self._joined: dict[Target, zenoh.Session] = {}
        self._said: set[str] = set()
        self.waiting: list[str] = []
        """What is not joined yet, one line each, for the frame."""

    def refresh(self) -> None:
        """Join what can be joined now. JoinError when a bus refuses ``watch`` before any
        was joined (wrong credentials: waiting would not help)."""
        if self._from_registry:
            # A --cell that stopped is no TargetError here: what is shown stays until it runs.
            with contextlib.suppress(CellsError):
                self._wanted = cells.targets(self._args)
        for target in [t for t in self._joined if t not in self._wanted]:
            self._joined.pop(target).close()
            self._watcher.unfollow(target)
        self.waiting = []
        for target in self._wanted:
            if target not in self._joined:
                self._join(target)
        if not self._wanted:
            self._say("waiting for a cell to start here (`motocell up`) ...")

    def _join(self, target: Target) -> None:
        try:
            session = cells.join(target, OBSERVER)
        except NoRouterError:
            where = f"waiting for a Zenoh router at {target.endpoint}"
            self._say(f"{where} ({target.describe()}) ..." if target.cells else f"{where} ...")
            return
        except JoinError as exc:
            if not self._joined:
                raise
            self.waiting.append(f"cannot join yet: {exc}")
            return
        self._joined[target] = session
        self._watcher.follow(session, target)

    def _say(self, line: str) -> None:
        """Once on stderr (a script reading the frames on stdout is not disturbed), and in
        every frame while it lasts."""
        self.waiting.append(line)
        if line not in self._said:
            self._said.add(line)
            print(f"motocell watch: {line}", file=sys.stderr, flush=True)

    @property
    def joined(self) -> bool:
        return bool(self._joined)

    @property
    def targets(self) -> list[Target]:
        """The buses wanted now, joined or not."""
        return list(self._wanted)

    def close(self) -> None:
        for session in self._joined.values():
            session.close()
        self._joined.clear()


# -- the command ------------------------------------------------------------------------------


def add_arguments(watch: argparse.ArgumentParser) -> None:
    """The options of ``motocell watch`` (``tools.cli`` names the command)."""
    cells.add_arguments(watch, several=True)
    watch.add_argument(
        "--interval", type=_interval, default=0.5, help="seconds between refreshes (>= 0.05)"
    )
    watch.add_argument(
        "--count",
        type=_count,
        help="stop after this many refreshes (--count 1: one complete snapshot)",
    )
    watch.set_defaults(run=run_watch)


MIN_INTERVAL_S = 0.05
"""Faster than a terminal is read; --interval 0 would redraw in a busy loop."""


def _interval(text: str) -> float:
    try:
        seconds = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not seconds >= MIN_INTERVAL_S:  # NaN too
        raise argparse.ArgumentTypeError(f"{text} s is too short: at least {MIN_INTERVAL_S}")
    return seconds


def _count(text: str) -> int:
    try:
        count = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if count < 1:
        raise argparse.ArgumentTypeError(f"{text}: at least 1 refresh (1: one snapshot)")
    return count


def run_watch(args: argparse.Namespace) -> int:
    watcher = Watcher()
    try:
        buses = Buses(args, watcher)
    except CellsError as exc:
        return cells.failed("watch", exc)
    # Read once: a certificate does not end between two frames of one watch.
    now = datetime.datetime.now(datetime.UTC)
    ending = warnings([t.credentials for t in buses.targets if t.credentials], now)
    for line in ending:
        print(f"motocell watch: {line}", file=sys.stderr, flush=True)
    try:
        with stop_on_signals() as stop:
            show(watcher, buses, stop, args.interval, args.count, warned=ending)
    except CellsError as exc:
        return cells.failed("watch", exc)
    finally:
        buses.close()
    return 0


def show(
    watcher: Watcher,
    buses: Buses,
    stop: StopFlag,
    interval: float,
    count: int | None,
    *,
    warned: list[str],
) -> None:
    """Render every ``interval`` s until ``count`` frames or ``stop``; nothing before a bus is
    joined, and the first frame once it is complete (or ``FIRST_FRAME_WAIT_S`` passed).
    ``warned``: lines every frame shows (certificates that end soon)."""
    clear = "\x1b[H\x1b[2J" if sys.stdout.isatty() else ""
    frames = 0
    while not stop.is_set():
        buses.refresh()
        if not buses.joined:
            stop.wait(RETRY_S)
            continue
        if frames == 0:
            watcher.wait_until_complete(stop, FIRST_FRAME_WAIT_S)
        sys.stdout.write(
            clear + render(watcher, [*warned, *buses.waiting], time.monotonic()) + "\n"
        )
        sys.stdout.flush()
        frames += 1
        if count is not None and frames >= count:
            return
        stop.wait(interval)
