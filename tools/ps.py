"""``motocell ps``: every live service of the cells, what each says about itself (host, pid,
uptime, version, the TCP ports it serves), and where each cell's bus is.

A plain Zenoh observer: it asks every service found by its liveliness token for its
``ServiceInfo`` and never commands. The ports come from the services that serve them (the
gateway: motion and I/O, the broadcaster: state), the Zenoh endpoint from how ``ps`` itself
reached the cell.
"""

from __future__ import annotations

import argparse
import datetime
import sys
import time
from dataclasses import dataclass

import msgspec
import zenoh

from motocell.shared.bus.access import Identity
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.expiry import warnings
from motocell.shared.bus.keys import ALIVE_ROOT, ROOT
from motocell.shared.bus.schemas import Decoder, ServiceInfo
from motocell.tools import cells
from motocell.tools.cells import CellsError, Target
from motocell.tools.realtime import NOT_REALTIME, ClockModes, fix_for

QUERY_TIMEOUT_S = 2.0
OBSERVER = Identity(Role.OBSERVER)
PORT_NAMES = ("motion", "state", "io")
"""A cell's TCP ports, in the order of their numbers (port base, +1, +2)."""
_info_decoder = Decoder(ServiceInfo)


@dataclass(frozen=True)
class Row:
    cell: str
    service: str
    instance: str
    info: ServiceInfo | None


def add_arguments(ps: argparse.ArgumentParser) -> None:
    """The options of ``motocell ps`` (``tools.cli`` names the command)."""
    cells.add_arguments(ps, several=True)
    ps.set_defaults(run=run_ps)


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


def render_cells(found: list[tuple[Target, list[Row]]]) -> str:
    """A line per cell: its Zenoh endpoint and credentials (what a tool of one's own needs to
    join its bus) and its TCP ports as the services serving them say (``?``: no live service
    said)."""
    lines = []
    for target, rows in found:
        bus = f"Zenoh {target.endpoint}, " + (
            f"credentials {target.credentials}" if target.credentials else "open bus"
        )
        for cell in sorted({*target.cells, *(row.cell for row in rows)}):
            ports = tcp_ports([row for row in rows if row.cell == cell])
            shown = ", ".join(f"{name} {ports.get(name, '?')}" for name in PORT_NAMES)
            lines.append(f"cell {cell}: {bus}; TCP {shown}")
    return "\n".join(lines)


def tcp_ports(rows: list[Row]) -> dict[str, str]:
    """``{"motion": "127.0.0.1:50240", ...}``: the ports one cell's services serve."""
    return {
        port.port_name: f"{port.host}:{port.port}"
        for row in rows
        if row.info is not None
        for port in row.info.listening
    }


def run_ps(args: argparse.Namespace) -> int:
    try:
        found = cells.targets(args)
    except CellsError as exc:
        return cells.failed("ps", exc)
    now = datetime.datetime.now(datetime.UTC)
    for line in warnings([t.credentials for t in found if t.credentials], now):
        print(f"motocell ps: {line}", file=sys.stderr)
    try:
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
        by_target = [(target, live_services(session, target)) for target, session in joined]
        rows = [row for _, target_rows in by_target for row in target_rows]
        realtime = modes.wait_for({row.cell for row in rows if row.service == "executor"})
    finally:
        modes.close()
        cells.close_all(joined)
    if rows:
        print(render_ps(rows, time.time_ns(), realtime))
    else:
        print(f"no motocell service is live on {', '.join(t.describe() for t in found)}")
    for section in (render_clock_warnings(rows, realtime), render_cells(by_target)):
        if section:
            print(f"\n{section}")
    return 0
