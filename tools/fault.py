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
from motocell.shared.faults import KINDS, inject, request_for
from motocell.shared.protocol.constants import Result, describe_reply
from motocell.tools import cells
from motocell.tools.cells import CellsError, JoinError, Target, TargetError

OPERATOR = Identity(Role.OPERATOR)


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


def echo(args: argparse.Namespace) -> str:
    """The fault as given, in the words the command takes: ``alarm 4100 2``, ``hold on``."""
    words = [args.kind, args.setting.lower()]
    if args.subcode is not None:
        words.append(str(args.subcode))
    return " ".join(words)


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
