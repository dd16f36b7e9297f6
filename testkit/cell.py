"""Running real cells for tests: real processes, real TCP, real Zenoh, on free loopback ports.

Each cell gets its own Zenoh router on a free port (never the well-known 7447, never
multicast), so tests cannot see each other's cells. Teardown stops the launcher and then
proves that no process it started is left.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import zenoh

from shared.bus.keys import CellKeys
from shared.bus.schemas import Decoder, Tick
from shared.config import Cell, load_cell
from shared.ports import free_port, free_port_block
from shared.protocol.codec import ByteOrder
from shared.protocol.constants import Command, NotReadySubcode
from testkit.client import MotionClient, StateListener
from testkit.processes import alive, connectable, descendants, wait_until

REPO = Path(__file__).resolve().parent.parent
START_TIMEOUT_S = 30.0


@dataclass
class RunningCell:
    cell: Cell
    host: str
    port_base: int
    zenoh_endpoint: str
    process: subprocess.Popen[bytes]

    @property
    def byte_order(self) -> ByteOrder:
        return ByteOrder(self.cell.byte_order)

    def motion(self) -> MotionClient:
        return MotionClient(self.host, self.port_base, self.byte_order)

    def io(self) -> MotionClient:
        return MotionClient(self.host, self.port_base + 2, self.byte_order)

    def state(self) -> StateListener:
        return StateListener(self.host, self.port_base + 1, self.byte_order)

    def children(self) -> set[int]:
        return descendants(self.process.pid)


def wait_for_whole_cell(
    host: str, port_base: int, byte_order: ByteOrder, timeout: float = START_TIMEOUT_S
) -> None:
    """Every service is up: state flows and motion-ready no longer reports a missing service
    (INC_MOVE_ERROR); START_TRAJ_MODE can then succeed."""
    wait_until(lambda: connectable(host, port_base + 1), timeout, "the state port to listen")
    with StateListener(host, port_base + 1, byte_order) as state:
        state.wait_for(lambda f: f.status is not None and f.status.drives_powered != -1, timeout)
    with MotionClient(host, port_base, byte_order) as motion:
        wait_until(
            lambda: (
                motion.command(Command.CHECK_MOTION_READY).subcode != NotReadySubcode.INC_MOVE_ERROR
            ),
            timeout,
            "every service of the cell to be alive",
        )


@contextmanager
def running_cell(
    config: str | None = None,
    extra: Sequence[str] = (),
    router: str | None = None,
    skip: Sequence[str] = (),
) -> Iterator[RunningCell]:
    """``motocell up`` on free ports: with its own router, or joining ``router``. ``skip``ped
    services are the test's to run; the cell is only waited for when nothing is skipped."""
    cell = load_cell(config)
    port_base = free_port_block(3)
    endpoint = router or f"tcp/127.0.0.1:{free_port()}"
    zenoh_option = "--zenoh-connect" if router else "--zenoh-listen"
    command = [
        *(sys.executable, "-m", "tools.cli", "up", "--port-base", str(port_base)),
        *(zenoh_option, endpoint, *extra),
    ]
    for service in skip:
        command += ["--skip", service]
    if config:
        command += ["--config", config]
    env = {**os.environ, "MOTOCELL_LOG": os.environ.get("MOTOCELL_TEST_LOG", "WARNING")}
    process = subprocess.Popen(command, cwd=REPO, env=env)
    running = RunningCell(cell, "127.0.0.1", port_base, endpoint, process)
    started: set[int] = set()
    try:
        expected = 4 + len(cell.groups) - len(skip)
        wait_until(
            lambda: len(running.children()) >= expected,
            START_TIMEOUT_S,
            "every service process to start",
        )
        started = running.children()
        if not skip:
            wait_for_whole_cell(running.host, port_base, running.byte_order)
        yield running
    finally:
        started |= running.children()
        process.send_signal(signal.SIGTERM)
        try:
            process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
            raise AssertionError("motocell up did not stop within 10 s of SIGTERM") from None
        wait_until(
            lambda: not any(alive(pid) for pid in started), 5.0, "every service process to exit"
        )


class TickLog:
    """Every executor tick, as any Zenoh observer sees it."""

    def __init__(self, session: zenoh.Session, keys: CellKeys) -> None:
        self.ticks: list[Tick] = []
        self.lock = threading.Lock()
        decoder = Decoder(Tick)

        def store(sample: zenoh.Sample) -> None:
            tick = decoder.decode(sample.payload.to_bytes())
            with self.lock:
                self.ticks.append(tick)

        self.subscriber = session.declare_subscriber(keys.executor_tick, store)

    def since(self, index: int) -> list[Tick]:
        with self.lock:
            return self.ticks[index:]

    def __len__(self) -> int:
        with self.lock:
            return len(self.ticks)
