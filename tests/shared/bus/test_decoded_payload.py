"""The one rule for a payload read off the bus: decoded, or None, never an exception; a payload
that does not decode is logged with its key."""

from __future__ import annotations

import logging

import pytest

from motocell.shared.bus.ignored import decoded_payload
from motocell.shared.bus.schemas import Decoder, Slot, encode

KEY = "motocell/c1/group/0/slot"
SLOTS = Decoder(Slot)


def test_a_payload_decodes() -> None:
    assert decoded_payload(encode(Slot(3, 1)), SLOTS, KEY) == Slot(3, 1)


@pytest.mark.parametrize("payload", [None, b""])
def test_no_payload_and_an_empty_one_are_none_and_not_logged(
    payload: bytes | None, caplog: pytest.LogCaptureFixture
) -> None:
    assert decoded_payload(payload, SLOTS, KEY) is None
    assert caplog.records == []


@pytest.mark.parametrize("payload", [b"\xc1", encode(Slot(3, 1))[:-1], b"\x91\xa1x"])
def test_a_payload_that_does_not_decode_is_none_and_logged_with_its_key(
    payload: bytes, caplog: pytest.LogCaptureFixture
) -> None:
    with caplog.at_level(logging.WARNING, logger="bus"):
        assert decoded_payload(payload, SLOTS, KEY) is None
    assert [record.getMessage() for record in caplog.records] == [
        f"undecodable sample on {KEY} ignored"
    ]
