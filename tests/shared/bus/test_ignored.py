"""The tally of ignored samples: every one counted, at most one log line per interval."""

from __future__ import annotations

import logging

import pytest

from motocell.shared.bus.ignored import IgnoredSamples

KEY = "motocell/c1/group/*/point"


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def clock() -> Clock:
    return Clock()


def lines(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [record.getMessage() for record in caplog.records]


def test_the_first_is_logged_at_once_with_its_key(
    clock: Clock, caplog: pytest.LogCaptureFixture
) -> None:
    tally = IgnoredSamples(10.0, clock)
    with caplog.at_level(logging.WARNING, logger="bus"):
        tally.note(KEY, "point for no group of this cell")
    assert lines(caplog) == [f"point for no group of this cell on {KEY} ignored"]
    assert tally.total == 1


def test_a_flood_is_counted_and_logged_once_per_interval(
    clock: Clock, caplog: pytest.LogCaptureFixture
) -> None:
    tally = IgnoredSamples(10.0, clock)
    with caplog.at_level(logging.WARNING, logger="bus"):
        for _ in range(10_000):
            tally.note(KEY, "undecodable sample")
            clock.now += 0.001
        assert len(caplog.records) == 1
        clock.now += 0.001  # 10.001 s after the first line
        tally.note("motocell/c1/controller/status", "undecodable sample")
    assert tally.total == 10_001
    assert lines(caplog)[1] == (
        "undecodable sample on motocell/c1/controller/status ignored"
        " (and 9999 more since the last such line)"
    )


def test_after_a_quiet_interval_the_next_is_logged_alone(
    clock: Clock, caplog: pytest.LogCaptureFixture
) -> None:
    tally = IgnoredSamples(10.0, clock)
    with caplog.at_level(logging.WARNING, logger="bus"):
        tally.note(KEY, "undecodable sample")
        clock.now += 10.0
        tally.note(KEY, "undecodable sample")
    assert lines(caplog) == [f"undecodable sample on {KEY} ignored"] * 2
