"""What a test asks of a running cell, as its bus carries it: the newest state snapshot and
controller status, which face holds trajectory mode, the executor's ticks of the last motion,
and when its clock comes to rest.

One subscriber per key on the test's session (closing the session ends them); their callbacks
run on Zenoh's threads and only store, under one condition that the test's thread waits on.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import TypeVar

import zenoh

from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import (
    CommandRequest,
    ControllerStatus,
    Decoder,
    MotionHolder,
    State,
    Tick,
)
from motocell.testing.following import moving

T = TypeVar("T")

HOLDERS = frozenset(MotionHolder)
HOLDER_ARG = 3
"""Where a ``connections`` notice names the face holding trajectory mode (after the motion,
state and I/O client counts; ``MotionHolder``)."""


class CellObserver:
    """The cell ``keys`` names, from the moment it is made."""

    def __init__(self, session: zenoh.Session, keys: CellKeys) -> None:
        self._changed = threading.Condition()
        self._state: State | None = None
        self._controller: ControllerStatus | None = None
        self._holder: MotionHolder | None = None
        self._rests = 0
        """Resting ticks received: the executor sends one when its clock comes to rest and
        again every second while it rests."""
        self._motion: list[Tick] = []
        self._rested = True
        """The clock rested since the last moving tick: the next moving tick starts a motion."""
        state, tick = Decoder(State), Decoder(Tick)
        controller, connections = Decoder(ControllerStatus), Decoder(CommandRequest)
        self._subscribers = [
            session.declare_subscriber(keys.state, self._store(state, self._take_state)),
            session.declare_subscriber(keys.executor_tick, self._store(tick, self._take_tick)),
            session.declare_subscriber(
                keys.controller_status, self._store(controller, self._take_controller)
            ),
            session.declare_subscriber(
                keys.controller_cmd("connections"), self._store(connections, self._take_holder)
            ),
        ]

    def _store(self, decoder: Decoder[T], take: Callable[[T], None]) -> Callable[..., None]:
        def callback(sample: zenoh.Sample) -> None:
            item = decoder.decode(sample.payload.to_bytes())
            with self._changed:
                take(item)
                self._changed.notify_all()

        return callback

    def _take_state(self, state: State) -> None:
        self._state = state

    def _take_controller(self, status: ControllerStatus) -> None:
        self._controller = status

    def _take_holder(self, notice: CommandRequest) -> None:
        # The broadcaster sends this key too, without the holder: only the gateway's say it.
        holder = notice.args[HOLDER_ARG : HOLDER_ARG + 1]
        if holder and holder[0] in HOLDERS:
            self._holder = MotionHolder(holder[0])

    def _take_tick(self, tick: Tick) -> None:
        if moving([tick]):
            if self._rested:
                self._motion = []
                self._rested = False
            self._motion.append(tick)
        elif tick.resting:
            self._rested = True
            self._rests += 1

    def state(self, timeout: float) -> State:
        """The newest snapshot; the first one, waited for, if none came yet."""
        with self._changed:
            self._wait(lambda: self._state is not None, timeout, "a state snapshot")
            assert self._state is not None
            return self._state

    def controller(self, timeout: float, since_seq: int = 0) -> ControllerStatus:
        """The newest controller status, numbered ``since_seq`` or later: waited for until one
        is (a fault's reply names the status that shows it, ``CommandReply.status_seq``)."""
        with self._changed:
            self._wait(
                lambda: self._controller is not None and self._controller.seq >= since_seq,
                timeout,
                f"a controller status numbered {since_seq} or later",
            )
            assert self._controller is not None
            return self._controller

    def holder(self, timeout: float) -> MotionHolder:
        """Which face holds trajectory mode, as the gateway last said (it says so every second
        and on every change); waited for if it has not said yet."""
        with self._changed:
            self._wait(lambda: self._holder is not None, timeout, "the gateway's connections")
            assert self._holder is not None
            return self._holder

    def wait_at_rest(self, timeout: float) -> None:
        """Until a resting tick arrives after this call."""
        with self._changed:
            seen = self._rests
            self._wait(lambda: self._rests > seen, timeout, "the executor's clock to rest")

    def last_motion(self) -> list[Tick]:
        """The moving ticks since the clock last rested before a motion (empty: none yet)."""
        with self._changed:
            return list(self._motion)

    def _wait(self, predicate: Callable[[], bool], timeout: float, what: str) -> None:
        deadline = time.monotonic() + timeout
        while not predicate():
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise TimeoutError(f"timed out after {timeout} s waiting for {what}")
            self._changed.wait(remaining)
