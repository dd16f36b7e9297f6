"""The INIT_ROS job's transition table, over every (state, event) pair.

The expected table is written out here independently, from the job's listing in
motoros1 §7.4 and START_TRAJ_MODE in motoros1 §7.3.
"""

from __future__ import annotations

import itertools

import pytest

from motocell.services.controller.core.job import TRANSITIONS, Job, JobAction, JobEvent, step
from motocell.services.controller.core.model import OT_ROS_DONE, OT_ROS_READY, Controller

IDLE, S, T, W = Job.IDLE, Job.STARTING, Job.TIMER, Job.WAITING
START, SERVO, TIMER, DONE, HALT = (
    JobEvent.START,
    JobEvent.SERVO_ON,
    JobEvent.TIMER_DONE,
    JobEvent.ROS_DONE,
    JobEvent.HALT,
)

# state: {event: (next state, action)}; an event not listed leaves the state alone.
EXPECTED: dict[Job, dict[JobEvent, tuple[Job, JobAction]]] = {
    IDLE: {START: (S, JobAction.NONE)},
    S: {SERVO: (T, JobAction.BEGIN), HALT: (IDLE, JobAction.NONE)},
    T: {TIMER: (W, JobAction.READY), HALT: (IDLE, JobAction.NONE)},
    W: {DONE: (IDLE, JobAction.END), HALT: (IDLE, JobAction.NONE)},
}


@pytest.mark.parametrize(("job", "event"), list(itertools.product(Job, JobEvent)))
def test_every_state_and_event(job: Job, event: JobEvent) -> None:
    assert step(job, event) == EXPECTED[job].get(event, (job, JobAction.NONE))


def test_the_table_is_complete() -> None:
    assert set(TRANSITIONS) == set(itertools.product(Job, JobEvent))


@pytest.mark.parametrize(("job", "event"), list(itertools.product(Job, JobEvent)))
def test_the_controller_carries_out_each_step(job: Job, event: JobEvent) -> None:
    controller = Controller(groups=1, servo_on=True)
    controller.job = job
    controller.outputs[OT_ROS_DONE] = 1
    controller.outputs[OT_ROS_READY] = 1
    controller.fire(event, now=10.0)
    next_job, action = EXPECTED[job].get(event, (job, JobAction.NONE))
    assert controller.job is next_job
    outputs = (controller.outputs[OT_ROS_DONE], controller.outputs[OT_ROS_READY])
    expected_outputs = {
        JobAction.NONE: (1, 1),
        JobAction.BEGIN: (0, 0),
        JobAction.READY: (1, 1),
        JobAction.END: (0, 0),
    }[action]
    assert outputs == expected_outputs
    if action is JobAction.BEGIN:
        assert controller.job_timer_until == pytest.approx(10.05)
