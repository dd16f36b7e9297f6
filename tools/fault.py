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

from shared.bus.access import Identity
from shared.bus.catalog import Role
from shared.bus.keys import CellKeys
from shared.bus.schemas import CommandRequest
from shared.bus.session import call
from shared.protocol.constants import Result
from tools import cells
from tools.cells import CellsError, JoinError, Target, TargetError

OPERATOR = Identity(Role.OPERATOR)

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
    cells.add_arguments(fault, several=False)
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
        cell, session = join_one(args)
    except CellsError as exc:
        return cells.failed("fault", exc)
    try:
        reply = call(session, CellKeys(cell).controller_fault(args.kind), request, timeout=3.0)
    finally:
        session.close()
    if reply is None:
        print(f"motocell fault: no controller of cell {cell!r} answered", file=sys.stderr)
        return 1
    print(f"{args.kind} {args.setting}: {Result(reply.result).name}")
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
