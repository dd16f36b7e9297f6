"""The gateway's state table (``core/states.py``), row by row through the motion handler on a
fake cell: each test brings a group's trajectory into the row's state, makes the row's event
happen as a client and the cell would, and checks the state after it and the point's reply."""

from __future__ import annotations

from motocell.services.gateway.core.motion import MotionHandler
from motocell.services.gateway.core.states import (
    OUT_OF_SEQUENCE,
    TRANSITIONS,
    TrajectoryEvent,
    TrajectoryState,
)
from motocell.shared.protocol.constants import Command, Result
from motocell.shared.protocol.replies import motion_ctrl, traj_point
from tests.services.gateway.core.fake_cell import (
    NOW,
    FakeCell,
    exchange,
    gateway,
    slot,
    status,
    verdict_of,
)

ZEROS = (0.0,) * 6
OK = (int(Result.SUCCESS), 0)
NONE, RUNNING = TrajectoryState.NONE, TrajectoryState.RUNNING


def state_of(handler: MotionHandler) -> TrajectoryState:
    return handler.trajectories.tracks[0].state


def send(handler: MotionHandler, sequence: int, time: float) -> tuple[int, int]:
    """A JOINT_TRAJ_PT_FULL for group 0; its verdict."""
    return verdict_of(exchange(handler, traj_point(0, sequence, time, ZEROS, ZEROS)).reply)


def in_state(state: TrajectoryState) -> tuple[MotionHandler, FakeCell]:
    """A ready gateway whose group 0 has no trajectory, or runs one (sequence 0 taken)."""
    handler, cell = gateway()
    if state is RUNNING:
        assert send(handler, 0, 0.0) == OK
    assert state_of(handler) is state
    return handler, cell


def stop_motion(handler: MotionHandler, cell: FakeCell) -> None:
    cell.effects["executor/stop"] = cell.take_all
    reply = exchange(handler, motion_ctrl(Command.STOP_MOTION, 0)).reply
    assert verdict_of(reply) == OK


def readiness_blinks(cell: FakeCell) -> None:
    """A not-ready status between two requests, ready again by the next."""
    cell.state.on_status(status(ready=False), NOW)
    cell.state.on_status(status(), NOW)


def interpolator_drops_it(cell: FakeCell) -> None:
    """The interpolator took point 1 and runs no trajectory now (its ring was cleared)."""
    cell.state.on_slot(0, slot(taken=1, trajectory_id=0))


# -- STARTED -------------------------------------------------------------------------------
def test_none_started_runs_a_trajectory() -> None:
    handler, _ = in_state(NONE)
    assert send(handler, 0, 0.0) == OK
    assert state_of(handler) is RUNNING


def test_running_started_begins_the_trajectory_again() -> None:
    """Even one that ended unseen: the new sequence 0 is what later points continue."""
    handler, cell = in_state(RUNNING)
    assert send(handler, 1, 0.1) == OK
    readiness_blinks(cell)
    assert send(handler, 0, 0.0) == OK
    assert state_of(handler) is RUNNING
    assert handler.trajectories.tracks[0].start_id == 3
    cell.take_all(trajectory_id=3)
    assert send(handler, 1, 0.1) == OK


# -- LATER_POINT ---------------------------------------------------------------------------
def test_none_later_point_is_out_of_sequence() -> None:
    handler, cell = in_state(NONE)
    assert send(handler, 1, 0.1) == OUT_OF_SEQUENCE
    assert state_of(handler) is NONE
    assert cell.sent == []


def test_running_later_point_continues_it() -> None:
    handler, cell = in_state(RUNNING)
    assert send(handler, 1, 0.1) == OK
    assert state_of(handler) is RUNNING
    assert [sent.sequence for _, sent in cell.sent] == [0, 1]


# -- READINESS_DROPPED ---------------------------------------------------------------------
def test_none_readiness_dropped_stays_without_a_trajectory() -> None:
    handler, cell = in_state(NONE)
    readiness_blinks(cell)
    assert send(handler, 1, 0.1) == OUT_OF_SEQUENCE
    assert state_of(handler) is NONE
    assert send(handler, 0, 0.0) == OK


def test_running_readiness_dropped_ends_it() -> None:
    handler, cell = in_state(RUNNING)
    readiness_blinks(cell)
    assert send(handler, 1, 0.1) == OUT_OF_SEQUENCE
    assert state_of(handler) is NONE


# -- DROPPED_BY_INTERPOLATOR ---------------------------------------------------------------
def test_none_dropped_by_interpolator_stays_without_a_trajectory() -> None:
    handler, cell = in_state(RUNNING)
    stop_motion(handler, cell)
    interpolator_drops_it(cell)
    assert send(handler, 1, 0.1) == OUT_OF_SEQUENCE
    assert state_of(handler) is NONE


def test_running_dropped_by_interpolator_ends_it() -> None:
    handler, cell = in_state(RUNNING)
    interpolator_drops_it(cell)
    assert send(handler, 1, 0.1) == OUT_OF_SEQUENCE
    assert state_of(handler) is NONE


# -- STOPPED -------------------------------------------------------------------------------
def test_none_stopped_stays_without_a_trajectory() -> None:
    handler, cell = in_state(NONE)
    stop_motion(handler, cell)
    assert state_of(handler) is NONE
    assert send(handler, 0, 0.0) == OK


def test_running_stopped_ends_it() -> None:
    handler, cell = in_state(RUNNING)
    stop_motion(handler, cell)
    assert state_of(handler) is NONE
    assert send(handler, 1, 0.1) == OUT_OF_SEQUENCE


def test_every_state_takes_every_event() -> None:
    assert set(TRANSITIONS) == {(s, e) for s in TrajectoryState for e in TrajectoryEvent}
