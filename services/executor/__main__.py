"""The executor: the controller's interpolation clock (``clock``), deciding with ``core``,
reading ``inputs`` and publishing ``outputs``; this module wires them."""

from __future__ import annotations

import time
from collections.abc import Sequence

from motocell.services.executor.clock import Clock
from motocell.services.executor.core import ExecutorCore, pulse_ranges, starting_pulses
from motocell.services.executor.inputs import Inputs
from motocell.services.executor.outputs import Outputs
from motocell.shared.bus.session import call
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.motion.servo import Servos
from motocell.shared.service import ServiceContext, argument_parser, running_service


def build_core(ctx: ServiceContext) -> ExecutorCore:
    """The core, starting where the broadcaster last saw the robot (an executor restart) or
    where the cell file puts it."""
    cell = ctx.cell
    remembered = call(ctx.session, ctx.keys.broadcaster_cmd("positions"), timeout=1.0)
    start = starting_pulses(cell, remembered)
    return ExecutorCore(
        start,
        first_epoch=time.time_ns() // 1000,
        max_increments=[AxisMap(group).max_increments(cell.period_s) for group in cell.groups],
        ranges=pulse_ranges(cell),
        period_ns=cell.period_ns,
        servos=Servos([group.servo for group in cell.groups], cell.period_s, start),
        max_lateness_periods=cell.max_lateness_periods,
    )


def main(argv: Sequence[str] | None = None) -> None:
    args = argument_parser("executor", "The interpolation clock of one controller.").parse_args(
        argv
    )
    with running_service("executor", "0", args) as ctx:
        groups = len(ctx.cell.groups)
        inputs = Inputs(ctx.session, ctx.keys, groups, ctx.stop)
        outputs = Outputs(ctx.session, ctx.keys, groups)
        inputs.start()
        ctx.alive.announce()
        try:
            Clock(build_core(ctx), inputs, outputs, ctx.stop).run()
        finally:
            ctx.stop.set()  # on an error too: it ends the waker
            inputs.close()


if __name__ == "__main__":
    main()
