"""A four-group cell that streams on its own: figure 10's moving cell and figure 11's neighbour.

One ``bench_cell`` (arm6, arm6, arm7, positioner2), ``state_clients`` state clients
(``bench.state_client``, each its own process) and a motion client (``bench.stream_client``)
streaming one long 2016 trajectory, every axis swinging ``AMPLITUDE`` either side of its start
(a sine of ``SWING_PERIOD_S``), points ``POINT_INTERVAL_S`` apart, like motoman_driver: the
next point at once after SUCCESS, a BUSY point resent after 5 ms, so the gateway answers BUSY
points all along. It streams until ``close`` (STOP_MOTION), and never leaves the joint ranges.

The benchmark's observer of the ticks is needed only to start: where the robot is, and that it
moves. With ``observe=False`` it is closed once the robot moves, so that nothing of the
benchmark's own subscribes to the cell while it is measured (a subscription to 250 ticks a
second would be part of the cell's cost).
"""

from __future__ import annotations

import contextlib
from pathlib import Path

from motocell.testing.client import ex_messages
from motocell.testing.running_cell import RunningCell
from motocell.tools.bench.clients import StateClientProcess, StreamClientProcess, StreamRecord
from motocell.tools.bench.measuring import (
    Observer,
    bench_cell,
    oscillations,
    positions_of,
    wait_moving,
)

AMPLITUDE = 0.2
SWING_PERIOD_S = 20.0
POINT_INTERVAL_S = 0.2


class SwingingCell:
    """A cell streaming until closed (module docstring)."""

    def __init__(
        self,
        directory: Path,
        name: str,
        seconds: float,
        *,
        state_period_ms: float = 10.0,
        state_clients: int = 1,
        observe: bool = True,
        tables: str = "",
    ) -> None:
        """``seconds``: the longest it may stream (its trajectory's length); ``tables``: TOML
        tables for its cell file (``bench_cell``)."""
        self.stack = contextlib.ExitStack()
        self.record: StreamRecord | None = None
        self.observer: Observer | None = None
        try:
            self._start(
                directory,
                name,
                seconds,
                state_period_ms=state_period_ms,
                state_clients=state_clients,
                observe=observe,
                tables=tables,
            )
        except BaseException:
            self.stack.close()
            raise

    def _start(
        self,
        directory: Path,
        name: str,
        seconds: float,
        *,
        state_period_ms: float,
        state_clients: int,
        observe: bool,
        tables: str,
    ) -> None:
        stack = self.stack
        self.cell: RunningCell = stack.enter_context(
            bench_cell(directory, name, state_period_ms=state_period_ms, tables=tables)
        )
        observer = Observer(self.cell)
        try:
            observer.record_ticks()
            for index in range(state_clients):
                out = directory / f"{name}-state{index}.npz"
                stack.callback(StateClientProcess(self.cell, out, seconds).kill)
            streamer = stack.enter_context(StreamClientProcess(self.cell, directory))
            streamer.start_traj_mode()
            starts = positions_of(self.cell.cell, observer.wait_still())
            plans = oscillations(starts, AMPLITUDE, SWING_PERIOD_S, seconds, POINT_INTERVAL_S)
            mark = observer.mark()
            streamer.begin(ex_messages(plans), seconds)

            def end() -> None:
                self.record = streamer.end()

            stack.callback(end)
            wait_moving(observer, mark)
        except BaseException:
            observer.close()
            raise
        if observe:
            self.observer = observer
            stack.callback(observer.close)
        else:
            observer.close()

    def close(self) -> StreamRecord | None:
        """Stop streaming and the cell; the stream's record (None if it could not be read)."""
        self.stack.close()
        return self.record

    def __enter__(self) -> SwingingCell:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
