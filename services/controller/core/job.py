"""The INIT_ROS job as one explicit transition table (motoros1 §7.3-7.4).

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


class Job(Enum):
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


_I, _S, _T, _W = Job.IDLE, Job.STARTING, Job.TIMER, Job.WAITING
_NONE, _BEGIN, _READY, _END = JobAction.NONE, JobAction.BEGIN, JobAction.READY, JobAction.END

TRANSITIONS: Mapping[tuple[Job, JobEvent], tuple[Job, JobAction]] = {
    (_I, JobEvent.START): (_S, _NONE),
    (_I, JobEvent.SERVO_ON): (_I, _NONE),
    (_I, JobEvent.TIMER_DONE): (_I, _NONE),
    (_I, JobEvent.ROS_DONE): (_I, _NONE),
    (_I, JobEvent.HALT): (_I, _NONE),
    (_S, JobEvent.START): (_S, _NONE),
    (_S, JobEvent.SERVO_ON): (_T, _BEGIN),
    (_S, JobEvent.TIMER_DONE): (_S, _NONE),
    (_S, JobEvent.ROS_DONE): (_S, _NONE),
    (_S, JobEvent.HALT): (_I, _NONE),
    # A running job is not restarted: START_TRAJ_MODE refuses while operating
    # (motoros1 §7.3 step 3).
    (_T, JobEvent.START): (_T, _NONE),
    (_T, JobEvent.SERVO_ON): (_T, _NONE),
    (_T, JobEvent.TIMER_DONE): (_W, _READY),
    # OT#890 is cleared by BEGIN; if something sets it during the TIMER, the WAIT that follows
    # passes at once, which ROS_DONE in WAITING then handles.
    (_T, JobEvent.ROS_DONE): (_T, _NONE),
    (_T, JobEvent.HALT): (_I, _NONE),
    (_W, JobEvent.START): (_W, _NONE),
    (_W, JobEvent.SERVO_ON): (_W, _NONE),
    (_W, JobEvent.TIMER_DONE): (_W, _NONE),
    (_W, JobEvent.ROS_DONE): (_I, _END),
    (_W, JobEvent.HALT): (_I, _NONE),
}


def step(job: Job, event: JobEvent) -> tuple[Job, JobAction]:
    return TRANSITIONS[job, event]
