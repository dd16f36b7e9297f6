"""Controller: START_TRAJ_MODE, the INIT_ROS job and OT#889/890, perturbations, and the
NOT_READY subcode order of motoros1 §7.2. Time is passed in; nothing sleeps."""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass

import pytest

from motocell.services.controller.core.model import (
    JOB_TIMER_S,
    OT_INIT_DONE,
    OT_ROS_DONE,
    OT_ROS_READY,
    OT_SERVER_RUNNING,
    SERVO_ON_DELAY_S,
    Controller,
)
from motocell.services.controller.core.states import JobState
from motocell.shared.bus.schemas import Alarm, ControllerStatus

SUCCESS = (0, 0)


def start(c: Controller, now: float) -> tuple[int, int] | None:
    return c.begin_start_traj_mode(now)


def ready_controller(groups: int = 1) -> Controller:
    """A controller after a successful START_TRAJ_MODE at t = 0 (ready at t = 0.10 s)."""
    c = Controller(groups)
    assert start(c, 0.0) is None
    c.advance(0.05)
    c.advance(0.10)
    assert c.motion_ready()
    return c


# -- START_TRAJ_MODE and the INIT_ROS job ---------------------------------------------------


def test_initial_state() -> None:
    c = Controller(2)
    assert c.tools == [0, 0]
    assert c.outputs == {OT_INIT_DONE: 1, OT_SERVER_RUNNING: 1}
    assert (OT_ROS_READY, OT_ROS_DONE, OT_INIT_DONE, OT_SERVER_RUNNING) == (
        11120, 11121, 11122, 11123
    )  # fmt: skip
    assert c.job is JobState.IDLE
    assert not c.operating
    assert not c.motion_ready()
    assert c.not_ready_subcode() == 5006  # servo off comes before "not operating"


def test_start_traj_mode_sequence_from_servo_off() -> None:
    assert (SERVO_ON_DELAY_S, JOB_TIMER_S) == (0.05, 0.05)
    c = Controller(1)
    assert start(c, 0.0) is None
    assert c.job is JobState.STARTING
    assert not c.servo_on
    c.advance(0.049)
    assert not c.servo_on
    assert c.job is JobState.STARTING
    assert c.not_ready_subcode() == 5006

    # Servo on after its delay; the job starts at once: OT#889/890 off, TIMER 50 ms.
    c.advance(0.05)
    assert c.servo_on
    assert c.job is JobState.TIMER
    assert c.operating
    assert c.outputs[OT_ROS_READY] == 0
    assert c.outputs[OT_ROS_DONE] == 0
    assert not c.job_ready
    assert not c.motion_ready()
    assert c.not_ready_subcode() == 5009  # operating, OT#889 still off

    c.advance(0.0999)
    assert c.job is JobState.TIMER
    assert not c.motion_ready()

    # TIMER done: OT#889 ON (rising edge latches job_ready), parked at WAIT OT#890.
    c.advance(0.1)
    assert c.job is JobState.WAITING
    assert c.outputs[OT_ROS_READY] == 1
    assert c.job_ready
    assert c.motion_ready()
    assert c.not_ready_subcode() == 0

    # It stays there.
    c.advance(100.0)
    assert c.job is JobState.WAITING
    assert c.motion_ready()


def test_start_traj_mode_with_servo_already_on_starts_the_job_at_once() -> None:
    c = Controller(1)
    c.set_servo(True, 0.0)
    c.advance(0.05)
    assert c.servo_on
    assert start(c, 1.0) is None
    assert c.job is JobState.TIMER
    assert c.job_timer_until == pytest.approx(1.05)
    c.advance(1.0499)
    assert not c.motion_ready()
    c.advance(1.05)
    assert c.motion_ready()


def test_start_traj_mode_when_already_ready_succeeds_at_once() -> None:
    c = ready_controller()
    assert start(c, 5.0) == SUCCESS
    assert c.job is JobState.WAITING
    assert c.outputs[OT_ROS_READY] == 1  # no job restart, no falling edge


def test_start_traj_mode_while_the_job_is_starting_is_refused() -> None:
    c = Controller(1)
    c.set_servo(True, 0.0)
    c.advance(0.05)
    assert start(c, 1.0) is None
    assert start(c, 1.01) == (5, 5009)  # operating: the job is in its TIMER
    assert c.job is JobState.TIMER


def test_start_traj_mode_refused_under_estop() -> None:
    c = Controller(1)
    c.raise_alarm(4107)
    c.set_estop(True)
    assert start(c, 0.0) == (5, 5001)  # nothing attempted: the alarm is not even reset
    assert c.alarms == [Alarm(4107, 0)]
    c.alarms.clear()
    assert start(c, 0.0) == (5, 5003)
    assert c.servo_on_at is None
    assert c.job is JobState.IDLE
    c.advance(10.0)
    assert not c.servo_on


def test_start_traj_mode_refused_under_hold() -> None:
    c = Controller(1)
    c.set_servo(True, 0.0)
    c.advance(0.05)
    c.set_error(4200)
    c.set_hold(True)
    assert start(c, 1.0) == (5, 5002)  # the error is not cancelled either
    assert c.error == 4200
    c.error = 0
    assert start(c, 1.0) == (5, 5007)
    c.advance(2.0)
    assert c.job is JobState.IDLE


def test_start_traj_mode_refused_when_not_remote() -> None:
    c = Controller(1)
    c.set_remote(False)
    assert start(c, 0.0) == (5, 5005)
    c.advance(1.0)
    assert (c.servo_on, c.job) == (False, JobState.IDLE)


def test_start_traj_mode_in_teach_resets_but_does_not_start() -> None:
    c = Controller(1)
    c.set_error(10)
    c.set_play(False)
    assert start(c, 0.0) == (5, 5004)
    assert c.error == 0
    assert c.job is JobState.IDLE
    assert c.servo_on_at is None


def test_start_traj_mode_resets_alarms_and_servo_on() -> None:
    c = ready_controller()
    c.raise_alarm(4321, 7)
    assert not c.servo_on
    assert c.not_ready_subcode() == 5001
    assert start(c, 1.0) is None
    assert c.alarms == []
    c.advance(1.05)
    c.advance(1.10)
    assert c.motion_ready()


def test_start_traj_mode_cancels_an_error() -> None:
    c = ready_controller()
    c.set_error(4400)
    assert c.servo_on  # an error does not switch the servo off
    assert start(c, 1.0) is None
    assert c.error == 0
    assert c.job is JobState.TIMER
    c.advance(1.05)
    assert c.motion_ready()


def test_start_traj_mode_clears_pfl_and_incmove_error() -> None:
    c = ready_controller()
    c.set_pfl(True)
    c.set_pfl(False)  # the PFL stop is over, its latch is not
    c.set_incmove_error()
    assert c.not_ready_subcode() == 5011
    assert start(c, 1.0) == SUCCESS  # the job is still at its WAIT: ready at once
    assert (c.pfl, c.incmove_error) == (False, False)
    assert c.motion_ready()


def test_start_traj_mode_clears_eco_before_servo_on() -> None:
    c = Controller(1)
    c.eco = True
    assert c.not_ready_subcode() == 5006
    assert start(c, 0.0) is None
    assert not c.eco
    c.advance(0.05)
    c.advance(0.10)
    assert c.motion_ready()


def test_reset_alarm_clears_alarms_and_error() -> None:
    c = Controller(1)
    c.raise_alarm(1)
    c.raise_alarm(2, 3)
    c.set_error(9)
    assert c.reset_alarm() == 0
    assert (c.alarms, c.error) == ([], 0)
    assert c.reset_alarm() == 0  # nothing to reset is still success


def test_stop_traj_mode_releases_the_wait() -> None:
    c = ready_controller()
    c.stop_traj_mode()
    assert c.outputs[OT_ROS_DONE] == 1
    c.advance(1.0)
    assert c.job is JobState.IDLE
    assert c.outputs[OT_ROS_DONE] == 0
    assert c.outputs[OT_ROS_READY] == 0  # falling edge: job no longer ready
    assert not c.job_ready
    assert not c.motion_ready()
    assert c.not_ready_subcode() == 5008
    # And START_TRAJ_MODE works again (servo still on).
    assert start(c, 2.0) is None
    c.advance(2.05)
    assert c.motion_ready()


def test_stop_traj_mode_before_the_wait_ends_the_job_when_it_gets_there() -> None:
    c = Controller(1)
    c.set_servo(True, 0.0)
    c.advance(0.05)
    assert start(c, 1.0) is None
    # OT#890 set during the TIMER: the WAIT is passed as soon as the job gets there.
    c.stop_traj_mode()
    c.advance(1.05)
    assert c.job is JobState.IDLE
    assert not c.motion_ready()


def test_ot890_written_by_the_io_path_releases_the_wait() -> None:
    c = ready_controller()
    c.set_output(OT_ROS_DONE, 1)
    c.advance(0.2)
    assert c.job is JobState.IDLE
    assert not c.motion_ready()


def test_ot889_rising_edge_latches_and_falling_edge_drops() -> None:
    c = Controller(1)
    c.set_output(OT_ROS_READY, 1)
    assert c.job_ready
    c.set_output(OT_ROS_READY, 1)
    assert c.job_ready
    c.set_output(OT_ROS_READY, 0)
    assert not c.job_ready
    c.job_ready = True  # the latch only changes on an edge
    c.set_output(OT_ROS_READY, 0)
    assert c.job_ready


def test_status_reports_every_field() -> None:
    c = ready_controller(groups=2)
    c.select_tool(1, 5)
    c.set_missing_services(["gateway", "executor"])
    assert c.status() == ControllerStatus(
        seq=0,
        servo_on=True,
        estop=False,
        hold=False,
        alarms=[],
        error=0,
        play=True,
        remote=True,
        operating=True,
        job_ready=True,
        pfl_active=False,
        incmove_error=False,
        eco=False,
        missing_services=["executor", "gateway"],
        motion_ready=False,
        not_ready_subcode=5012,
        tools=[0, 5],
        heartbeat_ms=1000,  # nothing can move: the slow heartbeat
    )
    c.set_missing_services([])
    status = c.status()
    assert (status.motion_ready, status.not_ready_subcode, status.heartbeat_ms) == (True, 0, 100)


# -- perturbations --------------------------------------------------------------------------


@dataclass(frozen=True)
class Perturbation:
    name: str
    apply: Callable[[Controller], None]
    subcode: int
    stops_job: bool


PERTURBATIONS = [
    Perturbation("estop", lambda c: c.set_estop(True), 5003, True),
    Perturbation("hold", lambda c: c.set_hold(True), 5007, True),
    Perturbation("alarm", lambda c: c.raise_alarm(4100, 2), 5001, True),
    Perturbation("error", lambda c: c.set_error(4300), 5002, True),
    Perturbation("servo off", lambda c: c.set_servo(False, 1.0), 5006, True),
    Perturbation("teach", lambda c: c.set_play(False), 5004, True),
    Perturbation("remote off", lambda c: c.set_remote(False), 5005, True),
    Perturbation("pfl", lambda c: c.set_pfl(True), 5011, False),
    Perturbation("incmove error", lambda c: c.set_incmove_error(), 5012, False),
    Perturbation("missing service", lambda c: c.set_missing_services(["executor"]), 5012, False),
]


@pytest.mark.parametrize("perturbation", PERTURBATIONS, ids=lambda p: p.name)
def test_every_perturbation_drops_motion_ready(perturbation: Perturbation) -> None:
    c = ready_controller()
    perturbation.apply(c)
    assert not c.motion_ready()
    assert c.not_ready_subcode() == perturbation.subcode
    assert c.status().motion_ready is False
    assert c.status().not_ready_subcode == perturbation.subcode
    assert c.operating is not perturbation.stops_job
    # Time passing does not bring it back.
    c.advance(60.0)
    assert not c.motion_ready()


@pytest.mark.parametrize(
    ("apply", "undo", "subcode"),
    [
        (lambda c: c.set_estop(True), lambda c: c.set_estop(False), 5006),
        (lambda c: c.set_hold(True), lambda c: c.set_hold(False), 5008),
        (lambda c: c.raise_alarm(1), lambda c: c.reset_alarm(), 5006),
        (lambda c: c.set_error(1), lambda c: c.set_error(0), 5008),
        (lambda c: c.set_servo(False, 1.0), lambda c: c.set_servo(True, 1.0), 5008),
        (lambda c: c.set_play(False), lambda c: c.set_play(True), 5008),
        (lambda c: c.set_remote(False), lambda c: c.set_remote(True), 5008),
    ],
)
def test_removing_the_cause_does_not_restore_motion_ready(
    apply: Callable[[Controller], None], undo: Callable[[Controller], None], subcode: int
) -> None:
    c = ready_controller()
    apply(c)
    undo(c)
    c.advance(2.0)
    assert not c.motion_ready()
    assert c.not_ready_subcode() == subcode
    # The job stopped with OT#889 still on; a new START_TRAJ_MODE restarts it (falling then
    # rising edge) and the cell is ready again.
    assert c.outputs[OT_ROS_READY] == 1
    assert start(c, 3.0) is None
    assert c.outputs[OT_ROS_READY] == 0 or c.job is JobState.STARTING
    c.advance(3.05)
    c.advance(3.10)
    assert c.motion_ready()


def test_missing_service_coming_back_restores_motion_ready() -> None:
    c = ready_controller()
    c.set_missing_services(["interpolator-0"])
    assert not c.motion_ready()
    c.set_missing_services([])
    assert c.motion_ready()


def test_eco_alone_does_not_enter_motion_ready() -> None:
    # motoros1 §7.1: eco acts only through OPERATING (the v1.9.11 eco check was reverted).
    c = ready_controller()
    c.eco = True
    assert c.motion_ready()


def test_pfl_during_a_ros_move_latches_until_start_traj_mode() -> None:
    c = ready_controller()
    c.set_pfl(True)
    c.set_pfl(False)
    assert not c.motion_ready()
    assert c.not_ready_subcode() == 5011


# -- NOT_READY subcode order (motoros1 §7.2) ------------------------------------------------


@dataclass(frozen=True)
class Condition:
    name: str
    rank: int
    subcode: int
    apply: Callable[[Controller], None]


def _alarm(c: Controller) -> None:
    c.alarms.append(Alarm(4100, 0))


def _set(name: str, value: object) -> Callable[[Controller], None]:
    return lambda c: setattr(c, name, value)


def _ot889_off(c: Controller) -> None:
    c.set_output(OT_ROS_READY, 0)


# Raw state changes (not the perturbation methods, which have side effects such as stopping
# the job), in the motoros1 §7.2 order. Rank ties share a subcode.
CONDITIONS = [
    Condition("alarm", 1, 5001, _alarm),
    Condition("error", 2, 5002, _set("error", 4300)),
    Condition("estop", 3, 5003, _set("estop", True)),
    Condition("not play", 4, 5004, _set("play", False)),
    Condition("not remote", 5, 5005, _set("remote", False)),
    Condition("servo off", 6, 5006, _set("servo_on", False)),
    Condition("eco", 6, 5006, _set("eco", True)),
    Condition("hold", 7, 5007, _set("hold", True)),
    Condition("pfl", 8, 5011, _set("pfl", True)),
    Condition("incmove error", 9, 5012, _set("incmove_error", True)),
    Condition("missing service", 9, 5012, _set("missing_services", ["executor"])),
    Condition("not operating", 10, 5008, _set("job", JobState.IDLE)),
    Condition("OT#889 off", 11, 5009, _ot889_off),
    Condition("latch not set", 12, 5010, _set("job_ready", False)),
]


def not_ready_with(*conditions: Condition) -> Controller:
    c = ready_controller()
    for condition in conditions:
        condition.apply(c)
    if c.motion_ready():
        # Conditions 1-7 act on readiness only through OPERATING: drop it in the background.
        # It ranks after all of them, so it does not change which one wins.
        c.job = JobState.IDLE
    assert not c.motion_ready()
    return c


@pytest.mark.parametrize("condition", CONDITIONS, ids=lambda c: c.name)
def test_single_condition_subcode(condition: Condition) -> None:
    assert not_ready_with(condition).not_ready_subcode() == condition.subcode


@pytest.mark.parametrize(
    ("first", "second"),
    list(itertools.permutations(CONDITIONS, 2)),
    ids=lambda c: c.name,
)
def test_pairwise_first_match_wins(first: Condition, second: Condition) -> None:
    winner = min(first, second, key=lambda c: c.rank)
    assert not_ready_with(first, second).not_ready_subcode() == winner.subcode


def test_all_conditions_at_once_report_the_alarm_and_ready_reports_zero() -> None:
    assert not_ready_with(*CONDITIONS).not_ready_subcode() == 5001
    assert ready_controller().not_ready_subcode() == 0
