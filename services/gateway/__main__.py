"""The gateway: Simple Message over TCP on the motion and I/O ports, forwarded over Zenoh (the
state port is the broadcaster's).

Wiring only: the handlers in ``core`` decide, ``ZenohCell``, ``tcp`` and ``reporter`` do the
I/O.
"""

from __future__ import annotations

import itertools
import logging
import time
from collections.abc import Sequence
from typing import Protocol

from motocell.services.gateway.bus import ZenohBus
from motocell.services.gateway.core.motion import MotionHandler
from motocell.services.gateway.core.robot_io import RobotIoHandler
from motocell.services.gateway.core.sources import Source
from motocell.services.gateway.face_port import FacePort
from motocell.services.gateway.metrics import GatewayStats
from motocell.services.gateway.reporter import Reporter
from motocell.services.gateway.tcp import RequestServer, SocketListener
from motocell.services.gateway.zenoh_cell import ZenohCell
from motocell.shared.protocol.codec import ByteOrder
from motocell.shared.running_service import running_service
from motocell.shared.service import add_listening_arguments, argument_parser, listen

log = logging.getLogger("gateway")


class Adapter(Protocol):
    def start(self) -> None: ...

    def close(self) -> None: ...


def main(argv: Sequence[str] | None = None) -> None:
    parser = argument_parser("gateway", "Simple Message TCP servers of one controller.")
    add_listening_arguments(parser)
    args = parser.parse_args(argv)
    with running_service("gateway", "0", args) as ctx:
        cell = ctx.cell
        byte_order = ByteOrder(cell.byte_order)
        bus = ZenohBus(ctx.session)
        cell_port = ZenohCell(cell, ctx.keys, bus)
        io = RobotIoHandler(cell_port)
        # Sync ids count from the clock so they differ from a previous gateway's.
        sync_ids = itertools.count(time.time_ns() // 1000 + 1)
        motion = MotionHandler(cell, cell_port, io, sync_ids, Source.SIMPLE_MESSAGE)
        stats = GatewayStats(len(cell.groups))
        moving = cell_port.moving
        motion_socket, io_socket = (
            listen(cell.host, cell.motion_port),
            listen(cell.host, cell.io_port),
        )
        ctx.description.listening("motion", motion_socket.getsockname())
        ctx.description.listening("io", io_socket.getsockname())
        motion_server = RequestServer(
            name="motion",
            listener=SocketListener(motion_socket),
            byte_order=byte_order,
            respond=motion.respond,
            error_reply=motion.error_reply,
            moving=moving,
            on_disconnect=motion.disconnected,
            observe=stats.observe,
            reply_priority=True,
        )
        io_server = RequestServer(
            name="io",
            listener=SocketListener(io_socket),
            byte_order=byte_order,
            respond=io.respond,
            error_reply=io.error_reply,
            moving=moving,
            observe=stats.observe,
        )
        reporter = Reporter(
            bus,
            ctx.keys,
            stats=stats,
            motion=motion_server,
            io=io_server,
            holder=cell_port.motion_holder,
        )
        motion_server.on_change = io_server.on_change = reporter.report_connections
        adapters: tuple[Adapter, ...] = (cell_port, motion_server, io_server, reporter)
        if cell.ros2 is not None:
            face_motion = MotionHandler(cell, cell_port, io, sync_ids, Source.ROS2)
            adapters += (FacePort(bus, ctx.keys, byte_order, face_motion, io),)
        for adapter in adapters:
            adapter.start()
        ctx.alive.announce()
        log.info(
            "listening on %s:%d and %d (%s-endian)",
            cell.host,
            cell.motion_port,
            cell.io_port,
            byte_order,
        )
        ctx.stop.wait()
        # In reverse: the ports stop taking requests (and a client's clean-up still reaches
        # the cell) before the cell adapter stops.
        for adapter in reversed(adapters):
            adapter.close()


if __name__ == "__main__":
    main()
