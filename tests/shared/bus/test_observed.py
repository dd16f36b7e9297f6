"""``observed``: whether a subscriber anywhere on the bus matches a publisher, through a router."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import zenoh

from motocell.shared.bus.router import router_settings, zenoh_config
from motocell.shared.bus.session import observed, open_session, publisher
from motocell.shared.ports import free_port
from motocell.testkit.processes import wait_until

KEY = "motocell/c1/state"


@pytest.fixture
def bus() -> Iterator[tuple[zenoh.Session, zenoh.Session]]:
    listen = f"tcp/127.0.0.1:{free_port()}"
    router = zenoh.open(zenoh_config(router_settings([listen])))
    sessions = [open_session("client", [listen], wait=False) for _ in range(2)]
    yield sessions[0], sessions[1]
    for session in sessions:
        session.close()
    router.close()


def test_a_publisher_is_observed_while_a_subscriber_matches(
    bus: tuple[zenoh.Session, zenoh.Session],
) -> None:
    sender, receiver = bus
    state_publisher = publisher(sender, KEY)
    try:
        assert not observed(state_publisher)
        subscriber = receiver.declare_subscriber("motocell/c1/**", lambda _sample: None)
        wait_until(lambda: observed(state_publisher), 10.0, "the subscriber to match")
        subscriber.undeclare()
        wait_until(lambda: not observed(state_publisher), 10.0, "the match to end")
    finally:
        state_publisher.undeclare()
