"""``motocell echo`` and ``motocell hz`` without a cell: which keys they take, how a sample is
shown, the rate statistics, and how the samples reach the command's thread, which sleeps until
one comes or it is stopped (a broken wake-up hangs: pytest-timeout ends the test)."""

from __future__ import annotations

import json
import os
import threading

import pytest

from motocell.shared.bus.schemas import Slot, encode
from motocell.shared.service import StopFlag
from motocell.tools.bell import Bell
from motocell.tools.cells import TargetError
from motocell.tools.echo import as_json
from motocell.tools.hz import Rate
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


def test_the_rate_over_the_window() -> None:
    rate = Rate(window=3)
    assert rate.report() == "no new samples"
    rate.add(0)
    assert rate.report() == "one sample so far"
    for t in (10 * MS, 30 * MS, 40 * MS, 50 * MS):
        rate.add(t)
    # The window keeps the last 3 intervals: 20, 10 and 10 ms.
    assert rate.report() == (
        "average rate 75.000 Hz  min 0.0100 s  max 0.0200 s  std dev 0.00471 s  window 3"
    )
    assert rate.report() == "no new samples"


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
