"""The broadcaster's shells over ``ZenohBus`` on a secured router, each session with its role's
identity: the executor's ticks reach the tick source while its doorbell never leaves the session
(the broadcaster may not publish ticks to anyone); the controller's status and token reach the
watch; the reports reach an observer; a restarted executor's question is answered. The same
shells run against the scripted bus in the other tests."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import zenoh

from motocell.services.broadcaster.bus import ZenohBus
from motocell.services.broadcaster.controller_watch import ControllerWatch
from motocell.services.broadcaster.reports import REFRESH_S, StatePortReports
from motocell.services.broadcaster.ticks import TickSource
from motocell.shared.bus.access import Identity, cell_identities
from motocell.shared.bus.adapters import ZenohPublication
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.credentials import load, write_passwords
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.router import router_settings, zenoh_config
from motocell.shared.bus.schemas import (
    BroadcasterMetrics,
    CommandReply,
    CommandRequest,
    Decoder,
    encode,
)
from motocell.shared.bus.session import open_session, publisher
from motocell.shared.protocol.constants import Result
from motocell.shared.service import StopFlag
from motocell.testing.ports import listening
from motocell.testing.processes import wait_until
from tests.services.broadcaster.scripted import STATUS, tick

CELL = "c1"
KEYS = CellKeys(CELL)
SOON_S = 0.05


@contextmanager
def cell_bus(directory: Path, *roles: Role) -> Iterator[list[zenoh.Session]]:
    """A session per role through a router with the cell's access rules."""
    write_passwords(directory, CELL, cell_identities(1))

    def open_router(endpoint: str) -> zenoh.Session:
        settings = router_settings(
            [endpoint], cell=CELL, identities=cell_identities(1), credentials=directory
        )
        return zenoh.open(zenoh_config(settings))

    endpoint, router = listening(open_router)
    sessions = [
        open_session("client", [endpoint], credentials=load(directory, CELL, Identity(role)))
        for role in roles
    ]
    try:
        yield sessions
    finally:
        for session in sessions:
            session.close()
        router.close()


@contextmanager
def routed_ticks(directory: Path) -> Iterator[tuple[TickSource, ZenohPublication]]:
    """A tick source on the broadcaster's session and the executor's tick publisher, through a
    router with the cell's access rules, once a tick has reached the source (the subscription
    travels through the router: publish until one arrives)."""
    with cell_bus(directory, Role.BROADCASTER, Role.EXECUTOR) as (broadcaster, executor):
        stop = StopFlag()
        source = TickSource(ZenohBus(broadcaster), KEYS, stop)
        source.start()
        ticks = ZenohPublication(publisher(executor, KEYS.executor_tick, latest=True))
        sent = [0]

        def another_tick() -> bool:
            sent[0] += 1
            ticks.put(encode(tick(sent[0])))
            got = source.next(time.monotonic() + SOON_S, ticks_expected=True)
            return got is not None and got.tick == sent[0]

        try:
            wait_until(another_tick, 10.0, "a tick")
            yield source, ticks
        finally:
            stop.set()
            source.close()
            ticks.undeclare()


def test_the_executors_ticks_reach_the_tick_source(tmp_path: Path) -> None:
    with routed_ticks(tmp_path) as (source, ticks):
        for number in (100, 101, 102):
            ticks.put(encode(tick(number)))
        wait_until(
            lambda: (
                (got := source.next(time.monotonic(), ticks_expected=False)) is not None
                and got.tick == 102
            ),
            5.0,
            "the newest, taken without blocking",
        )


def test_at_rest_a_tick_through_the_router_ends_the_sleep(tmp_path: Path) -> None:
    """Parked on the tick key (a callback subscriber the cell's access rules allow): a tick that
    comes while the reader sleeps wakes it long before its deadline."""
    with routed_ticks(tmp_path) as (source, ticks):
        pouring = threading.Event()

        def pour() -> None:  # from now on, a tick every 20 ms, while the reader sleeps
            while not pouring.wait(0.02):
                ticks.put(encode(tick(1000)))

        pourer = threading.Thread(target=pour)
        pourer.start()
        try:
            started = time.monotonic()
            got = source.next(started + 30.0, ticks_expected=False)
            assert got is not None and got.tick == 1000
            assert time.monotonic() - started < 30.0
        finally:
            pouring.set()
            pourer.join()


def test_the_doorbell_wakes_the_reader_and_never_leaves_the_session(tmp_path: Path) -> None:
    roles = (Role.BROADCASTER, Role.EXECUTOR, Role.OBSERVER)
    with cell_bus(tmp_path, *roles) as (broadcaster, executor, observer):
        heard = observer.declare_subscriber(KEYS.executor_tick, zenoh.handlers.FifoChannel(64))
        ticks = publisher(executor, KEYS.executor_tick, latest=True)
        payloads: list[bytes] = []

        def observed(number: int) -> bool:
            ticks.put(encode(tick(number)))
            while (sample := heard.try_recv()) is not None:
                payloads.append(sample.payload.to_bytes())
            return encode(tick(number)) in payloads

        wait_until(lambda: observed(1), 10.0, "the observer's subscription")
        stop = StopFlag()
        source = TickSource(ZenohBus(broadcaster), KEYS, stop)
        source.start()
        try:
            # The doorbell rings at each deadline and when rung (a tick still on its way to
            # the new subscription may come first: either way next returns).
            for _ in range(3):
                source.next(time.monotonic() + SOON_S, ticks_expected=True)
            source.ring()
            source.next(None, ticks_expected=True)
        finally:
            stop.set()
            source.close()
        wait_until(lambda: observed(2), 5.0, "a tick after the doorbells")
        assert b"" not in payloads
        ticks.undeclare()
        heard.undeclare()


def test_the_controllers_status_and_token_reach_the_watch(tmp_path: Path) -> None:
    with cell_bus(tmp_path, Role.BROADCASTER, Role.CONTROLLER) as (broadcaster, controller):
        watch = ControllerWatch(ZenohBus(broadcaster), KEYS)
        statuses = publisher(controller, KEYS.controller_status)
        token = controller.liveliness().declare_token(KEYS.alive("controller", "0"))
        try:
            wait_until(watch.alive, 10.0, "the controller's token")

            def heard() -> bool:
                statuses.put(encode(STATUS))
                return watch.status() == STATUS

            wait_until(heard, 10.0, "the controller's status")
            token.undeclare()
            wait_until(lambda: not watch.alive(), 10.0, "the token gone")
        finally:
            watch.close()
            statuses.undeclare()


def test_the_reports_reach_an_observer(tmp_path: Path) -> None:
    with cell_bus(tmp_path, Role.BROADCASTER, Role.OBSERVER) as (broadcaster, observer):
        notices = observer.declare_subscriber(
            KEYS.controller_cmd("connections"), zenoh.handlers.FifoChannel(256)
        )
        metrics = observer.declare_subscriber(
            KEYS.metrics("broadcaster"), zenoh.handlers.FifoChannel(256)
        )
        reports = StatePortReports(ZenohBus(broadcaster), KEYS)
        now = [0.0]
        seen: list[list[int]] = []
        measured: list[BroadcasterMetrics] = []

        def report_every_second() -> bool:
            now[0] += REFRESH_S
            reports.report(now[0], 2, 5, 1)
            while (sample := notices.try_recv()) is not None:
                seen.append(Decoder(CommandRequest).decode(sample.payload.to_bytes()).args)
            while (sample := metrics.try_recv()) is not None:
                measured.append(Decoder(BroadcasterMetrics).decode(sample.payload.to_bytes()))
            return bool(seen) and bool(measured)

        # The subscriptions travel through the router: report until both arrive.
        wait_until(report_every_second, 10.0, "a connections notice and metrics")
        assert seen[-1] == [-1, 2, -1]
        assert (measured[-1].state_clients, measured[-1].replaced_total) == (2, 5)
        reports.close()
        notices.undeclare()
        metrics.undeclare()


def test_a_restarted_executor_is_answered_where_the_robot_was(tmp_path: Path) -> None:
    with cell_bus(tmp_path, Role.BROADCASTER, Role.EXECUTOR) as (broadcaster, executor):
        reply = CommandReply(Result.SUCCESS, pulses=[[1, 2, 3, 4, 5, 6, 0, 0]])
        served = ZenohBus(broadcaster).serve(KEYS.broadcaster_cmd("positions"), lambda: reply)
        decoder = Decoder(CommandReply)

        def answered() -> bool:
            replies = executor.get(
                KEYS.broadcaster_cmd("positions"), payload=encode(CommandRequest()), timeout=1.0
            )
            return any(
                r.ok is not None and decoder.decode(r.ok.payload.to_bytes()) == reply
                for r in replies
            )

        try:
            wait_until(answered, 10.0, "the answer")
        finally:
            served.undeclare()
