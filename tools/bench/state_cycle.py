"""The broadcaster's own work per state cycle, in one process: a four-group moving tick in, its
snapshot and its frames out (``Broadcaster.on_tick`` and ``frames.state_frames``).

    python -m motocell.tools.bench.state_cycle [--cycles 500] [--repeats 5] [--period-ms 4]

No sockets and no Zenoh: what a state period costs the broadcaster's thread before its sends
and after its tick arrives, for the four groups of ``bench_cell`` (arm6, arm6, arm7,
positioner2) moving, a snapshot every tick (state period 4 ms). Each tick is a distinct one
decoded from msgpack, as the bus delivers it. Each cycle runs after a sleep to its period's
deadline, as the broadcaster's thread waits for the next tick, and only the cycle is timed: a
tight loop keeps the interpreter's caches warm and measures about half of it (``--period-ms
0``). Prints the median and [min - max] over the repeats, in microseconds per cycle.

To compare two versions of the code on the same machine in the same minute, run this file with
``PYTHONPATH`` set to a checkout of each: the imports below come from that checkout.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Sequence

from motocell.services.broadcaster.core.broadcaster import Broadcaster
from motocell.services.broadcaster.core.frames import state_frames
from motocell.shared.bus.schemas import ControllerStatus, Decoder, GroupTick, Tick, encode
from motocell.shared.config import Cell, parse_cell
from motocell.shared.protocol.codec import ByteOrder
from motocell.testing.statuses import ready_status
from motocell.tools.bench.measuring import GROUP_MODELS

PERIOD_MS = 4.0
AXES = 8


class ReadyController:
    """A controller that is there and ready, as while a cell moves."""

    def __init__(self) -> None:
        self._status = ready_status(play=False, tools=[0] * len(GROUP_MODELS))

    def status(self) -> ControllerStatus:
        return self._status

    def alive(self) -> bool:
        return True


def four_groups() -> Cell:
    groups = [{"name": f"G{index + 1}", "model": model} for index, model in enumerate(GROUP_MODELS)]
    return parse_cell(
        {"interpolation_period_ms": PERIOD_MS, "state_period_ms": PERIOD_MS, "groups": groups}
    )


def moving_ticks(count: int, groups: int) -> list[Tick]:
    """``count`` ticks of every group moving a pulse per axis per tick, the feedback 10 pulses
    behind, rings not empty; each decoded from its own msgpack bytes."""
    decoder = Decoder(Tick)
    period_ns = int(PERIOD_MS * 1e6)
    ticks = []
    for n in range(count):
        group_ticks = [
            GroupTick(
                command_pulses=[1000 + n + axis for axis in range(AXES)],
                feedback_pulses=[990 + n + axis for axis in range(AXES)],
                increment=[1] * AXES,
                depth=40,
                feedback_moved=[1.0] * AXES,
            )
            for _ in range(groups)
        ]
        tick = Tick(n, n * period_ns, 1000, 0, True, group_ticks)
        ticks.append(decoder.decode(encode(tick)))
    return ticks


def measure(cycles: int, repeats: int, period_s: float = PERIOD_MS / 1000) -> list[float]:
    """Microseconds per cycle, one value per repeat, each on a fresh broadcaster; each cycle
    after a sleep to the next ``period_s`` deadline (0: back to back)."""
    cell = four_groups()
    ticks = moving_ticks(cycles, len(cell.groups))
    results = []
    for _ in range(repeats):
        broadcaster = Broadcaster(cell, ReadyController())
        busy = 0.0
        deadline = time.monotonic()
        for tick in ticks:
            deadline += period_s
            if period_s:
                time.sleep(max(0.0, deadline - time.monotonic()))
            started = time.perf_counter()
            state = broadcaster.on_tick(tick, 0.0)
            if state is not None:
                state_frames(state, ByteOrder.LITTLE)
            busy += time.perf_counter() - started
        results.append(busy / cycles * 1e6)
    return results


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cycles", type=int, default=500)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument(
        "--period-ms", type=float, default=PERIOD_MS, help="sleep between cycles (0: none)"
    )
    args = parser.parse_args(argv)
    values = measure(args.cycles, args.repeats, args.period_ms / 1000)
    print(
        f"state cycle, four groups: {statistics.median(values):.1f} us "
        f"[{min(values):.1f} - {max(values):.1f}] over {args.repeats} x {args.cycles} cycles"
        f" {args.period_ms:g} ms apart"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
