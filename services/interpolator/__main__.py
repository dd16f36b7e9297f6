"""One group's interpolator (MotoROS's AddToIncQueue task, motoros1 §4).

Takes the points the gateway accepted, turns each segment into per-period pulse increments and
sends them to the executor only as far as the executor's ring has room, so nothing overflows
and nothing is dropped. The pending-point slot is free again (``Slot.taken_id``) once a point's
whole segment is in the ring, which is what makes the gateway answer BUSY meanwhile.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Sequence

from services.interpolator.core import Feeder, queue_point
from shared.bus.schemas import (
    ControllerStatus,
    Decoder,
    InterpolatorMetrics,
    Point,
    QueueState,
    encode,
)
from shared.bus.session import Inbox, payload_of, publisher
from shared.service import ServiceContext, argument_parser, running_service

SLOT_REFRESH_S = 0.5
"""Also publish the slot periodically, so a gateway that (re)starts learns it."""
METRICS_S = 1.0


def run(ctx: ServiceContext, group_index: int) -> None:
    cell = ctx.cell
    group = cell.groups[group_index]
    keys = ctx.keys
    session = ctx.session
    inbox = Inbox()
    increments_pub = publisher(session, keys.group_increments(group_index), realtime=True)
    slot_pub = publisher(session, keys.group_slot(group_index), realtime=True)
    feeder = Feeder(
        group,
        cell.period_ns,
        send=lambda batch: increments_pub.put(encode(batch)),
        instance=time.time_ns(),
    )
    subscribers = [
        session.declare_subscriber(
            keys.group_point(group_index), inbox.feed("point", payload_of(Decoder(Point)))
        ),
        session.declare_subscriber(
            keys.group_queue(group_index), inbox.feed("queue", payload_of(Decoder(QueueState)))
        ),
        session.declare_subscriber(
            keys.controller_status, inbox.feed("status", payload_of(Decoder(ControllerStatus)))
        ),
    ]
    metrics_pub = publisher(session, keys.group_metrics(group_index), latest=True)
    points: deque[Point] = deque()
    published_slot = None
    next_refresh = 0.0
    next_metrics = time.monotonic() + METRICS_S
    busy_s = 0.0
    last = time.monotonic()
    while not ctx.stop.is_set():
        item = inbox.get(timeout=0.1)
        while item is not None:
            tag, payload = item
            if tag == "queue":
                feeder.on_queue(payload)
            elif tag == "point":
                queue_point(points, payload)
            elif tag == "status":
                feeder.on_status(payload)
            item = inbox.get_nowait()
        now = time.monotonic()
        if feeder.segment is not None:
            busy_s += now - last  # the slot was full since the last pass
        last = now
        feeder.progress(points)
        slot = feeder.slot()
        if now >= next_metrics:
            metrics = InterpolatorMetrics(
                feeder.points_accepted, feeder.increments_sent, busy_s, feeder.busy_episodes
            )
            metrics_pub.put(encode(metrics))
            next_metrics = now + METRICS_S
        if slot != published_slot or now >= next_refresh:
            slot_pub.put(encode(slot))
            published_slot = slot
            next_refresh = now + SLOT_REFRESH_S
    for subscriber in subscribers:
        subscriber.undeclare()


def main(argv: Sequence[str] | None = None) -> None:
    parser = argument_parser("interpolator", "Trajectory interpolation for one control group.")
    parser.add_argument("--group", type=int, default=0, help="control group index (0-3)")
    args = parser.parse_args(argv)
    with running_service("interpolator", str(args.group), args) as ctx:
        if not 0 <= args.group < len(ctx.cell.groups):
            raise SystemExit(
                f"motocell-interpolator: --group {args.group}: the cell has groups 0 to "
                f"{len(ctx.cell.groups) - 1}"
            )
        run(ctx, args.group)


if __name__ == "__main__":
    main()
