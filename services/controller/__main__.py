"""The simulated controller process: the bus adapter (``bus``), the core (``core.dispatch``)
and the one thread that joins them (``loop``), wired."""

from __future__ import annotations

from collections.abc import Sequence

from motocell.services.controller.bus import ZenohControllerBus, others_alive_keys
from motocell.services.controller.core.dispatch import Dispatcher
from motocell.services.controller.core.io_table import IoTable
from motocell.services.controller.core.model import Controller
from motocell.services.controller.inbox import ReplyTo
from motocell.services.controller.loop import ControllerLoop, first_status_seq
from motocell.shared.running_service import running_service
from motocell.shared.service import argument_parser


def main(argv: Sequence[str] | None = None) -> None:
    args = argument_parser("controller", "The simulated Yaskawa controller.").parse_args(argv)
    with running_service("controller", "0", args) as ctx:
        bus = ZenohControllerBus(ctx.session, ctx.keys)
        model = Controller(groups=len(ctx.cell.groups))
        io = IoTable(ctx.cell.controller, model.outputs, model.set_output)
        dispatcher = Dispatcher[ReplyTo](
            model, io, others_alive_keys(ctx.cell, ctx.keys), first_seq=first_status_seq()
        )
        ctx.alive.announce()
        ControllerLoop(dispatcher, bus, ctx.stop).run()


if __name__ == "__main__":
    main()
