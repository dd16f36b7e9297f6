"""``motocell fault``: inject and clear faults in a running cell, through the controller's
``controller/fault/<kind>`` queryables (usable while the robot moves)."""

from __future__ import annotations

import argparse
import sys

from services.launcher.core import WELL_KNOWN_ENDPOINT
from shared.bus.keys import CellKeys
from shared.bus.schemas import CommandRequest
from shared.bus.session import call, open_session
from shared.protocol.constants import Result

# kind -> accepted words -> (value, needs code)
SWITCHES = {
    "estop": {"on": 1, "off": 0},
    "hold": {"on": 1, "off": 0},
    "servo": {"on": 1, "off": 0},
    "remote": {"on": 1, "off": 0},
    "pfl": {"on": 1, "off": 0},
    "play": {"play": 1, "teach": 0},
    "ot889": {"on": 1, "off": 0},
}


def add_parser(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    fault = commands.add_parser(
        "fault",
        help="inject or clear a fault in a running cell",
        description=(
            "Examples: motocell fault estop on | hold off | alarm 4100 2 | alarm clear | "
            "error 2010 | error clear | servo off | play teach | remote off | pfl on | ot889 off"
        ),
    )
    fault.add_argument("kind", choices=(*SWITCHES, "alarm", "error"))
    fault.add_argument("setting", help="on/off, play/teach, a code, or clear")
    fault.add_argument("subcode", nargs="?", type=int, default=0, help="alarm subcode")
    fault.add_argument("--cell", default="cell1")
    fault.add_argument("--zenoh-connect", default=WELL_KNOWN_ENDPOINT, metavar="ENDPOINT")
    fault.set_defaults(run=run)


def request_for(kind: str, setting: str, subcode: int) -> CommandRequest:
    if kind in SWITCHES:
        words = SWITCHES[kind]
        if setting not in words:
            raise ValueError(f"{kind}: expected {' or '.join(words)}, got {setting!r}")
        return CommandRequest(value=words[setting])
    if setting == "clear":
        return CommandRequest(value=0)
    try:
        code = int(setting)
    except ValueError:
        raise ValueError(f"{kind}: expected a code or 'clear', got {setting!r}") from None
    return CommandRequest(value=1, args=[code, subcode])


def run(args: argparse.Namespace) -> int:
    try:
        request = request_for(args.kind, args.setting, args.subcode)
    except ValueError as exc:
        print(f"motocell fault: {exc}", file=sys.stderr)
        return 2
    try:
        session = open_session("client", [args.zenoh_connect], wait=False)
    except ConnectionError as exc:
        print(f"motocell fault: {exc}", file=sys.stderr)
        return 1
    try:
        reply = call(session, CellKeys(args.cell).controller_fault(args.kind), request, timeout=3.0)
    finally:
        session.close()
    if reply is None:
        print(f"motocell fault: no controller of cell {args.cell!r} answered", file=sys.stderr)
        return 1
    print(f"{args.kind} {args.setting}: {Result(reply.result).name}")
    return 0 if reply.result == Result.SUCCESS else 1
