"""The state broadcaster: at the state period, one snapshot of the cell, to the TCP state clients
(port_base + 1) and on Zenoh. ``core`` decides when and what; ``loop`` runs the one thread that
carries a tick to the sockets; this module wires."""

from __future__ import annotations

import logging
from collections.abc import Sequence

from motocell.services.broadcaster.controller_watch import ControllerWatch
from motocell.services.broadcaster.core import Broadcaster
from motocell.services.broadcaster.loop import StateLoop
from motocell.services.broadcaster.reports import Reports
from motocell.services.broadcaster.state_port import Acceptor, StatePort
from motocell.services.broadcaster.ticks import TickSource
from motocell.shared.bus.session import answer, observed, publisher
from motocell.shared.protocol.codec import ByteOrder
from motocell.shared.service import (
    add_listening_arguments,
    argument_parser,
    listen,
    running_service,
)

log = logging.getLogger("broadcaster")


def main(argv: Sequence[str] | None = None) -> None:
    parser = argument_parser("broadcaster", "Controller state at the state period.")
    add_listening_arguments(parser)
    args = parser.parse_args(argv)
    with running_service("broadcaster", "0", args) as ctx:
        byte_order = ByteOrder(ctx.cell.byte_order)
        state_socket = listen(ctx.cell.host, ctx.cell.state_port)
        ctx.description.listening("state", state_socket.getsockname())
        watch = ControllerWatch(ctx.session, ctx.keys)
        broadcaster = Broadcaster(ctx.cell, watch)
        state_pub = publisher(ctx.session, ctx.keys.state, realtime=True, latest=True)
        positions = ctx.session.declare_queryable(
            ctx.keys.broadcaster_cmd("positions"),
            lambda query: answer(query, broadcaster.positions()),
        )
        reports = Reports(ctx.session, ctx.keys)
        ticks = TickSource(ctx.session, ctx.keys, ctx.stop)
        acceptor = Acceptor(state_socket, ticks.ring)
        state_port = StatePort(acceptor)
        loop = StateLoop(
            broadcaster,
            ticks,
            state_port,
            byte_order=byte_order,
            publish_state=state_pub.put,
            observed=lambda: observed(state_pub),
            reports=reports,
        )
        log.info("state port on %s:%d (%s-endian)", ctx.cell.host, ctx.cell.state_port, byte_order)
        ticks.start()
        acceptor.start()
        ctx.alive.announce()
        try:
            while not ctx.stop.is_set():
                loop.cycle()
        finally:
            ctx.stop.set()  # on an error too: it ends the waker
            ticks.close()
            loop.close()
            for adapter in (reports, watch):
                adapter.close()
            positions.undeclare()
            state_pub.undeclare()


if __name__ == "__main__":
    main()
