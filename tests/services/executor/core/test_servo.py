"""ExecutorCore with servos: the ticks carry the feedback the servo model gives, stops bring it
to rest through the servo, and servo off freezes it with the command set to it."""

from __future__ import annotations

from motocell.services.executor.core.executor import ExecutorCore
from motocell.shared.config import PositionLoop
from motocell.shared.motion.servo import Servos
from tests.services.executor.core.test_executor import FIRST_EPOCH, batch, set_ready, status, unit

PERIOD_S = 0.004
START = [[0] * 8]
STEP = 300
"""Axis-0 pulses per period of the test trajectories."""


def moving_core(entries: int = 50, limit: int = 100_000) -> ExecutorCore:
    """A ready one-group core with the default position loop, ``entries`` ramp entries and
    every axis's range ``limit`` pulses either side of 0."""
    core = ExecutorCore(
        START,
        FIRST_EPOCH,
        ranges=[([-limit] * 8, [limit] * 8)],
        servos=Servos([PositionLoop()], PERIOD_S, START),
    )
    set_ready(core, True)
    core.accept(0, batch(FIRST_EPOCH, 0, [unit(STEP)] * entries))
    return core


def axis0(core: ExecutorCore) -> tuple[int, int, float]:
    """(commanded, feedback, feedback moved) of axis 0 in this tick's report."""
    (group,) = core.group_ticks()
    return group.command_pulses[0], group.feedback_pulses[0], group.feedback_moved[0]


def test_the_feedback_lags_the_command_while_moving_and_reaches_it_at_rest() -> None:
    core = moving_core()
    for _ in range(50):
        core.step()
        command, feedback, moved = axis0(core)
        assert 0 < feedback < command
        assert moved > 0
    assert command == 50 * STEP
    for _ in range(500):
        core.step()
        if axis0(core) == (command, command, 0.0):
            break
    assert axis0(core) == (command, command, 0.0)


def test_stop_motion_brings_the_feedback_to_rest_through_the_servo() -> None:
    """STOP_MOTION (every ring cleared): the command freezes at once, the feedback keeps
    moving toward it for several periods, never past it, and ends on it exactly."""
    core = moving_core()
    for _ in range(30):
        core.step()
    core.clear_all()
    core.step()
    frozen, feedback, moved = axis0(core)
    assert frozen == 30 * STEP
    assert moved > STEP / 2, "no stop in one period"
    periods = 0
    while axis0(core)[2] != 0.0:
        core.step()
        periods += 1
        command, feedback, _ = axis0(core)
        assert command == frozen
        assert feedback <= frozen
    assert periods > 10
    assert axis0(core) == (frozen, frozen, 0.0)


def test_servo_off_freezes_the_feedback_and_the_command_follows_it() -> None:
    """E-stop: the axis stops where it is in the tick that learns it; the command is set to the
    feedback, so the servo coming on again moves nothing."""
    core = moving_core()
    for _ in range(30):
        core.step()
    _, feedback_before, _ = axis0(core)
    core.on_status(status(False, servo_on=False), 0)
    core.step()
    command, feedback, moved = axis0(core)
    assert command == feedback
    assert abs(feedback - feedback_before) <= 1
    assert moved == 0.0
    assert core.queue_state(0).command_pulses[0] == feedback, "what START_TRAJ_MODE reads"
    core.on_status(status(False), 0)
    for _ in range(20):
        core.step()
        assert axis0(core) == (command, command, 0.0)


def test_the_feedback_stays_within_the_joint_range() -> None:
    """A ramp that ends exactly on a limit: the feedback approaches it from inside."""
    upper = 40 * STEP
    core = moving_core(entries=40, limit=upper)
    for _ in range(400):
        assert not core.step()
        command, feedback, _ = axis0(core)
        assert feedback <= command <= upper
    assert axis0(core) == (upper, upper, 0.0)
