"""The tick source on a secured router, as the broadcaster's identity: the executor's ticks come
straight from the channel, the newest first; without ticks, at the deadline the reader set, when
rung and at stop, the doorbell wakes the reader, although the broadcaster may not publish ticks
to anyone (it stays in the session)."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
import zenoh

from motocell.services.broadcaster.ticks import TickSource
from motocell.shared.bus.access import Identity, cell_identities
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.credentials import load, write_passwords
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.router import router_settings, zenoh_config
from motocell.shared.bus.schemas import encode
from motocell.shared.bus.session import open_session, publisher
from motocell.shared.ports import free_port
from motocell.shared.service import StopFlag
from motocell.testing.processes import wait_until
from tests.services.broadcaster.test_core import tick

CELL = "c1"
KEYS = CellKeys(CELL)
SOON_S = 0.05


@contextmanager
def cell_bus(directory: Path, *roles: Role) -> Iterator[list[zenoh.Session]]:
    """A session per role through a router with the cell's access rules."""
    write_passwords(directory, CELL, cell_identities(1))
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    settings = router_settings(
        [endpoint], cell=CELL, identities=cell_identities(1), credentials=directory
    )
    router = zenoh.open(zenoh_config(settings))
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


@pytest.fixture
def bus(tmp_path: Path) -> Iterator[tuple[zenoh.Session, zenoh.Session]]:
    """(the broadcaster's session, the executor's)."""
    with cell_bus(tmp_path, Role.BROADCASTER, Role.EXECUTOR) as sessions:
        yield sessions[0], sessions[1]


@pytest.fixture
def source(bus: tuple[zenoh.Session, zenoh.Session]) -> Iterator[TickSource]:
    stop = StopFlag()
    ticks = TickSource(bus[0], KEYS, stop)
    ticks.start()
    yield ticks
    stop.set()
    ticks.close()


@pytest.mark.parametrize("ticks_expected", [True, False])
def test_a_deadline_wakes_the_reader_without_a_tick(
    source: TickSource, ticks_expected: bool
) -> None:
    assert source.next(time.monotonic() + SOON_S, ticks_expected) is None


@pytest.mark.parametrize("ticks_expected", [True, False])
def test_a_ring_wakes_the_reader(source: TickSource, ticks_expected: bool) -> None:
    source.ring()
    assert source.next(None, ticks_expected) is None


def test_the_executors_ticks_reach_the_reader(
    bus: tuple[zenoh.Session, zenoh.Session], source: TickSource
) -> None:
    ticks = publisher(bus[1], KEYS.executor_tick, latest=True)
    sent = [0]

    def another_tick() -> bool:
        sent[0] += 1
        ticks.put(encode(tick(sent[0])))
        got = source.next(time.monotonic() + SOON_S, ticks_expected=True)
        return got is not None and got.tick == sent[0]

    # The subscription travels through the router: publish until one arrives.
    wait_until(another_tick, 10.0, "a tick")
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
    ticks.undeclare()


def test_stop_wakes_the_reader(bus: tuple[zenoh.Session, zenoh.Session]) -> None:
    stop = StopFlag()
    source = TickSource(bus[0], KEYS, stop)
    source.start()
    stop.set()
    assert source.next(None, ticks_expected=True) is None
    assert source.next(None, ticks_expected=False) is None
    source.close()


def test_the_doorbell_never_leaves_the_session(tmp_path: Path) -> None:
    with cell_bus(tmp_path, Role.BROADCASTER, Role.EXECUTOR, Role.OBSERVER) as sessions:
        broadcaster, executor, observer = sessions
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
        source = TickSource(broadcaster, KEYS, stop)
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
