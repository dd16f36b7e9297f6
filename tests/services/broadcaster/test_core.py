"""The broadcaster's core: the snapshot schedule on ticks, feedback in ROS order, ROBOT_STATUS."""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import msgspec
import pytest

from motocell.services.broadcaster.core import (
    IN_MOTION_PULSES,
    MAX_STATE_CLIENTS,
    Admission,
    Broadcaster,
    Feedback,
    Pacing,
    Schedule,
    admission,
    in_motion,
    queued,
    robot_status,
)
from motocell.shared.bus.liveness import AT_REST_HEARTBEAT_S
from motocell.shared.bus.schemas import Alarm, ControllerStatus, GroupTick, State, Tick
from motocell.shared.config import Cell, parse_cell
from motocell.shared.protocol.constants import Result
from motocell.testing.statuses import ready_status

MS = 1_000_000
ARM6_PPU = (58670.0, 58670.0, 58670.0, 32594.0, 32594.0, 21990.0)
ARM7_PPU = (65536.0, 65536.0, 65536.0, 65536.0, 36408.0, 36408.0, 24576.0)
"""ROS order S-L-E-U-R-B-T, from shared/models.toml."""


def cell(*models: str, period_ms: float = 4.0, state_period_ms: float = 10.0) -> Cell:
    groups = [{"name": f"G{i}", "model": model} for i, model in enumerate(models or ("arm6",))]
    return parse_cell(
        {
            "interpolation_period_ms": period_ms,
            "state_period_ms": state_period_ms,
            "groups": groups,
        }
    )


def group_tick(
    command: Sequence[int] = (0,) * 8,
    feedback: Sequence[int] | None = None,
    increment: Sequence[int] = (0,) * 8,
    depth: int = 0,
) -> GroupTick:
    feedback = command if feedback is None else feedback
    return GroupTick(list(command), list(feedback), list(increment), depth)


def tick(n: int = 1, deadline_ns: int = 0, *groups: GroupTick, lateness_ns: int = 0) -> Tick:
    return Tick(n, deadline_ns, lateness_ns, 0, True, list(groups or (group_tick(),)))


STATUS = ready_status(play=False)


def status(**changes: object) -> ControllerStatus:
    return msgspec.structs.replace(STATUS, **changes)


class FakeController:
    """A ``ControllerView`` that counts how often it is asked."""

    def __init__(self, status: ControllerStatus | None = STATUS, alive: bool = True) -> None:
        self.current = status
        self.present = alive
        self.asked = 0

    def status(self) -> ControllerStatus | None:
        self.asked += 1
        return self.current

    def alive(self) -> bool:
        return self.present


# --------------------------------------------------------------------------- schedule


def due_ticks(period_ns: int, tick_ns: int, ticks: int) -> list[int]:
    schedule = Schedule(period_ns)
    return [n for n in range(ticks) if schedule.due(n * tick_ns)]


def test_the_first_tick_is_due() -> None:
    assert Schedule(10 * MS).due(123 * MS)


def test_a_tick_before_the_due_time_is_not_due() -> None:
    schedule = Schedule(10 * MS)
    schedule.due(0)
    assert not schedule.due(9 * MS)


def test_a_tick_exactly_at_the_due_time_is_due() -> None:
    schedule = Schedule(10 * MS)
    schedule.due(0)
    assert schedule.due(10 * MS)


def test_a_period_of_one_tick_sends_on_every_tick() -> None:
    assert due_ticks(4 * MS, 4 * MS, 20) == list(range(20))


def test_a_period_of_whole_ticks_sends_on_every_nth_tick() -> None:
    assert due_ticks(12 * MS, 4 * MS, 30) == list(range(0, 30, 3))


def test_a_period_not_a_multiple_of_the_tick_alternates_intervals() -> None:
    sent = due_ticks(10 * MS, 4 * MS, 50)
    intervals = {4 * (b - a) for a, b in itertools.pairwise(sent)}
    assert intervals == {8, 12}


@pytest.mark.parametrize(
    ("period_ms", "tick_ms"), [(10, 4), (10, 3), (7, 2), (25, 4), (1000, 4), (10, 10)]
)
def test_the_rate_is_exact_on_average(period_ms: int, tick_ms: int) -> None:
    ticks = 10_000
    sent = due_ticks(period_ms * MS, tick_ms * MS, ticks)
    span_ms = (ticks - 1) * tick_ms
    assert len(sent) == span_ms // period_ms + 1


def test_each_snapshot_is_the_first_tick_at_or_after_its_due_time() -> None:
    period, step = 10 * MS, 3 * MS
    for n in due_ticks(period, step, 200)[1:]:
        due = n * step // period * period  # the due time this tick answers
        assert due <= n * step < due + step


def test_after_a_gap_in_ticks_there_is_no_burst_to_catch_up() -> None:
    schedule = Schedule(10 * MS)
    assert schedule.due(0)
    assert schedule.due(55 * MS)
    assert not schedule.due(59 * MS)
    assert schedule.due(65 * MS)


# --------------------------------------------------------------------------- in_motion


def test_an_idle_cell_is_not_in_motion() -> None:
    assert not in_motion(tick(1, 0, group_tick((5,) * 8)))


def test_entries_in_the_ring_mean_in_motion() -> None:
    assert in_motion(tick(1, 0, group_tick(depth=1)))


def test_a_lag_of_exactly_the_limit_is_not_motion() -> None:
    lagging = group_tick(command=[0] * 8, feedback=[IN_MOTION_PULSES, 0, 0, 0, 0, 0, 0, 0])
    assert not in_motion(tick(1, 0, lagging))


@pytest.mark.parametrize("lag", [IN_MOTION_PULSES + 1, -IN_MOTION_PULSES - 1])
def test_a_lag_beyond_the_limit_either_way_is_motion(lag: int) -> None:
    lagging = group_tick(command=[0] * 8, feedback=[0, 0, lag, 0, 0, 0, 0, 0])
    assert in_motion(tick(1, 0, lagging))


def test_a_lag_on_the_last_axis_counts() -> None:
    lagging = group_tick(command=[0] * 8, feedback=[0] * 7 + [IN_MOTION_PULSES + 1])
    assert in_motion(tick(1, 0, lagging))


def test_any_group_moving_makes_the_cell_in_motion() -> None:
    assert in_motion(tick(1, 0, group_tick(), group_tick(), group_tick(depth=3)))


# --------------------------------------------------------------------------- robot_status


def test_a_ready_controller_gives_every_field() -> None:
    fields = robot_status(STATUS, tick(), controller_alive=True)
    assert fields.drives_powered == 1
    assert fields.e_stopped == 0
    assert (fields.error_code, fields.in_error) == (0, 0)
    assert fields.in_motion == 0
    assert fields.mode == 1
    assert fields.motion_possible == 1


def test_no_status_yet_leaves_everything_unknown_and_motion_impossible() -> None:
    fields = robot_status(None, tick(1, 0, group_tick(depth=2)), controller_alive=True)
    assert fields.drives_powered == fields.e_stopped == fields.error_code == -1
    assert fields.in_error == fields.mode == -1
    assert fields.motion_possible == 0
    assert fields.in_motion == 1, "in_motion comes from the ticks, not the controller"


def test_a_status_from_a_controller_that_is_gone_is_not_believed() -> None:
    fields = robot_status(STATUS, tick(), controller_alive=False)
    assert (fields.drives_powered, fields.motion_possible, fields.mode) == (-1, 0, -1)


@pytest.mark.parametrize(
    ("servo_on", "eco", "powered"), [(True, False, 1), (True, True, 0), (False, False, 0)]
)
def test_drives_are_powered_with_servo_on_outside_energy_saving(
    servo_on: bool, eco: bool, powered: int
) -> None:
    fields = robot_status(status(servo_on=servo_on, eco=eco), tick(), controller_alive=True)
    assert fields.drives_powered == powered


def test_estop_is_reported() -> None:
    assert robot_status(status(estop=True), tick(), controller_alive=True).e_stopped == 1


def test_the_first_alarm_is_the_error_code() -> None:
    alarms = [Alarm(4107, 3), Alarm(9999)]
    fields = robot_status(status(alarms=alarms), tick(), controller_alive=True)
    assert (fields.error_code, fields.in_error) == (4107, 1)


def test_an_error_without_an_alarm_is_not_in_error() -> None:
    fields = robot_status(status(error=3), tick(), controller_alive=True)
    assert (fields.error_code, fields.in_error) == (0, 0)


@pytest.mark.parametrize(("play", "mode"), [(True, 2), (False, 1)])
def test_mode_is_two_in_play_else_one(play: bool, mode: int) -> None:
    assert robot_status(status(play=play), tick(), controller_alive=True).mode == mode


def test_motion_possible_follows_motion_ready() -> None:
    fields = robot_status(status(motion_ready=False), tick(), controller_alive=True)
    assert fields.motion_possible == 0


# --------------------------------------------------------------------------- feedback


def test_positions_are_pulses_over_pulses_per_radian() -> None:
    pulses = [58670, -58670, 29335, 32594, 0, 21990, 0, 0]
    (state,) = Feedback(cell()).groups(tick(1, 0, group_tick(pulses)))
    assert state.positions == pytest.approx([1.0, -1.0, 0.5, 1.0, 0.0, 1.0])


def test_a_seven_axis_arm_reports_in_ros_order() -> None:
    # Motoman order S-L-U-R-B-T-E: the E axis (ROS index 2) is the seventh pulse.
    moto_ppu = [ARM7_PPU[i] for i in (0, 1, 3, 4, 5, 6, 2)]
    pulses = [round(moto_ppu[i] * (i + 1) / 10) for i in range(7)] + [0]
    (state,) = Feedback(cell("arm7")).groups(tick(1, 0, group_tick(pulses)))
    assert state.positions == pytest.approx([0.1, 0.2, 0.7, 0.3, 0.4, 0.5, 0.6], abs=1e-4)


def test_velocities_are_the_increment_per_period_in_radians_per_second() -> None:
    increment = [235, 0, 0, 0, 0, -176, 0, 0]
    (state,) = Feedback(cell(period_ms=4)).groups(tick(1, 0, group_tick(increment=increment)))
    expected = [235 / ARM6_PPU[0] / 0.004, 0, 0, 0, 0, -176 / ARM6_PPU[5] / 0.004]
    assert state.velocities == pytest.approx(expected)


def test_a_servo_lag_gives_feedback_and_commanded_velocities_each_in_ros_order() -> None:
    """The feedback's velocity is what the servo moved (fractional pulses), the commanded one
    the increment; the 7-axis arm's E axis (seventh pulse) is ROS index 2 in both."""
    moto_ppu = [ARM7_PPU[i] for i in (0, 1, 3, 4, 5, 6, 2)]
    increment = [round(moto_ppu[i] * (i + 1) * 0.004) for i in range(7)] + [0]
    moved = [inc / 2 + 0.25 for inc in increment[:7]] + [0.0]
    lagging = msgspec.structs.replace(group_tick(increment=increment), feedback_moved=moved)
    (state,) = Feedback(cell("arm7")).groups(tick(1, 0, lagging))
    per_second = [m / ppu / 0.004 for m, ppu in zip(moved, moto_ppu, strict=False)]
    commanded = [i / ppu / 0.004 for i, ppu in zip(increment, moto_ppu, strict=False)]
    ros_of_moto = (0, 1, 3, 4, 5, 6, 2)
    assert state.velocities == pytest.approx([per_second[ros_of_moto.index(r)] for r in range(7)])
    assert state.command_velocities == pytest.approx(
        [commanded[ros_of_moto.index(r)] for r in range(7)]
    )
    assert state.command_velocities[2] == pytest.approx(7.0, abs=1e-3)


def test_velocities_scale_with_the_interpolation_period() -> None:
    increment = [587, 0, 0, 0, 0, 0, 0, 0]
    (state,) = Feedback(cell(period_ms=10)).groups(tick(1, 0, group_tick(increment=increment)))
    assert state.velocities[0] == pytest.approx(587 / ARM6_PPU[0] / 0.010)


def test_command_positions_come_from_the_command_pulses() -> None:
    command = [58670, 0, 0, 0, 0, 0, 0, 0]
    lagging = group_tick(command=command, feedback=[0] * 8)
    (state,) = Feedback(cell()).groups(tick(1, 0, lagging))
    assert state.command_positions[0] == pytest.approx(1.0)
    assert state.positions[0] == 0.0


def test_every_group_reports_its_own_axes_and_number() -> None:
    groups = Feedback(cell("arm6", "arm7", "positioner2")).groups(
        tick(1, 0, group_tick(), group_tick(), group_tick())
    )
    assert [g.group_no for g in groups] == [0, 1, 2]
    assert [len(g.positions) for g in groups] == [6, 7, 2]
    assert [len(g.velocities) for g in groups] == [6, 7, 2]


def test_a_linear_axis_reports_metres() -> None:
    (state,) = Feedback(cell("track1")).groups(tick(1, 0, group_tick([250_000] + [0] * 7)))
    assert state.positions == pytest.approx([0.25])


def test_a_tick_with_the_wrong_number_of_groups_is_refused() -> None:
    with pytest.raises(ValueError):
        Feedback(cell("arm6", "arm6")).groups(tick(1, 0, group_tick()))


# --------------------------------------------------------------------------- broadcaster


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


def resting_tick(n: int = 9) -> Tick:
    return msgspec.structs.replace(tick(n, n * 4 * MS), resting=True)


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


def test_at_rest_without_clients_observers_get_a_state_every_rest_heartbeat() -> None:
    broadcaster = Broadcaster(cell(state_period_ms=10), FakeController())
    broadcaster.on_tick(resting_tick(), 0.0)
    assert broadcaster.on_wake(0.01, clients=False) is not None  # the beat set by the tick
    assert broadcaster.next_wake(0.01, clients=False) == pytest.approx(0.01 + AT_REST_HEARTBEAT_S)
    assert broadcaster.on_wake(0.5, clients=False) is None


def test_a_client_connecting_at_rest_gets_a_state_at_once() -> None:
    broadcaster = Broadcaster(cell(state_period_ms=10), FakeController())
    broadcaster.on_tick(resting_tick(), 0.0)
    broadcaster.on_wake(0.01, clients=False)  # next beat in a second
    assert broadcaster.next_wake(0.3, clients=True) == pytest.approx(0.31)
    assert broadcaster.on_wake(0.31, clients=True) is not None
    assert broadcaster.on_wake(0.32, clients=True) is not None


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


# -- state clients (motoros1 §6) ---------------------------------------------------------------


@pytest.mark.parametrize("clients", range(MAX_STATE_CLIENTS))
@pytest.mark.parametrize("motion_queued", [False, True])
def test_up_to_four_state_clients_are_taken(clients: int, motion_queued: bool) -> None:
    assert admission(clients, motion_queued) is Admission.ACCEPT


def test_a_fifth_state_client_replaces_the_first_while_nothing_is_queued() -> None:
    assert admission(MAX_STATE_CLIENTS, motion_queued=False) is Admission.REPLACE_FIRST


def test_a_fifth_state_client_is_refused_while_motion_is_queued() -> None:
    assert admission(MAX_STATE_CLIENTS, motion_queued=True) is Admission.REFUSE


def test_motion_is_queued_while_any_ring_holds_entries() -> None:
    assert not queued(tick(1, 0, group_tick(), group_tick()))
    assert queued(tick(1, 0, group_tick(), group_tick(depth=1)))


def test_a_feedback_lag_alone_is_motion_but_queues_nothing() -> None:
    lagging = tick(1, 0, group_tick(command=[IN_MOTION_PULSES + 1] + [0] * 7, feedback=[0] * 8))
    assert in_motion(lagging) and not queued(lagging)


def test_the_broadcaster_knows_whether_motion_is_queued_from_the_newest_tick() -> None:
    broadcaster = Broadcaster(cell(), FakeController())
    assert not broadcaster.motion_queued()
    broadcaster.on_tick(tick(1, 0, group_tick(depth=3)), 0.0)
    assert broadcaster.motion_queued()
    broadcaster.on_tick(tick(2, 4 * MS), 0.0)
    assert not broadcaster.motion_queued()


# --------------------------------------------------------------------------- poses

ARM6_HOME_FLANGE = [0.560, 0.0, 0.815]
"""The GP7's flange at all-zero joints (tests/shared/motion/test_forward_kinematics.py)."""
ARM6_HOME_ORIENTATION = [math.sqrt(0.5), 0.0, math.sqrt(0.5), 0.0]
"""Flange z forward, x up: a half turn about (x + z) / sqrt(2)."""


def posed(broadcaster: Broadcaster, *groups: GroupTick) -> State:
    state = broadcaster.on_tick(tick(1, 0, *groups), 0.0)
    assert state is not None
    return broadcaster.for_observers(state)


def test_arms_get_flange_and_tcp_poses_and_positioners_none() -> None:
    dual = parse_cell({"groups": [{"model": "arm6"}, {"name": "R2", "model": "positioner2"}]})
    state = posed(Broadcaster(dual, FakeController()), group_tick(), group_tick())
    arm, positioner = state.groups
    for pose in (arm.flange, arm.tcp, arm.command_flange, arm.command_tcp):
        assert pose is not None
        assert pose.position == pytest.approx(ARM6_HOME_FLANGE, abs=2e-5)
        assert pose.orientation == pytest.approx(ARM6_HOME_ORIENTATION, abs=2e-5)
    assert positioner.flange is positioner.tcp is positioner.command_tcp is None


def test_feedback_and_commanded_poses_follow_their_own_joints() -> None:
    """S commanded a quarter turn, the feedback still at 0: the commanded flange faces +y."""
    quarter = round(math.pi / 2 * ARM6_PPU[0])
    state = posed(
        Broadcaster(cell(), FakeController()),
        group_tick(command=[quarter] + [0] * 7, feedback=[0] * 8),
    )
    (arm,) = state.groups
    assert arm.flange is not None and arm.command_flange is not None
    assert arm.flange.position == pytest.approx(ARM6_HOME_FLANGE, abs=2e-5)
    assert arm.command_flange.position == pytest.approx([0.0, 0.560, 0.815], abs=2e-5)


def test_the_tcp_uses_the_tool_the_controller_has_selected() -> None:
    """Tool 1 reaches 0.100 out of the flange face, which points forward at home."""
    tooled = parse_cell({"tools": [[0.0] * 6, [0, 0, 0.100, 0, 0, 0]]})
    state = posed(Broadcaster(tooled, FakeController(status(tools=[1]))), group_tick())
    (arm,) = state.groups
    assert arm.tool == 1
    assert arm.tcp is not None and arm.command_tcp is not None
    assert arm.tcp.position == pytest.approx([0.660, 0.0, 0.815], abs=2e-5)
    assert arm.command_tcp.position == arm.tcp.position


def test_without_a_controller_status_the_tcp_is_tool_0() -> None:
    tooled = parse_cell({"tools": [[0, 0, 0.100, 0, 0, 0]]})
    state = posed(Broadcaster(tooled, FakeController(status=None)), group_tick())
    (arm,) = state.groups
    assert arm.tool == 0
    assert arm.tcp is not None
    assert arm.tcp.position == pytest.approx([0.660, 0.0, 0.815], abs=2e-5)


def test_a_moment_without_a_status_keeps_the_selected_tool() -> None:
    """The TCP does not jump back to the flange for a snapshot the controller had no status
    for: the last tool it selected stays."""
    tooled = parse_cell({"tools": [[0.0] * 6, [0, 0, 0.100, 0, 0, 0]]})
    controller = FakeController(status(tools=[1]))
    broadcaster = Broadcaster(tooled, controller)
    posed(broadcaster, group_tick())
    controller.current = None
    state = broadcaster.on_wake(10.0, clients=True)  # ticks stopped: a silent beat
    assert state is not None
    (arm,) = broadcaster.for_observers(state).groups
    assert arm.tool == 1
    assert arm.tcp is not None
    assert arm.tcp.position == pytest.approx([0.660, 0.0, 0.815], abs=2e-5)


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
    (whole,) = Feedback(cell()).groups(tick(1, 0, lagging))
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
