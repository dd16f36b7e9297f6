"""motocell's deeper pending-point FIFO (``pending_points``, docs/behaviour.md "Pending points"):
with 4, a client streaming without waiting gets SUCCESS for several points in a row while its
interpolator has not taken the first of them, where MotoROS's one pending point answers BUSY.

The first segment is made far longer than the executor's ring (60 s of motion, 15,000 entries
for 200 places), so its point stays untaken for the whole test: the condition the test relies
on holds by construction, not by timing."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from motocell.shared.protocol.constants import Command, Result
from motocell.shared.protocol.messages import Message
from motocell.shared.protocol.replies import ex_group, traj_point, traj_point_ex
from motocell.testing.client import MotionClient, StateListener
from motocell.testing.processes import wait_until
from motocell.testing.running_cell import RunningCell, running_cell

pytestmark = pytest.mark.cell

GROUPS = (0, 1)
AXES = 6
LONG_SEGMENT_S = 60.0
STILL = (0.0,) * AXES


@pytest.fixture(scope="module")
def cell(tmp_path_factory: pytest.TempPathFactory) -> Iterator[RunningCell]:
    path: Path = tmp_path_factory.mktemp("pending") / "cell.toml"
    path.write_text('pending_points = 4\n\n[[groups]]\nname = "R1"\n\n[[groups]]\nname = "R2"\n')
    with running_cell(path) as running:
        yield running


def positions(state: StateListener) -> dict[int, tuple[float, ...]]:
    """Where each group stands, once the robot stands still."""
    still = state.wait_still()
    return {group: tuple(still.groups[group].positions[:AXES]) for group in GROUPS}


def nudged(position: tuple[float, ...], by: float) -> tuple[float, ...]:
    return (position[0] + by, *position[1:])


def a_long_first_segment_is_in_the_ring(motion: MotionClient, first: list[Message]) -> None:
    """Send sequence 0 and a first segment the ring cannot hold, and wait until its entries
    flow: the interpolator took sequence 0 and now waits for room, its slot full for minutes."""
    assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
    for message in first:
        assert motion.motion(message).result == Result.SUCCESS
    wait_until(
        lambda: motion.command(Command.CHECK_QUEUE_CNT).subcode > 0,
        10.0,
        "the first segment's entries in the ring",
    )


def test_type_14_points_are_accepted_four_deep_while_the_first_is_not_taken(
    motion: MotionClient, state: StateListener
) -> None:
    start = positions(state)[0]
    a_long_first_segment_is_in_the_ring(
        motion,
        [
            traj_point(0, 0, 0.0, start, STILL),
            traj_point(0, 1, LONG_SEGMENT_S, nudged(start, 0.01), STILL),
        ],
    )
    results = [
        motion.motion(traj_point(0, sequence, LONG_SEGMENT_S + 0.1 * sequence, start, STILL))
        for sequence in range(2, 6)
    ]
    # Outstanding before each: 1, 2 and 3 points (the first segment's among them), then 4.
    assert [reply.result for reply in results] == [Result.SUCCESS] * 3 + [Result.BUSY]
    assert motion.command(Command.STOP_MOTION).result == Result.SUCCESS


def test_2016_points_are_accepted_four_deep_for_every_group(
    motion: MotionClient, state: StateListener
) -> None:
    start = positions(state)

    def point(sequence: int, time: float, by: float = 0.0) -> Message:
        groups = [ex_group(g, time, nudged(start[g], by), STILL) for g in GROUPS]
        return traj_point_ex(sequence, groups)

    a_long_first_segment_is_in_the_ring(motion, [point(0, 0.0), point(1, LONG_SEGMENT_S, by=0.01)])
    results = [
        motion.motion(point(sequence, LONG_SEGMENT_S + 0.1 * sequence)) for sequence in range(2, 6)
    ]
    assert [reply.result for reply in results] == [Result.SUCCESS] * 3 + [Result.BUSY]
    assert motion.command(Command.STOP_MOTION).result == Result.SUCCESS
