"""The points waiting for the feeder: at most the limit, the rest dropped and logged."""

from __future__ import annotations

from collections import deque

import pytest

from motocell.services.interpolator.core.pending import queue_point
from motocell.shared.bus.schemas import Point
from tests.services.interpolator.core.test_feeder import point


@pytest.mark.parametrize("limit", [3, 32])
def test_points_beyond_the_pending_limit_are_dropped(
    limit: int, caplog: pytest.LogCaptureFixture
) -> None:
    points: deque[Point] = deque()
    for n in range(limit):
        assert queue_point(points, point(n + 1, n, n * 0.1), limit)
    assert not caplog.records
    assert not queue_point(points, point(99, 99, 9.9), limit)
    assert len(points) == limit
    assert points[-1].point_id == limit
    assert [record.levelname for record in caplog.records] == ["ERROR"]
    assert f"more than {limit} points pending" in caplog.text
