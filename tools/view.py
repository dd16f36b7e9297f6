"""``motocell view``: the cells live in Foxglove, each arm moving in its place in its cell.

Serves the Foxglove WebSocket protocol (the official ``foxglove-sdk``) on HOST:PORT, loopback
port 8765 by default, the port Foxglove proposes. In Foxglove: Open connection, Foxglove
WebSocket, ws://HOST:PORT; then import the layout (``--layout FILE`` writes one for the cells
viewed, ``deploy/foxglove/motocell-layout.json`` is the one for the default cell).

Per cell, under ``/<cell>/``: each group's joints (feedback and commanded), the controller's
status, the state's ROBOT_STATUS fields, the executor's lateness and queue depths, and a 3D scene
(frames along every link, simple link geometry, each group placed by its cell file's ``base``).
``tools.view_channels`` lists the topics; ``motocell record`` writes the same ones.

Like ``watch`` and ``record`` it covers every cell running here, each joined through its own
router as its read-only observer; ``--zenoh-connect`` reaches cells elsewhere, whose cell files
``--config`` gives (a cell's own file, found by the name in it). It offers Foxglove nothing to
call, set or publish: the view cannot command a cell.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import msgspec
import zenoh

from motocell.shared.bus import catalog
from motocell.shared.bus.access import Identity
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.keys import ROOT
from motocell.shared.config import Cell, ConfigError
from motocell.shared.service import stop_on_signals
from motocell.tools import cell_files, cells
from motocell.tools.cells import CellsError, Target
from motocell.tools.record import Recorder

if TYPE_CHECKING:
    from motocell.tools.view_channels import ViewChannels

OBSERVER = Identity(Role.OBSERVER)
DEFAULT_PORT = 8765
"""The port Foxglove's "Open connection" proposes for a Foxglove WebSocket."""
SUBSCRIBED = ("state", "controller/status", "executor/tick", "executor/metrics")
"""The keys the view shows (``tools.view_channels``)."""


def add_parser(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    view = commands.add_parser(
        "view",
        help="serve the running cells live to Foxglove (3D scene, joints, status)",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_arguments(view)
    view.set_defaults(run=run)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--host", default="127.0.0.1", help="the address to serve on (default: %(default)s)"
    )
    parser.add_argument(
        "--port",
        type=int,
        default=DEFAULT_PORT,
        help="the WebSocket port (default: %(default)s; 0: any free port)",
    )
    cell_files.add_arguments(parser)
    parser.add_argument(
        "--layout", metavar="FILE", help="write a Foxglove layout for the cells viewed to FILE"
    )
    parser.add_argument(
        "--duration", type=float, metavar="S", help="stop after S seconds (default: at Ctrl-C)"
    )
    cells.add_arguments(parser, several=True)


def run(args: argparse.Namespace) -> int:
    try:
        joined = cells.join_all(cells.some_targets(args), OBSERVER)
    except CellsError as exc:
        return cells.failed("view", exc)
    try:
        known = cell_files.known((target for target, _ in joined), args.config, "view")
        return _serve(joined, known, args)
    except ConfigError as exc:
        print(f"motocell view: {exc}", file=sys.stderr)
        return 2
    finally:
        cells.close_all(joined)


def _serve(
    joined: list[tuple[Target, zenoh.Session]], known: dict[str, Cell], args: argparse.Namespace
) -> int:
    # foxglove-sdk is in the tools extra: imported by this command only.
    import foxglove  # noqa: PLC0415

    from motocell.tools.view_channels import ViewChannels  # noqa: PLC0415
    from motocell.tools.view_layout import layout_text  # noqa: PLC0415

    if args.layout is not None:
        Path(args.layout).write_text(layout_text(list(known.values())))
        print(f"wrote the Foxglove layout {args.layout}", flush=True)
    context = foxglove.Context()
    try:
        server = foxglove.start_server(
            name="motocell view", host=args.host, port=args.port, capabilities=[], context=context
        )
    except RuntimeError as exc:
        print(f"motocell view: cannot serve on {args.host}:{args.port}: {exc}", file=sys.stderr)
        return 2
    try:
        return _forward(joined, ViewSink(ViewChannels(context, known)), server.port, args)
    finally:
        server.stop()


class ViewSink:
    """``Recorder``'s sink for the view: each sample decoded and published, none kept."""

    def __init__(self, channels: ViewChannels) -> None:
        self.channels = channels

    def write(self, received_ns: int, key: str, data: bytes) -> None:
        try:
            value = catalog.decode(key, data)
        except msgspec.DecodeError:
            return  # e.g. a newer, incompatible payload: nothing to show
        if value is not None:
            self.channels.publish(key, value, received_ns)

    def finish(self) -> None:
        """Nothing kept, nothing to finish."""


def _forward(
    joined: list[tuple[Target, zenoh.Session]],
    sink: ViewSink,
    port: int,
    args: argparse.Namespace,
) -> int:
    with stop_on_signals() as stop:
        # The Recorder's queue keeps Zenoh's threads free: they only stamp and queue.
        forwarder = Recorder(sink, stop)
        try:
            subscribers = [
                session.declare_subscriber(f"{ROOT}/{name}/{suffix}", forwarder.on_sample)
                for target, session in joined
                for name in target.names
                for suffix in SUBSCRIBED
            ]
            where = ", ".join(target.describe() for target, _ in joined)
            print(
                f"serving {where} to Foxglove at ws://{args.host}:{port} (read-only); "
                "Ctrl-C to stop",
                flush=True,
            )
            stop.wait(args.duration)
            for subscriber in subscribers:
                subscriber.undeclare()
        finally:
            forwarder.close()
    if forwarder.error is not None:
        print(f"motocell view: {forwarder.error}", file=sys.stderr)
        return 1
    if forwarder.dropped:
        print(f"motocell view: {forwarder.dropped} samples dropped (fell behind)", file=sys.stderr)
    return 0
