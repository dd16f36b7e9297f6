"""A service that dies makes the cell NOT_READY with nothing moving, and the cell recovers."""

from __future__ import annotations

import os
import signal

import pytest

from motocell.shared.protocol.constants import Command, NotReadySubcode, Result
from motocell.testing.client import smooth_move, stream
from motocell.testing.processes import wait_until
from motocell.testing.running_cell import running_cell

pytestmark = pytest.mark.cell


@pytest.mark.parametrize("service", ["interpolator", "executor"])
def test_killed_service_is_restarted_and_the_cell_is_not_ready_meanwhile(service: str) -> None:
    with running_cell() as cell, cell.motion() as motion, cell.state() as state:
        state.wait_for(lambda f: f.status is not None, 10.0)
        assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
        (victim,) = cell.service_pids(service)

        os.kill(victim, signal.SIGKILL)

        def not_ready() -> bool:
            reply = motion.command(Command.CHECK_MOTION_READY)
            return (reply.result, reply.subcode) == (Result.FALSE, NotReadySubcode.INC_MOVE_ERROR)

        wait_until(not_ready, 5.0, "NOT_READY 5012 after the kill")
        state.wait_for(lambda f: f.status is not None and f.status.motion_possible == 0, 5.0)

        wait_until(
            lambda: bool(cell.service_pids(service) - {victim}), 10.0, f"{service} restarted"
        )
        wait_until(
            lambda: motion.command(Command.CHECK_MOTION_READY).result == Result.TRUE,
            15.0,
            "motion-ready again",
        )
        latest = state.latest()
        assert latest is not None
        start = latest.groups[0].positions[:6]
        result = stream(motion, smooth_move(start, tuple(p + 0.05 for p in start), 0.3, 4))
        assert result.points == 4, result.last_reply
