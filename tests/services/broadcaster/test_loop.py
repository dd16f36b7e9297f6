"""The broadcaster's cycle, tick to socket, without Zenoh: ticks from a list, a real state port
on loopback, the ``state`` samples and the reports kept for inspection."""

from __future__ import annotations

import socket
import threading
from collections.abc import Iterator

import msgspec
import pytest

from motocell.services.broadcaster.core import Broadcaster
from motocell.services.broadcaster.loop import StateLoop
from motocell.services.broadcaster.state_port import Acceptor, StatePort
from motocell.shared.bus.schemas import Decoder, State, Tick
from motocell.shared.protocol.codec import NEED_DATA, ByteOrder, Role, SimpleMessageCodec
from motocell.shared.protocol.constants import MsgType
from motocell.shared.protocol.messages import JointFeedback, Message
from motocell.shared.service import listen
from tests.services.broadcaster.test_core import MS, FakeController, cell, group_tick, tick

PULSES_PER_RADIAN = 58670


class Ticks:
    """Ticks from a list (None: woken without one), each ``step_s`` after the last."""

    def __init__(self, step_s: float) -> None:
        self.ticks: list[Tick | None] = []
        self.now = 0.0
        self.step_s = step_s
        self.waits: list[tuple[float | None, bool]] = []

    def next(self, deadline: float | None, ticks_expected: bool) -> Tick | None:
        self.waits.append((deadline, ticks_expected))
        self.now += self.step_s
        return self.ticks.pop(0)


class Reports:
    def __init__(self) -> None:
        self.ages: list[int] = []
        self.clients: list[int] = []

    def written(self, age_ns: int) -> None:
        self.ages.append(age_ns)

    def report(self, now: float, clients: int, replaced: int, stuck_closed: int) -> None:
        self.clients.append(clients)

    @property
    def next_due(self) -> float:
        return 1e9


class Harness:
    def __init__(self, byte_order: ByteOrder) -> None:
        self.woken = threading.Event()
        acceptor = Acceptor(listen("127.0.0.1", 0), self.woken.set)
        acceptor.start()
        self.port = StatePort(acceptor)
        self.ticks = Ticks(step_s=0.06)  # more than the silence (50 ms): a wake is a beat
        self.published: list[State] = []
        self.observed = True
        """Whether a subscriber on the bus matches ``state``."""
        self.reports = Reports()
        decoder = Decoder(State)
        self.loop = StateLoop(
            Broadcaster(cell(state_period_ms=4.0), FakeController()),
            self.ticks,
            self.port,
            byte_order=byte_order,
            publish_state=lambda data: self.published.append(decoder.decode(data)),
            observed=lambda: self.observed,
            reports=self.reports,
            clock=lambda: self.ticks.now,
        )
        self.byte_order = byte_order
        self.clients: list[socket.socket] = []

    def run(self, *ticks: Tick | None) -> None:
        self.ticks.ticks += ticks
        while self.ticks.ticks:
            self.loop.cycle()

    def connect(self) -> SimpleMessageCodec:
        self.woken.clear()
        sock = socket.create_connection(self.port.acceptor.server.getsockname(), timeout=5.0)
        self.clients.append(sock)
        assert self.woken.wait(5.0), "the acceptor took the connection"
        return SimpleMessageCodec(Role.CLIENT, self.byte_order)

    def read(self, index: int, codec: SimpleMessageCodec, count: int) -> list[Message]:
        messages: list[Message] = []
        while len(messages) < count:
            event = codec.next_event()
            if event is NEED_DATA:
                codec.receive_data(self.clients[index].recv(65536))
            else:
                assert isinstance(event, Message)
                messages.append(event)
        return messages

    def close(self) -> None:
        self.loop.close()
        for sock in self.clients:
            sock.close()


@pytest.fixture(params=[ByteOrder.LITTLE, ByteOrder.BIG])
def harness(request: pytest.FixtureRequest) -> Iterator[Harness]:
    made = Harness(request.param)
    yield made
    made.close()


def moved(n: int, radians: int) -> Tick:
    return tick(n, n * 4 * MS, group_tick([radians * PULSES_PER_RADIAN] + [0] * 7))


def test_a_due_tick_reaches_a_new_client_and_zenoh_in_the_same_cycle(harness: Harness) -> None:
    codec = harness.connect()
    harness.run(moved(1, 2))
    feedback, status = harness.read(0, codec, 2)
    assert (feedback.msg_type, status.msg_type) == (MsgType.JOINT_FEEDBACK, MsgType.ROBOT_STATUS)
    assert isinstance(feedback.body, JointFeedback)
    assert feedback.body.positions[0] == pytest.approx(2.0)
    assert [state.tick for state in harness.published] == [1]
    assert harness.reports.clients == [1]
    assert len(harness.reports.ages) == 1


def test_no_state_sample_and_no_poses_while_nobody_observes(harness: Harness) -> None:
    codec = harness.connect()
    harness.observed = False
    harness.run(moved(1, 1))
    assert harness.published == []
    assert len(harness.read(0, codec, 2)) == 2  # the TCP clients get their frames all the same
    harness.observed = True
    harness.run(moved(2, 2))
    assert [state.tick for state in harness.published] == [2]


def test_every_client_gets_every_cycle_in_order(harness: Harness) -> None:
    codecs = [harness.connect() for _ in range(3)]
    harness.run(moved(1, 1), moved(2, 2), moved(3, 3))
    for index, codec in enumerate(codecs):
        messages = harness.read(index, codec, 6)
        positions = [m.body.positions[0] for m in messages if isinstance(m.body, JointFeedback)]
        assert positions == pytest.approx([1.0, 2.0, 3.0])


def test_silence_beats_with_the_last_tick_but_is_not_an_age(harness: Harness) -> None:
    codec = harness.connect()
    harness.run(moved(1, 1), None)
    messages = harness.read(0, codec, 4)
    assert [m.msg_type for m in messages].count(MsgType.ROBOT_STATUS) == 2
    assert [state.tick for state in harness.published] == [1, 1]
    assert len(harness.reports.ages) == 1


def test_without_clients_the_state_still_goes_on_zenoh(harness: Harness) -> None:
    harness.run(moved(1, 1), moved(2, 2))
    assert [state.tick for state in harness.published] == [1, 2]
    assert harness.reports.ages == []
    assert harness.reports.clients == [0, 0]


def test_closing_tells_the_reports_the_clients_are_gone(harness: Harness) -> None:
    harness.connect()
    harness.run(moved(1, 1))
    harness.loop.close()
    assert harness.reports.clients == [1, 0]


def test_at_rest_the_loop_sleeps_until_the_next_beat_instead_of_waiting_for_ticks(
    harness: Harness,
) -> None:
    harness.connect()
    resting = msgspec.structs.replace(moved(1, 1), resting=True)
    harness.run(moved(0, 1), resting, None)
    waits = harness.ticks.waits
    assert [expected for _, expected in waits] == [True, True, False]
    state_period_s = 0.004
    deadline, _ = waits[2]
    assert deadline == pytest.approx(2 * harness.ticks.step_s + state_period_s)
    assert [state.tick for state in harness.published] == [0, 1, 1]
