"""The simulated Yaskawa controller as MotoROS's status poller sees it. Pure: time is passed in.

Motion-ready and its NOT_READY subcode follow motoros1 §7.1-7.2 exactly; the INIT_ROS job
and its OT#889/OT#890 handshake follow motoros1 §7.4. Servo-off, E-stop, HOLD, alarms,
errors and mode changes do not enter motion-ready directly: they stop the job, and
"operating" dropping is what makes the cell not ready, as on the real controller.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from motocell.services.controller.core.states import JobAction, JobEvent, JobState, step
from motocell.shared.bus.liveness import heartbeat_ms
from motocell.shared.bus.schemas import Alarm, ControllerStatus
from motocell.shared.protocol.constants import NotReadySubcode, Result

OT_ROS_READY = 11120
"""OT#889, set by the INIT_ROS job just before its WAIT."""
OT_ROS_DONE = 11121
"""OT#890, set by MotoROS on STOP_TRAJ_MODE to release the WAIT."""
OT_INIT_DONE = 11122
OT_SERVER_RUNNING = 11123
OT_MOTION_CONNECTED = 11124
OT_STATE_CONNECTED = 11125
OT_IO_CONNECTED = 11126
OT_FAILURE = 11127

JOB_TIMER_S = 0.05
"""INIT_ROS's TIMER T=0.05 before it sets OT#889 (motoros1 §7.4)."""
SERVO_ON_DELAY_S = 0.05
"""How long the simulated servo amplifiers take to power up."""
START_TIMEOUT_S = 5.0
"""START_TRAJ_MODE polls up to 5000 ms for motion-ready (motoros1 §7.3 step 11)."""


@dataclass
class Controller:
    groups: int
    servo_on: bool = False
    servo_on_at: float | None = None
    estop: bool = False
    hold: bool = False
    alarms: list[Alarm] = field(default_factory=list)
    error: int = 0
    play: bool = True
    remote: bool = True
    eco: bool = False
    pfl: bool = False
    """The "PFL during ROS move" latch: set by a PFL stop while ready, cleared only by
    START_TRAJ_MODE (MotoROS 1.9.3, motoros1 §7.1)."""
    pfl_signal: bool = False
    """The PFL stop/escape/avoiding inputs (YRC1000 family)."""
    incmove_error: bool = False
    job: JobState = JobState.IDLE
    job_timer_until: float = 0.0
    job_ready: bool = False
    missing_services: list[str] = field(default_factory=list)
    outputs: dict[int, int] = field(default_factory=dict)
    tools: list[int] = field(default_factory=list)

    def __post_init__(self) -> None:
        if not self.tools:
            self.tools = [0] * self.groups
        self.outputs[OT_INIT_DONE] = 1
        self.outputs[OT_SERVER_RUNNING] = 1

    # -- derived status -------------------------------------------------------------------
    @property
    def operating(self) -> bool:
        return self.job in (JobState.TIMER, JobState.WAITING)

    def motion_ready(self) -> bool:
        """motoros1 §7.1: job-ready latch, operating, REMOTE, no PFL, no IncMove error; plus
        every service of the cell alive (the increment path needs them all)."""
        return (
            self.job_ready
            and self.operating
            and self.remote
            and not self.pfl_active
            and not self.incmove_error
            and not self.missing_services
        )

    def not_ready_subcode(self) -> int:
        """motoros1 §7.2, first match wins. A missing service reports INC_MOVE_ERROR (5012):
        increments cannot reach the robot, which is what that code means."""
        if self.motion_ready():
            return 0
        checks = (
            (bool(self.alarms), NotReadySubcode.ALARM),
            (self.error != 0, NotReadySubcode.ERROR),
            (self.estop, NotReadySubcode.ESTOP),
            (not self.play, NotReadySubcode.NOT_PLAY),
            (not self.remote, NotReadySubcode.NOT_REMOTE),
            (not self.servo_on or self.eco, NotReadySubcode.SERVO_OFF),
            (self.hold, NotReadySubcode.HOLD),
            (self.pfl_active, NotReadySubcode.PFL_ACTIVE),
            (self.incmove_error or bool(self.missing_services), NotReadySubcode.INC_MOVE_ERROR),
            (not self.operating, NotReadySubcode.NOT_STARTED),
            (not self.outputs.get(OT_ROS_READY, 0), NotReadySubcode.WAITING_ROS),
        )
        for condition, subcode in checks:
            if condition:
                return int(subcode)
        return int(NotReadySubcode.SKILLSEND)

    def status(self) -> ControllerStatus:
        return ControllerStatus(
            seq=0,
            servo_on=self.servo_on,
            estop=self.estop,
            hold=self.hold,
            alarms=list(self.alarms),
            error=self.error,
            play=self.play,
            remote=self.remote,
            operating=self.operating,
            job_ready=self.job_ready,
            pfl_active=self.pfl_active,
            incmove_error=self.incmove_error,
            eco=self.eco,
            missing_services=list(self.missing_services),
            motion_ready=self.motion_ready(),
            not_ready_subcode=self.not_ready_subcode(),
            tools=list(self.tools),
            heartbeat_ms=heartbeat_ms(motion_possible=self.motion_ready()),
        )

    # -- the INIT_ROS job ---------------------------------------------------------------
    def set_output(self, address: int, value: int) -> None:
        before = self.outputs.get(address, 0)
        self.outputs[address] = value
        if address == OT_ROS_READY and before != value:
            # Readiness is latched on OT#889's rising edge and lost on its falling edge
            # (motoros1 §7.1).
            self.job_ready = bool(value)

    def fire(self, event: JobEvent, now: float = 0.0) -> None:
        """Move the INIT_ROS job by its state table (``states.TRANSITIONS``) and carry out the
        step's action."""
        self.job, action = step(self.job, event)
        if action is JobAction.BEGIN:
            self.set_output(OT_ROS_DONE, 0)
            self.set_output(OT_ROS_READY, 0)
            self.job_timer_until = now + JOB_TIMER_S
        elif action is JobAction.READY:
            self.set_output(OT_ROS_READY, 1)
        elif action is JobAction.END:
            self.set_output(OT_ROS_DONE, 0)
            self.set_output(OT_ROS_READY, 0)

    def _stop_job(self) -> None:
        self.fire(JobEvent.HALT)

    def advance(self, now: float) -> None:
        """Let simulated time pass: servo power-up and the job's TIMER/WAIT/END steps."""
        if self.servo_on_at is not None and now >= self.servo_on_at:
            self.servo_on_at = None
            if self.servo_possible():
                self.servo_on = True
        if self.servo_on:
            self.fire(JobEvent.SERVO_ON, now)
        if self.job is JobState.TIMER and now >= self.job_timer_until:
            self.fire(JobEvent.TIMER_DONE, now)
        if self.outputs.get(OT_ROS_DONE, 0):
            self.fire(JobEvent.ROS_DONE, now)

    def next_event(self) -> float | None:
        """When ``advance`` next has something to do on its own (servo power-up, the job's
        TIMER step), or None: the rest happens only when a command or fault comes."""
        times = [self.servo_on_at] if self.servo_on_at is not None else []
        if self.job is JobState.TIMER:
            times.append(self.job_timer_until)
        return min(times, default=None)

    def servo_possible(self) -> bool:
        return not self.estop and not self.alarms

    # -- perturbations ------------------------------------------------------------------
    def set_estop(self, on: bool) -> None:
        self.estop = on
        if on:
            self.servo_on = False
            self.servo_on_at = None
            self._stop_job()

    def set_hold(self, on: bool) -> None:
        self.hold = on
        if on:
            self._stop_job()

    def raise_alarm(self, code: int, subcode: int = 0) -> None:
        self.alarms.append(Alarm(code, subcode))
        self.servo_on = False
        self._stop_job()

    def set_error(self, code: int) -> None:
        self.error = code
        if code:
            self._stop_job()

    def set_servo(self, on: bool, now: float) -> None:
        if on:
            if not self.servo_on and self.servo_on_at is None:
                self.servo_on_at = now + SERVO_ON_DELAY_S
        else:
            self.servo_on = False
            self.servo_on_at = None
            self._stop_job()

    def set_play(self, play: bool) -> None:
        if play != self.play:
            self.play = play
            self._stop_job()

    def set_remote(self, remote: bool) -> None:
        if remote != self.remote:
            self.remote = remote
            self._stop_job()

    @property
    def pfl_active(self) -> bool:
        return self.pfl or self.pfl_signal

    def set_pfl(self, on: bool) -> None:
        """A PFL stop while the job is ready latches until START_TRAJ_MODE (motoros1 §7.1,
        v1.9.3)."""
        self.pfl_signal = on
        if on and self.job_ready:
            self.pfl = True

    def set_missing_services(self, missing: list[str]) -> None:
        self.missing_services = sorted(missing)

    def set_incmove_error(self) -> None:
        self.incmove_error = True

    # -- commands -------------------------------------------------------------------------
    def reset_alarm(self) -> int:
        """RESET_ALARM: reset alarms, cancel the error (motoros1 §2.3). Always 0: like MotoROS
        it does not verify that the alarm is gone."""
        self.alarms.clear()
        self.error = 0
        return int(Result.SUCCESS)

    def begin_start_traj_mode(self, now: float) -> tuple[int, int] | None:
        """START_TRAJ_MODE steps 1-10 (motoros1 §7.3). Returns a final (result, subcode) when it is
        decided at once, or None when the caller should poll ``motion_ready`` until the
        deadline (step 11)."""
        self.pfl = False
        self.incmove_error = False
        if self.motion_ready():
            return int(Result.SUCCESS), 0
        if self.operating:
            return int(Result.NOT_READY), self.not_ready_subcode()
        if self.estop or self.hold or not self.remote:
            return int(Result.NOT_READY), self.not_ready_subcode()
        self.error = 0
        self.alarms.clear()
        if not self.play:
            return int(Result.NOT_READY), self.not_ready_subcode()
        if not self.servo_on:
            self.eco = False
            self.set_servo(True, now)
        self.fire(JobEvent.START, now)
        if self.servo_on:
            self.fire(JobEvent.SERVO_ON, now)
        return None

    def stop_traj_mode(self) -> None:
        """Set OT#890 so the job's WAIT is released and the job runs to END."""
        self.set_output(OT_ROS_DONE, 1)

    def set_connections(self, motion: int, state: int, io: int) -> None:
        """OT#893-#895: a motion, state or I/O client is connected (incremental-motion §4.2,
        motoros1 §7.4). A negative count leaves its output as it is: that port is another
        process's to report."""
        counts = ((OT_MOTION_CONNECTED, motion), (OT_STATE_CONNECTED, state), (OT_IO_CONNECTED, io))
        for output, count in counts:
            if count >= 0:
                self.set_output(output, int(count > 0))

    def select_tool(self, group: int, tool: int) -> None:
        self.tools[group] = tool
