"""The controller's state table: the INIT_ROS job and its OT#889/OT#890 handshake
(motoros1 §7.3-7.4), which ``model.Controller`` steps through on every event. The rest of what
the controller reports are switches that commands and faults set (servo, E-stop, HOLD, PLAY,
REMOTE, ...), not modes; motion-ready and its NOT_READY subcode are derived from them in
``model.Controller`` (motoros1 §7.1-7.2, a first-match order).

    NOP
    DOUT OT#890 OFF ; DOUT OT#889 OFF      <- BEGIN
    TIMER T=0.05                           (TIMER)
    DOUT OT#889 ON                         <- READY
    WAIT OT#890=ON                         (WAITING: the only state that accepts increments)
    DOUT OT#890 OFF ; DOUT OT#889 OFF      <- END
    END

A job can only run with the servo on, so START_TRAJ_MODE first waits for it (STARTING). Any
perturbation that stops a playing job (E-stop, HOLD, alarm, error, servo off, TEACH, REMOTE
off) is HALT: the job stops where it is and its outputs keep their values, as on a real
controller; motion-ready drops because the cell is no longer operating.
"""

from __future__ import annotations

from collections.abc import Mapping
from enum import Enum


class JobState(Enum):
    IDLE = "idle"
    STARTING = "starting"
    """START_TRAJ_MODE asked for the job; it starts once the servo is on."""
    TIMER = "timer"
    WAITING = "waiting"


class JobEvent(Enum):
    START = "start"
    """START_TRAJ_MODE, its operator checks passed."""
    SERVO_ON = "servo on"
    """The servo amplifiers are on (reported every poll while they are)."""
    TIMER_DONE = "timer done"
    ROS_DONE = "ros done"
    """OT#890 is on (STOP_TRAJ_MODE, or a client writing it)."""
    HALT = "halt"


class JobAction(Enum):
    NONE = "none"
    BEGIN = "begin"
    """OT#890 off, OT#889 off, arm the 50 ms timer."""
    READY = "ready"
    """OT#889 on: the rising edge MotoROS latches as "job ready"."""
    END = "end"
    """OT#890 off, OT#889 off."""


TRANSITIONS: Mapping[tuple[JobState, JobEvent], tuple[JobState, JobAction]] = {
    (JobState.IDLE, JobEvent.START): (JobState.STARTING, JobAction.NONE),
    (JobState.IDLE, JobEvent.SERVO_ON): (JobState.IDLE, JobAction.NONE),
    (JobState.IDLE, JobEvent.TIMER_DONE): (JobState.IDLE, JobAction.NONE),
    (JobState.IDLE, JobEvent.ROS_DONE): (JobState.IDLE, JobAction.NONE),
    (JobState.IDLE, JobEvent.HALT): (JobState.IDLE, JobAction.NONE),
    (JobState.STARTING, JobEvent.START): (JobState.STARTING, JobAction.NONE),
    (JobState.STARTING, JobEvent.SERVO_ON): (JobState.TIMER, JobAction.BEGIN),
    (JobState.STARTING, JobEvent.TIMER_DONE): (JobState.STARTING, JobAction.NONE),
    (JobState.STARTING, JobEvent.ROS_DONE): (JobState.STARTING, JobAction.NONE),
    (JobState.STARTING, JobEvent.HALT): (JobState.IDLE, JobAction.NONE),
    # A running job is not restarted: START_TRAJ_MODE refuses while operating
    # (motoros1 §7.3 step 3).
    (JobState.TIMER, JobEvent.START): (JobState.TIMER, JobAction.NONE),
    (JobState.TIMER, JobEvent.SERVO_ON): (JobState.TIMER, JobAction.NONE),
    (JobState.TIMER, JobEvent.TIMER_DONE): (JobState.WAITING, JobAction.READY),
    # OT#890 is cleared by BEGIN; if something sets it during the TIMER, the WAIT that follows
    # passes at once, which ROS_DONE in WAITING then handles.
    (JobState.TIMER, JobEvent.ROS_DONE): (JobState.TIMER, JobAction.NONE),
    (JobState.TIMER, JobEvent.HALT): (JobState.IDLE, JobAction.NONE),
    (JobState.WAITING, JobEvent.START): (JobState.WAITING, JobAction.NONE),
    (JobState.WAITING, JobEvent.SERVO_ON): (JobState.WAITING, JobAction.NONE),
    (JobState.WAITING, JobEvent.TIMER_DONE): (JobState.WAITING, JobAction.NONE),
    (JobState.WAITING, JobEvent.ROS_DONE): (JobState.IDLE, JobAction.END),
    (JobState.WAITING, JobEvent.HALT): (JobState.IDLE, JobAction.NONE),
}


def step(job: JobState, event: JobEvent) -> tuple[JobState, JobAction]:
    return TRANSITIONS[job, event]
