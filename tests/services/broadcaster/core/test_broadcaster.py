"""The broadcaster's core: numbered snapshots on the ticks, with the controller as it is; beats
without ticks (at rest, silence); what observers get besides; where a restarted executor resumes."""

from __future__ import annotations

import pytest

from motocell.services.broadcaster.core.broadcaster import Broadcaster
from motocell.services.broadcaster.core.joints import JointStates
from motocell.services.broadcaster.core.states import Pacing
from motocell.shared.bus.liveness import AT_REST_HEARTBEAT_S
from motocell.shared.protocol.constants import Result
from tests.services.broadcaster.scripted import (
    MS,
    FakeController,
    cell,
    group_tick,
    resting_tick,
    status,
    tick,
)


def test_snapshots_are_numbered_from_one() -> None:
    broadcaster = Broadcaster(cell(state_period_ms=4), FakeController())
    states = [broadcaster.on_tick(tick(n, n * 4 * MS), 0.0) for n in range(3)]
    assert [s.seq for s in states if s is not None] == [1, 2, 3]


def test_a_tick_that_is_not_due_sends_nothing_and_asks_nothing() -> None:
    controller = FakeController()
    broadcaster = Broadcaster(cell(), controller)
    assert broadcaster.on_tick(tick(1, 0), 0.0) is not None
    assert broadcaster.on_tick(tick(2, 4 * MS), 0.0) is None
    assert controller.asked == 1
    assert broadcaster.seq == 1


def test_ten_millisecond_state_on_four_millisecond_ticks() -> None:
    broadcaster = Broadcaster(cell(period_ms=4, state_period_ms=10), FakeController())
    sent = [n for n in range(251) if broadcaster.on_tick(tick(n, n * 4 * MS), 0.0) is not None]
    assert len(sent) == 101
    assert sent[:5] == [0, 3, 5, 8, 10]


def test_the_snapshot_carries_the_tick_and_its_actual_time() -> None:
    broadcaster = Broadcaster(cell(), FakeController())
    state = broadcaster.on_tick(tick(42, 1000 * MS, lateness_ns=150_000), 0.0)
    assert state is not None
    assert state.tick == 42
    assert state.tick_ns == 1000 * MS + 150_000


def test_the_snapshot_carries_the_controller_status_when_due() -> None:
    controller = FakeController(status(estop=True, servo_on=False))
    state = Broadcaster(cell(), controller).on_tick(tick(), 0.0)
    assert state is not None
    assert (state.status.e_stopped, state.status.drives_powered) == (1, 0)


def test_a_missing_status_gives_unknown_fields() -> None:
    state = Broadcaster(cell(), FakeController(status=None)).on_tick(tick(), 0.0)
    assert state is not None
    assert state.status.drives_powered == -1
    assert state.status.motion_possible == 0


def test_a_dead_controller_gives_unknown_fields() -> None:
    state = Broadcaster(cell(), FakeController(alive=False)).on_tick(tick(), 0.0)
    assert state is not None
    assert state.status.mode == -1


def test_nothing_to_send_before_any_tick() -> None:
    broadcaster = Broadcaster(cell(), FakeController())
    assert broadcaster.pacing is Pacing.WAITING
    assert broadcaster.on_wake(100.0, clients=True) is None
    assert broadcaster.next_wake(100.0, clients=True) is None


def test_silence_repeats_the_last_tick_with_the_controller_as_it_is_now() -> None:
    controller = FakeController()
    broadcaster = Broadcaster(cell(), controller)
    broadcaster.on_tick(tick(7, 0, group_tick([58670] + [0] * 7)), 10.0)
    assert broadcaster.next_wake(10.0, clients=True) == 10.0 + broadcaster.silence_s
    assert broadcaster.on_wake(10.0 + broadcaster.silence_s / 2, clients=True) is None
    controller.present = False
    state = broadcaster.on_wake(10.0 + broadcaster.silence_s, clients=True)
    assert broadcaster.pacing is Pacing.SILENT
    assert state is not None
    assert (state.seq, state.tick) == (2, 7)
    assert state.groups[0].positions[0] == pytest.approx(1.0)
    assert state.status.motion_possible == 0


def test_silent_beats_come_every_silence_s_until_a_tick() -> None:
    broadcaster = Broadcaster(cell(), FakeController())
    broadcaster.on_tick(tick(1, 0), 0.0)
    silence = broadcaster.silence_s
    beats = [
        t
        for t in (silence, 1.5 * silence, 2 * silence, 3 * silence)
        if broadcaster.on_wake(t, clients=False) is not None
    ]
    assert beats == [silence, 2 * silence, 3 * silence]
    broadcaster.on_tick(tick(2, 4 * MS), 4 * silence)
    assert broadcaster.pacing is Pacing.TICKS


def test_a_tick_that_is_not_due_still_becomes_the_one_silence_repeats() -> None:
    broadcaster = Broadcaster(cell(), FakeController())
    broadcaster.on_tick(tick(1, 0), 0.0)
    broadcaster.on_tick(tick(2, 4 * MS), 0.004)
    state = broadcaster.on_wake(1.0, clients=True)
    assert state is not None
    assert state.tick == 2


def test_the_tick_before_a_rest_is_always_sent() -> None:
    broadcaster = Broadcaster(cell(state_period_ms=100), FakeController())
    broadcaster.on_tick(tick(1, 0), 0.0)
    state = broadcaster.on_tick(resting_tick(2), 0.004)  # not due on the schedule
    assert state is not None
    assert broadcaster.pacing is Pacing.AT_REST


def test_at_rest_clients_get_a_state_every_state_period() -> None:
    broadcaster = Broadcaster(cell(state_period_ms=10), FakeController())
    broadcaster.on_tick(resting_tick(), 5.0)
    times = [5.0 + 0.001 * ms for ms in range(1, 51)]
    sent = [t for t in times if broadcaster.on_wake(t, clients=True) is not None]
    assert sent == pytest.approx([5.01, 5.02, 5.03, 5.04, 5.05])
    assert broadcaster.next_wake(5.05, clients=True) == pytest.approx(5.06)


def test_at_rest_without_clients_observers_get_one_state_a_second() -> None:
    """The executor's resting tick, again every rest heartbeat, is the observers' beat; the
    broadcaster beats by itself only when one does not come."""
    broadcaster = Broadcaster(cell(state_period_ms=10), FakeController())
    silence = broadcaster.silence_s
    sent = []
    for resent in (0.0, AT_REST_HEARTBEAT_S, 2 * AT_REST_HEARTBEAT_S):
        for wake in (resent + 0.01, resent + AT_REST_HEARTBEAT_S / 2):
            if broadcaster.on_wake(wake, clients=False) is not None:
                sent.append(wake)
        if broadcaster.on_tick(resting_tick(), resent + AT_REST_HEARTBEAT_S) is not None:
            sent.append(resent + AT_REST_HEARTBEAT_S)
    assert sent == pytest.approx([1.0, 2.0, 3.0])
    gone = 3.0 + AT_REST_HEARTBEAT_S + silence  # no resting tick since: the executor went
    assert broadcaster.next_wake(3.0, clients=False) == pytest.approx(gone)
    assert broadcaster.on_wake(gone, clients=False) is not None
    following = gone + AT_REST_HEARTBEAT_S
    assert broadcaster.next_wake(gone, clients=False) == pytest.approx(following)


def test_a_client_connecting_at_rest_gets_a_state_at_once() -> None:
    broadcaster = Broadcaster(cell(state_period_ms=10), FakeController())
    broadcaster.on_tick(resting_tick(), 0.0)
    assert broadcaster.on_wake(0.01, clients=False) is None  # observers only: next beat later
    assert broadcaster.next_wake(0.3, clients=True) == pytest.approx(0.3)
    assert broadcaster.on_wake(0.3, clients=True) is not None
    assert broadcaster.on_wake(0.305, clients=True) is None
    assert broadcaster.on_wake(0.31, clients=True) is not None


def test_the_first_tick_after_a_rest_ends_the_beats() -> None:
    broadcaster = Broadcaster(cell(), FakeController())
    broadcaster.on_tick(resting_tick(), 0.0)
    broadcaster.on_tick(tick(300, 300 * 4 * MS), 2.0)
    assert broadcaster.pacing is Pacing.TICKS
    assert broadcaster.next_wake(2.0, clients=True) == 2.0 + broadcaster.silence_s


@pytest.mark.parametrize(("state_period_ms", "silence_s"), [(4, 0.05), (10, 0.05), (100, 0.3)])
def test_silence_is_three_state_periods_but_never_under_fifty_ms(
    state_period_ms: float, silence_s: float
) -> None:
    broadcaster = Broadcaster(cell(state_period_ms=state_period_ms), FakeController())
    assert broadcaster.silence_s == pytest.approx(silence_s)


def test_the_broadcaster_knows_whether_motion_is_queued_from_the_newest_tick() -> None:
    broadcaster = Broadcaster(cell(), FakeController())
    assert not broadcaster.motion_queued()
    broadcaster.on_tick(tick(1, 0, group_tick(depth=3)), 0.0)
    assert broadcaster.motion_queued()
    broadcaster.on_tick(tick(2, 4 * MS), 0.0)
    assert not broadcaster.motion_queued()


def test_the_snapshot_for_the_state_port_has_no_poses() -> None:
    """The TCP clients' frames carry joints only: the poses come after their send."""
    state = Broadcaster(cell(), FakeController()).on_tick(tick(), 0.0)
    assert state is not None
    assert state.groups[0].flange is None


def test_the_commanded_joints_are_converted_for_observers_only() -> None:
    """The frames carry the feedback; the commanded joints are the ``state`` sample's, added
    with the poses, the same as the whole conversion gives."""
    lagging = group_tick(command=[58670] + [0] * 7, feedback=[0] * 8, increment=[5] + [0] * 7)
    broadcaster = Broadcaster(cell(), FakeController())
    state = broadcaster.on_tick(tick(1, 0, lagging), 0.0)
    assert state is not None
    (frames_only,) = state.groups
    assert frames_only.command_positions == frames_only.command_velocities == []
    (observed,) = broadcaster.for_observers(state).groups
    (whole,) = JointStates(cell()).groups(tick(1, 0, lagging))
    assert observed.command_positions == whole.command_positions
    assert observed.command_positions[0] == pytest.approx(1.0)
    assert observed.command_velocities == whole.command_velocities
    assert (observed.positions, observed.velocities) == (whole.positions, whole.velocities)
    assert (frames_only.positions, frames_only.velocities) == (whole.positions, whole.velocities)


def test_a_restarted_executor_resumes_where_the_newest_tick_left_the_robot() -> None:
    broadcaster = Broadcaster(cell("arm6", "positioner2"), FakeController())
    assert broadcaster.positions().result == Result.FAILURE  # no tick yet
    command = [[1, 2, 3, 4, 5, 6, 0, 0], [7, 8, 0, 0, 0, 0, 0, 0]]
    broadcaster.on_tick(tick(5, 0, *(group_tick(pulses) for pulses in command)), 0.0)
    reply = broadcaster.positions()
    assert (reply.result, reply.pulses) == (Result.SUCCESS, command)
