"""The recorder's queue between Zenoh's callback threads and its one writer: what fits is
written in order, what does not is counted, exactly, whichever threads drop it; what was
written reaches the file by a flush, also when no sample follows: the first sample at once,
each later one within ``FLUSH_S``."""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import cast

import pytest
import zenoh

from motocell.shared.service import StopFlag
from motocell.tools import record

THREADS = 4
SAMPLES_PER_THREAD = 2_000


@dataclass(frozen=True)
class Payload:
    data: bytes

    def to_bytes(self) -> bytes:
        return self.data


@dataclass(frozen=True)
class Sample:
    """What ``Recorder.on_sample`` reads of a ``zenoh.Sample``."""

    key_expr: str
    payload: Payload


def sample(key: str, data: bytes) -> zenoh.Sample:
    return cast("zenoh.Sample", Sample(key, Payload(data)))


class BlockedSink:
    """A writer stuck on its first sample until ``release``: the queue behind it fills."""

    def __init__(self) -> None:
        self.writing = threading.Event()
        self.released = threading.Event()
        self.written: list[tuple[str, bytes]] = []
        self.finished = False

    def write(self, received_ns: int, key: str, data: bytes) -> None:
        self.writing.set()
        if not self.released.wait(10.0):
            raise TimeoutError("the test never released the sink")
        self.written.append((key, data))

    def flush(self) -> None:
        """Nothing to hand on: every sample is written when released."""

    def finish(self) -> None:
        self.finished = True


class FlushWatch:
    """Says when a flush follows a write."""

    def __init__(self) -> None:
        self.events: list[str] = []
        self.flushed = threading.Event()

    def write(self, received_ns: int, key: str, data: bytes) -> None:
        self.events.append(f"write {key}")

    def flush(self) -> None:
        self.events.append("flush")
        self.flushed.set()

    def finish(self) -> None:
        self.events.append("finish")


def test_a_sample_is_flushed_without_waiting_for_another(monkeypatch: pytest.MonkeyPatch) -> None:
    # A resting cell sends a sample a second or less: the last one before a kill must not
    # wait in the chunk for a next one, or for the chunk to fill.
    monkeypatch.setattr(record, "FLUSH_S", 0.05)
    sink = FlushWatch()
    recorder = record.Recorder(sink, StopFlag())
    recorder.start()
    try:
        recorder.on_sample(sample("only", b"1"))
        assert sink.flushed.wait(10.0), "no flush followed the sample"
    finally:
        recorder.close()
    assert sink.events == ["write only", "flush", "finish"]


def test_the_first_sample_is_flushed_at_once_then_every_flush_period() -> None:
    # Times are given, not read: this is the policy alone, what the writer thread follows.
    flushes = record.Flushes()
    assert flushes.due is None  # nothing written, nothing to flush
    flushes.wrote(100.0)
    assert flushes.is_due(100.0), "a recording's start waits for nothing"
    flushes.flushed()
    assert flushes.due is None
    flushes.wrote(100.01)
    flushes.wrote(100.3)  # a later sample does not push the flush back
    assert flushes.due == 100.01 + record.FLUSH_S
    assert not flushes.is_due(100.01 + record.FLUSH_S - 0.001)
    assert flushes.is_due(100.01 + record.FLUSH_S)
    flushes.flushed()
    flushes.wrote(205.0)  # after a quiet while: one period from this sample on
    assert flushes.due == 205.0 + record.FLUSH_S


def test_samples_that_do_not_fit_are_counted_exactly_across_callback_threads(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(record, "QUEUE_SIZE", 1)
    sink = BlockedSink()
    recorder = record.Recorder(sink, StopFlag())
    recorder.start()
    try:
        recorder.on_sample(sample("first", b"1"))
        assert sink.writing.wait(10.0), "the writer took the first sample"
        recorder.on_sample(sample("queued", b"2"))

        def flood() -> None:
            for _ in range(SAMPLES_PER_THREAD):
                recorder.on_sample(sample("lost", b""))

        threads = [threading.Thread(target=flood) for _ in range(THREADS)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
    finally:
        sink.released.set()
        recorder.close()
    assert recorder.dropped == THREADS * SAMPLES_PER_THREAD
    assert sink.written == [("first", b"1"), ("queued", b"2")]
    assert sink.finished and recorder.error is None
