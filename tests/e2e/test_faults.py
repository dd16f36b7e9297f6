"""Faults injected while the robot moves: motion stops within one period and never resumes
on its own; the next point is refused with the right NOT_READY subcode; recovery works."""

from __future__ import annotations

from dataclasses import dataclass

import pytest
import zenoh

from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import CommandRequest, Tick
from motocell.shared.bus.session import call
from motocell.shared.protocol.constants import Command, NotReadySubcode, Result
from motocell.shared.protocol.replies import traj_point
from motocell.testing.client import MotionClient, StateListener, smooth_move, stream
from motocell.testing.processes import wait_until
from motocell.testing.running_cell import RunningCell, TickLog

pytestmark = pytest.mark.cell


@dataclass(frozen=True)
class Fault:
    kind: str
    inject: CommandRequest
    clear: CommandRequest
    subcode: NotReadySubcode
    needs_reset: bool = False


FAULTS = [
    Fault("estop", CommandRequest(value=1), CommandRequest(value=0), NotReadySubcode.ESTOP),
    Fault("hold", CommandRequest(value=1), CommandRequest(value=0), NotReadySubcode.HOLD),
    Fault(
        "alarm",
        CommandRequest(value=1, args=[4100, 2]),
        CommandRequest(value=0),
        NotReadySubcode.ALARM,
        needs_reset=True,
    ),
    Fault(
        "error",
        CommandRequest(value=1, args=[2010]),
        CommandRequest(value=0),
        NotReadySubcode.ERROR,
        needs_reset=True,
    ),
    Fault("servo", CommandRequest(value=0), CommandRequest(value=1), NotReadySubcode.SERVO_OFF),
    Fault("play", CommandRequest(value=0), CommandRequest(value=1), NotReadySubcode.NOT_PLAY),
    Fault("remote", CommandRequest(value=0), CommandRequest(value=1), NotReadySubcode.NOT_REMOTE),
    Fault("pfl", CommandRequest(value=1), CommandRequest(value=0), NotReadySubcode.PFL_ACTIVE),
    Fault("ot889", CommandRequest(value=0), CommandRequest(value=1), NotReadySubcode.WAITING_ROS),
]


def position(state: StateListener) -> tuple[float, ...]:
    """Where the robot stands, once it stands still (as a client checks before planning)."""
    return tuple(state.wait_still().groups[0].positions[:6])


@pytest.mark.parametrize("fault", FAULTS, ids=[f.kind for f in FAULTS])
def test_fault_during_motion_stops_everything_and_recovery_works(
    cell: RunningCell,
    bus: zenoh.Session,
    ticks: TickLog,
    motion: MotionClient,
    state: StateListener,
    fault: Fault,
) -> None:
    keys = cell.keys
    assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
    start = position(state)
    goal = tuple(p + 0.5 for p in start)
    result = stream(motion, smooth_move(start, goal, 2.0, 9))
    assert result.points == 9, result.last_reply
    assert motion.command(Command.CHECK_QUEUE_CNT).subcode > 0, "still moving"

    moving_from = len(ticks)
    assert all(t.motion_ready for t in ticks.since(moving_from - 5))
    reply = call(bus, keys.controller_fault(fault.kind), fault.inject)
    assert reply is not None and reply.result == Result.SUCCESS

    # The first tick that saw motion-ready gone: from it on, nothing moves.
    def stopped() -> list[Tick]:
        later = ticks.since(moving_from)
        seen = [i for i, t in enumerate(later) if not t.motion_ready]
        return later[seen[0] :] if seen else []

    state.wait_for(lambda f: f.status is not None and f.status.motion_possible == 0, 5.0)
    wait_until(lambda: len(stopped()) >= 25, 5.0, "100 ms of ticks after the fault")
    after = stopped()
    frozen = after[0].groups[0].command_pulses
    assert all(t.groups[0].command_pulses == frozen for t in after)
    assert all(not any(t.groups[0].increment) for t in after)
    assert frozen != ticks.since(moving_from - 5)[0].groups[0].command_pulses, "it moved"

    reply_cnt = motion.command(Command.CHECK_QUEUE_CNT)
    assert (reply_cnt.result, reply_cnt.subcode) == (Result.SUCCESS, 0)
    here = position(state)
    refused = motion.motion(traj_point(0, 0, 0.0, here, (0.0,) * 6))
    assert (refused.result, refused.subcode) == (Result.NOT_READY, fault.subcode)
    ready = motion.command(Command.CHECK_MOTION_READY)
    assert (ready.result, ready.subcode) == (Result.FALSE, fault.subcode)

    recover(motion, bus, keys, fault)
    here = position(state)
    result = stream(motion, smooth_move(here, tuple(p - 0.1 for p in here), 0.4, 5))
    assert result.points == 5, result.last_reply


def recover(motion: MotionClient, bus: zenoh.Session, keys: CellKeys, fault: Fault) -> None:
    reply = call(bus, keys.controller_fault(fault.kind), fault.clear)
    assert reply is not None and reply.result == Result.SUCCESS
    if fault.needs_reset:
        assert motion.command(Command.RESET_ALARM).result == Result.SUCCESS
    started = motion.command(Command.START_TRAJ_MODE)
    assert (started.result, started.subcode) == (Result.SUCCESS, 0)
