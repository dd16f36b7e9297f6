"""A scripted ``ControllerBus`` for the controller's loop (as httpcore's mock network backend):
the test writes down what arrives during each of the loop's waits, and reads what the loop
did, in order (``log``): each wait and its time-out, each question for tokens, each status
published and each reply sent.

Time is a ``FakeClock``: a wait during which nothing arrives (``idle``) lets it run to the
wait's end, as the real wait would sleep. A wait past the end of the script fails the test,
unless the bus is ``blocking``: then it blocks, up to ``WAIT_S``, for what another thread
delivers (the stop watch's ``Stop``).
"""

from __future__ import annotations

import contextlib
import queue
import threading
from collections import deque
from collections.abc import Collection

from motocell.services.controller.inbox import Arrival, Stop
from motocell.shared.bus.schemas import CommandReply, ControllerStatus

WAIT_S = 5.0
"""Deadline for what another thread is expected to do soon (generous for a loaded host)."""


class FakeClock:
    def __init__(self, now: float = 0.0) -> None:
        self.now = now

    def __call__(self) -> float:
        return self.now


class FakeReplyTo:
    """A query's reply handle; each reply is also logged by the bus."""

    def __init__(self, bus: FakeControllerBus, name: str) -> None:
        self._bus = bus
        self.name = name
        self.replies: list[CommandReply] = []

    def send(self, reply: CommandReply) -> None:
        self._bus.log.append(f"reply {self.name}")
        self.replies.append(reply)


class FakeControllerBus:
    def __init__(self, clock: FakeClock, *, blocking: bool = False) -> None:
        self.clock = clock
        self.blocking = blocking
        self._script: deque[tuple[tuple[Arrival, ...], Collection[str] | None]] = deque()
        self._batch: deque[Arrival] = deque()
        """What arrived with the last wait's arrival, for ``poll``."""
        self._from_threads: queue.Queue[Arrival] = queue.Queue()
        self.tokens: set[str] = set()
        self.departed: set[str] = set()
        """Tokens deleted since ``tokens_departed`` last looked."""
        self.log: list[str] = []
        self.waits: list[float] = []
        """Each wait's time-out, in seconds."""
        self.waited: list[Arrival | None] = []
        """What each wait returned."""
        self.published: list[ControllerStatus] = []
        self.asked_at: list[float] = []
        self.waiting = threading.Event()
        """Set once a blocking bus waits past the end of its script."""

    def reply_to(self, name: str) -> FakeReplyTo:
        return FakeReplyTo(self, name)

    def arrive(self, *arrivals: Arrival, tokens: Collection[str] | None = None) -> None:
        """What arrives during the next wait not yet scripted; ``tokens``: the tokens present
        from then on."""
        assert arrivals
        self._script.append((arrivals, tokens))

    def idle(self) -> None:
        """Nothing arrives during the next wait not yet scripted: it runs to its end."""
        self._script.append(((), None))

    # -- ControllerBus ---------------------------------------------------------------------
    def wait(self, timeout: float) -> Arrival | None:
        self.log.append(f"wait {timeout:g}")
        self.waits.append(timeout)
        arrival: Arrival | None = None
        if self._script:
            arrivals, tokens = self._script.popleft()
            if tokens is not None:
                self.tokens = set(tokens)
            if arrivals:
                arrival, *rest = arrivals
                self._batch.extend(rest)
            else:
                self.clock.now += timeout
        elif self.blocking:
            self.waiting.set()
            with contextlib.suppress(queue.Empty):
                arrival = self._from_threads.get(timeout=WAIT_S)
        else:
            raise AssertionError(f"the loop waited past the end of the script: {self.log}")
        self.waited.append(arrival)
        return arrival

    def poll(self) -> Arrival | None:
        return self._batch.popleft() if self._batch else None

    def stop_waiting(self) -> None:
        self.log.append("stop waiting")
        self._from_threads.put(Stop())

    def publish(self, status: ControllerStatus) -> None:
        self.log.append(f"publish {status.seq}")
        self.published.append(status)

    def ask_tokens(self) -> None:
        self.log.append("ask")
        self.asked_at.append(self.clock.now)

    def tokens_present(self) -> frozenset[str]:
        return frozenset(self.tokens)

    def tokens_departed(self) -> frozenset[str]:
        departed, self.departed = frozenset(self.departed), set()
        return departed
