"""The simulated controller process: Zenoh around ``core.dispatch``, which owns the controller
model, answers commands and faults, follows which services of the cell are alive, and says
when to publish the status."""

from __future__ import annotations

import time
from collections.abc import Sequence

import msgspec
import zenoh

from motocell.services.controller.core.dispatch import COMMANDS, FAULTS, Dispatcher
from motocell.services.controller.core.io_table import IoTable
from motocell.services.controller.core.model import Controller
from motocell.shared.bus.schemas import CommandReply, CommandRequest, Decoder, Tick, encode
from motocell.shared.bus.session import Inbox, Liveness, answer, command_of, publisher
from motocell.shared.service import (
    ServiceContext,
    argument_parser,
    required_alive_keys,
    running_service,
)

_request_decoder = Decoder(CommandRequest)
_tick_decoder = Decoder(Tick)
_notice_decoder = Decoder(CommandReply)

POLL_S = 0.01
"""MotoROS polls the controller status every 10 ms (motoros1 §0)."""

NOTICES = ("incmove_error", "connections")
"""Notices that need no reply come as plain puts: the executor's broken increment path, the
gateway's connection counts."""


class ControllerService:
    def __init__(self, ctx: ServiceContext) -> None:
        self.ctx = ctx
        keys = ctx.keys
        session = ctx.session
        model = Controller(groups=len(ctx.cell.groups))
        required = required_alive_keys(ctx.cell)
        required.remove(keys.alive("controller", "0"))
        self.dispatcher: Dispatcher[zenoh.Query] = Dispatcher(
            model,
            IoTable(ctx.cell.controller, model.outputs, model.set_output),
            required,
            first_seq=time.time_ns() // 1000,
        )
        self.inbox = Inbox()
        self.status_pub = publisher(session, keys.controller_status, realtime=True)
        self.alive = Liveness(session, keys.alive_all, lambda: self.inbox.put("alive", None))
        self.entities: list[object] = [
            session.declare_queryable(keys.controller_cmd(verb), self.inbox.feed(f"cmd/{verb}"))
            for verb in COMMANDS
        ]
        self.entities += [
            session.declare_queryable(keys.controller_fault(kind), self.inbox.feed(f"fault/{kind}"))
            for kind in FAULTS
        ]
        self.entities += [
            session.declare_subscriber(keys.controller_cmd(notice), self.inbox.feed(notice))
            for notice in NOTICES
        ]
        # Only the newest tick matters (the positions to hand a restarted executor), so it
        # is kept by the callback instead of waking the loop 250 times a second.
        self.entities.append(session.declare_subscriber(keys.executor_tick, self._keep_tick))

    def _keep_tick(self, sample: zenoh.Sample) -> None:
        try:
            tick = _tick_decoder.decode(sample.payload.to_bytes())
        except msgspec.DecodeError:
            return
        self.dispatcher.command_pulses = [group.command_pulses for group in tick.groups]

    def run(self) -> None:
        dispatcher = self.dispatcher
        dispatcher.services_present(self.alive.present())
        while not self.ctx.stop.is_set():
            item = self.inbox.get(timeout=POLL_S)
            while item is not None:
                self.handle(*item)
                item = self.inbox.get_nowait()
            now = time.monotonic()
            dispatcher.advance(now)
            status = dispatcher.status_due(now)
            if status is not None:
                self.status_pub.put(encode(status))
            for query, reply in dispatcher.take_replies():
                answer(query, reply)

    def handle(self, tag: str, item: object) -> None:
        """Decode one inbox item and hand it to the dispatcher."""
        dispatcher = self.dispatcher
        now = time.monotonic()
        try:
            if tag == "alive":
                dispatcher.services_present(self.alive.present())
            elif tag == "connections":
                assert isinstance(item, zenoh.Sample)
                dispatcher.connections(_request_decoder.decode(item.payload.to_bytes()))
            elif tag == "incmove_error":
                assert isinstance(item, zenoh.Sample)
                dispatcher.incmove_error(_notice_decoder.decode(item.payload.to_bytes()))
            elif tag.startswith("cmd/"):
                assert isinstance(item, zenoh.Query)
                dispatcher.command(tag.removeprefix("cmd/"), command_of(item), item, now)
            elif tag.startswith("fault/"):
                assert isinstance(item, zenoh.Query)
                dispatcher.fault(tag.removeprefix("fault/"), command_of(item), item, now)
        except (msgspec.DecodeError, msgspec.ValidationError, IndexError) as exc:
            dispatcher.bad_payload(tag, item if isinstance(item, zenoh.Query) else None, exc)


def main(argv: Sequence[str] | None = None) -> None:
    args = argument_parser("controller", "The simulated Yaskawa controller.").parse_args(argv)
    with running_service("controller", "0", args) as ctx:
        ControllerService(ctx).run()


if __name__ == "__main__":
    main()
