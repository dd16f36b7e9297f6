"""The executor: the controller's interpolation clock (``loop``), deciding with ``core``, reading
``inputs`` and publishing ``outputs`` over the bus (``bus``); this module wires them."""

from __future__ import annotations

import time
from collections.abc import Sequence

from motocell.services.executor.bus import ZenohBus
from motocell.services.executor.core.start import core_for_cell
from motocell.services.executor.inputs import Inputs
from motocell.services.executor.loop import Clock
from motocell.services.executor.outputs import Outputs
from motocell.shared.running_service import running_service
from motocell.shared.service import argument_parser


def main(argv: Sequence[str] | None = None) -> None:
    args = argument_parser("executor", "The interpolation clock of one controller.").parse_args(
        argv
    )
    with running_service("executor", "0", args) as ctx:
        groups = len(ctx.cell.groups)
        bus = ZenohBus(ctx.session)
        inputs = Inputs(bus, ctx.keys, groups, ctx.stop)
        outputs = Outputs(bus, ctx.keys, groups)
        inputs.start()
        ctx.alive.announce()
        try:
            core = core_for_cell(
                ctx.cell, inputs.remembered_positions(), first_epoch=time.time_ns() // 1000
            )
            Clock(core, inputs, outputs, ctx.stop).run()
        finally:
            ctx.stop.set()  # on an error too: it ends the waker
            inputs.close()


if __name__ == "__main__":
    main()
