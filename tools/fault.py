"""``motocell fault``: inject and clear faults in a running cell, through the controller's
``controller/fault/<kind>`` queryables (usable while the robot moves).

It acts on exactly one cell, as that cell's operator identity: the one named by ``--cell``,
or the only one running (``tools.cells`` finds it). With two candidates it refuses and lists
them rather than guess: a fault injected into the wrong robot's cell is not harmless.
"""

from __future__ import annotations

import argparse
import sys

import zenoh

from motocell.shared.bus.access import Identity
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import CommandReply, CommandRequest
from motocell.shared.bus.session import call
from motocell.shared.protocol.constants import Result, describe_reply
from motocell.tools import cells
from motocell.tools.cells import CellsError, JoinError, Target, TargetError

OPERATOR = Identity(Role.OPERATOR)

# kind -> accepted words (any case) -> value
SWITCHES = {
    "estop": {"on": 1, "off": 0},
    "hold": {"on": 1, "off": 0},
    "servo": {"on": 1, "off": 0},
    "remote": {"on": 1, "off": 0},
    "pfl": {"on": 1, "off": 0},
    "play": {"play": 1, "teach": 0},
    "ot889": {"on": 1, "off": 0},
}
KINDS = (*SWITCHES, "alarm", "error")
"""What ``motocell fault`` injects: a switch, or an alarm or error with its code."""
CODES = range(1, 10_000)
"""A controller numbers its alarms and errors with at most four digits (4100, 2010)."""
SUBCODES = range(10_000)


def add_arguments(fault: argparse.ArgumentParser) -> None:
    """The options of ``motocell fault`` (``tools.cli`` names the command)."""
    fault.description = (
        "Examples: motocell fault estop on | hold off | alarm 4100 2 | alarm clear | "
        "error 2010 | error clear | servo off | play teach | remote off | pfl on | ot889 off"
    )
    fault.add_argument("kind", type=str.lower, choices=KINDS)
    fault.add_argument("setting", help="on/off, play/teach, a code, or clear (any case)")
    fault.add_argument("subcode", nargs="?", type=int, help="alarm subcode (default 0)")
    cells.add_arguments(fault, several=False)
    fault.set_defaults(run=run)


def request_for(kind: str, setting: str, subcode: int | None = None) -> CommandRequest:
    """The fault request; ValueError with one line for a setting the kind does not take."""
    word = setting.lower()
    if kind == "alarm" and subcode is not None and word != "clear":
        if subcode not in SUBCODES:
            raise ValueError(f"alarm: subcode {subcode} is not 0 to {SUBCODES[-1]}")
    elif subcode is not None:
        raise ValueError(f"{kind} {setting}: takes no subcode (got {subcode})")
    if kind in SWITCHES:
        words = SWITCHES[kind]
        if word not in words:
            raise ValueError(f"{kind}: expected {' or '.join(words)}, got {setting!r}")
        return CommandRequest(value=words[word])
    if word == "clear":
        return CommandRequest(value=0)
    try:
        code = int(setting)
    except ValueError:
        raise ValueError(f"{kind}: expected a code or 'clear', got {setting!r}") from None
    if code not in CODES:
        raise ValueError(f"{kind}: code {code} is not 1 to {CODES[-1]}")
    return CommandRequest(value=1, args=[code, subcode or 0])


def echo(args: argparse.Namespace) -> str:
    """The fault as given, in the words the command takes: ``alarm 4100 2``, ``hold on``."""
    words = [args.kind, args.setting.lower()]
    if args.subcode is not None:
        words.append(str(args.subcode))
    return " ".join(words)


def inject(
    session: zenoh.Session, cell: str, kind: str, request: CommandRequest
) -> CommandReply | None:
    """Ask ``cell``'s controller to apply the fault (``session`` joined as its operator); its
    reply, or None when no controller answered in time."""
    return call(session, CellKeys(cell).controller_fault(kind), request, timeout=3.0)


def run(args: argparse.Namespace) -> int:
    try:
        request = request_for(args.kind, args.setting, args.subcode)
    except ValueError as exc:
        print(f"motocell fault: {exc}", file=sys.stderr)
        return 2
    try:
        cell, session = join_one(args)
    except CellsError as exc:
        return cells.failed("fault", exc)
    try:
        reply = inject(session, cell, args.kind, request)
        live = cells.cells_on(session) if reply is None else []
    finally:
        session.close()
    if reply is None:
        # A cell name that is not on the router named with --zenoh-connect: say which are.
        there = f" (live there: {', '.join(live)})" if live and cell not in live else ""
        print(f"motocell fault: no controller of cell {cell!r} answered{there}", file=sys.stderr)
        return 1
    shown = describe_reply(reply.result, reply.subcode)
    print(f"{echo(args)}: {shown}" + (f" ({reply.detail})" if reply.detail else ""))
    return 0 if reply.result == Result.SUCCESS else 1


def join_one(args: argparse.Namespace) -> tuple[str, zenoh.Session]:
    """The one cell the command means, and a session on its bus as its operator."""
    found = cells.some_targets(args)
    if len(found) > 1:
        names = ", ".join(cell for target in found for cell in target.cells)
        raise TargetError(f"{len(found)} cells are running here ({names}): choose one with --cell")
    target = found[0]
    session = cells.join(target, OPERATOR)
    if target.cells:
        return target.cells[0], session
    try:
        return only_cell_on(session, target), session
    except CellsError:
        session.close()
        raise


def only_cell_on(session: zenoh.Session, target: Target) -> str:
    """On an open router named without ``--cell``: the one cell it carries."""
    live = cells.cells_on(session)
    if not live:
        raise JoinError(f"no service of any cell is live behind {target.endpoint}")
    if len(live) > 1:
        carried = ", ".join(live)
        raise TargetError(f"{target.endpoint} carries cells: {carried}: choose one with --cell")
    return live[0]
