"""A cell started with ``motocell.testing`` dies with the process that started it, however that
process ends: killed (SIGKILL, as the OOM killer or a CI agent does), terminated (SIGTERM, an
IDE's stop button, ``timeout``), or at the end of its ``with cell():`` block. Within seconds no
process of the cell runs, its ports are free, and nothing it had is left in the temporary
directory (its registry, credentials, cell file).

The starting process is ``tests/testing/starter.py``, a plain program with a TMPDIR of its own.
A router it started with the harness (``zenoh_router``) goes the same way.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import msgspec
import pytest

from motocell.testing.processes import alive, connectable, wait_until
from motocell.testing.running_cell import HOST
from tests.testing.starter import Started

pytestmark = pytest.mark.cell

REPO = Path(__file__).resolve().parents[2]
READY_TIMEOUT_S = 90.0
"""For the starter's cell to be whole: a second here, many on a loaded machine (a bound for a
hang, not a speed)."""
GONE_TIMEOUT_S = 15.0
"""For the cell to be gone once its starter is: the launcher stops its services within 5 s
(``STOP_GRACE_S``) and removes its directories right after; three times that is a hang."""


class Starter:
    """The starter as a child process of this test, its cell and what is left of it."""

    def __init__(self, tmp_path: Path, *options: str) -> None:
        self.tmp = tmp_path / "tmp"
        self.tmp.mkdir()
        self.log = tmp_path / "starter.log"
        ready = tmp_path / "ready.json"
        with self.log.open("wb") as out:
            self.process = subprocess.Popen(
                [sys.executable, "-m", "tests.testing.starter", "--ready", str(ready), *options],
                cwd=REPO,
                env={**os.environ, "TMPDIR": str(self.tmp)},
                stdin=subprocess.PIPE,
                stdout=out,
                stderr=subprocess.STDOUT,
            )
        try:
            wait_until(
                lambda: ready.exists() or self.process.poll() is not None,
                READY_TIMEOUT_S,
                "the starter's cell to be whole",
            )
        except TimeoutError:
            self.finish()
            raise
        assert self.process.poll() is None, self.output()
        self.cell = msgspec.json.decode(ready.read_bytes(), type=Started)

    def output(self) -> str:
        return self.log.read_text(errors="replace")

    def leftovers(self) -> list[str]:
        """What of the cell is still there."""
        return [
            *(f"process {pid}" for pid in self.cell.pids if alive(pid)),
            *(f"port {port} listens" for port in self.cell.ports if connectable(HOST, port)),
            *(f"{entry} in TMPDIR" for entry in self.tmp.iterdir()),
        ]

    def wait_gone(self) -> float:
        """Seconds until nothing of the cell is left; AssertionError naming what is left, after
        GONE_TIMEOUT_S."""
        start = time.monotonic()
        try:
            wait_until(lambda: not self.leftovers(), GONE_TIMEOUT_S, "the cell to be gone")
        except TimeoutError:
            raise AssertionError(f"{self.leftovers()}\n{self.output()}") from None
        return time.monotonic() - start

    def finish(self) -> None:
        """Kill the starter, if it still runs, and reap it (its cell then goes by itself)."""
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait()
        assert self.process.stdin is not None
        self.process.stdin.close()


@pytest.fixture
def starter(tmp_path: Path, request: pytest.FixtureRequest) -> Iterator[Starter]:
    options: tuple[str, ...] = getattr(request, "param", ())
    started = Starter(tmp_path, *options)
    try:
        yield started
    finally:
        started.finish()
        started.wait_gone()


@pytest.mark.parametrize("how", [signal.SIGKILL, signal.SIGTERM], ids=["SIGKILL", "SIGTERM"])
def test_a_cell_dies_with_the_process_that_started_it(
    starter: Starter, how: signal.Signals
) -> None:
    assert all(alive(pid) for pid in starter.cell.pids), starter.output()
    starter.process.send_signal(how)
    assert starter.process.wait(GONE_TIMEOUT_S) == -how
    starter.wait_gone()


@pytest.mark.parametrize("starter", [("--router",)], indirect=True)
def test_a_router_the_harness_started_dies_with_it_too(starter: Starter) -> None:
    starter.process.kill()
    starter.process.wait()
    starter.wait_gone()


@pytest.mark.parametrize("starter", [("--from-thread",)], indirect=True)
def test_a_cell_started_from_a_thread_outlives_the_thread_not_the_process(
    starter: Starter,
) -> None:
    # The starter's thread ended before it said the cell was whole: every process still runs.
    assert all(alive(pid) for pid in starter.cell.pids), starter.output()
    assert all(connectable(HOST, port) for port in starter.cell.ports), starter.output()
    starter.process.kill()
    starter.process.wait()
    starter.wait_gone()


def test_the_end_of_the_block_stops_the_cell_and_leaves_nothing(starter: Starter) -> None:
    assert starter.process.stdin is not None
    starter.process.stdin.close()  # the starter leaves its `with cell():` block
    assert starter.process.wait(GONE_TIMEOUT_S) == 0, starter.output()
    assert starter.leftovers() == [], starter.output()
