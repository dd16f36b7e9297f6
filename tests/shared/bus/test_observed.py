"""``observed``: whether a subscriber anywhere on the bus matches a publisher, through a router."""

from __future__ import annotations

import zenoh

from motocell.shared.bus.session import observed, publisher
from motocell.testing.processes import wait_until

KEY = "motocell/c1/state"


def test_a_publisher_is_observed_while_a_subscriber_matches(
    sessions: tuple[zenoh.Session, zenoh.Session],
) -> None:
    sender, receiver = sessions
    state_publisher = publisher(sender, KEY)
    try:
        assert not observed(state_publisher)
        subscriber = receiver.declare_subscriber("motocell/c1/**", lambda _sample: None)
        wait_until(lambda: observed(state_publisher), 10.0, "the subscriber to match")
        subscriber.undeclare()
        wait_until(lambda: not observed(state_publisher), 10.0, "the match to end")
    finally:
        state_publisher.undeclare()
