"""One state-port client in its own process: the state figures (3, 6) and the load of 4, 5, 7.

  python -m motocell.tools.bench.state_client --port P --config CELL.toml --seconds S --out OUT.npz

A lean recorder, so that what it measures is the cell and not itself: it reads the socket in its
main thread (no reader thread, no queue), stamps CLOCK_MONOTONIC as soon as a read returns, and
stores each state cycle (ended by its ROBOT_STATUS, motoros1 §6 order) in numpy arrays allocated
up front for ``--seconds`` of the cell's state rate plus a quarter (``capacity``); later cycles
are counted, not stored. The garbage collector is off once connected (``freeze_gc``). It prints
``ready``, records until a line or the end of stdin, and writes to OUT.npz:

- ``received_ns``: when the read that completed the cycle's ROBOT_STATUS returned;
- ``pulses``: each group's JOINT_FEEDBACK positions converted back to pulses (Motoman order,
  groups concatenated in group order); a row missing a group is all ``INCOMPLETE``;
- ``dropped``: cycles past the capacity.
"""

from __future__ import annotations

import argparse
import math
import select
import socket
import sys
import time

import numpy as np

from motocell.shared.config import Cell, load_cell
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.protocol.codec import CLOSED, NEED_DATA, ByteOrder, Role, SimpleMessageCodec
from motocell.shared.protocol.messages import JointFeedback, Message, RobotStatus
from motocell.testing.client import connect
from motocell.tools.bench.recording import freeze_gc, report, take_the_cells_priority

INCOMPLETE = np.iinfo(np.int64).min
HEADROOM = 1.25
"""Rows beyond the nominal rate: a cell that sends faster than configured is still recorded."""


def capacity(seconds: float, state_period_ns: int) -> int:
    """Rows for ``seconds`` of state cycles at the cell's rate, with headroom."""
    return math.ceil(seconds * 1e9 / state_period_ns * HEADROOM) + 100


class StateRecorder:
    """Decodes state frames and fills preallocated rows, one per state cycle."""

    def __init__(self, cell: Cell, rows: int) -> None:
        self.maps = [AxisMap(group) for group in cell.groups]
        starts = np.cumsum([0] + [m.axes for m in self.maps])
        self.slices = {g: (int(starts[g]), m.axes) for g, m in enumerate(self.maps)}
        self.codec = SimpleMessageCodec(Role.CLIENT, ByteOrder(cell.byte_order))
        self.received_ns = np.zeros(rows, dtype=np.int64)
        self.positions = np.full((rows, int(starts[-1])), np.nan, dtype=np.float64)
        self.rows = 0
        self.dropped = 0

    def feed(self, data: bytes, read_ns: int) -> bool:
        """Take the bytes of one read; False once the cell closed the connection."""
        codec = self.codec
        codec.receive_data(data)
        while True:
            event = codec.next_event()
            if event is NEED_DATA:
                return True
            if event is CLOSED:
                return False
            if isinstance(event, Message):
                self._take(event.body, read_ns)

    def _take(self, body: object, read_ns: int) -> None:
        row = self.rows
        if row >= len(self.received_ns):
            if type(body) is RobotStatus:
                self.dropped += 1
            return
        if type(body) is JointFeedback:
            where = self.slices.get(body.group_no)
            if where is not None:
                start, axes = where
                self.positions[row, start : start + axes] = body.positions[:axes]
        elif type(body) is RobotStatus:
            self.received_ns[row] = read_ns
            self.rows = row + 1

    def pulses(self) -> np.ndarray:
        """Pulses per recorded cycle (``INCOMPLETE`` rows where a group was missing)."""
        positions = self.positions[: self.rows]
        result = np.full(positions.shape, INCOMPLETE, dtype=np.int64)
        complete = ~np.isnan(positions).any(axis=1)
        for g, axis_map in enumerate(self.maps):
            start, axes = self.slices[g]
            columns = slice(start, start + axes)
            result[complete, columns] = axis_map.ros_to_pulses(positions[complete, columns])
        return result


def record(sock: socket.socket, recorder: StateRecorder) -> None:
    """Until a line or the end of stdin (or the cell closes the port)."""
    stdin = sys.stdin.fileno()
    poller = select.poll()
    poller.register(sock.fileno(), select.POLLIN)
    poller.register(stdin, select.POLLIN | select.POLLHUP)
    while True:
        events = poller.poll()
        if any(fd == stdin for fd, _ in events):
            return
        data = sock.recv(1 << 16)
        if not recorder.feed(data, time.monotonic_ns()):
            return


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--config", required=True)
    parser.add_argument("--seconds", type=float, required=True, help="the longest recording")
    parser.add_argument("--out", required=True)
    args = parser.parse_args(argv)
    take_the_cells_priority()
    cell = load_cell(args.config)
    recorder = StateRecorder(cell, capacity(args.seconds, cell.state_period_ns))
    with connect(args.host, args.port) as sock:
        sock.settimeout(None)
        freeze_gc()
        report("ready")
        record(sock, recorder)
    np.savez(
        args.out,
        received_ns=recorder.received_ns[: recorder.rows],
        pulses=recorder.pulses(),
        dropped=np.int64(recorder.dropped),
    )


if __name__ == "__main__":
    main()
