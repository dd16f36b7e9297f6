"""What the broadcaster reports, against a scripted bus: the state client count for OT#894 (the
other ports left to the gateway) at once on a change and every second, and its metrics every
second while anyone subscribes."""

from __future__ import annotations

import pytest

from motocell.services.broadcaster.reports import REFRESH_S, StatePortReports
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import BroadcasterMetrics, CommandRequest, Decoder
from tests.services.broadcaster.fake_bus import FakeBus
from tests.services.fakes import FakePublication

KEYS = CellKeys("c1")


class Reported:
    def __init__(self) -> None:
        self.bus = FakeBus()
        self.reports = StatePortReports(self.bus, KEYS)
        self.connections = self.bus.publications[KEYS.controller_cmd("connections")]
        self.metrics = self.bus.publications[KEYS.metrics("broadcaster")]
        self.metrics.subscribed = True

    def notices(self) -> list[list[int]]:
        decoder = Decoder(CommandRequest)
        return [decoder.decode(payload).args for payload in self.connections.payloads]

    def published_metrics(self) -> list[BroadcasterMetrics]:
        decoder = Decoder(BroadcasterMetrics)
        return [decoder.decode(payload) for payload in self.metrics.payloads]


@pytest.fixture
def reported() -> Reported:
    return Reported()


def test_both_are_latest_value_streams(reported: Reported) -> None:
    """Dropped rather than blocking the state loop under congestion."""
    publications: list[FakePublication] = [reported.connections, reported.metrics]
    assert all(p.latest and not p.realtime for p in publications)


def test_a_change_in_clients_is_reported_at_once_and_everything_every_second(
    reported: Reported,
) -> None:
    reports = reported.reports
    reports.report(10.0, 2, 5, 1)
    assert reported.notices() == [[-1, 2, -1]]
    assert reports.next_due == 10.0 + REFRESH_S
    reports.written(1_500_000)
    reports.report(10.0 + REFRESH_S / 2, 1, 5, 1)  # not due: only the change
    assert reported.notices()[-1] == [-1, 1, -1]
    assert len(reported.published_metrics()) == 1
    reports.report(10.0 + REFRESH_S, 1, 6, 1)
    assert reported.notices() == [[-1, 2, -1], [-1, 1, -1], [-1, 1, -1]]
    last = reported.published_metrics()[-1]
    assert (last.state_clients, last.replaced_total, last.stuck_closed_total) == (1, 6, 1)
    assert (last.write_age.count, last.write_age.max_us) == (1, 1500.0)


def test_nothing_is_sent_while_nothing_changed_and_nothing_is_due(reported: Reported) -> None:
    reported.reports.report(10.0, 1, 0, 0)
    reported.reports.report(10.5, 1, 0, 0)
    assert len(reported.notices()) == 1
    assert len(reported.published_metrics()) == 1


def test_metrics_are_made_only_while_observed_and_their_window_is_a_second(
    reported: Reported,
) -> None:
    reports = reported.reports
    reported.metrics.subscribed = False
    reports.written(2_000_000)
    reports.report(10.0, 0, 0, 0)
    assert reported.published_metrics() == []
    assert reported.notices() == [[-1, 0, -1]]  # the controller is told all the same
    reported.metrics.subscribed = True
    reports.report(10.0 + REFRESH_S, 0, 0, 0)
    (metrics,) = reported.published_metrics()
    assert metrics.write_age.count == 0, "the ages of the second before were cleared"


def test_closing_undeclares_both(reported: Reported) -> None:
    reported.reports.close()
    assert reported.connections.undeclared and reported.metrics.undeclared
