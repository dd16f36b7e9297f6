"""``motocell view``: the cells live in Foxglove, each arm moving in its place in its cell.

Serves the Foxglove WebSocket protocol (the official ``foxglove-sdk``) on HOST:PORT, loopback
port 8765 by default, the port Foxglove proposes. In Foxglove: Open connection, Foxglove
WebSocket, ws://HOST:PORT; then import the layout (``--layout FILE`` writes one for the cells
viewed; the default cell's ships in the package, ``tools.view_layout.SHIPPED``). The server
speaks the WebSocket subprotocol ``foxglove.sdk.v1`` only (docs/observing.md: which viewers).

Per cell, under ``/<cell>/``: each group's joints (feedback and commanded), the controller's
status, the state's ROBOT_STATUS fields, the executor's lateness and queue depths, and a 3D scene
(frames along every link, simple link geometry, each group placed by its cell file's ``base``).
``tools.view_channels`` lists the topics; ``motocell record`` writes the same ones. Each
topic goes out at most ``--rate`` times a second (30 by default), its newest sample
(``tools.view_rate``): the cell's 1,100-odd samples a second are for its clients, not for eyes.

Like ``watch`` and ``record`` it covers every cell running here, each joined through its own
router as its read-only observer; ``--zenoh-connect`` reaches cells elsewhere, whose cell files
``--config`` gives (a cell's own file, found by the name in it). It offers Foxglove nothing to
call, set or publish: the view cannot command a cell.
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import msgspec

from motocell.services.launcher.ports import NOT_HERE, TAKEN, bind_problem
from motocell.shared.bus import catalog
from motocell.shared.bus.keys import ROOT
from motocell.shared.config import Cell
from motocell.shared.service import stop_on_signals
from motocell.tools import cell_files, cells
from motocell.tools.cell_files import Joined
from motocell.tools.record import subscribed_until_stopped
from motocell.tools.view_forward import PacedForwarder

if TYPE_CHECKING:
    from motocell.tools.view_channels import ViewChannels

DEFAULT_PORT = 8765
"""The port Foxglove's "Open connection" proposes for a Foxglove WebSocket."""
MESSAGE_BACKLOG = 1024
"""Messages the server holds for a client that does not read (a stalled or slow Foxglove):
past that the oldest are dropped, so such a client costs a few MB (a frame tree is ~3 kB),
never memory without bound. About three seconds of the dual-arm cell at the default rate."""
DEFAULT_RATE_HZ = 30.0
"""What a person watches needs no more: motion in the 3D panel looks continuous, and a plot of
the last 30 s (the layout's window) gets 900 samples across a few hundred pixels, more than
one per pixel column. The cell's own rates (state 100 Hz, ticks 250 Hz) are for its clients."""
SUBSCRIBED = ("state", "controller/status", "executor/tick", "executor/metrics")
"""The keys the view shows (``tools.view_channels``)."""
SUBPROTOCOL = "foxglove.sdk.v1"
"""The one WebSocket subprotocol foxglove-sdk's server accepts."""
OFFERED_BY = (
    f"a viewer must offer the WebSocket subprotocol {SUBPROTOCOL}: current Foxglove releases "
    "and Lichtblick 1.22.0 or later do; Foxglove Studio and older Lichtblick offer only "
    "foxglove.websocket.v1"
)
"""Which viewers connect (docs/observing.md, In Foxglove). Lichtblick's first release with the
name is 1.22.0 (its pull request 819); 1.21.0 refused an SDK server."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``motocell view`` (``tools.cli`` names the command)."""
    parser.description = __doc__
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.add_argument(
        "--host", default="127.0.0.1", help="the address to serve on (default: %(default)s)"
    )
    parser.add_argument(
        "--port",
        type=int,
        default=DEFAULT_PORT,
        help="the WebSocket port (default: %(default)s; 0: any free port)",
    )
    parser.add_argument(
        "--rate",
        type=float,
        default=DEFAULT_RATE_HZ,
        metavar="HZ",
        help="send each topic at most HZ times a second, its newest sample (default: "
        "%(default)g; above the cell's rates, e.g. 1000, every sample)",
    )
    parser.add_argument(
        "--layout", metavar="FILE", help="write a Foxglove layout for the cells viewed to FILE"
    )
    cell_files.add_arguments(parser)
    cells.add_arguments(parser, several=True)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    if not 0 < args.rate < math.inf:
        print("motocell view: --rate must be a number of Hz above 0", file=sys.stderr)
        return 2
    # Before any cell is joined: a port that cannot be served is one line, as for `motocell up`.
    problem = None if args.port == 0 else bind_problem(args.host, args.port)
    if problem is not None:
        print(f"motocell view: {_cannot_serve(args, problem)}", file=sys.stderr)
        return 2
    return cell_files.observe(args, "view", lambda joined, known: _serve(joined, known, args))


_ADVICE = {
    TAKEN: " (stop that process, or choose --port N; 0 takes any free port)",
    NOT_HERE: " (--host takes 127.0.0.1, 0.0.0.0 or an address of this host)",
}


def _cannot_serve(args: argparse.Namespace, problem: str) -> str:
    return f"cannot serve Foxglove on {args.host}:{args.port}: {problem}{_ADVICE.get(problem, '')}"


def _serve(joined: Joined, known: dict[str, Cell], args: argparse.Namespace) -> int:
    # foxglove-sdk is in the tools extra: imported by this command only.
    import foxglove  # noqa: PLC0415

    from motocell.tools.view_channels import ViewChannels  # noqa: PLC0415

    if args.layout is not None:
        problem = _write_layout(args.layout, list(known.values()))
        if problem is not None:
            print(f"motocell view: --layout {args.layout}: {problem}", file=sys.stderr)
            return 2
    logging.getLogger(REFUSALS_LOGGER).addFilter(_EXPLAIN_REFUSALS)
    context = foxglove.Context()
    try:
        server = foxglove.start_server(
            name="motocell view",
            host=args.host,
            port=args.port,
            capabilities=[],
            context=context,
            message_backlog_size=MESSAGE_BACKLOG,
        )
    except RuntimeError as exc:  # the port taken since it was tried
        print(f"motocell view: {_cannot_serve(args, str(exc))}", file=sys.stderr)
        return 2
    try:
        return _forward(joined, ViewSink(ViewChannels(context, known)), server.port, args)
    finally:
        server.stop()


REFUSALS_LOGGER = "foxglove.websocket.server"
"""Where foxglove-sdk's Rust server logs through Python's logging that it dropped a client."""


class ExplainRefusals(logging.Filter):
    """foxglove-sdk answers a handshake without ``foxglove.sdk.v1`` with HTTP 400 inside its Rust
    server, out of Python's reach, and logs only ``Dropping client ADDR: handshake failed``.
    This adds to that line what the client needs. The SDK logs the same words for any failed
    handshake (a plain HTTP request, a client that hung up), so they say what a viewer must
    offer rather than claim that it did not."""

    def filter(self, record: logging.LogRecord) -> bool:
        message = record.getMessage()
        if message.endswith(": handshake failed"):
            record.msg, record.args = f"{message} ({OFFERED_BY})", ()
        return True


_EXPLAIN_REFUSALS = ExplainRefusals()
"""One instance, so that serving again (a test's second view) adds no second copy."""


def _write_layout(path: str, known: list[Cell]) -> str | None:
    """Writes the layout of the cells ``known``; what stopped it, if anything."""
    from motocell.tools.view_layout import layout_text  # noqa: PLC0415

    if not known:
        return "no cell file for the cells viewed (--config FILE gives one)"
    try:
        Path(path).write_text(layout_text(known))
    except OSError as exc:
        return f"cannot write it: {exc.strerror}"
    print(f"wrote the Foxglove layout {path}", flush=True)
    return None


class ViewSink:
    """Where the forwarder hands each sample due: decoded and published, none kept."""

    def __init__(self, channels: ViewChannels) -> None:
        self.channels = channels

    def write(self, received_ns: int, key: str, data: bytes) -> None:
        try:
            value = catalog.decode(key, data)
        except msgspec.DecodeError:
            return  # e.g. a newer, incompatible payload: nothing to show
        if value is not None:
            self.channels.publish(key, value, received_ns)


def _forward(joined: Joined, sink: ViewSink, port: int, args: argparse.Namespace) -> int:
    subscriptions = [
        (session, f"{ROOT}/{name}/{suffix}")
        for target, session in joined
        for name in target.names
        for suffix in SUBSCRIBED
    ]
    where = ", ".join(target.describe() for target, _ in joined)
    ready = (
        f"serving {where} to Foxglove at ws://{args.host}:{port} (read-only, each topic at "
        f"most {args.rate:g} Hz); Ctrl-C to stop"
    )
    with stop_on_signals() as stop:
        forwarder = PacedForwarder(sink.write, args.rate, stop)
        forwarder.start()
        try:
            subscribed_until_stopped(forwarder.on_sample, subscriptions, ready, stop, args.duration)
        finally:
            forwarder.close()
    if forwarder.error is not None:
        print(f"motocell view: {forwarder.error}", file=sys.stderr)
        return 1
    return 0
