"""The points waiting for the feeder, and how many may wait. Pure."""

from __future__ import annotations

import logging
from collections import deque

from motocell.shared.bus.schemas import Point

log = logging.getLogger("interpolator")


def queue_point(points: deque[Point], point: Point, limit: int) -> bool:
    """Keep ``point`` for the feeder; False (dropped) when ``limit`` points already wait. The
    gateway lets no more be outstanding (``Cell.points_outstanding``) but for type-14
    sequence-0 points, which never get BUSY (motoros1 §2.4): only a client sending several in a
    row while a segment waits for room reaches the limit."""
    if len(points) >= limit:
        log.error("more than %d points pending; dropping %s", len(points), point)
        return False
    points.append(point)
    return True
