"""The benchmark's TCP clients, each in a process of its own, as a real client is.

``StateClientProcess`` runs ``tools.bench.state_client`` (one state-port connection, recorded);
``StreamClientProcess`` runs ``tools.bench.stream_client`` (the cell's one motion-port connection,
jobs of timed requests and streams). Both measure with the garbage collector off into arrays
sized up front, and talk to this process by lines on their stdin and stdout.
"""

from __future__ import annotations

import contextlib
import os
import select
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

import msgspec
import numpy as np

from motocell.shared.protocol.codec import Role, SimpleMessageCodec
from motocell.shared.protocol.constants import Command, Result
from motocell.shared.protocol.messages import Message
from motocell.shared.protocol.replies import motion_ctrl
from motocell.testing.running_cell import RunningCell
from motocell.tools.bench.measuring import LogTail, refusal_text
from motocell.tools.bench.stream_client import BUSY_RETRY_S, Requests, Stream

T = TypeVar("T")

START_TIMEOUT_S = 30.0
JOB_TIMEOUT_S = 600.0
"""Beyond a job's own bound: a job that takes longer is a hang."""
RECOVER_TIMEOUT_S = 30.0
RETRIES = 2
"""How often a run the cell refused is measured again (``measured_again``)."""


def stream_bound_s(nominal_s: float) -> float:
    """The longest a stream of ``nominal_s`` of points may take: BUSY back-offs can stretch
    it (motoman_driver's 5 ms retry against 4 ms points), so three times that and 10 s."""
    return 3 * nominal_s + 10.0


class ChildProcess:
    """A ``python -m`` child that answers in lines on stdout."""

    def __init__(self, module: str, arguments: Sequence[str]) -> None:
        command = [sys.executable, "-m", module, *arguments]
        self.name = module
        self.process = subprocess.Popen(
            command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, bufsize=0
        )
        self._buffer = b""
        try:
            self.expect("ready", START_TIMEOUT_S)
        except BaseException:
            self.kill()
            raise

    def send(self, line: str) -> None:
        """One line (a job can be megabytes: a raw pipe may take it in several writes)."""
        assert self.process.stdin is not None
        data = memoryview(line.encode() + b"\n")
        while data:
            data = data[self.process.stdin.write(data) or 0 :]

    def expect(self, word: str, timeout: float) -> None:
        line = self.read_line(timeout)
        if line != word:
            raise RuntimeError(f"{self.name}: {line or 'exited'}")

    def read_line(self, timeout: float) -> str:
        """The next line ("" if the child exited first); TimeoutError after ``timeout``."""
        assert self.process.stdout is not None
        fd = self.process.stdout.fileno()
        deadline = time.monotonic() + timeout
        while b"\n" not in self._buffer:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise TimeoutError(f"{self.name} did not answer within {timeout:g} s")
            readable, _, _ = select.select([fd], [], [], remaining)
            if readable:
                data = os.read(fd, 4096)
                if not data:
                    return ""
                self._buffer += data
        line, _, self._buffer = self._buffer.partition(b"\n")
        return line.decode()

    def close(self, timeout: float = 30.0) -> None:
        """End its stdin and wait for it to exit (killed after ``timeout``)."""
        with contextlib.suppress(OSError):
            assert self.process.stdin is not None
            self.process.stdin.close()
        try:
            self.process.wait(timeout)
        except subprocess.TimeoutExpired:
            self.kill()
            raise
        self._close_pipes()

    def kill(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait()
        self._close_pipes()

    def _close_pipes(self) -> None:
        for pipe in (self.process.stdin, self.process.stdout):
            if pipe is not None:
                with contextlib.suppress(OSError):
                    pipe.close()


def load(path: Path) -> dict[str, np.ndarray]:
    with np.load(path) as data:
        return {key: data[key] for key in data.files}


class StateClientProcess:
    """``python -m motocell.tools.bench.state_client``: records each state cycle for ``seconds``."""

    def __init__(self, cell: RunningCell, out: Path, seconds: float) -> None:
        self.out = out
        arguments = [
            *("--host", cell.host, "--port", str(cell.port_base + 1)),
            *("--config", str(cell.config), "--seconds", f"{seconds:g}", "--out", str(out)),
        ]
        self.child = ChildProcess("motocell.tools.bench.state_client", arguments)

    def stop(self, timeout: float = 30.0) -> dict[str, np.ndarray]:
        """``received_ns``, ``pulses`` and ``dropped`` (see ``tools.bench.state_client``)."""
        self.child.close(timeout)
        return load(self.out)

    def kill(self) -> None:
        self.child.kill()


@dataclass
class StreamRecord:
    """What ``tools.bench.stream_client`` recorded of one stream (times CLOCK_MONOTONIC ns)."""

    sent_ns: np.ndarray
    rtt_ns: np.ndarray
    result: np.ndarray
    """Per request: sent, round trip, result."""
    accepted_ns: np.ndarray
    """Per point: when its SUCCESS was read (0: never accepted)."""
    probe_rtt_ns: np.ndarray
    probe_index: np.ndarray
    """Per probe: round trip, and which of the job's probes it was."""
    points: int
    busy: int
    first_sent_ns: int
    last_accepted_ns: int
    dropped: int
    """Requests past the record's capacity (counted, not recorded)."""
    error: str

    @classmethod
    def from_arrays(cls, data: dict[str, np.ndarray]) -> StreamRecord:
        return cls(
            sent_ns=data["sent_ns"],
            rtt_ns=data["rtt_ns"],
            result=data["result"],
            accepted_ns=data["accepted_ns"],
            probe_rtt_ns=data["probe_rtt_ns"],
            probe_index=data["probe_index"],
            points=int(data["points"]),
            busy=int(data["busy"]),
            first_sent_ns=int(data["first_sent_ns"]),
            last_accepted_ns=int(data["last_accepted_ns"]),
            dropped=int(data["dropped"]),
            error=str(data["error"]),
        )

    def rtts_ms(self, result: Result) -> np.ndarray:
        chosen: np.ndarray = self.rtt_ns[self.result == int(result)]
        return chosen / 1e6

    def probes_ms(self, index: int) -> np.ndarray:
        chosen: np.ndarray = self.probe_rtt_ns[self.probe_index == index]
        return chosen / 1e6

    def check(self) -> StreamRecord:
        if self.error:
            raise StreamRefusedError(f"streaming failed: {self.error}")
        return self


class StreamRefusedError(RuntimeError):
    """A stream stopped at a point the cell refused (NOT_READY, INVALID, ...)."""


class StreamClientProcess:
    """``python -m motocell.tools.bench.stream_client``: the motion client, one job at a time."""

    def __init__(self, cell: RunningCell, directory: Path, *, priority: str = "services") -> None:
        """``priority``: one of ``recording.CLIENT_PRIORITIES`` (``take_client_priority``)."""
        self.directory = directory
        self.codec = SimpleMessageCodec(Role.CLIENT, cell.byte_order)
        self.jobs = 0
        self._job_out = ""
        self._job_seconds = 0.0
        arguments = [
            *("--host", cell.host, "--port", str(cell.port_base)),
            *("--byte-order", cell.byte_order.value),
            *("--priority", priority),
        ]
        self.child = ChildProcess("motocell.tools.bench.stream_client", arguments)

    def _out(self) -> str:
        self.jobs += 1
        # Named by the client's pid: a figure's clients (figure 7's four, figure 15's eight)
        # share a directory, and the benchmark's own pid would give them all the same file.
        return str(self.directory / f"{self.child.process.pid}-job{self.jobs}.npz")

    def _finish(self, out: str, timeout: float) -> dict[str, np.ndarray]:
        line = self.child.read_line(timeout)
        if line != "done":
            raise RuntimeError(f"bench.stream_client: {line or 'exited'}")
        data = load(Path(out))
        Path(out).unlink()
        return data

    def requests(self, message: Message, count: int) -> dict[str, np.ndarray]:
        """``message`` ``count`` times: ``rtt_ns``, ``result``, ``subcode`` per request."""
        out = self._out()
        job = Requests(self.codec.send(message), count, out)
        self.child.send(msgspec.json.encode(job).decode())
        return self._finish(out, JOB_TIMEOUT_S)

    def command(self, command: Command, group: int = 0) -> tuple[int, int]:
        """(result, subcode) of one MOTO_MOTION_CTRL."""
        data = self.requests(motion_ctrl(command, group), 1)
        return int(data["result"][0]), int(data["subcode"][0])

    def start_traj_mode(self) -> None:
        result, subcode = self.command(Command.START_TRAJ_MODE)
        if result != Result.SUCCESS:
            raise RuntimeError(f"START_TRAJ_MODE refused: result {result}, subcode {subcode}")

    def recover(self, timeout: float = RECOVER_TIMEOUT_S) -> None:
        """After a refused stream: START_TRAJ_MODE until it succeeds (it resets an alarm, as a
        ROS driver's robot_enable does)."""
        deadline = time.monotonic() + timeout
        while True:
            result, subcode = self.command(Command.START_TRAJ_MODE)
            if result == Result.SUCCESS:
                return
            if time.monotonic() > deadline:
                raise RuntimeError(
                    f"START_TRAJ_MODE refused for {timeout:g} s: result {result}, subcode {subcode}"
                )
            time.sleep(0.5)

    def begin(
        self,
        messages: Sequence[Message],
        seconds: float,
        *,
        busy_retry_s: float = BUSY_RETRY_S,
        pace_s: float = 0.0,
        probes: Sequence[Message] = (),
    ) -> None:
        """Start streaming ``messages`` (expected to take at most ``seconds``); ``end`` or
        ``finish`` collects the record."""
        self._job_out = self._out()
        job = Stream(
            [self.codec.send(m) for m in messages],
            seconds,
            self._job_out,
            busy_retry_s=busy_retry_s,
            pace_s=pace_s,
            probes=[self.codec.send(m) for m in probes],
        )
        self.child.send(msgspec.json.encode(job).decode())
        self._job_seconds = seconds

    def finish(self) -> StreamRecord:
        """The record once the stream has ended by itself."""
        data = self._finish(self._job_out, self._job_seconds + JOB_TIMEOUT_S)
        return StreamRecord.from_arrays(data)

    def end(self) -> StreamRecord:
        """Stop the stream now (STOP_MOTION clears the queues) and return its record."""
        self.child.send("stop")
        return self.finish()

    def stream(
        self,
        messages: Sequence[Message],
        seconds: float,
        *,
        busy_retry_s: float = BUSY_RETRY_S,
        pace_s: float = 0.0,
        probes: Sequence[Message] = (),
    ) -> StreamRecord:
        """Stream ``messages`` to the end (see ``begin``)."""
        self.begin(messages, seconds, busy_retry_s=busy_retry_s, pace_s=pace_s, probes=probes)
        return self.finish()

    def __enter__(self) -> StreamClientProcess:
        return self

    def __exit__(self, kind: type[BaseException] | None, *rest: object) -> None:
        if kind is None:
            self.child.close()
        else:
            self.child.kill()


def measured_again(
    streamer: StreamClientProcess,
    measure: Callable[[], T],
    log: LogTail,
    refusals: list[tuple[int, str]] | None,
    run: int,
) -> T:
    """``measure()``. A stream the cell refuses ends the figure, unless ``refusals`` is given:
    the refusal is noted there (``run``, and why: the alarms ``log`` has since its last good
    run), the cell recovered (START_TRAJ_MODE) and ``measure`` run again, at most RETRIES
    times."""
    attempt = 0
    while True:
        try:
            measured = measure()
        except StreamRefusedError as refused:
            if refusals is None or attempt == RETRIES:
                raise
            attempt += 1
            refusals.append((run, refusal_text(refused, log.lines("alarm"))))
            streamer.recover()
            continue
        log.skip()  # a refusal's alarms: those logged since the last good run
        return measured
