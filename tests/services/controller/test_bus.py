"""The controller's bus adapter as far as it goes without a router: each kind of payload
decoded into its inbox item, garbage into ``BadPayload`` (with the query's reply handle, so it
is answered), the inbox's order and bound, and the tokens the controller waits for."""

from __future__ import annotations

import pytest

from motocell.services.controller.bus import (
    command_arrival,
    connections_arrival,
    fault_arrival,
    incmove_error_arrival,
    not_on_its_key,
    others_alive_keys,
)
from motocell.services.controller.core.dispatch import FaultKind, Verb
from motocell.services.controller.inbox import (
    BadPayload,
    CommandQuery,
    ConnectionCounts,
    FaultQuery,
    Inbox,
    IncMoveError,
    Stop,
    TokensChanged,
)
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import CommandReply, CommandRequest, encode
from motocell.shared.config import load_cell
from tests.services.controller.fake_bus import FakeClock, FakeControllerBus

GARBAGE = [b"", b"\xc1", b"\x91\xa1x", b"\x93\x01\x02\xa1x", b"\x80", b"not msgpack at all"]
"""Truncated, malformed, a string for the first field, a string for the third, a map for an
array, text."""

REPLY_TO = FakeControllerBus(FakeClock()).reply_to("q")


@pytest.mark.parametrize("verb", Verb)
def test_a_command_is_decoded(verb: Verb) -> None:
    request = CommandRequest(group=1, value=10010, args=[1])
    assert command_arrival(verb, encode(request), REPLY_TO) == CommandQuery(verb, request, REPLY_TO)


@pytest.mark.parametrize("kind", FaultKind)
def test_a_fault_is_decoded(kind: FaultKind) -> None:
    request = CommandRequest(value=1, args=[4100, 2])
    assert fault_arrival(kind, encode(request), REPLY_TO) == FaultQuery(kind, request, REPLY_TO)


def test_a_query_without_a_payload_is_an_empty_request() -> None:
    empty = CommandRequest()
    assert command_arrival(Verb.READ_BIT, None, REPLY_TO) == CommandQuery(
        Verb.READ_BIT, empty, REPLY_TO
    )
    assert fault_arrival(FaultKind.HOLD, None, REPLY_TO) == FaultQuery(
        FaultKind.HOLD, empty, REPLY_TO
    )


@pytest.mark.parametrize("garbage", GARBAGE)
def test_a_query_with_garbage_is_a_bad_payload_that_keeps_its_reply_handle(
    garbage: bytes,
) -> None:
    for arrival, source in [
        (command_arrival(Verb.SELECT_TOOL, garbage, REPLY_TO), "cmd/select_tool"),
        (fault_arrival(FaultKind.ALARM, garbage, REPLY_TO), "fault/alarm"),
    ]:
        assert isinstance(arrival, BadPayload)
        assert (arrival.source, arrival.reply_to) == (source, REPLY_TO)
        assert arrival.reason


@pytest.mark.parametrize("asked_on", ["motocell/c/controller/cmd/*", "motocell/c/controller/**"])
def test_a_command_asked_on_a_wildcard_is_a_bad_request_answered(asked_on: str) -> None:
    own = CellKeys("c").controller_cmd(Verb.STOP_SERVOS)
    arrival = not_on_its_key("cmd/stop_servos", asked_on, own, REPLY_TO)
    assert isinstance(arrival, BadPayload)
    assert (arrival.source, arrival.reply_to) == ("cmd/stop_servos", REPLY_TO)
    assert asked_on in arrival.reason


def test_a_command_asked_on_its_own_key_goes_on_to_be_decoded() -> None:
    own = CellKeys("c").controller_fault(FaultKind.HOLD)
    assert not_on_its_key("fault/hold", own, own, REPLY_TO) is None


def test_the_notices_are_decoded() -> None:
    counts = CommandRequest(args=[1, -1, 0])
    notice = CommandReply(1, value=4416, subcode=1, detail="axis 0 past its range")
    assert connections_arrival(encode(counts)) == ConnectionCounts(counts)
    assert incmove_error_arrival(encode(notice)) == IncMoveError(notice)


@pytest.mark.parametrize("garbage", GARBAGE)
def test_a_notice_with_garbage_is_a_bad_payload_with_no_one_to_answer(garbage: bytes) -> None:
    for arrival, source in [
        (connections_arrival(garbage), "connections"),
        (incmove_error_arrival(garbage), "incmove_error"),
    ]:
        assert isinstance(arrival, BadPayload)
        assert (arrival.source, arrival.reply_to) == (source, None)


def test_the_inbox_keeps_the_order_things_arrived_in() -> None:
    inbox = Inbox()
    counts = ConnectionCounts(CommandRequest())
    inbox.offer(counts)
    inbox.put(TokensChanged())
    inbox.offer(Stop())
    assert [inbox.get(0.0), inbox.get_nowait(), inbox.get_nowait()] == [
        counts,
        TokensChanged(),
        Stop(),
    ]
    assert inbox.get_nowait() is None
    assert inbox.get(0.0) is None


def test_a_full_inbox_drops_and_counts_what_is_offered() -> None:
    inbox = Inbox(size=2)
    for _ in range(5):
        inbox.offer(TokensChanged())
    assert inbox.dropped == 3
    assert [inbox.get_nowait(), inbox.get_nowait(), inbox.get_nowait()] == [
        TokensChanged(),
        TokensChanged(),
        None,
    ]


def test_the_controller_waits_for_every_service_of_the_cell_but_itself() -> None:
    cell = load_cell("dual-arm-positioner")
    keys = CellKeys(cell.name)
    others = others_alive_keys(cell, keys)
    assert keys.alive("controller", "0") not in others
    assert keys.alive("gateway", "0") in others
    assert {keys.alive("interpolator", str(g.index)) for g in cell.groups} <= set(others)
