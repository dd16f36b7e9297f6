"""The controller's one thread: it waits for what arrives on the bus (``ControllerBus``), hands
each item to ``core.dispatch``, lets simulated time pass, publishes the status when it is due,
then sends the replies that waited for it.

Between arrivals it sleeps until the dispatcher's next deadline (the status heartbeat, a
reply's time-out, the simulated servo's or job's next step, the next question for liveliness
tokens): MotoROS polls its controller every 10 ms, the simulated controller looks only when
something can have changed.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import assert_never

from motocell.services.controller.bus import ControllerBus
from motocell.services.controller.core.dispatch import Dispatcher
from motocell.services.controller.inbox import (
    Arrival,
    BadPayload,
    CommandQuery,
    ConnectionCounts,
    FaultQuery,
    IncMoveError,
    ReplyTo,
    Stop,
    TokensAnswered,
    TokensChanged,
)
from motocell.shared.bus import ignored
from motocell.shared.service import StopFlag


def first_status_seq() -> int:
    """Where the status sequence numbers start (``Dispatcher``'s ``first_seq``): the wall
    clock in microseconds, so that they grow across controller restarts too."""
    return time.time_ns() // 1000


class ControllerLoop:
    def __init__(
        self,
        dispatcher: Dispatcher[ReplyTo],
        bus: ControllerBus,
        stop: StopFlag,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        """``clock`` gives the instants the dispatcher decides by (tests pass their own)."""
        self.dispatcher = dispatcher
        self.bus = bus
        self._stop = stop
        self._clock = clock
        self._stopping = False
        """``Stop`` arrived: this pass is the last."""

    def run(self) -> None:
        """Serve until the stop flag is raised, on this thread."""
        # The loop sleeps on the bus up to a heartbeat (1 s at rest), and a signal handler
        # must not touch the inbox's lock (shared.service.StopFlag), so a thread of its own
        # turns the stop into an arrival: the controller stops at once, not a second later,
        # which the launcher waits for before it stops the others.
        stop_watch = threading.Thread(target=self._wake_on_stop, name="stop-watch")
        stop_watch.start()
        try:
            self.serve()
        finally:
            self._stop.set()  # on an error too: it ends the stop watch
            stop_watch.join()

    def _wake_on_stop(self) -> None:
        self._stop.wait()
        self.bus.stop_waiting()

    def serve(self) -> None:
        """Pass after pass, until the stop flag is raised or ``Stop`` arrives."""
        self.dispatcher.services_present(self.bus.tokens_present(), self.bus.tokens_departed())
        while not self._stop.is_set() and not self._stopping:
            self.one_pass()

    def one_pass(self) -> None:
        """Ask for liveliness tokens if it is time; wait for arrivals until the dispatcher's
        next deadline and hand each to it; let time pass; publish the status if it is due,
        then send the replies (each names that status, so it must be out first)."""
        dispatcher, bus = self.dispatcher, self.bus
        now = self._clock()
        if now >= dispatcher.next_token_question():
            bus.ask_tokens()
            dispatcher.tokens_asked(now)
        arrival = bus.wait(max(0.0, dispatcher.next_deadline() - now))
        while arrival is not None:
            self.handle(arrival)
            arrival = bus.poll()
        now = self._clock()
        dispatcher.advance(now)
        status = dispatcher.status_due(now)
        if status is not None:
            bus.publish(status)
        for reply_to, reply in dispatcher.take_replies():
            reply_to.send(reply)

    def handle(self, arrival: Arrival) -> None:
        """Hand one arrival to the dispatcher."""
        dispatcher = self.dispatcher
        match arrival:
            case CommandQuery(verb, request, reply_to):
                dispatcher.command(verb, request, reply_to, self._clock())
            case FaultQuery(kind, request, reply_to):
                dispatcher.fault(kind, request, reply_to, self._clock())
            case ConnectionCounts(counts):
                dispatcher.connections(counts)
            case IncMoveError(notice):
                dispatcher.incmove_error(notice)
            case BadPayload(source, reason, reply_to):
                ignored.note(f"controller/{source}", f"bad payload ({reason})")
                dispatcher.bad_payload(source, reply_to, reason)
            case TokensChanged():
                dispatcher.services_present(self.bus.tokens_present(), self.bus.tokens_departed())
            case TokensAnswered():
                dispatcher.tokens_answered(self._clock())
            case Stop():
                self._stopping = True
            case _:
                assert_never(arrival)
