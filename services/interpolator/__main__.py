"""One group's interpolator (MotoROS's AddToIncQueue task, motoros1 §4).

Takes the points the gateway accepted, turns each segment into per-period pulse increments and
sends them to the executor only as far as the executor's ring has room, so nothing overflows
and nothing is dropped. The pending-point slot is free again (``Slot.taken_id``) once a point's
whole segment is in the ring, which is what makes the gateway answer BUSY meanwhile; the slot
is published in the same pass that took the point (``inputs`` for how the pass is woken).
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Sequence

from motocell.services.interpolator.core import Feeder, queue_point
from motocell.services.interpolator.inputs import Inputs
from motocell.services.interpolator.reports import Reports
from motocell.shared.bus.schemas import Point, encode
from motocell.shared.bus.session import publisher
from motocell.shared.service import ServiceContext, argument_parser, running_service


def run(ctx: ServiceContext, group_index: int) -> None:
    cell = ctx.cell
    increments_pub = publisher(ctx.session, ctx.keys.group_increments(group_index), realtime=True)
    feeder = Feeder(
        cell.groups[group_index],
        cell.period_ns,
        send=lambda batch: increments_pub.put(encode(batch)),
        instance=time.time_ns(),
        start_buffer_periods=cell.start_buffer_periods,
    )
    reports = Reports(ctx, group_index, feeder)
    inputs = Inputs(ctx, group_index)
    points: deque[Point] = deque()
    inputs.start()
    ctx.alive.announce()
    try:
        while not ctx.stop.is_set():
            inputs.wait(feeder.waits_for_ring(points), reports.next_metrics)
            status = inputs.status()
            if status is not None:
                feeder.on_status(status)
            queue = inputs.queue()
            if queue is not None:
                # Before the points: a cleared ring ends the trajectory they might extend.
                feeder.on_queue(queue)
            for point in inputs.points():
                queue_point(points, point, cell.points_outstanding)
            reports.before_progress()
            feeder.progress(points)
            reports.after_progress()
    finally:
        ctx.stop.set()  # on an error too: it ends the waker
        inputs.close()
        reports.close()


def main(argv: Sequence[str] | None = None) -> None:
    parser = argument_parser("interpolator", "Trajectory interpolation for one control group.")
    parser.add_argument("--group", type=int, default=0, help="control group index (0-3)")
    args = parser.parse_args(argv)
    # running_service refuses a group the cell lacks before it joins Zenoh.
    with running_service("interpolator", str(args.group), args) as ctx:
        run(ctx, args.group)


if __name__ == "__main__":
    main()
