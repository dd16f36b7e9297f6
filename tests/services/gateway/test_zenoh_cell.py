"""``ZenohCell`` on a scripted bus: what it subscribes to, asks and publishes; streams that
stop arriving; slot and token questions; command queries answered late or never; payloads
that do not decode; its watchdog thread. The watchdog's passes (``check``) run on the test's
clock; no bus call may be made under the decision lock (checked after every test)."""

from __future__ import annotations

import itertools
import logging
import threading
from collections.abc import Iterator

import pytest

from motocell.services.gateway.core.motion import START_TRAJ_MODE_TIMEOUT_S, MotionHandler
from motocell.services.gateway.core.robot_io import RobotIoHandler
from motocell.services.gateway.core.sources import Source
from motocell.services.gateway.zenoh_cell import ZenohCell
from motocell.shared.bus import ignored
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.liveness import (
    ASK_AGAIN_S,
    AT_REST_HEARTBEAT_S,
    QUERY_TIMEOUT_S,
    STALE_HEARTBEATS,
)
from motocell.shared.bus.schemas import CommandReply, encode
from motocell.shared.protocol.constants import Command, IoResult, NotReadySubcode, Result
from motocell.shared.protocol.messages import Message, ReadIOBitReply, WriteIOBitReply
from motocell.shared.protocol.replies import motion_ctrl, read_io_bit, write_io_bit
from motocell.testing.processes import wait_until
from tests.services.gateway.core.fake_cell import (
    NOW,
    queue,
    reply_of,
    slot,
    status,
    two_groups,
    verdict_of,
)
from tests.services.gateway.fake_bus import WAIT_S, FakeBus, Query

KEYS = CellKeys("cell1")
CONTROLLER = KEYS.alive("controller", "0")
SPAN = STALE_HEARTBEATS * 0.1
REST_SPAN = STALE_HEARTBEATS * AT_REST_HEARTBEAT_S
AT_REST = 1000
GARBAGE = b"\xc1\xff not msgpack"


class Clock:
    def __init__(self) -> None:
        self.now = NOW

    def __call__(self) -> float:
        return self.now


class Harness:
    def __init__(self) -> None:
        self.bus = FakeBus()
        self.clock = Clock()
        self.cell = ZenohCell(two_groups(), KEYS, self.bus, self.clock)
        # The one lock every decision takes: no bus call may be made while it is held.
        self.bus.held = self.cell._lock.locked
        [self.tokens] = self.bus.tokens_made

    def status(
        self,
        heartbeat: int = 100,
        *,
        ready: bool = True,
        subcode: int = 0,
        missing: tuple[str, ...] = (),
        seq: int = 1,
    ) -> None:
        sample = status(ready, subcode, missing, seq, heartbeat)
        self.bus.publish(KEYS.controller_status, encode(sample))

    def queue(self, group: int, heartbeat: int = 100, depth: int = 0) -> None:
        self.bus.publish(KEYS.group_queue(group), encode(queue(depth, heartbeat=heartbeat)))

    def slot(self, group: int, taken: int = 0) -> None:
        self.bus.publish(KEYS.group_slot(group), encode(slot(taken)))

    def whole(self, heartbeat: int = 100) -> None:
        """Every service heard: the controller's token, status, rings and slots."""
        self.tokens.appear(CONTROLLER)
        self.status(heartbeat)
        for group in range(2):
            self.queue(group, heartbeat)
            self.slot(group)

    def check_at(self, now: float) -> float | None:
        self.clock.now = now
        return self.cell.check()


@pytest.fixture
def harness() -> Iterator[Harness]:
    made = Harness()
    yield made
    made.cell.close()
    assert made.bus.under_lock == []


def motion_request(harness: Harness, request: Message) -> Message | None:
    handler = MotionHandler(
        two_groups(),
        harness.cell,
        RobotIoHandler(harness.cell),
        itertools.count(2),
        Source.SIMPLE_MESSAGE,
    )
    return handler.respond(request).reply


# -- construction and the first pass -----------------------------------------------------
def test_construction_starts_no_thread_and_asks_nothing() -> None:
    before = set(threading.enumerate())
    made = Harness()
    assert set(threading.enumerate()) == before
    assert made.bus.queries() == []
    assert made.tokens.asked == 0
    made.cell.close()


def test_the_first_pass_asks_for_the_controller_token_and_every_slot(harness: Harness) -> None:
    harness.cell.check()
    assert harness.tokens.asked == 1
    queries = harness.bus.queries()
    assert [query.key for query in queries] == [KEYS.group_slot(0), KEYS.group_slot(1)]
    assert all(query.payload is None for query in queries)
    assert all(query.timeout == QUERY_TIMEOUT_S for query in queries)


# -- the controller's token --------------------------------------------------------------
def test_a_missing_token_is_asked_for_again_at_a_slow_rate(harness: Harness) -> None:
    harness.check_at(NOW)
    harness.check_at(NOW + ASK_AGAIN_S)
    assert harness.tokens.asked == 1
    again = NOW + QUERY_TIMEOUT_S + ASK_AGAIN_S
    assert harness.check_at(again - 0.01) == pytest.approx(again)
    assert harness.check_at(again) is not None
    assert harness.tokens.asked == 2


def test_a_present_token_is_never_asked_for_again(harness: Harness) -> None:
    harness.whole(AT_REST)
    harness.check_at(NOW)
    asked = harness.tokens.asked
    next_check = harness.check_at(NOW + 3 * ASK_AGAIN_S)
    assert harness.tokens.asked == asked
    assert next_check == pytest.approx(NOW + REST_SPAN)


def test_a_token_that_vanishes_is_asked_for_at_once(harness: Harness) -> None:
    harness.whole()
    harness.check_at(NOW)
    assert harness.tokens.asked == 0
    harness.tokens.vanish(CONTROLLER)
    harness.check_at(NOW + 0.01)
    assert harness.tokens.asked == 1
    assert not harness.cell.controller_alive()


# -- slots -------------------------------------------------------------------------------
def test_a_slot_answer_is_applied_like_a_published_slot(harness: Harness) -> None:
    harness.cell.check()
    harness.bus.next_query(KEYS.group_slot(1)).reply(encode(slot(taken=4)))
    with harness.cell.current() as state:
        assert [group.known for group in state.groups] == [False, True]
        assert state.groups[1].taken == 4


def test_an_answer_older_than_a_published_slot_does_not_undo_it(harness: Harness) -> None:
    harness.cell.check()
    harness.slot(0, taken=5)
    with harness.cell.current():
        pass
    harness.bus.next_query(KEYS.group_slot(0)).reply(encode(slot(taken=3)))
    with harness.cell.current() as state:
        assert state.groups[0].taken == 5


def test_an_unanswered_slot_is_asked_again_after_a_while(harness: Harness) -> None:
    harness.check_at(NOW)
    harness.bus.next_query(KEYS.group_slot(0)).finish()
    assert harness.check_at(NOW + 0.5) is not None
    assert len(harness.bus.queries(KEYS.group_slot(0))) == 1
    harness.check_at(NOW + ASK_AGAIN_S)
    assert len(harness.bus.queries(KEYS.group_slot(0))) == 2


def test_a_slot_is_asked_when_its_interpolator_is_no_longer_missing(harness: Harness) -> None:
    harness.whole()
    harness.check_at(NOW)
    asked = len(harness.bus.queries(KEYS.group_slot(1)))
    harness.status(ready=False, missing=("interpolator/1",))
    harness.check_at(NOW + 0.1)
    assert len(harness.bus.queries(KEYS.group_slot(1))) == asked
    harness.clock.now = NOW + 0.2
    harness.status()
    harness.check_at(NOW + 0.2)
    assert len(harness.bus.queries(KEYS.group_slot(1))) == asked + 1


# -- streams that stop -------------------------------------------------------------------
def test_a_status_stream_that_stops_is_forgotten_and_subscribed_again(
    harness: Harness,
) -> None:
    harness.whole()
    assert harness.check_at(NOW) == pytest.approx(NOW + SPAN)
    harness.queue(0)
    harness.queue(1)
    [old] = harness.bus.live(KEYS.controller_status)

    harness.check_at(NOW + SPAN)
    assert harness.cell.state.status is None
    [new] = harness.bus.live(KEYS.controller_status)
    assert new is not old

    harness.status(seq=9)
    assert harness.cell.state.status is not None
    assert harness.cell.state.status.seq == 9


def test_a_queue_stream_that_stops_is_subscribed_again_with_its_slot_which_is_asked(
    harness: Harness,
) -> None:
    harness.whole()
    harness.check_at(NOW)
    old = harness.bus.live(KEYS.group_queue(1)) + harness.bus.live(KEYS.group_slot(1))
    slot_queries = len(harness.bus.queries(KEYS.group_slot(1)))
    harness.clock.now = NOW + SPAN - 0.1
    harness.status()
    harness.queue(0)

    harness.check_at(NOW + SPAN)
    with harness.cell.current() as state:
        assert state.groups[1].queue is None
        assert state.groups[0].queue is not None
    new = harness.bus.live(KEYS.group_queue(1)) + harness.bus.live(KEYS.group_slot(1))
    assert len(new) == 2
    assert not set(map(id, new)) & set(map(id, old))
    assert len(harness.bus.queries(KEYS.group_slot(1))) == slot_queries + 1
    harness.queue(1, depth=3)
    with harness.cell.current() as state:
        assert state.queue_count(1) == 3


def test_at_rest_the_next_check_is_five_long_heartbeats_away(harness: Harness) -> None:
    harness.whole(AT_REST)
    assert harness.check_at(NOW) == pytest.approx(NOW + REST_SPAN)
    assert harness.check_at(NOW + REST_SPAN - 0.1) == pytest.approx(NOW + REST_SPAN)
    assert harness.cell.state.status is not None


# -- what does not decode ----------------------------------------------------------------
def test_samples_that_do_not_decode_are_ignored_and_logged(
    harness: Harness, caplog: pytest.LogCaptureFixture
) -> None:
    harness.whole()
    with harness.cell.current() as state:
        before = (state.status, [group.queue for group in state.groups], state.groups[0].taken)
    with caplog.at_level(logging.WARNING, logger="bus"):
        for key in (KEYS.controller_status, KEYS.group_queue(0), KEYS.group_slot(0)):
            harness.bus.publish(key, GARBAGE)
        with harness.cell.current() as state:
            after = (state.status, [group.queue for group in state.groups], state.groups[0].taken)
    assert after == before
    # Every one counted, the first logged: a flood must not flood the log.
    warned = [record.getMessage() for record in caplog.records]
    assert warned == [f"undecodable sample on {KEYS.controller_status} ignored"]
    assert ignored.IGNORED.total == 3


def test_a_command_reply_that_does_not_decode_counts_as_none(harness: Harness) -> None:
    harness.bus.answers[KEYS.executor_cmd("stop")] = lambda query: query.reply(GARBAGE)
    assert harness.cell.executor("stop", timeout=60.0) is None


# -- commands ----------------------------------------------------------------------------
def test_a_command_is_answered_and_waits_for_the_status_it_names(harness: Harness) -> None:
    harness.whole()

    def answer(query: Query) -> None:
        """The controller publishes the status that shows the command done, then replies."""
        harness.status(seq=7)
        query.reply(encode(CommandReply(int(Result.SUCCESS), status_seq=7)))

    harness.bus.answers[KEYS.controller_cmd("reset_alarm")] = answer
    reply = harness.cell.controller("reset_alarm", timeout=60.0)
    assert reply is not None
    assert harness.cell.state.status is not None
    assert harness.cell.state.status.seq == 7


def test_a_command_nobody_answers_gives_none_once_the_bus_ends_the_query(
    harness: Harness,
) -> None:
    """A timeout as Zenoh reports it: the query ends without an answer. (A minute-long
    timeout: returning proves it did not wait for it.)"""
    harness.bus.answers[KEYS.executor_cmd("stop")] = lambda query: query.finish()
    assert harness.cell.executor("stop", timeout=60.0) is None
    [query] = harness.bus.queries(KEYS.executor_cmd("stop"))
    assert query.timeout == 60.0


def test_a_query_the_bus_never_ends_does_not_hang(harness: Harness) -> None:
    assert harness.cell.controller("read_bit", timeout=0.05) is None


def test_start_traj_mode_unanswered_is_not_ready_with_the_controllers_subcode(
    harness: Harness,
) -> None:
    harness.whole()
    harness.status(ready=False, subcode=int(NotReadySubcode.SERVO_OFF))
    harness.bus.answers[KEYS.controller_cmd("start_traj_mode")] = lambda query: query.finish()
    reply = motion_request(harness, motion_ctrl(Command.START_TRAJ_MODE))
    assert verdict_of(reply) == (int(Result.NOT_READY), int(NotReadySubcode.SERVO_OFF))
    [query] = harness.bus.queries(KEYS.controller_cmd("start_traj_mode"))
    assert query.timeout == START_TRAJ_MODE_TIMEOUT_S


def test_io_unanswered_is_the_api_error_of_a_read_or_a_write(harness: Harness) -> None:
    for verb in ("read_bit", "write_bit"):
        harness.bus.answers[KEYS.controller_cmd(verb)] = lambda query: query.finish()
    io = RobotIoHandler(harness.cell)
    read = io.respond(read_io_bit(10010)).reply
    write = io.respond(write_io_bit(10010, 1)).reply
    assert read is not None and write is not None
    assert isinstance(read.body, ReadIOBitReply)
    assert isinstance(write.body, WriteIOBitReply)
    assert read.body.result_code == IoResult.READ_API_ERROR
    assert write.body.result_code == IoResult.WRITE_API_ERROR


def test_stop_motion_unanswered_is_a_failure(harness: Harness) -> None:
    harness.whole()
    harness.bus.answers[KEYS.executor_cmd("stop")] = lambda query: query.finish()
    reply = motion_request(harness, motion_ctrl(Command.STOP_MOTION))
    assert reply_of(reply).result == Result.FAILURE


# -- the watchdog thread -----------------------------------------------------------------
def test_the_watchdog_is_started_by_start_named_and_joined_by_close() -> None:
    made = Harness()
    made.cell.start()
    [watchdog] = [t for t in threading.enumerate() if t.name == "gateway-watchdog"]
    made.cell.close()
    assert not watchdog.is_alive()
    assert made.tokens.closed
    assert all(not made.bus.live(key) for key in (*made.bus.latests, *made.bus.subscriptions))
    assert made.bus.under_lock == []


def quiet_watchdog(harness: Harness) -> None:
    """Start the watchdog with nothing to plan (the token there, every slot known, no stream
    heard): it sleeps until something wakes it, and never on its own."""
    harness.tokens.appear(CONTROLLER)
    for group in range(2):
        harness.slot(group)
    harness.cell.start()
    wait_until(
        lambda: all(group.known for group in harness.cell.state.groups), WAIT_S, "a first pass"
    )


def test_a_status_wakes_a_watchdog_with_nothing_to_plan(harness: Harness) -> None:
    quiet_watchdog(harness)
    harness.status(AT_REST)
    wait_until(lambda: harness.cell.wake_at == NOW + REST_SPAN, WAIT_S, "a plan")
    assert harness.bus.queries() == []


def test_a_queue_state_read_by_a_request_wakes_the_watchdog(harness: Harness) -> None:
    """A sample drained by a request (not by the watchdog) that may go stale before the
    watchdog wakes: the watchdog plans again at once."""
    quiet_watchdog(harness)
    harness.queue(0)
    with harness.cell.current():
        pass
    wait_until(lambda: harness.cell.wake_at == pytest.approx(NOW + SPAN), WAIT_S, "a plan")


def test_requests_read_what_arrived_but_only_the_watchdog_ages_it(harness: Harness) -> None:
    harness.whole()
    harness.check_at(NOW)
    harness.clock.now = NOW + SPAN
    with harness.cell.current() as state:
        assert state.status is not None
    harness.cell.check()
    assert harness.cell.state.status is None
