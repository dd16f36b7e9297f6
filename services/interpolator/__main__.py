"""One group's interpolator (MotoROS's AddToIncQueue task, motoros1 §4).

Takes the points the gateway accepted, turns each segment into per-period pulse increments and
sends them to the executor only as far as the executor's ring has room, so nothing overflows
and nothing is dropped. The pending-point slot is free again (``Slot.taken_id``) once a point's
whole segment is in the ring, which is what makes the gateway answer BUSY meanwhile. ``core``
decides; ``loop`` runs the one thread; ``inputs`` and ``reports`` are its bus adapters; this
module wires.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

from motocell.services.interpolator.bus import ZenohBus
from motocell.services.interpolator.core.feeder import Feeder
from motocell.services.interpolator.inputs import Inputs
from motocell.services.interpolator.loop import FeederLoop
from motocell.services.interpolator.reports import Reports
from motocell.shared.bus.schemas import encode
from motocell.shared.running_service import running_service
from motocell.shared.service import argument_parser


def main(argv: Sequence[str] | None = None) -> None:
    parser = argument_parser("interpolator", "Trajectory interpolation for one control group.")
    parser.add_argument("--group", type=int, default=0, help="control group index (0-3)")
    args = parser.parse_args(argv)
    group = args.group
    # running_service refuses a group the cell lacks before it joins Zenoh.
    with running_service("interpolator", str(group), args) as ctx:
        cell = ctx.cell
        bus = ZenohBus(ctx.session)
        increments = bus.publisher(ctx.keys.group_increments(group), realtime=True)
        feeder = Feeder(
            cell.groups[group],
            cell.period_ns,
            send=lambda batch: increments.put(encode(batch)),
            instance=time.time_ns(),
            start_buffer_periods=cell.start_buffer_periods,
        )
        reports = Reports(bus, ctx.keys, group, feeder)
        inputs = Inputs(bus, ctx.keys, group, cell.groups[group].axes, ctx.stop)
        loop = FeederLoop(feeder, inputs, reports, cell.points_outstanding)
        inputs.start()
        ctx.alive.announce()
        try:
            loop.run(ctx.stop)
        finally:
            ctx.stop.set()  # on an error too: it ends the waker
            inputs.close()
            reports.close()


if __name__ == "__main__":
    main()
