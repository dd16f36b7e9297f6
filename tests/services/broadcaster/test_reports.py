"""What the broadcaster reports, as an observer on a secured router sees it: the state client
count for OT#894 (the other ports left to the gateway) at once on a change, and its metrics."""

from __future__ import annotations

from pathlib import Path

import zenoh

from motocell.services.broadcaster.reports import REFRESH_S, Reports
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.schemas import BroadcasterMetrics, CommandRequest, Decoder
from motocell.testing.processes import wait_until
from tests.services.broadcaster.test_ticks import KEYS, cell_bus


def test_a_change_in_clients_is_reported_at_once_and_everything_every_second(
    tmp_path: Path,
) -> None:
    with cell_bus(tmp_path, Role.BROADCASTER, Role.OBSERVER) as (broadcaster, observer):
        notices = observer.declare_subscriber(
            KEYS.controller_cmd("connections"), zenoh.handlers.FifoChannel(256)
        )
        metrics = observer.declare_subscriber(
            KEYS.metrics("broadcaster"), zenoh.handlers.FifoChannel(256)
        )
        reports = Reports(broadcaster, KEYS)
        seen: list[list[int]] = []
        decoder = Decoder(CommandRequest)

        def heard() -> list[list[int]]:
            while (sample := notices.try_recv()) is not None:
                seen.append(decoder.decode(sample.payload.to_bytes()).args)
            return seen

        now = [0.0]

        def report_every_second() -> bool:
            now[0] += REFRESH_S
            reports.report(now[0], 2, 5, 1)
            return bool(heard())

        # The subscriptions travel through the router: report until one arrives.
        wait_until(report_every_second, 10.0, "a connections notice")
        assert seen[-1] == [-1, 2, -1]
        reports.written(1_500_000)
        reports.report(now[0] + REFRESH_S / 2, 1, 5, 1)  # not due: only the change
        wait_until(lambda: heard()[-1] == [-1, 1, -1], 5.0, "the change")
        reports.report(now[0] + REFRESH_S, 1, 6, 1)
        decoded: list[BroadcasterMetrics] = []
        metrics_decoder = Decoder(BroadcasterMetrics)

        def newest_metrics() -> BroadcasterMetrics | None:
            while (sample := metrics.try_recv()) is not None:
                decoded.append(metrics_decoder.decode(sample.payload.to_bytes()))
            return decoded[-1] if decoded else None

        wait_until(
            lambda: (m := newest_metrics()) is not None and m.replaced_total == 6, 5.0, "metrics"
        )
        last = decoded[-1]
        assert (last.state_clients, last.stuck_closed_total) == (1, 1)
        assert (last.write_age.count, last.write_age.max_us) == (1, 1500.0)
        reports.close()
        notices.undeclare()
        metrics.undeclare()
