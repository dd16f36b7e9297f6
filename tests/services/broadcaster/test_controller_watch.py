"""The controller as the broadcaster sees it, against a scripted bus: its newest status, read
when asked and kept until a newer one; its token, asked for once at the start."""

from __future__ import annotations

import pytest

from motocell.services.broadcaster.controller_watch import ControllerWatch
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import encode
from tests.services.broadcaster.fake_bus import FakeBus, FakeTokens
from tests.services.broadcaster.scripted import STATUS, status

KEYS = CellKeys("c1")
TOKEN = KEYS.alive("controller", "0")


@pytest.fixture
def bus() -> FakeBus:
    return FakeBus()


@pytest.fixture
def watch(bus: FakeBus) -> ControllerWatch:
    return ControllerWatch(bus, KEYS)


def tokens(bus: FakeBus) -> FakeTokens:
    return bus.watched[TOKEN]


def test_nothing_is_known_before_the_controller_is_heard(watch: ControllerWatch) -> None:
    assert watch.status() is None
    assert not watch.alive()


def test_the_newest_status_is_read_and_kept_until_a_newer_one(
    bus: FakeBus, watch: ControllerWatch
) -> None:
    bus.publish(KEYS.controller_status, encode(STATUS))
    bus.publish(KEYS.controller_status, encode(status(estop=True)))
    newest = status(estop=True)
    assert watch.status() == newest
    assert watch.status() == newest


def test_an_undecodable_status_leaves_the_one_before(bus: FakeBus, watch: ControllerWatch) -> None:
    bus.publish(KEYS.controller_status, encode(STATUS))
    assert watch.status() == STATUS
    bus.publish(KEYS.controller_status, b"\x93\x01")
    assert watch.status() == STATUS


def test_the_controller_is_alive_while_its_token_is_present(
    bus: FakeBus, watch: ControllerWatch
) -> None:
    assert tokens(bus).asked == 1
    tokens(bus).tokens.add(KEYS.alive("controller", "1"))
    assert not watch.alive(), "another controller's token does not count"
    tokens(bus).tokens.add(TOKEN)
    assert watch.alive()
    tokens(bus).tokens.discard(TOKEN)
    assert not watch.alive()
    assert tokens(bus).asked == 1, "asked once, at the start"


def test_closing_undeclares_both(bus: FakeBus, watch: ControllerWatch) -> None:
    watch.close()
    assert bus.latests[KEYS.controller_status].undeclared
    assert tokens(bus).closed
