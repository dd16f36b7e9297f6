"""Joint soft limits on a running cell: a trajectory past an axis's range stops at the limit,
the state port never shows the axis beyond it, ROBOT_STATUS shows alarm 4416, and the robot
moves again after RESET_ALARM (or START_TRAJ_MODE) with a trajectory from where it stopped."""

from __future__ import annotations

import pytest

from motocell.shared.config import load_catalogue
from motocell.shared.protocol.constants import Command, NotReadySubcode, Result
from motocell.shared.protocol.replies import traj_point
from motocell.testing.client import Feedback, MotionClient, StateListener, smooth_move, stream
from motocell.testing.running_cell import TickLog

pytestmark = pytest.mark.cell

SOFT_LIMIT_ALARM = 4416
ARM6 = load_catalogue()["arm6"]


def limit_pulses(axis: int, side: int) -> int:
    """The limit as the executor holds it: the range in radians rounded to whole pulses."""
    return round(ARM6.joint_limits[axis][side] * ARM6.pulses_per_unit[axis])


def positions(state: StateListener) -> tuple[float, ...]:
    return tuple(state.wait_still().groups[0].positions[:6])


def drive_past(
    motion: MotionClient, state: StateListener, ticks: TickLog, axis: int, target: float
) -> tuple[list[Feedback], dict[int, int]]:
    """Stream a move of ``axis`` to ``target`` (beyond its range) until the alarm shows; the
    state cycles and the commanded pulses of ``axis`` of each tick seen meanwhile, by tick."""
    assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
    start = positions(state)
    goal = tuple(target if i == axis else p for i, p in enumerate(start))
    first_cycle, first_tick = len(state.cycles), len(ticks)
    stream(motion, smooth_move(start, goal, 1.5, 9))
    alarmed = state.wait_for(
        lambda f: f.status is not None and f.status.error_code == SOFT_LIMIT_ALARM, 10.0
    )
    assert alarmed.status is not None and alarmed.status.in_error == 1
    assert alarmed.status.motion_possible == 0
    state.wait_still()
    commanded = {tick.tick: tick.groups[0].command_pulses[axis] for tick in ticks.since(first_tick)}
    return state.cycles[first_cycle:], commanded


def assert_stopped_at_the_limit(
    cycles: list[Feedback], commanded: dict[int, int], axis: int, side: int
) -> None:
    limit = limit_pulses(axis, side)

    def beyond(pulses: int) -> bool:
        return pulses > limit if side == 1 else pulses < limit

    assert not any(beyond(p) for p in commanded.values()), "the axis passed its limit"
    reported = [f.groups[0].positions[axis] * ARM6.pulses_per_unit[axis] for f in cycles]
    assert not any(beyond(round(p)) for p in reported), "feedback beyond the limit"
    # It stopped within one period's move of the limit, not somewhere before. The alarm then
    # turns the servo off, which sets the command to the lagging feedback (docs/servo.md).
    most = ARM6.max_speed[axis] * 0.004 * ARM6.pulses_per_unit[axis]
    nearest = max if side == 1 else min
    furthest_tick = nearest(commanded, key=lambda tick: commanded[tick])
    # Ticks are a latest-value stream (a full queue drops one, never stalls the clock): each
    # tick the log missed right after the furthest one seen may have moved one period more.
    later = [tick for tick in commanded if tick > furthest_tick]
    unseen = min(later, default=furthest_tick + 1) - furthest_tick - 1
    assert abs(commanded[furthest_tick] - limit) <= most * (1 + unseen)


def assert_motion_refused(motion: MotionClient, here: tuple[float, ...]) -> None:
    refused = motion.motion(traj_point(0, 0, 0.0, here, (0.0,) * 6))
    assert (refused.result, refused.subcode) == (Result.NOT_READY, NotReadySubcode.ALARM)


def move_back_exactly(motion: MotionClient, state: StateListener, goal: tuple[float, ...]) -> None:
    here = positions(state)
    result = stream(motion, smooth_move(here, goal, 1.0, 5))
    assert result.points == 5, result.last_reply
    final = state.wait_for(
        lambda f: (
            f.status is not None
            and f.status.in_motion == 0
            and all(
                abs(p - g) * ppu <= 0.5
                for p, g, ppu in zip(
                    f.groups[0].positions[:6], goal, ARM6.pulses_per_unit, strict=True
                )
            )
        ),
        10.0,
    )
    assert final.status is not None and final.status.in_error == 0


def test_a_trajectory_past_the_upper_limit_stops_there_until_reset_alarm(
    motion: MotionClient, state: StateListener, ticks: TickLog
) -> None:
    cycles, commanded = drive_past(motion, state, ticks, axis=0, target=3.3)
    assert_stopped_at_the_limit(cycles, commanded, axis=0, side=1)
    here = positions(state)
    assert_motion_refused(motion, here)

    assert motion.command(Command.RESET_ALARM).result == Result.SUCCESS
    state.wait_for(lambda f: f.status is not None and f.status.in_error == 0, 5.0)
    started = motion.command(Command.START_TRAJ_MODE)
    assert (started.result, started.subcode) == (Result.SUCCESS, 0)
    move_back_exactly(motion, state, (1.0, *here[1:]))


def test_start_traj_mode_alone_recovers_from_the_lower_limit(
    motion: MotionClient, state: StateListener, ticks: TickLog
) -> None:
    cycles, commanded = drive_past(motion, state, ticks, axis=1, target=-1.5)
    assert_stopped_at_the_limit(cycles, commanded, axis=1, side=0)
    here = positions(state)
    assert_motion_refused(motion, here)

    started = motion.command(Command.START_TRAJ_MODE)
    assert (started.result, started.subcode) == (Result.SUCCESS, 0)
    move_back_exactly(motion, state, (here[0], -0.5, *here[2:]))
