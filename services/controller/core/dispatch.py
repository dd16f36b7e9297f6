"""The controller's answers: decoded commands, faults and notices in, replies and statuses out.

No I/O. A reply waits in the outbox until the service has published the status it depends on
(``status_due`` before ``take_replies``), so the gateway's next answer cannot be stale. Which
query a reply answers is the adapter's business: ``Q`` is whatever handle it passes in.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass
from typing import Generic, TypeVar

import msgspec

from motocell.services.controller.core.io_table import IoTable
from motocell.services.controller.core.model import OT_ROS_READY, START_TIMEOUT_S, Controller
from motocell.shared.bus.keys import service_of_alive
from motocell.shared.bus.schemas import Alarm, CommandReply, CommandRequest, ControllerStatus
from motocell.shared.protocol.constants import TOOL_NUMBERS, InvalidSubcode, Result

log = logging.getLogger("controller")

Q = TypeVar("Q")


COMMANDS = (
    "start_servos",
    "stop_servos",
    "reset_alarm",
    "start_traj_mode",
    "stop_traj_mode",
    "select_tool",
    "read_bit",
    "write_bit",
    "read_group",
    "write_group",
    "read_register",
    "write_register",
)
FAULTS = ("estop", "hold", "alarm", "error", "servo", "play", "remote", "pfl", "ot889")

IO_READS: dict[str, Callable[[IoTable, int], tuple[int, int]]] = {
    "read_bit": IoTable.read_bit,
    "read_group": IoTable.read_group,
    "read_register": IoTable.read_register,
}
IO_WRITES: dict[str, Callable[[IoTable, int, int], int]] = {
    "write_bit": IoTable.write_bit,
    "write_group": IoTable.write_group,
    "write_register": IoTable.write_register,
}


@dataclass
class PendingReply(Generic[Q]):
    query: Q
    deadline: float
    done: Callable[[Controller], bool]
    on_timeout: Callable[[Controller], tuple[int, int]]


def _failure(_model: Controller) -> tuple[int, int]:
    return int(Result.FAILURE), 0


def _not_ready(model: Controller) -> tuple[int, int]:
    return int(Result.NOT_READY), model.not_ready_subcode()


class Dispatcher(Generic[Q]):
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
        self.pending: list[PendingReply[Q]] = []
        self.outbox: list[tuple[Q, CommandReply]] = []
        self.sequence = first_seq
        self._published: ControllerStatus | None = None
        self._next_refresh = 0.0
        self._whole_once = False
        """Every required service has been present at least once (start-up is over)."""

    # -- notices ---------------------------------------------------------------------------
    def services_present(self, present: Collection[str]) -> None:
        """The liveliness tokens present now: a missing service makes the cell not ready. A
        token is missing only on evidence that its service is gone (``Presence``): it exited,
        was killed, or went unheard for the lease."""
        missing = sorted(service_of_alive(key) for key in self.required_alive if key not in present)
        if missing != self.model.missing_services:
            if not missing:
                self._whole_once = True
                log.info("all services present")
            elif self._whole_once:
                log.warning("not ready: services missing: %s", ", ".join(missing))
            else:
                # Starting up: services join one after another; nothing is wrong yet.
                log.info("waiting for services: %s", ", ".join(missing))
        self.model.set_missing_services(missing)

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

    def bad_payload(self, what: str, query: Q | None, error: Exception) -> None:
        """A payload that does not decode gets INVALID (queries) or is only logged (notices);
        it never stops the controller or changes its state."""
        log.warning("%s: bad payload ignored: %s", what, error)
        if query is not None:
            self.reply(query, CommandReply(Result.INVALID, InvalidSubcode.DATA, detail=str(error)))

    # -- commands --------------------------------------------------------------------------
    def command(self, verb: str, request: CommandRequest, query: Q, now: float) -> None:
        model = self.model
        if verb == "reset_alarm":
            self.reply(query, CommandReply(model.reset_alarm()))
        elif verb == "start_servos":
            model.eco = False
            model.set_servo(True, now)
            self._await(
                query, now, lambda m: m.servo_on, _failure, impossible=not model.servo_possible()
            )
        elif verb == "stop_servos":
            model.set_servo(False, now)
            self.reply(query, CommandReply(Result.SUCCESS))
        elif verb == "start_traj_mode":
            decided = model.begin_start_traj_mode(now)
            if decided is not None:
                self.reply(query, CommandReply(*decided))
            else:
                self._await(query, now, Controller.motion_ready, _not_ready)
        elif verb == "stop_traj_mode":
            model.stop_traj_mode()
            self.reply(query, CommandReply(Result.SUCCESS))
        elif verb in IO_READS:
            value, code = IO_READS[verb](self.io, request.value)
            self.reply(query, CommandReply(code, value=value))
        elif verb in IO_WRITES:
            value = request.args[0] if request.args else -1
            self.reply(query, CommandReply(IO_WRITES[verb](self.io, request.value, value)))
        elif verb == "select_tool":
            self.reply(query, self._select_tool(request))

    def _select_tool(self, request: CommandRequest) -> CommandReply:
        if not 0 <= request.group < self.model.groups:
            return CommandReply(Result.INVALID, InvalidSubcode.GROUPNO)
        if request.value not in TOOL_NUMBERS:
            return CommandReply(Result.INVALID, InvalidSubcode.DATA_TOOLNO)
        self.model.select_tool(request.group, request.value)
        return CommandReply(Result.SUCCESS)

    def _await(
        self,
        query: Q,
        now: float,
        done: Callable[[Controller], bool],
        on_timeout: Callable[[Controller], tuple[int, int]],
        impossible: bool = False,
    ) -> None:
        """Reply SUCCESS once ``done`` holds, else ``on_timeout`` at the 5 s deadline MotoROS
        polls for (motoros1 §2.3, motoros1 §7.3). When the simulation already knows it cannot
        happen (``impossible``), it answers at once instead of making the client wait 5 s."""
        deadline = now if impossible else now + START_TIMEOUT_S
        self.pending.append(PendingReply(query, deadline, done, on_timeout))
        self._finish_pending(now)

    def _finish_pending(self, now: float) -> None:
        still = []
        for pending in self.pending:
            if pending.done(self.model):
                self.reply(pending.query, CommandReply(Result.SUCCESS))
            elif now >= pending.deadline:
                self.reply(pending.query, CommandReply(*pending.on_timeout(self.model)))
            else:
                still.append(pending)
        self.pending = still

    # -- faults ----------------------------------------------------------------------------
    def fault(self, kind: str, request: CommandRequest, query: Q, now: float) -> None:
        """An injected fault; always acknowledged with SUCCESS."""
        model = self.model
        on = bool(request.value)
        log.warning("fault injected: %s %s %s", kind, request.value, request.args)
        if kind == "estop":
            model.set_estop(on)
        elif kind == "hold":
            model.set_hold(on)
        elif kind == "alarm":
            if on:
                code, subcode = ([*request.args, 0, 0])[:2]
                model.raise_alarm(code or 9999, subcode)
            else:
                model.alarms.clear()
        elif kind == "error":
            model.set_error(request.args[0] if on and request.args else (9999 if on else 0))
        elif kind == "servo":
            model.set_servo(on, now)
        elif kind == "play":
            model.set_play(on)
        elif kind == "remote":
            model.set_remote(on)
        elif kind == "pfl":
            model.set_pfl(on)
        elif kind == "ot889":
            # Something (a job edit, an I/O write) drops the job's "ready for ROS" output.
            model.set_output(OT_ROS_READY, int(on))
        self.reply(query, CommandReply(Result.SUCCESS))

    # -- time and output -------------------------------------------------------------------
    def advance(self, now: float) -> None:
        """Let simulated time pass, and answer the commands that were waiting for it."""
        self.model.advance(now)
        self._finish_pending(now)

    def reply(self, query: Q, reply: CommandReply) -> None:
        self.outbox.append((query, reply))

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
        status heartbeat, a reply's time-out, or the model's own next step."""
        times = [self._next_refresh, *(pending.deadline for pending in self.pending)]
        model_event = self.model.next_event()
        if model_event is not None:
            times.append(model_event)
        return min(times)

    def take_replies(self) -> list[tuple[Q, CommandReply]]:
        """The replies to send, each naming the last status published (which shows their
        effect)."""
        replies = [
            (query, msgspec.structs.replace(reply, status_seq=self.sequence))
            for query, reply in self.outbox
        ]
        self.outbox.clear()
        return replies
