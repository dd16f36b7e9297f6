"""A client that does not offer ``foxglove.sdk.v1``: foxglove-sdk's server (in this process,
on a free port) refuses it with HTTP 400, and the one line it logs says what a viewer must
offer and which ones do."""

from __future__ import annotations

import logging
from collections.abc import Iterator

import foxglove
import pytest
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect
from websockets.typing import Subprotocol

from motocell.testing.processes import wait_until
from motocell.tools.view import OFFERED_BY, REFUSALS_LOGGER, ExplainRefusals

DEADLINE_S = 10.0
"""The SDK logs from its own thread after the client has its answer: a bound for a hang."""


@pytest.fixture
def server_url() -> Iterator[str]:
    explain = ExplainRefusals()
    logger = logging.getLogger(REFUSALS_LOGGER)
    logger.addFilter(explain)
    server = foxglove.start_server(
        name="test", host="127.0.0.1", port=0, capabilities=[], context=foxglove.Context()
    )
    try:
        yield f"ws://127.0.0.1:{server.port}"
    finally:
        server.stop()
        logger.removeFilter(explain)


@pytest.mark.parametrize("offered", [[], ["foxglove.websocket.v1"]], ids=["none", "older"])
def test_a_refused_client_is_one_line_naming_the_subprotocol_and_the_viewers(
    server_url: str, offered: list[str], caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.ERROR, logger=REFUSALS_LOGGER)
    with pytest.raises(InvalidStatus) as refused:
        connect(server_url, subprotocols=[Subprotocol(p) for p in offered], open_timeout=5)
    assert refused.value.response.status_code == 400

    def dropped() -> list[str]:
        return [r.getMessage() for r in caplog.records if r.name == REFUSALS_LOGGER]

    wait_until(lambda: dropped() != [], DEADLINE_S, "the server to log the refusal")
    [line] = dropped()
    assert line.startswith("Dropping client 127.0.0.1:"), line
    assert line.endswith(f": handshake failed ({OFFERED_BY})"), line
    assert "foxglove.sdk.v1" in OFFERED_BY and "Lichtblick 1.22.0" in OFFERED_BY


def test_other_lines_pass_unchanged() -> None:
    record = logging.LogRecord(REFUSALS_LOGGER, logging.INFO, "", 0, "Started server", (), None)
    assert ExplainRefusals().filter(record) and record.getMessage() == "Started server"
