"""The benchmark's client processes against a real one-group cell: jobs, streams, records."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from motocell.shared.protocol.constants import Result
from motocell.testing.client import point_messages
from motocell.testing.running_cell import running_cell
from motocell.tools.bench.clients import StateClientProcess, StreamClientProcess, stream_bound_s
from motocell.tools.bench.measuring import (
    CHECK_MOTION_READY,
    Observer,
    positions_of,
    ramp,
    wait_for_every_slot,
    wait_moving,
    write_cell_file,
)

pytestmark = pytest.mark.cell


def test_the_clients_time_requests_stream_stop_and_record_state(tmp_path: Path) -> None:
    config = write_cell_file(tmp_path, "clients", models=("arm6",))
    with running_cell(config) as cell, Observer(cell) as observer:
        wait_for_every_slot(cell)
        observer.record_ticks()
        state = StateClientProcess(cell, tmp_path / "state.npz", 120.0)
        try:
            with StreamClientProcess(cell, tmp_path) as streamer:
                streamer.start_traj_mode()
                requests = streamer.requests(CHECK_MOTION_READY, 5)
                assert requests["result"].tolist() == [Result.SUCCESS] * 5
                assert (requests["rtt_ns"] > 0).all()

                start = positions_of(cell.cell, observer.wait_still())[0]
                short = point_messages(0, ramp(start, 0.1, 0.2, 0.02))
                record = streamer.stream(short, stream_bound_s(0.2)).check()
                assert record.points == len(short) == 11
                assert (np.diff(record.accepted_ns) > 0).all()
                assert record.last_accepted_ns == record.accepted_ns[-1]
                assert len(record.rtts_ms(Result.SUCCESS)) == 11

                start = positions_of(cell.cell, observer.wait_still())[0]
                long = point_messages(0, ramp(start, -0.1, 10.0, 0.1))
                mark = observer.mark()
                streamer.begin(long, stream_bound_s(10.0))
                wait_moving(observer, mark)
                stopped = streamer.end().check()
                assert 0 < stopped.points < len(long)
                assert stopped.dropped == 0
        finally:
            recorded = state.stop()
    assert len(recorded["received_ns"]) > 0
    assert (np.diff(recorded["received_ns"]) >= 0).all()
    assert recorded["pulses"].shape == (len(recorded["received_ns"]), 6)
    assert int(recorded["dropped"]) == 0
