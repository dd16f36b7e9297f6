"""The executor's CPU per tick while four groups move, in-process: figure 3's tick-path rows.

    python -m motocell.tools.bench.tick_path [ticks]
    PYTHONPATH=<another tree> python tools/bench/tick_path.py [ticks]   # the same loop on its code

The real ``ExecutorCore`` of the benchmark's four groups (arm6, arm6, arm7, positioner2, their
speed limits, ranges and servo models) and the real ``Outputs`` on a Zenoh session, with a
second session subscribed to everything it publishes, so each put is sent. Every tick does
what the clock's does while the robot moves: decode the batches that came (50 entries each,
whenever a ring is below 150), step, publish the tick and the queue states that are due; each
used axis moves 3 pulses a tick, turning every 500 ticks. Between ticks the thread sleeps to
the next 4 ms deadline as the clock does, so the caches are as cold as the clock finds them; a
tight loop measures about a third of it (docs/realtime.md, "The tick's cost").

What is timed is the thread's own CPU time (``CLOCK_THREAD_CPUTIME_ID``) around each tick's
work, not the sleep; Zenoh's own threads (the transmit thread each put wakes) are not in it,
figure 10 shows the whole process. The second form runs this loop on another tree whose
executor has the same interface (``core.start.core_for_cell``, ``outputs.Outputs`` over a
``bus.ZenohBus``).
"""

from __future__ import annotations

import struct
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import zenoh

from motocell.services.executor.bus import ZenohBus
from motocell.services.executor.core.executor import ExecutorCore
from motocell.services.executor.core.start import core_for_cell
from motocell.services.executor.outputs import Outputs
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import Decoder, IncrementBatch, encode
from motocell.shared.bus.session import bus_config
from motocell.shared.config import Cell, load_cell
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.ports import free_port
from motocell.shared.protocol.constants import MAX_AXES
from motocell.testing.statuses import ready_status

MODELS = ("arm6", "arm6", "arm7", "positioner2")
BATCH = 50
REFILL_BELOW = 150
STEP_PULSES = 3
TURN_EVERY = 500
STATUS_EVERY = 25
"""Ticks between controller statuses: 10 a second, as the controller's heartbeat while moving."""


def four_groups(directory: Path) -> Cell:
    lines = ['name = "tick"', 'controller = "YRC1000"', "interpolation_period_ms = 4", ""]
    for index, model in enumerate(MODELS):
        lines += ["[[groups]]", f'name = "G{index + 1}"', f'model = "{model}"', ""]
    path = directory / "tick.toml"
    path.write_text("\n".join(lines))
    return load_cell(path)


class Feed:
    """Batches for each ring, numbered as an interpolator numbers them (anew per epoch)."""

    def __init__(self, core: ExecutorCore, cell: Cell) -> None:
        self.core = core
        self.axes = [AxisMap(group).axes for group in cell.groups]
        self.epochs = [ring.epoch for ring in core.rings]
        self.sent = [0] * len(cell.groups)

    def batch(self, group: int, step: int) -> bytes:
        ring = self.core.rings[group]
        if ring.epoch != self.epochs[group]:
            self.epochs[group], self.sent[group] = ring.epoch, 0
        row = [step if axis < self.axes[group] else 0 for axis in range(MAX_AXES)]
        data = struct.pack(f"<{MAX_AXES * BATCH}i", *(row * BATCH))
        batch = IncrementBatch(
            epoch=ring.epoch,
            first_seq=self.sent[group],
            count=BATCH,
            increments=data,
            partial=[],
            tool=0,
            times_ns=list(range(BATCH)),
        )
        self.sent[group] += BATCH
        return encode(batch)


def tick_path_us(ticks: int) -> np.ndarray:
    """Microseconds of this thread's CPU time per tick (module docstring)."""
    with tempfile.TemporaryDirectory(prefix="motocell-tick-") as directory:
        cell = four_groups(Path(directory))
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    publishing = zenoh.open(bus_config("peer", listen=[endpoint]))
    subscribing = zenoh.open(bus_config("peer", connect=[endpoint]))
    try:
        heard = subscribing.declare_subscriber("motocell/**", lambda _sample: None)
        outputs = Outputs(ZenohBus(publishing), CellKeys("tick"), len(cell.groups))
        taken = measure_ticks(cell, outputs, ticks)
        heard.undeclare()
    finally:
        subscribing.close()
        publishing.close()
    return taken / 1000.0


def measure_ticks(cell: Cell, outputs: Outputs, ticks: int) -> np.ndarray:
    """Nanoseconds of this thread's CPU time per tick."""
    core = core_for_cell(cell, None, first_epoch=1)
    feed = Feed(core, cell)
    decoder = Decoder(IncrementBatch)
    status = ready_status(tools=[0] * len(cell.groups))
    deadline = time.monotonic_ns()
    core.on_status(status, deadline)
    core.on_controller(True, deadline)
    taken = np.empty(ticks)
    for tick in range(ticks):
        step = STEP_PULSES if (tick // TURN_EVERY) % 2 == 0 else -STEP_PULSES
        due = [
            (group, feed.batch(group, step))
            for group, ring in enumerate(core.rings)
            if len(ring.entries) < REFILL_BELOW
        ]
        start = time.thread_time_ns()
        for group, data in due:
            core.accept(group, decoder.decode(data))
        if tick % STATUS_EVERY == 0:
            core.on_status(status, deadline)
        core.on_controller(True, deadline)
        core.on_tick(deadline, 0)
        notices = core.take_notices()
        outputs.notices(notices)
        outputs.tick(core.tick_report(deadline, 0, 0))
        outputs.queues(core.queue_updates(deadline))
        taken[tick] = time.thread_time_ns() - start
        if notices:
            raise RuntimeError(f"the motion system refused a tick: {notices}")
        deadline += cell.period_ns
        time.sleep(max(0, deadline - time.monotonic_ns()) / 1e9)
    return taken


def main() -> None:
    ticks = int(sys.argv[1]) if len(sys.argv) > 1 else 2000
    taken = tick_path_us(ticks)
    p50, p99 = np.percentile(taken, (50, 99))
    mean = taken.mean()
    print(f"executor tick path, {ticks} ticks: mean {mean:.1f} us, p50 {p50:.1f}, p99 {p99:.1f}")


if __name__ == "__main__":
    main()
