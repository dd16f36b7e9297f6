"""What ``motocell hz`` says of a key, from samples stamped by hand: no rate before the samples
mean one, the statistics over the window after, and a publisher at rest named as such from
what its samples say."""

from __future__ import annotations

import pytest

from motocell.shared.bus.liveness import heartbeat_ms
from motocell.shared.bus.schemas import (
    GroupTick,
    QueueState,
    RobotStatusFields,
    State,
    Tick,
    encode,
)
from motocell.tools.listen import Received
from motocell.tools.rates import MIN_SAMPLES, MIN_SPAN_S, Rate, rest_note

MS = 1_000_000
KEY = "motocell/c1/group/0/metrics"
"""A key whose samples say nothing of resting (an interpolator's metrics)."""


def at(ms: float, key: str = KEY, payload: bytes = b"") -> Received:
    return Received(key, payload, round(ms * MS))


def rate_of(*ms: float, window: int = 1000) -> Rate:
    rate = Rate(window)
    for t in ms:
        rate.add(at(t))
    return rate


def test_no_samples_no_rate() -> None:
    rate = rate_of()
    assert rate.report() == "no new samples"


def test_two_samples_back_to_back_are_no_rate() -> None:
    # As a resting cell's state arrives: twice, a state period apart, then a second later.
    rate = rate_of(0, 10)
    assert rate.report() == ("2 samples over 0.010 s: too few for a rate (it takes 3 over 0.5 s)")


def test_many_samples_over_a_short_span_are_no_rate_yet() -> None:
    rate = rate_of(*range(0, 400, 4))
    assert rate.report().startswith("100 samples over 0.396 s: too few for a rate")


def test_two_samples_however_far_apart_are_no_rate() -> None:
    assert rate_of(0, 1000).report().startswith("2 samples over 1.000 s: too few")
    assert rate_of(0).report().startswith("1 sample over 0.000 s: too few")


def test_the_thresholds_are_what_the_report_says() -> None:
    assert (MIN_SAMPLES, MIN_SPAN_S) == (3, 0.5)
    assert rate_of(0, 250, 499).report().startswith("3 samples over 0.499 s: too few")
    assert rate_of(0, 250, 500).report().startswith("average rate 4.000 Hz")


def test_the_rate_over_the_window() -> None:
    rate = rate_of(0, 10, 30, 40, 510, window=3)
    # The window keeps the last 3 intervals: 20, 10 and 470 ms.
    assert rate.report() == (
        "average rate 6.000 Hz  min 0.0100 s  max 0.4700 s  std dev 0.21453 s  window 3"
    )
    assert rate.report() == "no new samples"
    rate.add(at(600))
    assert rate.report().startswith(
        "average rate 5.263 Hz  min 0.0100 s  max 0.4700 s"
    )  # 10, 470, 90


def test_the_span_counts_from_the_first_sample_not_the_window() -> None:
    # A window of one interval still gives a rate once the samples span enough.
    assert rate_of(0, 300, 600, window=1).report() == (
        "average rate 3.333 Hz  min 0.3000 s  max 0.3000 s  std dev 0.00000 s  window 1"
    )


# -- a publisher at rest -------------------------------------------------------------------


def tick(n: int, *, resting: bool) -> Received:
    value = Tick(n, 0, 0, 0, False, [GroupTick([0], [0], [0], 0)], resting=resting)
    return Received("motocell/c1/executor/tick", encode(value), 0)


def queue(*, motion_possible: bool) -> Received:
    value = QueueState(0, 0, 0, 200, [0], 7, heartbeat_ms=heartbeat_ms(motion_possible))
    return Received("motocell/c1/group/0/queue", encode(value), 0)


def state(n: int) -> Received:
    status = RobotStatusFields(0, 0, 0, 0, 0, 2, 0)
    return Received("motocell/c1/state", encode(State(n, 40, 0, [], status)), 0)


def state_of_tick(n: int) -> Received:
    status = RobotStatusFields(0, 0, 0, 0, 1, 2, 1)
    return Received("motocell/c1/state", encode(State(n, n, 0, [], status)), 0)


def test_a_resting_tick_says_the_clock_rests() -> None:
    assert rest_note(None, tick(5, resting=True)) == (
        "the executor's clock rests while nothing moves: its last tick again every 1 s"
    )
    assert rest_note(tick(4, resting=False), tick(5, resting=False)) is None


def test_a_stream_announcing_the_at_rest_heartbeat_says_so() -> None:
    assert rest_note(None, queue(motion_possible=False)) == (
        "at rest, nothing can move: sent on change and every 1 s"
    )
    assert rest_note(None, queue(motion_possible=True)) is None


def test_states_of_one_tick_say_nothing_moves() -> None:
    assert rest_note(state(1), state(2)) == (
        "nothing moves (tick 40 again): sent every 1 s, or every state period while a client"
        " is on the state port"
    )
    assert rest_note(None, state(2)) is None
    assert rest_note(state_of_tick(1), state_of_tick(2)) is None


@pytest.mark.parametrize("payload", [b"", b"\x01\x02\xff", b"\x93\x01\x02\x03"])
def test_a_sample_that_does_not_decode_says_nothing(payload: bytes) -> None:
    garbage = Received("motocell/c1/executor/tick", payload, 0)
    assert rest_note(garbage, garbage) is None


def test_the_report_ends_with_the_rest_it_saw() -> None:
    rate = Rate(1000)
    for n, ms in enumerate((0, 10, 1000, 1010)):
        rate.add(Received("motocell/c1/state", state(n).payload, ms * MS))
    assert rate.report() == (
        "average rate 2.970 Hz  min 0.0100 s  max 0.9900 s  std dev 0.46198 s  window 3"
        "; nothing moves (tick 40 again): sent every 1 s, or every state period while a client"
        " is on the state port"
    )
