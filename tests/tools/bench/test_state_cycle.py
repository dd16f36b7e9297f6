"""The broadcaster's per-cycle benchmark times real snapshots and frames of four moving groups."""

from __future__ import annotations

from motocell.services.broadcaster.core.broadcaster import Broadcaster
from motocell.services.broadcaster.core.frames import state_frames
from motocell.shared.protocol.codec import ByteOrder
from motocell.tools.bench.state_cycle import ReadyController, four_groups, measure, moving_ticks


def test_every_tick_is_a_snapshot_of_four_moving_groups() -> None:
    cell = four_groups()
    broadcaster = Broadcaster(cell, ReadyController())
    ticks = moving_ticks(3, len(cell.groups))
    first, *_, last = [broadcaster.on_tick(tick, 0.0) for tick in ticks]
    assert first is not None and last is not None
    assert last.status.in_motion == 1 and last.status.motion_possible == 1
    frames = state_frames(last, ByteOrder.LITTLE)
    assert len(frames) == 4 + 2  # JOINT_FEEDBACK per group, JOINT_FEEDBACK_EX, ROBOT_STATUS
    assert frames != state_frames(first, ByteOrder.LITTLE)  # the robot moved between them


def test_measure_gives_one_positive_value_per_repeat() -> None:
    for period_s in (0.0, 0.001):
        values = measure(cycles=20, repeats=3, period_s=period_s)
        assert len(values) == 3
        assert all(value > 0 for value in values)
