"""``motocell ps`` and ``motocell watch``: what runs, and what it does, for a person at a terminal.

Both are plain Zenoh observers: they subscribe and query, they never command, and they join a
secured cell as its read-only observer identity. With no arguments they cover every cell
running on this machine, each through its own router (``tools.cells`` finds them);
``--zenoh-connect`` reaches cells elsewhere.
"""

from __future__ import annotations

import argparse
import sys
import threading
import time
from dataclasses import dataclass, field

import msgspec
import zenoh

from shared.bus import catalog
from shared.bus.access import Identity
from shared.bus.catalog import Role
from shared.bus.keys import ALIVE_ROOT, ROOT
from shared.bus.schemas import (
    BroadcasterMetrics,
    ControllerStatus,
    Decoder,
    ExecutorMetrics,
    GatewayMetrics,
    InterpolatorMetrics,
    ServiceInfo,
    State,
)
from shared.protocol.constants import NotReadySubcode
from shared.service import stop_on_signals
from tools import cells
from tools.cells import CellsError, Target
from tools.realtime import NOT_REALTIME, ClockModes, fix_for

QUERY_TIMEOUT_S = 2.0
OBSERVER = Identity(Role.OBSERVER)
_info_decoder = Decoder(ServiceInfo)


def add_parsers(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    ps = commands.add_parser("ps", help="list every live service of the cells running here")
    cells.add_arguments(ps, several=True)
    ps.set_defaults(run=run_ps)

    watch = commands.add_parser("watch", help="a live view of the cells running here")
    cells.add_arguments(watch, several=True)
    watch.add_argument("--interval", type=float, default=0.5, help="seconds between refreshes")
    watch.add_argument("--count", type=int, help="stop after this many refreshes")
    watch.set_defaults(run=run_watch)


# -- ps ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Row:
    cell: str
    service: str
    instance: str
    info: ServiceInfo | None


def live_services(session: zenoh.Session, target: Target) -> list[Row]:
    """Every liveliness token of ``target``'s cells, with the service's own description where
    it answers."""
    tokens: set[str] = set()
    for name in target.names:
        alive = session.liveliness().get(f"{ALIVE_ROOT}/{name}/alive/*/*", timeout=QUERY_TIMEOUT_S)
        tokens |= {str(reply.ok.key_expr) for reply in alive if reply.ok is not None}
    # @motocell/<cell>/alive/<service>/<instance>
    found = [tuple(token.split("/")[1:]) for token in sorted(tokens) if token.count("/") == 4]
    # One exact query per service, all in flight together: a secured router passes a query to
    # a service only on that service's own key, never a wildcard one.
    asked = [
        session.get(f"{ROOT}/{cell}/service/{service}/{instance}", timeout=QUERY_TIMEOUT_S)
        for cell, _, service, instance in found
    ]
    return [
        Row(cell, service, instance, _info(replies))
        for (cell, _, service, instance), replies in zip(found, asked, strict=True)
    ]


def _info(replies: zenoh.Handler[zenoh.Reply]) -> ServiceInfo | None:
    for reply in replies:
        if reply.ok is not None:
            try:
                return _info_decoder.decode(reply.ok.payload.to_bytes())
            except msgspec.DecodeError:
                continue
    return None


def format_uptime(seconds: float) -> str:
    minutes, secs = divmod(int(seconds), 60)
    hours, minutes = divmod(minutes, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}"


def render_ps(rows: list[Row], now_ns: int, realtime: dict[str, bool]) -> str:
    """``realtime``: whether each cell's executor runs SCHED_FIFO, where known (column RT)."""
    header = ("CELL", "SERVICE", "GROUP", "HOST", "PID", "UPTIME", "VERSION", "RT")
    table = [header]
    for row in rows:
        group = row.instance if row.service == "interpolator" else "-"
        clock = _clock(row, realtime)
        info = row.info
        if info is None:
            table.append((row.cell, row.service, group, "?", "?", "?", "?", clock))
            continue
        uptime = format_uptime((now_ns - info.started_unix_ns) / 1e9)
        details = (info.host, str(info.pid), uptime, info.version, clock)
        table.append((row.cell, row.service, group, *details))
    widths = [max(len(line[i]) for line in table) for i in range(len(header))]
    return "\n".join(
        "  ".join(cell.ljust(width) for cell, width in zip(line, widths, strict=True)).rstrip()
        for line in table
    )


def _clock(row: Row, realtime: dict[str, bool]) -> str:
    if row.service != "executor":
        return "-"
    known = realtime.get(row.cell)
    return "?" if known is None else "yes" if known else "NO"


def render_clock_warnings(rows: list[Row], realtime: dict[str, bool]) -> str:
    """A line for every executor that runs without SCHED_FIFO, with what allows it."""
    return "\n".join(
        f"cell {row.cell}: the executor runs {NOT_REALTIME}; to allow it: {fix_for(row.info)}"
        for row in rows
        if row.service == "executor" and realtime.get(row.cell) is False
    )


def render_buses(found: list[Target]) -> str:
    """Where each named cell's bus is, and whether it is secured: what a tool of one's own
    needs to join it."""
    return "\n".join(
        f"cell {target.cells[0]}: Zenoh {target.endpoint}, "
        + (f"credentials {target.credentials}" if target.credentials else "open bus")
        for target in found
        if len(target.cells) == 1
    )


def run_ps(args: argparse.Namespace) -> int:
    try:
        found = cells.targets(args)
        joined = cells.join_all(found, OBSERVER)
    except CellsError as exc:
        return cells.failed("ps", exc)
    if not found:
        print(cells.NOTHING_RUNNING)
        return 0
    modes = ClockModes()
    try:
        for target, session in joined:
            modes.follow(session, target.names)
        rows = [row for target, session in joined for row in live_services(session, target)]
        realtime = modes.wait_for({row.cell for row in rows if row.service == "executor"})
    finally:
        modes.close()
        cells.close_all(joined)
    if rows:
        print(render_ps(rows, time.time_ns(), realtime))
    else:
        print(f"no motocell service is live on {', '.join(t.describe() for t in found)}")
    for section in (render_clock_warnings(rows, realtime), render_buses(found)):
        if section:
            print(f"\n{section}")
    return 0


# -- watch ------------------------------------------------------------------------------------


@dataclass
class WatchedCell:
    """The newest sample of each kind that ``watch`` shows for one cell."""

    status: ControllerStatus | None = None
    state: State | None = None
    executor: ExecutorMetrics | None = None
    gateway: GatewayMetrics | None = None
    broadcaster: BroadcasterMetrics | None = None
    groups: dict[int, InterpolatorMetrics] = field(default_factory=dict)
    alive: set[str] = field(default_factory=set)


SHOWN = (
    "controller/status",
    "state",
    "executor/metrics",
    "gateway/metrics",
    "broadcaster/metrics",
    "group/*/metrics",
)
"""The keys ``watch`` subscribes to: ticks, queues and increments are too fast to matter to a
person."""


class Watcher:
    """Keeps the newest sample of every shown key of the watched cells; Zenoh's threads only
    store."""

    def __init__(self) -> None:
        self.cells: dict[str, WatchedCell] = {}
        self.lock = threading.Lock()
        self.entities: list[zenoh.Subscriber[None]] = []

    def follow(self, session: zenoh.Session, target: Target) -> None:
        """Watch ``target``'s cells through ``session``; named cells show before any sample."""
        with self.lock:
            for cell in target.cells:
                self._view(cell)
        for name in target.names:
            self.entities += [
                session.declare_subscriber(f"{ROOT}/{name}/{suffix}", self._on_sample)
                for suffix in SHOWN
            ]
            self.entities.append(
                session.liveliness().declare_subscriber(
                    f"{ALIVE_ROOT}/{name}/alive/*/*", self._on_token, history=True
                )
            )

    def _view(self, cell: str) -> WatchedCell:
        return self.cells.setdefault(cell, WatchedCell())

    def _on_sample(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        try:
            payload = catalog.decode(key, sample.payload.to_bytes())
        except msgspec.DecodeError:
            return
        with self.lock:
            view = self._view(catalog.cell_of(key))
            if isinstance(payload, ControllerStatus):
                view.status = payload
            elif isinstance(payload, State):
                view.state = payload
            elif isinstance(payload, ExecutorMetrics):
                view.executor = payload
            elif isinstance(payload, GatewayMetrics):
                view.gateway = payload
            elif isinstance(payload, BroadcasterMetrics):
                view.broadcaster = payload
            elif isinstance(payload, InterpolatorMetrics):
                view.groups[int(key.split("/")[3])] = payload

    def _on_token(self, sample: zenoh.Sample) -> None:
        parts = str(sample.key_expr).split("/")
        if len(parts) != 5:
            return
        with self.lock:
            alive = self._view(parts[1]).alive
            name = f"{parts[3]}/{parts[4]}"
            if sample.kind == zenoh.SampleKind.PUT:
                alive.add(name)
            else:
                alive.discard(name)

    def render(self) -> str:
        with self.lock:
            lines = [f"motocell watch  {time.strftime('%H:%M:%S')}  {len(self.cells)} cell(s)"]
            for name in sorted(self.cells):
                lines += render_cell(name, self.cells[name])
        return "\n".join(lines)


def _subcode_name(subcode: int) -> str:
    try:
        return NotReadySubcode(subcode).name
    except ValueError:
        return str(subcode)


def _joints(values: list[float]) -> str:
    return " ".join(f"{v:+8.4f}" for v in values)


def render_cell(name: str, view: WatchedCell) -> list[str]:
    lines = ["", f"cell {name}"]
    status = view.status
    if status is None:
        lines.append("  controller: no status yet")
    else:
        ready = (
            "YES"
            if status.motion_ready
            else (f"NO {status.not_ready_subcode} {_subcode_name(status.not_ready_subcode)}")
        )
        alarms = ", ".join(f"{a.code}[{a.subcode}]" for a in status.alarms) or "-"
        lines.append(
            f"  motion-ready {ready}   servo {'ON' if status.servo_on else 'off'}   "
            f"{'PLAY' if status.play else 'TEACH'}   remote {'yes' if status.remote else 'NO'}   "
            f"e-stop {'YES' if status.estop else 'no'}   hold {'YES' if status.hold else 'no'}"
        )
        lines.append(
            f"  alarms {alarms}   error {status.error or '-'}   job "
            f"{'at WAIT' if status.job_ready else ('running' if status.operating else 'idle')}"
        )
    executor = view.executor
    if executor is not None:
        late = executor.lateness
        lines.append(
            f"  executor: tick {executor.tick}   lateness p50 {late.p50_us:.0f} us  p99 "
            f"{late.p99_us:.0f} us  max {late.max_us:.0f} us   missed {executor.missed_total}   "
            f"{'SCHED_FIFO' if executor.realtime else 'NO REAL-TIME PRIORITY'}"
        )
        if not executor.realtime:
            lines.append(
                f"  !! the executor runs {NOT_REALTIME}; `motocell ps` says what allows it"
            )
    gateway, broadcaster = view.gateway, view.broadcaster
    if gateway is not None:
        # The state port is the broadcaster's: its count comes from its own metrics.
        state = "?" if broadcaster is None else broadcaster.state_clients
        lines.append(
            f"  clients: motion {gateway.motion_clients}  state {state}  "
            f"io {gateway.io_clients}   BUSY {gateway.busy_total}  INVALID "
            f"{gateway.invalid_total}  NOT_READY {gateway.not_ready_total}"
        )
    if broadcaster is not None:
        age = broadcaster.write_age
        lines.append(
            f"  state port: frames out {age.p50_us:.0f} us after the tick (p50), p99 "
            f"{age.p99_us:.0f} us  max {age.max_us:.0f} us   replaced "
            f"{broadcaster.replaced_total}  closed stuck {broadcaster.stuck_closed_total}"
        )
    lines.append(f"  services alive: {' '.join(sorted(view.alive)) or 'none'}")
    if view.state is not None:
        depths = executor.queue_depths if executor is not None else []
        for group in view.state.groups:
            depth = depths[group.group_no] if group.group_no < len(depths) else "?"
            lines.append(f"  group {group.group_no}  queue {depth}")
            lines.append(f"    position rad  {_joints(group.positions)}")
            lines.append(f"    velocity rad/s{_joints(group.velocities)}")
    return lines


def run_watch(args: argparse.Namespace) -> int:
    try:
        joined = cells.join_all(cells.some_targets(args), OBSERVER)
    except CellsError as exc:
        return cells.failed("watch", exc)
    try:
        watcher = Watcher()
        for target, session in joined:
            watcher.follow(session, target)
        show(watcher, args.interval, args.count)
    finally:
        cells.close_all(joined)
    return 0


def show(watcher: Watcher, interval: float, count: int | None) -> None:
    """Render ``watcher`` every ``interval`` s until ``count`` frames, SIGINT or SIGTERM."""
    clear = "\x1b[H\x1b[2J" if sys.stdout.isatty() else ""
    frames = 0
    with stop_on_signals() as stop:
        while not stop.is_set():
            sys.stdout.write(clear + watcher.render() + "\n")
            sys.stdout.flush()
            frames += 1
            if count is not None and frames >= count:
                break
            stop.wait(interval)
