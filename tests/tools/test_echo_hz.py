"""``motocell echo`` and ``motocell hz`` without a cell: which keys they take, how a sample is
shown, when hz reports (on a fake clock; what a report says: test_rates.py), and how the
samples reach the command's thread, which sleeps until one comes or it is stopped (a broken
wake-up hangs: pytest-timeout ends the test)."""

from __future__ import annotations

import json
import os
import threading

import pytest

from motocell.shared.bus.schemas import Slot, encode
from motocell.shared.service import StopFlag
from motocell.tools.bell import Bell, StopSignal
from motocell.tools.cells import TargetError
from motocell.tools.echo import as_json
from motocell.tools.hz import report
from motocell.tools.listen import PUBLISHED, Arrivals, Received, published_key

MS = 1_000_000


@pytest.mark.parametrize("key", ["state", "controller/status", "group/0/queue", "group/*/queue"])
def test_published_keys_are_taken(key: str) -> None:
    assert published_key(key) == key


def test_every_published_key_is_one_an_observer_receives() -> None:
    assert "state" in PUBLISHED
    assert "controller/cmd/*" not in PUBLISHED
    assert all("/**" not in key for key in PUBLISHED)


@pytest.mark.parametrize(
    ("key", "problem"),
    [
        ("stat", "no cell publishes 'stat'; did you mean state? (keys: "),
        ("group/0/queu", "did you mean group/*/queue? (keys: "),
        ("**", "no cell publishes '**' (keys: "),
        ("controller/cmd/positions", "'controller/cmd/positions' is asked (a Zenoh query)"),
    ],
)
def test_other_keys_are_refused_naming_the_published_ones(key: str, problem: str) -> None:
    with pytest.raises(TargetError) as refused:
        published_key(key)
    assert problem in str(refused.value)
    assert refused.value.status == 2


def test_a_sample_is_one_json_line_with_field_names() -> None:
    line = as_json(Received("motocell/c1/group/1/slot", encode(Slot(7, 3)), 0))
    assert b"\n" not in line
    shown = json.loads(line)
    assert shown["key"] == "motocell/c1/group/1/slot"
    assert shown["payload"]["taken_id"] == 7
    assert shown["payload"]["epoch"] == 3


@pytest.mark.parametrize(
    ("key", "payload"),
    [("motocell/c1/state", b"\x01\x02\xff"), ("motocell/c1/somebody/else", b"\x93\x01\x02\x03")],
)
def test_a_payload_that_does_not_decode_is_shown_as_hex(key: str, payload: bytes) -> None:
    assert json.loads(as_json(Received(key, payload, 0))) == {"key": key, "hex": payload.hex()}


class Script:
    """Samples at given times of a fake clock: each ``next`` moves the clock to the next
    sample's time and hands it over, or to the wait's end when none comes before it."""

    def __init__(self, *ms: int) -> None:
        self.now = 0.0
        self.times = [t / 1e3 for t in ms]

    def clock(self) -> float:
        return self.now

    def next(self, stop: StopSignal, timeout: float | None = None) -> Received | None:
        assert timeout is not None
        if not self.times or self.times[0] > self.now + timeout:
            self.now += timeout
            return None
        self.now = self.times.pop(0)
        return Received(METRICS, b"", round(self.now * 1e9))


METRICS = "motocell/c1/group/0/metrics"


def test_a_report_every_second_once_samples_flow(capsys: pytest.CaptureFixture[str]) -> None:
    # Nothing for two seconds (no report), two samples back to back, then one a second.
    script = Script(2_500, 2_510, 3_500, 4_500)
    report(script, StopFlag(), window=1000, count=3, clock=script.clock)
    assert capsys.readouterr().out.splitlines() == [
        f"{METRICS}: 2 samples over 0.010 s: too few for a rate (it takes 3 over 0.5 s)",
        f"{METRICS}: average rate 2.000 Hz  min 0.0100 s  max 0.9900 s  std dev 0.49000 s"
        "  window 2",
        f"{METRICS}: average rate 1.500 Hz  min 0.0100 s  max 1.0000 s  std dev 0.46435 s"
        "  window 3",
    ]
    assert script.now == 5.0


def test_a_stop_ends_the_report_while_it_waits() -> None:
    """The fake clock never moves: only the stop can end the wait, and the test hangs (until
    pytest-timeout) if it does not."""
    stop = StopFlag()
    waiting = threading.Event()

    class Waiting:
        def next(self, stop: StopSignal, timeout: float | None = None) -> Received | None:
            waiting.set()
            return Arrivals().next(stop, timeout)

    reporter = threading.Thread(target=report, args=(Waiting(), stop, 1000, None, lambda: 0.0))
    reporter.start()
    waiting.wait()
    stop.set()
    reporter.join()


# -- the samples' way to the command's thread ----------------------------------------------


def received(n: int) -> Received:
    return Received("motocell/c1/state", bytes([n]), n)


def test_samples_are_taken_in_arrival_order() -> None:
    arrivals = Arrivals()
    for n in range(3):
        arrivals.put(received(n))
    stop = StopFlag()
    assert [arrivals.next(stop) for _ in range(3)] == [received(n) for n in range(3)]
    assert arrivals.next(stop, timeout=0) is None


def test_a_sample_put_by_another_thread_wakes_the_taker() -> None:
    arrivals = Arrivals()
    stop = StopFlag()
    taken: list[Received | None] = []
    taker = threading.Thread(target=lambda: taken.append(arrivals.next(stop)))
    taker.start()
    arrivals.put(received(1))
    taker.join()
    assert taken == [received(1)]


def test_a_stop_wakes_the_taker_with_nothing() -> None:
    arrivals = Arrivals()
    stop = StopFlag()
    taken: list[Received | None] = []
    taker = threading.Thread(target=lambda: taken.append(arrivals.next(stop)))
    taker.start()
    stop.set()
    taker.join()
    assert taken == [None]


def test_samples_beyond_the_bound_are_dropped_and_counted() -> None:
    arrivals = Arrivals(size=2)
    for n in range(5):
        arrivals.put(received(n))
    assert arrivals.dropped == 3
    stop = StopFlag()
    assert [arrivals.next(stop, 0), arrivals.next(stop, 0), arrivals.next(stop, 0)] == [
        received(0),
        received(1),
        None,
    ]


def test_a_ring_before_the_wait_is_kept_and_a_wait_takes_every_ring_before_it() -> None:
    bell = Bell()
    stop = StopFlag()
    for _ in range(3):
        bell.ring()
    assert bell.wait(stop, None) is True  # at once: it was rung
    assert bell.wait(stop, 0) is False
    threading.Thread(target=bell.ring).start()
    assert bell.wait(stop, None) is True


def test_a_stop_wakes_a_bell_not_rung() -> None:
    bell = Bell()
    stop = StopFlag()
    threading.Thread(target=stop.set).start()
    assert bell.wait(stop, None) is False


@pytest.mark.parametrize("times", [1, 100_000])
def test_ringing_never_blocks_however_often(times: int) -> None:
    bell = Bell()
    for _ in range(times):
        bell.ring()
    assert bell.wait(StopFlag(), None) is True
    assert bell.wait(StopFlag(), 0) is False


def test_a_forgotten_bell_releases_its_descriptors() -> None:
    before = len(os.listdir("/proc/self/fd"))
    for _ in range(50):
        Bell().ring()
    assert len(os.listdir("/proc/self/fd")) <= before + 2
