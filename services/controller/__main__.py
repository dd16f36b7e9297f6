"""The simulated controller process: owns the controller model, answers commands and faults,
watches that every service of the cell is alive, and publishes its status on every change."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import msgspec
import zenoh

from services.controller.io_table import IoTable
from services.controller.model import OT_ROS_READY, START_TIMEOUT_S, Controller
from shared.bus.keys import service_of_alive
from shared.bus.schemas import CommandReply, CommandRequest, Decoder, Tick, encode
from shared.bus.session import Inbox, Liveness, answer, command_of, publisher
from shared.protocol.constants import TOOL_NUMBERS, InvalidSubcode, Result
from shared.service import ServiceContext, argument_parser, required_alive_keys, running_service

log = logging.getLogger("controller")

_request_decoder = Decoder(CommandRequest)
_tick_decoder = Decoder(Tick)

POLL_S = 0.01
"""MotoROS polls the controller status every 10 ms (§0)."""
REFRESH_S = 0.1
"""Status is also republished this often, for subscribers that join late."""

COMMANDS = (
    "start_servos",
    "stop_servos",
    "reset_alarm",
    "start_traj_mode",
    "stop_traj_mode",
    "select_tool",
    "positions",
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
class PendingReply:
    query: zenoh.Query
    deadline: float
    done: Callable[[Controller], bool]
    on_timeout: Callable[[Controller], tuple[int, int]]


def _failure(_model: Controller) -> tuple[int, int]:
    return int(Result.FAILURE), 0


def _not_ready(model: Controller) -> tuple[int, int]:
    return int(Result.NOT_READY), model.not_ready_subcode()


class ControllerService:
    def __init__(self, ctx: ServiceContext) -> None:
        self.ctx = ctx
        self.model = Controller(groups=len(ctx.cell.groups))
        self.io = IoTable(ctx.cell.controller, self.model.outputs, self.model.set_output)
        self.inbox = Inbox()
        self.pending: list[PendingReply] = []
        self.outbox: list[tuple[zenoh.Query, CommandReply]] = []
        self.command_pulses: list[list[int]] = []
        keys = ctx.keys
        session = ctx.session
        self.status_pub = publisher(session, keys.controller_status, realtime=True)
        self.required = required_alive_keys(ctx.cell)
        self.required.remove(keys.alive("controller", "0"))
        self.alive = Liveness(session, keys.alive_all, lambda: self.inbox.put("alive", None))
        self.entities: list[object] = [
            session.declare_queryable(keys.controller_cmd(verb), self.inbox.feed(f"cmd/{verb}"))
            for verb in COMMANDS
        ]
        self.entities += [
            session.declare_queryable(keys.controller_fault(kind), self.inbox.feed(f"fault/{kind}"))
            for kind in FAULTS
        ]
        # Notices that need no reply come as plain puts: the executor's broken increment
        # path, the gateway's connection counts.
        for notice in ("incmove_error", "connections"):
            self.entities.append(
                session.declare_subscriber(keys.controller_cmd(notice), self.inbox.feed(notice))
            )
        # Only the newest tick matters (the positions to hand a restarted executor), so it
        # is kept by the callback instead of waking the loop 250 times a second.
        self.entities.append(session.declare_subscriber(keys.executor_tick, self._keep_tick))

    def _keep_tick(self, sample: zenoh.Sample) -> None:
        try:
            tick = _tick_decoder.decode(sample.payload.to_bytes())
        except msgspec.DecodeError:
            return
        self.command_pulses = [group.command_pulses for group in tick.groups]

    def reply(self, query: zenoh.Query, reply: CommandReply) -> None:
        """Replies wait until the status they depend on has been published (see ``run``)."""
        self.outbox.append((query, reply))

    def run(self) -> None:
        published = None
        next_refresh = 0.0
        # Sequence numbers grow across controller restarts too, so "seq >= n" stays meaningful.
        sequence = time.time_ns() // 1000
        self._update_missing()
        while not self.ctx.stop.is_set():
            item = self.inbox.get(timeout=POLL_S)
            while item is not None:
                self.handle(*item)
                item = self.inbox.get_nowait()
            now = time.monotonic()
            self.model.advance(now)
            self._finish_pending(now)
            status = self.model.status()
            if status != published or now >= next_refresh:
                sequence += 1
                self.status_pub.put(encode(msgspec.structs.replace(status, seq=sequence)))
                published = status
                next_refresh = now + REFRESH_S
            for query, reply in self.outbox:
                answer(query, msgspec.structs.replace(reply, status_seq=sequence))
            self.outbox.clear()

    def _update_missing(self) -> None:
        present = self.alive.present()
        missing = [service_of_alive(key) for key in self.required if key not in present]
        if missing != self.model.missing_services:
            if missing:
                log.warning("not ready: services missing: %s", ", ".join(missing))
            else:
                log.info("all services present")
        self.model.set_missing_services(missing)

    def handle(self, tag: str, item: object) -> None:
        """One command, fault or notice. A payload that does not decode gets INVALID (queries)
        or is logged (notices); it never stops the controller and its state."""
        try:
            self._handle(tag, item)
        except (msgspec.DecodeError, msgspec.ValidationError, IndexError) as exc:
            log.warning("%s: bad payload ignored: %s", tag, exc)
            if isinstance(item, zenoh.Query):
                self.reply(item, CommandReply(Result.INVALID, InvalidSubcode.DATA, detail=str(exc)))

    def _handle(self, tag: str, item: object) -> None:
        now = time.monotonic()
        if tag == "alive":
            self._update_missing()
        elif tag == "connections":
            assert isinstance(item, zenoh.Sample)
            counts = _request_decoder.decode(item.payload.to_bytes()).args
            self.model.set_connections(*[*counts, 0, 0, 0][:3])
        elif tag == "incmove_error":
            log.error("increment path broken; motion stopped (NOT_READY 5012)")
            self.model.set_incmove_error()
        elif tag.startswith("cmd/"):
            assert isinstance(item, zenoh.Query)
            self.command(tag[4:], item, now)
        elif tag.startswith("fault/"):
            assert isinstance(item, zenoh.Query)
            self.fault(tag[6:], command_of(item), now)
            self.reply(item, CommandReply(Result.SUCCESS))

    def command(self, verb: str, query: zenoh.Query, now: float) -> None:
        model = self.model
        request = command_of(query)
        if verb == "positions":
            self.reply(query, CommandReply(Result.SUCCESS, pulses=self.command_pulses))
        elif verb == "reset_alarm":
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
            if not 0 <= request.group < model.groups:
                self.reply(query, CommandReply(Result.INVALID, InvalidSubcode.GROUPNO))
            elif request.value not in TOOL_NUMBERS:
                self.reply(query, CommandReply(Result.INVALID, InvalidSubcode.DATA_TOOLNO))
            else:
                model.select_tool(request.group, request.value)
                self.reply(query, CommandReply(Result.SUCCESS))

    def _await(
        self,
        query: zenoh.Query,
        now: float,
        done: Callable[[Controller], bool],
        on_timeout: Callable[[Controller], tuple[int, int]],
        impossible: bool = False,
    ) -> None:
        """Reply SUCCESS once ``done`` holds, else ``on_timeout`` at the 5 s deadline MotoROS
        polls for (§2.3, §7.3). When the simulation already knows it cannot happen
        (``impossible``), it answers at once instead of making the client wait 5 s."""
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

    def fault(self, kind: str, request: CommandRequest, now: float) -> None:
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


def main(argv: Sequence[str] | None = None) -> None:
    args = argument_parser("controller", "The simulated Yaskawa controller.").parse_args(argv)
    with running_service("controller", "0", args) as ctx:
        ControllerService(ctx).run()


if __name__ == "__main__":
    main()
