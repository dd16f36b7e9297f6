"""``motocell ps`` and ``motocell watch``: what runs, and what it does, for a person at a terminal.

Both are plain Zenoh observers: they subscribe and query, they never command. With no
arguments they join the router that ``motocell up`` runs on this machine (tcp/127.0.0.1:7447);
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

from services.launcher.core import WELL_KNOWN_ENDPOINT
from shared.bus import catalog
from shared.bus.keys import ALIVE_ROOT, ROOT
from shared.bus.schemas import (
    ControllerStatus,
    Decoder,
    ExecutorMetrics,
    GatewayMetrics,
    InterpolatorMetrics,
    ServiceInfo,
    State,
)
from shared.bus.session import open_session
from shared.protocol.constants import NotReadySubcode
from shared.service import stop_on_signals

QUERY_TIMEOUT_S = 2.0


def add_parsers(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    ps = commands.add_parser("ps", help="list every live service of every cell")
    ps.add_argument("--zenoh-connect", default=WELL_KNOWN_ENDPOINT, metavar="ENDPOINT")
    ps.set_defaults(run=run_ps)

    watch = commands.add_parser("watch", help="a live view of running cells")
    watch.add_argument("--cell", action="append", help="only this cell (repeatable)")
    watch.add_argument("--zenoh-connect", default=WELL_KNOWN_ENDPOINT, metavar="ENDPOINT")
    watch.add_argument("--interval", type=float, default=0.5, help="seconds between refreshes")
    watch.add_argument("--count", type=int, help="stop after this many refreshes")
    watch.set_defaults(run=run_watch)


def connect(endpoint: str, command: str) -> zenoh.Session | None:
    try:
        return open_session("client", [endpoint], wait=False)
    except ConnectionError as exc:
        print(f"motocell {command}: no Zenoh router at {endpoint} ({exc})", file=sys.stderr)
        return None


# -- ps ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Row:
    cell: str
    service: str
    instance: str
    info: ServiceInfo | None


def live_services(session: zenoh.Session) -> list[Row]:
    """Every liveliness token, with the service's own description where it answers."""
    tokens = set()
    for reply in session.liveliness().get(f"{ALIVE_ROOT}/**", timeout=QUERY_TIMEOUT_S):
        if reply.ok is not None:
            tokens.add(str(reply.ok.key_expr))
    decoder = Decoder(ServiceInfo)
    infos: dict[tuple[str, str, str], ServiceInfo] = {}
    for reply in session.get(f"{ROOT}/*/service/*/*", timeout=QUERY_TIMEOUT_S):
        if reply.ok is not None:
            try:
                info = decoder.decode(reply.ok.payload.to_bytes())
            except msgspec.DecodeError:
                continue
            infos[info.cell, info.service, info.instance] = info
    rows = []
    for token in sorted(tokens):
        parts = token.split("/")  # @motocell/<cell>/alive/<service>/<instance>
        if len(parts) == 5:
            cell, service, instance = parts[1], parts[3], parts[4]
            rows.append(Row(cell, service, instance, infos.get((cell, service, instance))))
    return rows


def format_uptime(seconds: float) -> str:
    minutes, secs = divmod(int(seconds), 60)
    hours, minutes = divmod(minutes, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}"


def render_ps(rows: list[Row], now_ns: int) -> str:
    header = ("CELL", "SERVICE", "GROUP", "HOST", "PID", "UPTIME", "VERSION")
    table = [header]
    for row in rows:
        group = row.instance if row.service == "interpolator" else "-"
        info = row.info
        if info is None:
            table.append((row.cell, row.service, group, "?", "?", "?", "?"))
            continue
        uptime = format_uptime((now_ns - info.started_unix_ns) / 1e9)
        table.append((row.cell, row.service, group, info.host, str(info.pid), uptime, info.version))
    widths = [max(len(line[i]) for line in table) for i in range(len(header))]
    return "\n".join(
        "  ".join(cell.ljust(width) for cell, width in zip(line, widths, strict=True)).rstrip()
        for line in table
    )


def run_ps(args: argparse.Namespace) -> int:
    session = connect(args.zenoh_connect, "ps")
    if session is None:
        return 1
    try:
        rows = live_services(session)
    finally:
        session.close()
    if not rows:
        print(f"no motocell service is running behind {args.zenoh_connect}")
        return 0
    print(render_ps(rows, time.time_ns()))
    return 0


# -- watch ------------------------------------------------------------------------------------


@dataclass
class WatchedCell:
    """The newest sample of each kind that ``watch`` shows for one cell."""

    status: ControllerStatus | None = None
    state: State | None = None
    executor: ExecutorMetrics | None = None
    gateway: GatewayMetrics | None = None
    groups: dict[int, InterpolatorMetrics] = field(default_factory=dict)
    alive: set[str] = field(default_factory=set)


class Watcher:
    """Keeps the newest sample of every key of the watched cells; Zenoh's threads only store."""

    def __init__(self, session: zenoh.Session, cells: list[str] | None) -> None:
        self.cells: dict[str, WatchedCell] = {}
        self.lock = threading.Lock()
        selectors = [f"{ROOT}/{c}/**" for c in cells] if cells else [f"{ROOT}/**"]
        alive = [f"{ALIVE_ROOT}/{c}/alive/**" for c in cells] if cells else [f"{ALIVE_ROOT}/**"]
        self.entities = [session.declare_subscriber(s, self._on_sample) for s in selectors]
        self.entities += [
            session.liveliness().declare_subscriber(s, self._on_token, history=True) for s in alive
        ]

    def _view(self, cell: str) -> WatchedCell:
        return self.cells.setdefault(cell, WatchedCell())

    def _on_sample(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        suffix = catalog.suffix_of(key)
        if suffix not in (
            "controller/status",
            "state",
            "executor/metrics",
            "gateway/metrics",
            "group/*/metrics",
        ):
            return  # ticks, queues and increments are too fast to matter to a person
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
            f"{'SCHED_FIFO' if executor.realtime else 'no RT priority'}"
        )
    gateway = view.gateway
    if gateway is not None:
        lines.append(
            f"  clients: motion {gateway.motion_clients}  state {gateway.state_clients}  "
            f"io {gateway.io_clients}   BUSY {gateway.busy_total}  INVALID "
            f"{gateway.invalid_total}  NOT_READY {gateway.not_ready_total}"
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
    session = connect(args.zenoh_connect, "watch")
    if session is None:
        return 1
    watcher = Watcher(session, args.cell)
    clear = "\x1b[H\x1b[2J" if sys.stdout.isatty() else ""
    frames = 0
    try:
        with stop_on_signals() as stop:
            while not stop.is_set():
                sys.stdout.write(clear + watcher.render() + "\n")
                sys.stdout.flush()
                frames += 1
                if args.count is not None and frames >= args.count:
                    break
                stop.wait(args.interval)
    finally:
        session.close()
    return 0
