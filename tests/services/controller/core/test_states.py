"""The INIT_ROS job's state table, row by row: the controller is brought into the row's state
by the commands that lead there, the event is fired, and the state it lands in and the outputs
it leaves say whether the row was carried out.

The expected rows are written out here independently, from the job's listing in motoros1 §7.4
and START_TRAJ_MODE in motoros1 §7.3.
"""

from __future__ import annotations

import itertools

import pytest

from motocell.services.controller.core.model import (
    JOB_TIMER_S,
    OT_ROS_DONE,
    OT_ROS_READY,
    SERVO_ON_DELAY_S,
    Controller,
)
from motocell.services.controller.core.states import TRANSITIONS, JobAction, JobEvent, JobState

IDLE, STARTING, TIMER, WAITING = JobState
START, SERVO_ON, TIMER_DONE, ROS_DONE, HALT = JobEvent

EXPECTED: dict[JobState, dict[JobEvent, tuple[JobState, JobAction]]] = {
    IDLE: {START: (STARTING, JobAction.NONE)},
    STARTING: {SERVO_ON: (TIMER, JobAction.BEGIN), HALT: (IDLE, JobAction.NONE)},
    TIMER: {TIMER_DONE: (WAITING, JobAction.READY), HALT: (IDLE, JobAction.NONE)},
    WAITING: {ROS_DONE: (IDLE, JobAction.END), HALT: (IDLE, JobAction.NONE)},
}
"""state: {event: (next state, action)}; an event not listed leaves the state alone."""

OUTPUTS_AFTER = {
    JobAction.NONE: (1, 1),
    JobAction.BEGIN: (0, 0),
    JobAction.READY: (1, 1),
    JobAction.END: (0, 0),
}
"""(OT#890, OT#889) after each action, both on before it."""

FIRED_AT = 10.0


def controller_in(state: JobState) -> Controller:
    """A controller brought into ``state`` by START_TRAJ_MODE from servo off and the time
    that passes after it."""
    controller = Controller(groups=1)
    if state is not IDLE:
        assert controller.begin_start_traj_mode(0.0) is None
    if state in (TIMER, WAITING):
        controller.advance(SERVO_ON_DELAY_S)
    if state is WAITING:
        controller.advance(SERVO_ON_DELAY_S + JOB_TIMER_S)
    assert controller.job is state
    return controller


@pytest.mark.parametrize(("state", "event"), list(itertools.product(JobState, JobEvent)))
def test_each_row_is_carried_out(state: JobState, event: JobEvent) -> None:
    controller = controller_in(state)
    controller.set_output(OT_ROS_DONE, 1)
    controller.set_output(OT_ROS_READY, 1)
    controller.fire(event, now=FIRED_AT)
    next_state, action = EXPECTED[state].get(event, (state, JobAction.NONE))
    assert controller.job is next_state
    outputs = (controller.outputs[OT_ROS_DONE], controller.outputs[OT_ROS_READY])
    assert outputs == OUTPUTS_AFTER[action]
    if action is JobAction.BEGIN:
        assert controller.job_timer_until == pytest.approx(FIRED_AT + JOB_TIMER_S)


def test_the_table_has_a_row_for_every_state_and_event() -> None:
    assert set(TRANSITIONS) == set(itertools.product(JobState, JobEvent))
