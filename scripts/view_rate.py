"""How many messages a second ``motocell view`` sends a client that subscribes to everything,
while the dual-arm-positioner cell moves all three groups, at each ``--rate`` given.

Starts the sample cell (``testing.running_cell``); for each rate, a ``motocell view --rate HZ``
on it and a Foxglove WebSocket client (``tests.foxglove_ws``) subscribed to every topic; moves
the three groups out (5 s) and back with MOTO_JOINT_TRAJ_PT_FULL_EX and counts what the client
receives over 3 s of the way out: messages a second, in all and per topic.

    PYTHONPATH=. .venv/bin/python scripts/view_rate.py 1000 30
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import threading
import time
from collections import Counter

from motocell.shared.protocol.constants import Command
from motocell.shared.registry import ENV as RUNTIME_DIR_ENV
from motocell.testing.client import smooth_move, stream_ex
from motocell.testing.running_cell import RunningCell, running_cell
from tests.foxglove_ws import FoxgloveClient

AWAY = {0: (0.6, 0.5, 0.3, 0.0, -0.6, 0.0), 1: (-0.5, 0.6, 0.3, -0.9, 0.0, 0.7, 0.0), 2: (0.6, 1.2)}
OUT_S, BACK_S = 5.0, 2.0
SETTLE_S = 0.5
"""Motion before the count starts: every group moving, the ticks at their full rate."""
COUNT_S = 3.0
READY = re.compile(r"ws://[\d.]+:\d+")
TOPICS = {
    *(f"/dual/{g}/joints" for g in ("R1", "R2", "S1")),
    *(f"/dual/{arm}/tcp{command}" for arm in ("R1", "R2") for command in ("", "/command")),
    *(f"/dual/{name}" for name in ("robot_status", "status", "executor", "executor/metrics")),
    "/dual/transforms",
    "/dual/scene",
}
"""Every topic the view serves of the cell."""


def move_out_and_back(cell: RunningCell, moving: list[int]) -> None:
    """The three groups out and back; ``moving`` gets the instant (monotonic ns) the first
    point is sent."""
    with cell.motion() as motion, cell.state() as state:
        motion.command(Command.START_TRAJ_MODE)
        still = state.wait_still()
        home = {g: tuple(still.groups[g].positions[: len(goal)]) for g, goal in AWAY.items()}
        moving.append(time.monotonic_ns())
        # One leg out, counted, and one back, not: the clock rests between two legs.
        for start, end, seconds in ((home, AWAY, OUT_S), (AWAY, home, BACK_S)):
            legs = {g: smooth_move(start[g], end[g], duration=seconds, points=21) for g in AWAY}
            stream_ex(motion, legs)


def counted(cell: RunningCell, rate: str) -> Counter[str]:
    """The messages of each topic the client got over ``COUNT_S`` of motion."""
    env = {**os.environ, RUNTIME_DIR_ENV: str(cell.runtime_dir)}
    command = [sys.executable, "-m", "motocell.tools.cli", "view", "--port", "0", "--rate", rate]
    view = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, text=True)
    try:
        assert view.stdout is not None
        url = next(m.group(0) for line in view.stdout if (m := READY.search(line)))
        with FoxgloveClient(url, max_queue=1024) as client:
            advertised = client.wait_for_topics(TOPICS, 30.0)
            client.subscribe(list(advertised.values()))
            moving: list[int] = []
            mover = threading.Thread(target=move_out_and_back, args=(cell, moving))
            mover.start()
            try:
                # Read throughout, so each message is stamped when it comes; count those of
                # the window that starts SETTLE_S into the motion.
                def window() -> tuple[int, int] | None:
                    if not moving:
                        return None
                    start = moving[0] + int(SETTLE_S * 1e9)
                    return start, start + int(COUNT_S * 1e9)

                found = client.messages_until(
                    lambda got: (w := window()) is not None and got[-1].received_ns >= w[1],
                    60.0,
                    "the count",
                )
            finally:
                mover.join()
        start, end = window() or (0, 0)
        return Counter(m.topic for m in found if start <= m.received_ns < end)
    finally:
        view.terminate()
        view.wait(timeout=20)


def main() -> None:
    rates = sys.argv[1:] or ["1000", "30"]
    with running_cell("dual-arm-positioner") as cell:
        for rate in rates:
            counts = counted(cell, rate)
            total = sum(counts.values()) / COUNT_S
            print(f"--rate {rate}: {total:.0f} messages/s")
            for topic, count in sorted(counts.items()):
                print(f"  {topic}: {count / COUNT_S:.0f}/s")


if __name__ == "__main__":
    main()
