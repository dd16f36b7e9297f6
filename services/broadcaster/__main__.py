"""The state broadcaster: at the state period, one snapshot of the cell, to the TCP state clients
(``Cell.state_port``) and on Zenoh.

Wiring only: ``core`` decides when and what, ``loop`` runs the one thread that carries a tick
to the sockets, ``ticks``, ``controller_watch`` and ``reports`` are its bus (``bus``), and
``state_port`` its TCP server.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

from motocell.services.broadcaster.bus import ZenohBus
from motocell.services.broadcaster.controller_watch import ControllerWatch
from motocell.services.broadcaster.core.broadcaster import Broadcaster
from motocell.services.broadcaster.loop import StateLoop
from motocell.services.broadcaster.reports import StatePortReports
from motocell.services.broadcaster.state_port import Acceptor, StatePort
from motocell.services.broadcaster.ticks import TickSource
from motocell.shared.protocol.codec import ByteOrder
from motocell.shared.running_service import running_service
from motocell.shared.service import add_listening_arguments, argument_parser, listen

log = logging.getLogger("broadcaster")


def main(argv: Sequence[str] | None = None) -> None:
    parser = argument_parser("broadcaster", "Controller state at the state period.")
    add_listening_arguments(parser)
    args = parser.parse_args(argv)
    with running_service("broadcaster", "0", args) as ctx:
        cell, keys = ctx.cell, ctx.keys
        byte_order = ByteOrder(cell.byte_order)
        bus = ZenohBus(ctx.session)
        state_socket = listen(cell.host, cell.state_port)
        ctx.description.listening("state", state_socket.getsockname())
        controller = ControllerWatch(bus, keys)
        broadcaster = Broadcaster(cell, controller)
        state = bus.publisher(keys.state, realtime=True, latest=True)
        positions = bus.serve(keys.broadcaster_cmd("positions"), broadcaster.positions)
        reports = StatePortReports(bus, keys)
        ticks = TickSource(bus, keys, ctx.stop)
        acceptor = Acceptor(state_socket, ticks.ring)
        loop = StateLoop(
            broadcaster,
            ticks,
            StatePort(acceptor),
            byte_order=byte_order,
            state=state,
            reports=reports,
        )
        log.info("state port on %s:%d (%s-endian)", cell.host, cell.state_port, byte_order)
        ticks.start()
        acceptor.start()
        ctx.alive.announce()
        try:
            loop.run(ctx.stop)
        finally:
            ctx.stop.set()  # on an error too: it ends the waker
            # The port first: its acceptor wakes the tick source for each connection.
            loop.close()
            ticks.close()
            reports.close()
            controller.close()
            positions.undeclare()
            state.undeclare()


if __name__ == "__main__":
    main()
