"""The controller on the bus: Zenoh around ``core.dispatch``. Commands, faults, notices and
liveliness changes arrive in callbacks that only queue them (``Inbox``); the service's one
thread hands each to the dispatcher, publishes the status it says is due and sends the replies
that wait for it. Between inputs it sleeps until the dispatcher's next deadline (the status
heartbeat, a reply's time-out, the simulated job's next step): MotoROS polls its controller
every 10 ms, the simulated controller only when something can have changed.
"""

from __future__ import annotations

import threading
import time

import msgspec
import zenoh

from motocell.services.controller.core.dispatch import COMMANDS, FAULTS, Dispatcher
from motocell.services.controller.core.io_table import IoTable
from motocell.services.controller.core.model import Controller
from motocell.shared.bus.schemas import CommandReply, CommandRequest, Decoder, encode
from motocell.shared.bus.session import Inbox, Liveness, answer, command_of, publisher
from motocell.shared.service import ServiceContext, required_alive_keys

_request_decoder = Decoder(CommandRequest)
_notice_decoder = Decoder(CommandReply)

NOTICES = ("incmove_error", "connections")
"""Notices that need no reply come as plain puts: the executor's broken increment path, the
gateway's connection counts."""
ASK_AGAIN_S = 1.0
"""While a service is missing, how often to ask for liveliness tokens its events missed."""


class ControllerService:
    def __init__(self, ctx: ServiceContext) -> None:
        self.ctx = ctx
        keys, session = ctx.keys, ctx.session
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
        self._asked = False
        self._next_ask = 0.0
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

    def run(self) -> None:
        # The loop sleeps in the inbox up to a heartbeat (1 s at rest), and a signal handler
        # must not touch the inbox's lock (shared.service.StopFlag), so a thread of its own
        # turns the stop into an inbox item: the controller stops at once, not a second later,
        # which the launcher waits for before it stops the others.
        stop_watch = threading.Thread(target=self._wake_on_stop, name="stop-watch")
        stop_watch.start()
        try:
            self._loop()
        finally:
            self.ctx.stop.set()  # on an error too: it ends the stop watch
            stop_watch.join()

    def _wake_on_stop(self) -> None:
        self.ctx.stop.wait()
        self.inbox.put("stop", None)

    def _loop(self) -> None:
        dispatcher = self.dispatcher
        dispatcher.services_present(self.alive.present())
        while not self.ctx.stop.is_set():
            now = time.monotonic()
            if now >= self._ask_deadline():
                self.alive.ask()
                self._asked = True
                self._next_ask = now + ASK_AGAIN_S
            wait = min(dispatcher.next_deadline(), self._ask_deadline()) - now
            item = self.inbox.get(timeout=max(0.0, wait))
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

    def _ask_deadline(self) -> float:
        """When to ask which liveliness tokens are there: at start, then every ASK_AGAIN_S while
        a service is missing (a declaration the events missed); never while the cell is whole,
        since a token that stays is no news and its DELETE is an event."""
        if self._asked and not self.dispatcher.model.missing_services:
            return float("inf")
        return self._next_ask

    def handle(self, tag: str, item: object) -> None:
        """Decode one inbox item and hand it to the dispatcher."""
        dispatcher = self.dispatcher
        now = time.monotonic()
        try:
            if tag == "stop":
                return
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
