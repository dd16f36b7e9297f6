"""An FS100 cell speaks big-endian end to end; a client with the wrong byte order is refused
cleanly (every frame INVALID), never crashes the gateway."""

from __future__ import annotations

import numpy as np
import pytest

from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.protocol.codec import ByteOrder, Role, decode_frames
from motocell.shared.protocol.constants import Command, InvalidSubcode, Result
from motocell.shared.protocol.messages import MotoMotionReply
from motocell.shared.protocol.replies import motion_ctrl
from motocell.testing.client import MotionClient, smooth_move, stream
from motocell.testing.running_cell import RunningCell

pytestmark = [
    pytest.mark.cell,
    pytest.mark.parametrize("cell", ["fs100.toml"], indirect=True),
]


def test_fs100_cell_is_big_endian_end_to_end(cell: RunningCell) -> None:
    assert cell.byte_order is ByteOrder.BIG
    axis_map = AxisMap(cell.cell.groups[0])
    with cell.motion() as motion, cell.state() as state:
        assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
        still = state.wait_still()
        assert still.status is not None and still.status.mode == 2
        start = still.groups[0].positions[:6]
        goal = tuple(p - 0.2 for p in start)
        assert stream(motion, smooth_move(start, goal, 0.6, 7)).points == 7
        goal_pulses = axis_map.ros_to_pulses(np.array(goal))
        state.wait_for(
            lambda f: (
                f.status is not None
                and f.status.in_motion == 0
                and np.array_equal(
                    axis_map.ros_to_pulses(np.array(f.groups[0].positions[:6])), goal_pulses
                )
            ),
            10.0,
        )
    # A little-endian client's length prefix reads as about 1 GB: INVALID 3001 in the
    # controller's byte order, and the gateway keeps serving.
    with MotionClient(cell.host, cell.port_base, ByteOrder.LITTLE) as wrong:
        wrong.send(motion_ctrl(Command.CHECK_MOTION_READY))
        wrong.sock.settimeout(5.0)
        replies = decode_frames(wrong.sock.recv(4096), Role.CLIENT, ByteOrder.BIG)
    assert len(replies) == 1 and isinstance(replies[0].body, MotoMotionReply)
    assert (replies[0].body.result, replies[0].body.subcode) == (
        Result.INVALID,
        InvalidSubcode.MSGSIZE,
    )
    with cell.motion() as motion:
        assert motion.command(Command.CHECK_MOTION_READY).result == Result.TRUE
