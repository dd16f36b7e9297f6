"""The default cell's servo, end to end (docs/servo.md): the feedback lags the command while
moving, in_motion stays true until it has settled within 30 pulses, it comes to rest on the
command exactly; STOP_MOTION brings it to rest through the servo, an E-stop stops it dead."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest
import zenoh

from motocell.services.broadcaster.core.robot_status import IN_MOTION_PULSES
from motocell.shared.bus.schemas import CommandRequest, State, Tick
from motocell.shared.bus.session import call
from motocell.shared.protocol.constants import Command, Result
from motocell.testing.client import MotionClient, PlannedPoint, StateListener, stream
from motocell.testing.following import following_errors
from motocell.testing.processes import wait_until
from motocell.testing.running_cell import RunningCell, SampleLog, TickLog

pytestmark = pytest.mark.cell

SPEED = 0.5
"""rad/s on axis S: 29,335 pulses/s on arm6, so the default servo lags by about 630 pulses."""


@pytest.fixture
def states(cell: RunningCell, bus: zenoh.Session) -> Iterator[SampleLog[State]]:
    """Every ``state`` sample: commanded and feedback positions with in_motion, together."""
    log = SampleLog(bus, cell.keys.state, State)
    yield log
    log.subscriber.undeclare()


def ramp(start: tuple[float, ...], distance: float) -> list[PlannedPoint]:
    """Axis S at SPEED over ``distance`` rad, points 0.1 s apart, stopping dead at the end
    (the last point keeps the velocity): the command stops in one period."""
    speed = SPEED if distance > 0 else -SPEED
    count = round(abs(distance) / SPEED / 0.1) + 1
    return [
        PlannedPoint(
            0.1 * i,
            (start[0] + speed * 0.1 * i, *start[1:]),
            (speed, *([0.0] * (len(start) - 1))),
        )
        for i in range(count)
    ]


def at_rest(state: StateListener) -> tuple[float, ...]:
    return tuple(state.wait_still().groups[0].positions[:6])


def arrived(state: StateListener, axis_s: float) -> tuple[float, ...]:
    """At rest with axis S at ``axis_s`` (within half a pulse)."""
    return tuple(
        state.wait_for(
            lambda f: (
                f.status is not None
                and f.status.in_motion == 0
                and not any(f.groups[0].velocities)
                and abs(f.groups[0].positions[0] - axis_s) * 58670 < 0.5
            ),
            10.0,
        )
        .groups[0]
        .positions[:6]
    )


def error_pulses(state: State) -> int:
    group = state.groups[0]
    difference = np.subtract(group.command_positions, group.positions)
    return int(np.rint(np.abs(difference[0]) * 58670.0))


def test_the_feedback_lags_while_moving_and_settles_exactly(
    cell: RunningCell,
    motion: MotionClient,
    state: StateListener,
    states: SampleLog[State],
    ticks: TickLog,
) -> None:
    assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
    start = at_rest(state)
    first_state, first_tick = len(states), len(ticks)
    plan = ramp(start, 0.3)
    assert stream(motion, plan).points == len(plan)
    arrived(state, plan[-1].positions[0])

    moving = [t for t in ticks.since(first_tick) if any(t.groups[0].increment)]
    lags = [t.groups[0].command_pulses[0] - t.groups[0].feedback_pulses[0] for t in moving]
    assert max(lags) > 10 * IN_MOTION_PULSES, "the feedback lags the command"
    assert min(lags) >= 0, "and never leads it"
    (found,) = following_errors(cell.cell, ticks.since(first_tick))
    assert found.max_pulses[0] == max(lags)
    assert 0 < found.rms_pulses[0] < found.max_pulses[0]

    # in_motion holds after the command has stopped, until the feedback is within 30 pulses.
    seen = states.since(first_state)
    goal = seen[-1].groups[0].command_positions
    settling = [s for s in seen if s.groups[0].command_positions == goal and error_pulses(s) > 0]
    assert any(s.status.in_motion == 1 for s in settling)
    assert all(s.status.in_motion == 1 for s in settling if error_pulses(s) > IN_MOTION_PULSES)
    assert all(error_pulses(s) <= IN_MOTION_PULSES for s in seen if s.status.in_motion == 0)
    last = ticks.since(first_tick)[-1].groups[0]
    assert last.feedback_pulses == last.command_pulses, "the final error is 0 pulses"


def test_stop_motion_brings_the_feedback_to_rest_through_the_servo(
    motion: MotionClient, state: StateListener, ticks: TickLog
) -> None:
    assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
    start = at_rest(state)
    first_tick = len(ticks)
    plan = ramp(start, -0.5)
    assert stream(motion, plan[:5]).points == 5
    wait_until(
        lambda: any(any(t.groups[0].increment) for t in ticks.since(first_tick)),
        5.0,
        "the robot to move",
    )
    assert motion.command(Command.STOP_MOTION).result == Result.SUCCESS
    wait_until(
        lambda: not any(ticks.since(len(ticks) - 1)[0].groups[0].feedback_moved),
        5.0,
        "the feedback at rest",
    )
    after_stop = stopped_ticks(ticks.since(first_tick))
    frozen = after_stop[0].groups[0].command_pulses
    assert all(t.groups[0].command_pulses == frozen for t in after_stop)
    settling = [t for t in after_stop if t.groups[0].feedback_moved[0] != 0]
    assert len(settling) > 5, "not a stop in one tick"
    assert all(t.groups[0].feedback_pulses[0] >= frozen[0] for t in after_stop), "never past"
    assert after_stop[-1].groups[0].feedback_pulses == frozen


def fault(bus: zenoh.Session, key: str, *, on: bool) -> None:
    reply = call(bus, key, CommandRequest(value=int(on)))
    assert reply is not None and reply.result == Result.SUCCESS


def stopped_ticks(ticks: list[Tick]) -> list[Tick]:
    """The ticks from the first after the last commanded increment."""
    last = max(i for i, t in enumerate(ticks) if any(t.groups[0].increment))
    return ticks[last + 1 :]


def test_an_estop_stops_the_feedback_dead_and_servo_on_moves_nothing(
    cell: RunningCell,
    bus: zenoh.Session,
    motion: MotionClient,
    state: StateListener,
    ticks: TickLog,
) -> None:
    assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
    start = at_rest(state)
    first_tick = len(ticks)
    plan = ramp(start, 0.5)
    assert stream(motion, plan[:5]).points == 5
    wait_until(
        lambda: any(any(t.groups[0].increment) for t in ticks.since(first_tick)),
        5.0,
        "the robot to move",
    )
    estop = cell.keys.controller_fault("estop")
    fault(bus, estop, on=True)
    state.wait_for(lambda f: f.status is not None and f.status.e_stopped == 1, 5.0)

    def braked() -> list[Tick]:
        later = ticks.since(first_tick)
        off = [i for i, t in enumerate(later) if not t.motion_ready]
        return later[off[0] :] if off else []

    wait_until(lambda: len(braked()) >= 25, 5.0, "100 ms of ticks after the E-stop")
    after = braked()
    held = after[0].groups[0]
    assert held.command_pulses == held.feedback_pulses, "the command is set to the feedback"
    assert all(t.groups[0].feedback_pulses == held.feedback_pulses for t in after)
    assert all(not any(t.groups[0].feedback_moved) for t in after)

    fault(bus, estop, on=False)
    since = len(ticks)
    assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
    wait_until(
        lambda: any(t.motion_ready for t in ticks.since(since)), 5.0, "the executor ready again"
    )
    assert all(
        t.groups[0].command_pulses == held.command_pulses
        and t.groups[0].feedback_pulses == held.command_pulses
        for t in ticks.since(since)
    ), "servo on moved the robot"
