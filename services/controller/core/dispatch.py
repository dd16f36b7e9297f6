"""The controller's decisions: decoded commands, faults and notices in, replies and statuses
out, and when to ask which services are there.

No I/O. A reply waits in the outbox until the service has published the status it depends on
(``status_due`` before ``take_replies``), so the gateway's next answer cannot be stale. Where a
reply goes is the loop's business: ``ReplyHandle`` is whatever handle it passes in.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass
from enum import StrEnum, unique
from typing import Generic, TypeVar, assert_never

import msgspec

from motocell.services.controller.core.io_table import IoTable
from motocell.services.controller.core.model import OT_ROS_READY, START_TIMEOUT_S, Controller
from motocell.shared.bus.keys import service_of_alive
from motocell.shared.bus.liveness import Asking
from motocell.shared.bus.schemas import Alarm, CommandReply, CommandRequest, ControllerStatus
from motocell.shared.protocol.constants import TOOL_NUMBERS, InvalidSubcode, Result

log = logging.getLogger("controller")

ReplyHandle = TypeVar("ReplyHandle")


@unique
class Verb(StrEnum):
    """The commands the controller answers, each on its ``controller/cmd/<verb>`` queryable."""

    START_SERVOS = "start_servos"
    STOP_SERVOS = "stop_servos"
    RESET_ALARM = "reset_alarm"
    START_TRAJ_MODE = "start_traj_mode"
    STOP_TRAJ_MODE = "stop_traj_mode"
    SELECT_TOOL = "select_tool"
    READ_BIT = "read_bit"
    WRITE_BIT = "write_bit"
    READ_GROUP = "read_group"
    WRITE_GROUP = "write_group"
    READ_REGISTER = "read_register"
    WRITE_REGISTER = "write_register"


@unique
class FaultKind(StrEnum):
    """The faults an operator injects, each on its ``controller/fault/<kind>`` queryable."""

    ESTOP = "estop"
    HOLD = "hold"
    ALARM = "alarm"
    ERROR = "error"
    SERVO = "servo"
    PLAY = "play"
    REMOTE = "remote"
    PFL = "pfl"
    OT889 = "ot889"


IO_READS: dict[Verb, Callable[[IoTable, int], tuple[int, int]]] = {
    Verb.READ_BIT: IoTable.read_bit,
    Verb.READ_GROUP: IoTable.read_group,
    Verb.READ_REGISTER: IoTable.read_register,
}
IO_WRITES: dict[Verb, Callable[[IoTable, int, int], int]] = {
    Verb.WRITE_BIT: IoTable.write_bit,
    Verb.WRITE_GROUP: IoTable.write_group,
    Verb.WRITE_REGISTER: IoTable.write_register,
}


@dataclass
class PendingReply(Generic[ReplyHandle]):
    reply_to: ReplyHandle
    deadline: float
    done: Callable[[Controller], bool]
    on_timeout: Callable[[Controller], tuple[int, int]]


def _failure(_model: Controller) -> tuple[int, int]:
    return int(Result.FAILURE), 0


def _not_ready(model: Controller) -> tuple[int, int]:
    return int(Result.NOT_READY), model.not_ready_subcode()


class Dispatcher(Generic[ReplyHandle]):
    """Everything the controller service decides, with time passed in."""

    def __init__(
        self, model: Controller, io: IoTable, required_alive: Sequence[str], first_seq: int
    ) -> None:
        """``required_alive``: the liveliness tokens of the other services the cell needs.
        ``first_seq``: where status sequence numbers start; the caller makes them grow across
        controller restarts too, so "seq >= n" stays meaningful."""
        self.model = model
        self.io = io
        self.required_alive = list(required_alive)
        self.pending: list[PendingReply[ReplyHandle]] = []
        self.outbox: list[tuple[ReplyHandle, CommandReply]] = []
        self.sequence = first_seq
        self._published: ControllerStatus | None = None
        self._next_refresh = 0.0
        self._whole_once = False
        """Every required service has been present at least once (start-up is over)."""
        self._token_asking = Asking()
        self._tokens_asked = False

    # -- which services are there ----------------------------------------------------------
    def services_present(
        self, present: Collection[str], departed: Collection[str] = frozenset()
    ) -> None:
        """The liveliness tokens present now, and those deleted since the last call: a missing
        service makes the cell not ready. A token is missing only on evidence that its service
        is gone (``Presence``): it exited, was killed, or went unheard for the lease. One that
        went and is back already (a link that broke and came back at once) is an IncMove error
        until START_TRAJ_MODE: what passed between it and the others meanwhile may be lost,
        and a not-ready status it missed among it (the executor stops on its own side too,
        docs/motion-safety.md)."""
        if self._whole_once:
            self._note_came_back(
                [key for key in self.required_alive if key in departed and key in present]
            )
        missing = sorted(service_of_alive(key) for key in self.required_alive if key not in present)
        if missing != self.model.missing_services:
            if not missing:
                log.info("all services present")
            elif self._whole_once:
                log.warning("not ready: services missing: %s", ", ".join(missing))
            else:
                # Starting up: services join one after another; nothing is wrong yet.
                log.info("waiting for services: %s", ", ".join(missing))
        self._whole_once = self._whole_once or not missing
        self.model.set_missing_services(missing)

    def _note_came_back(self, departed: list[str]) -> None:
        if departed:
            log.warning(
                "not ready: %s left and came back: IncMove error until START_TRAJ_MODE",
                ", ".join(service_of_alive(key) for key in departed),
            )
            self.model.set_incmove_error()

    def next_token_question(self) -> float:
        """When to ask which liveliness tokens are there: at start, then as ``Asking`` says
        while a service is missing (a declaration the events missed); never while the cell is
        whole, since a token that stays is no news and its DELETE is an event."""
        if self._tokens_asked and not self.model.missing_services:
            return math.inf
        return self._token_asking.next

    def tokens_asked(self, now: float) -> None:
        self._tokens_asked = True
        self._token_asking.asked(now)

    def tokens_answered(self, now: float) -> None:
        """The last question for tokens is finished (what it found came as a change)."""
        self._token_asking.finished(now)

    # -- notices ---------------------------------------------------------------------------
    def connections(self, counts: CommandRequest) -> None:
        """Motion, state and I/O client counts, in ``args``: the gateway reports the motion and
        I/O ports, the broadcaster the state port, each -1 for the ports it does not serve."""
        self.model.set_connections(*[*counts.args, 0, 0, 0][:3])

    def incmove_error(self, notice: CommandReply) -> None:
        """The executor stopped motion: the increment path broke (the IncMove error, NOT_READY
        5012), or the motion system raised the alarm ``notice.value`` (a soft limit, 4416),
        subcode ``notice.subcode``. Either way the rings are already cleared."""
        if notice.value:
            # A stall notice is repeated until the executor sees a not-ready status (the
            # first may be lost while the router stalls): one alarm, however many copies.
            if Alarm(notice.value, notice.subcode) in self.model.alarms:
                return
            log.error("alarm %d: %s; motion stopped", notice.value, notice.detail)
            self.model.raise_alarm(notice.value, notice.subcode)
        else:
            log.error("increment path broken; motion stopped (NOT_READY 5012)")
            self.model.set_incmove_error()

    def bad_payload(self, source: str, reply_to: ReplyHandle | None, reason: str) -> None:
        """A payload that does not decode gets INVALID (queries) or nothing (notices); it never
        stops the controller or changes its state. ``source``: the key it came on, after
        ``controller/``. The loop has noted it with the process's ignored samples, which
        logs it without letting a flood of them flood the log."""
        if reply_to is not None:
            self.reply(reply_to, CommandReply(Result.INVALID, InvalidSubcode.DATA, detail=reason))

    # -- commands --------------------------------------------------------------------------
    def command(
        self, verb: Verb, request: CommandRequest, reply_to: ReplyHandle, now: float
    ) -> None:
        model = self.model
        match verb:
            case Verb.RESET_ALARM:
                self.reply(reply_to, CommandReply(model.reset_alarm()))
            case Verb.START_SERVOS:
                model.eco = False
                model.set_servo(True, now)
                impossible = not model.servo_possible()
                self._await(reply_to, now, lambda m: m.servo_on, _failure, impossible=impossible)
            case Verb.STOP_SERVOS:
                model.set_servo(False, now)
                self.reply(reply_to, CommandReply(Result.SUCCESS))
            case Verb.START_TRAJ_MODE:
                decided = model.begin_start_traj_mode(now)
                if decided is not None:
                    self.reply(reply_to, CommandReply(*decided))
                else:
                    self._await(reply_to, now, Controller.motion_ready, _not_ready)
            case Verb.STOP_TRAJ_MODE:
                model.stop_traj_mode()
                self.reply(reply_to, CommandReply(Result.SUCCESS))
            case Verb.READ_BIT | Verb.READ_GROUP | Verb.READ_REGISTER:
                value, code = IO_READS[verb](self.io, request.value)
                self.reply(reply_to, CommandReply(code, value=value))
            case Verb.WRITE_BIT | Verb.WRITE_GROUP | Verb.WRITE_REGISTER:
                value = request.args[0] if request.args else -1
                self.reply(reply_to, CommandReply(IO_WRITES[verb](self.io, request.value, value)))
            case Verb.SELECT_TOOL:
                self.reply(reply_to, self._select_tool(request))
            case _:
                assert_never(verb)

    def _select_tool(self, request: CommandRequest) -> CommandReply:
        if not 0 <= request.group < self.model.groups:
            return CommandReply(Result.INVALID, InvalidSubcode.GROUPNO)
        if request.value not in TOOL_NUMBERS:
            return CommandReply(Result.INVALID, InvalidSubcode.DATA_TOOLNO)
        self.model.select_tool(request.group, request.value)
        return CommandReply(Result.SUCCESS)

    def _await(
        self,
        reply_to: ReplyHandle,
        now: float,
        done: Callable[[Controller], bool],
        on_timeout: Callable[[Controller], tuple[int, int]],
        impossible: bool = False,
    ) -> None:
        """Reply SUCCESS once ``done`` holds, else ``on_timeout`` at the 5 s deadline MotoROS
        polls for (motoros1 §2.3, motoros1 §7.3). When the simulation already knows it cannot
        happen (``impossible``), it answers at once instead of making the client wait 5 s."""
        deadline = now if impossible else now + START_TIMEOUT_S
        self.pending.append(PendingReply(reply_to, deadline, done, on_timeout))
        self._finish_pending(now)

    def _finish_pending(self, now: float) -> None:
        still = []
        for pending in self.pending:
            if pending.done(self.model):
                self.reply(pending.reply_to, CommandReply(Result.SUCCESS))
            elif now >= pending.deadline:
                self.reply(pending.reply_to, CommandReply(*pending.on_timeout(self.model)))
            else:
                still.append(pending)
        self.pending = still

    # -- faults ----------------------------------------------------------------------------
    def fault(
        self, kind: FaultKind, request: CommandRequest, reply_to: ReplyHandle, now: float
    ) -> None:
        """An injected fault; always acknowledged with SUCCESS."""
        model = self.model
        on = bool(request.value)
        log.warning("fault injected: %s %s %s", kind, request.value, request.args)
        match kind:
            case FaultKind.ESTOP:
                model.set_estop(on)
            case FaultKind.HOLD:
                model.set_hold(on)
            case FaultKind.ALARM:
                if on:
                    code, subcode = ([*request.args, 0, 0])[:2]
                    model.raise_alarm(code or 9999, subcode)
                else:
                    model.alarms.clear()
            case FaultKind.ERROR:
                model.set_error(request.args[0] if on and request.args else (9999 if on else 0))
            case FaultKind.SERVO:
                model.set_servo(on, now)
            case FaultKind.PLAY:
                model.set_play(on)
            case FaultKind.REMOTE:
                model.set_remote(on)
            case FaultKind.PFL:
                model.set_pfl(on)
            case FaultKind.OT889:
                # Something (a job edit, an I/O write) drops the job's "ready for ROS" output.
                model.set_output(OT_ROS_READY, int(on))
            case _:
                assert_never(kind)
        self.reply(reply_to, CommandReply(Result.SUCCESS))

    # -- time and output -------------------------------------------------------------------
    def advance(self, now: float) -> None:
        """Let simulated time pass, and answer the commands that were waiting for it."""
        self.model.advance(now)
        self._finish_pending(now)

    def reply(self, reply_to: ReplyHandle, reply: CommandReply) -> None:
        self.outbox.append((reply_to, reply))

    def status_due(self, now: float) -> ControllerStatus | None:
        """The status to publish now, numbered: on every change, and at the heartbeat it
        announces for subscribers that join late and for those that age what they hold (the
        gateway, the executor): short while motion is possible, long while nothing can move."""
        status = self.model.status()
        if status == self._published and now < self._next_refresh:
            return None
        self.sequence += 1
        self._published = status
        self._next_refresh = now + status.heartbeat_ms / 1000
        return msgspec.structs.replace(status, seq=self.sequence)

    def next_deadline(self) -> float:
        """When the service must look again if no command, fault or notice comes first: the
        status heartbeat, a reply's time-out, the model's own next step, or the next question
        for tokens."""
        times = [
            self._next_refresh,
            self.next_token_question(),
            *(pending.deadline for pending in self.pending),
        ]
        model_event = self.model.next_event()
        if model_event is not None:
            times.append(model_event)
        return min(times)

    def take_replies(self) -> list[tuple[ReplyHandle, CommandReply]]:
        """The replies to send, each naming the last status published (which shows their
        effect)."""
        replies = [
            (reply_to, msgspec.structs.replace(reply, status_seq=self.sequence))
            for reply_to, reply in self.outbox
        ]
        self.outbox.clear()
        return replies
