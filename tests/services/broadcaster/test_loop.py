"""The broadcaster's cycle, tick to socket, against fakes of its Protocols: ticks from a list, a
state port that keeps what each client was sent, the ``state`` samples and the reports kept for
inspection. The frames are read back by a client's codec."""

from __future__ import annotations

from collections.abc import Sequence

import msgspec
import pytest

from motocell.services.broadcaster.core.backlog import Cycle
from motocell.services.broadcaster.core.broadcaster import Broadcaster
from motocell.services.broadcaster.loop import StateLoop
from motocell.shared.bus.schemas import Decoder, State, Tick
from motocell.shared.protocol.codec import NEED_DATA, ByteOrder, Role, SimpleMessageCodec
from motocell.shared.protocol.constants import MsgType
from motocell.shared.protocol.messages import JointFeedback, Message
from motocell.shared.service import StopFlag
from tests.services.broadcaster.fake_bus import RecordedReports, ScriptedTicks
from tests.services.broadcaster.scripted import MS, FakeController, cell, group_tick, tick
from tests.services.fakes import FakePublication

PULSES_PER_RADIAN = 58670
STATE_PERIOD_S = 0.004


class FakeClient:
    def __init__(self) -> None:
        self.cycles: list[Cycle] = []


class FakePort:
    """A ``StateClients``: connections wait until ``admit``; each client keeps the cycles it was
    sent."""

    def __init__(self) -> None:
        self.waiting: list[FakeClient] = []
        self.clients: list[FakeClient] = []
        self.admitted_while_queued: list[bool] = []
        self.flushed: list[float] = []
        self.replaced = 0
        self.closed_stuck = 0
        self.closed = False

    def connect(self) -> FakeClient:
        client = FakeClient()
        self.waiting.append(client)
        return client

    def admit(self, motion_queued: bool) -> None:
        self.admitted_while_queued.append(motion_queued)
        self.clients += self.waiting
        self.waiting = []

    def send(self, cycle: Cycle, now: float) -> None:
        for client in self.clients:
            client.cycles.append(cycle)

    def flush(self, now: float) -> None:
        self.flushed.append(now)

    def replaced_total(self) -> int:
        return self.replaced

    def close(self) -> None:
        self.closed = True
        self.clients = []


class Harness:
    def __init__(self, byte_order: ByteOrder) -> None:
        self.byte_order = byte_order
        self.port = FakePort()
        self.ticks = ScriptedTicks(step_s=0.06)  # more than the silence (50 ms): a wake is a beat
        self.state = FakePublication("state", realtime=True, latest=True)
        self.state.subscribed = True
        self.reports = RecordedReports()
        self.loop = StateLoop(
            Broadcaster(cell(state_period_ms=STATE_PERIOD_S * 1000), FakeController()),
            self.ticks,
            self.port,
            byte_order=byte_order,
            state=self.state,
            reports=self.reports,
            clock=lambda: self.ticks.now,
            clock_ns=lambda: 5_000_000_000,
        )

    def run(self, *ticks: Tick | None) -> None:
        self.ticks.ticks += ticks
        while self.ticks.ticks:
            self.loop.cycle()

    @property
    def published(self) -> list[State]:
        decoder = Decoder(State)
        return [decoder.decode(payload) for payload in self.state.payloads]

    def read(self, client: FakeClient) -> list[Message]:
        codec = SimpleMessageCodec(Role.CLIENT, self.byte_order)
        codec.receive_data(b"".join(frame for cycle in client.cycles for frame in cycle))
        messages = []
        while (event := codec.next_event()) is not NEED_DATA:
            assert isinstance(event, Message)
            messages.append(event)
        return messages


@pytest.fixture(params=[ByteOrder.LITTLE, ByteOrder.BIG])
def harness(request: pytest.FixtureRequest) -> Harness:
    return Harness(request.param)


def moved(n: int, radians: int, depth: int = 0) -> Tick:
    pulses = [radians * PULSES_PER_RADIAN] + [0] * 7
    return tick(n, n * 4 * MS, group_tick(pulses, depth=depth))


def first_joints(messages: Sequence[Message]) -> list[float]:
    return [m.body.positions[0] for m in messages if isinstance(m.body, JointFeedback)]


def test_a_due_tick_reaches_a_new_client_and_zenoh_in_the_same_cycle(harness: Harness) -> None:
    client = harness.port.connect()
    harness.run(moved(1, 2))
    feedback, status = harness.read(client)
    assert (feedback.msg_type, status.msg_type) == (MsgType.JOINT_FEEDBACK, MsgType.ROBOT_STATUS)
    assert first_joints([feedback]) == pytest.approx([2.0])
    assert [state.tick for state in harness.published] == [1]
    assert harness.reports.clients == [1]
    assert harness.reports.ages == [5_000_000_000 - 4 * MS]


def test_the_state_sample_carries_the_commanded_joints_and_poses(harness: Harness) -> None:
    harness.run(moved(1, 2))
    (state,) = harness.published
    (arm,) = state.groups
    assert arm.command_positions[0] == pytest.approx(2.0)
    assert arm.flange is not None


def test_no_state_sample_and_no_poses_while_nobody_observes(harness: Harness) -> None:
    client = harness.port.connect()
    harness.state.subscribed = False
    harness.run(moved(1, 1))
    assert harness.published == []
    assert len(harness.read(client)) == 2  # the TCP clients get their frames all the same
    harness.state.subscribed = True
    harness.run(moved(2, 2))
    assert [state.tick for state in harness.published] == [2]


def test_every_client_gets_every_cycle_in_order(harness: Harness) -> None:
    clients = [harness.port.connect() for _ in range(3)]
    harness.run(moved(1, 1), moved(2, 2), moved(3, 3))
    for client in clients:
        assert first_joints(harness.read(client)) == pytest.approx([1.0, 2.0, 3.0])


def test_silence_beats_with_the_last_tick_but_is_not_an_age(harness: Harness) -> None:
    client = harness.port.connect()
    harness.run(moved(1, 1), None)
    messages = harness.read(client)
    assert [m.msg_type for m in messages].count(MsgType.ROBOT_STATUS) == 2
    assert [state.tick for state in harness.published] == [1, 1]
    assert len(harness.reports.ages) == 1


def test_a_beat_that_changes_nothing_sends_the_same_frames_again(harness: Harness) -> None:
    client = harness.port.connect()
    harness.run(moved(1, 1), None, None)
    first, *beats = client.cycles
    assert all(beat is first for beat in beats)


def test_a_cycle_without_a_snapshot_flushes_the_backlogs(harness: Harness) -> None:
    harness.port.connect()
    harness.run(moved(1, 1))
    assert harness.port.flushed == []
    harness.run(moved(2, 1))  # 4 ms after the first, the state period is 4 ms: due
    harness.run(tick(3, 9 * MS))  # not due
    assert harness.port.flushed == [harness.ticks.now]


def test_without_clients_the_state_still_goes_on_zenoh(harness: Harness) -> None:
    harness.run(moved(1, 1), moved(2, 2))
    assert [state.tick for state in harness.published] == [1, 2]
    assert harness.reports.ages == []
    assert harness.reports.clients == [0, 0]


def test_newcomers_are_admitted_knowing_whether_motion_is_queued(harness: Harness) -> None:
    harness.run(moved(1, 1, depth=3), moved(2, 1))
    assert harness.port.admitted_while_queued == [False, True]


def test_closing_tells_the_reports_the_clients_are_gone(harness: Harness) -> None:
    harness.port.connect()
    harness.run(moved(1, 1))
    harness.loop.close()
    assert harness.port.closed
    assert harness.reports.clients == [1, 0]


def test_the_loop_wakes_for_the_reports_when_no_beat_is_due(harness: Harness) -> None:
    harness.reports.next_due = 7.0
    harness.run(None, moved(1, 1), None)
    deadlines = [deadline for deadline, _ in harness.ticks.waits]
    silence_s = 0.05
    assert deadlines == pytest.approx([None, 7.0, 0.12 + silence_s])


def test_at_rest_the_loop_sleeps_until_the_next_beat_instead_of_waiting_for_ticks(
    harness: Harness,
) -> None:
    harness.port.connect()
    resting = msgspec.structs.replace(moved(1, 1), resting=True)
    harness.run(moved(0, 1), resting, None)
    waits = harness.ticks.waits
    assert [expected for _, expected in waits] == [True, True, False]
    deadline, _ = waits[2]
    assert deadline == pytest.approx(2 * harness.ticks.step_s + STATE_PERIOD_S)
    assert [state.tick for state in harness.published] == [0, 1, 1]


class StoppingTicks(ScriptedTicks):
    """Sets ``stop`` as it hands over its last tick, as the tick source wakes at stop."""

    def __init__(self, stop: StopFlag) -> None:
        super().__init__(step_s=0.004)
        self.stop = stop

    def next(self, deadline: float | None, ticks_expected: bool) -> Tick | None:
        got = super().next(deadline, ticks_expected)
        if not self.ticks:
            self.stop.set()
        return got


def observed_loop(
    ticks: ScriptedTicks | RestingExecutor, state_period_ms: float
) -> tuple[StateLoop, FakePublication]:
    """A loop on ``ticks`` and its clock, without clients, its ``state`` observed."""
    state = FakePublication("state", realtime=True, latest=True)
    state.subscribed = True
    loop = StateLoop(
        Broadcaster(cell(state_period_ms=state_period_ms), FakeController()),
        ticks,
        FakePort(),
        byte_order=ByteOrder.LITTLE,
        state=state,
        reports=RecordedReports(),
        clock=lambda: ticks.now,
    )
    return loop, state


def test_run_cycles_until_stopped() -> None:
    stop = StopFlag()
    ticks = StoppingTicks(stop)
    ticks.ticks += [moved(1, 1), moved(2, 1)]
    loop, state = observed_loop(ticks, STATE_PERIOD_S * 1000)
    loop.run(stop)
    assert ticks.ticks == []
    assert len(state.payloads) == 2


class RestingExecutor:
    """A ``TickFeed`` of a resting executor, as ``ticks.TickSource`` reads one: at rest the
    loop sleeps until its deadline or until a tick comes, whichever is first: the resting tick
    the executor sends again every ``resent_s`` (from 0, and never after ``gone_at``)."""

    def __init__(self, first: Tick, resent_s: float, gone_at: float) -> None:
        self.tick = first
        self.now = 0.0
        self.resent_s = resent_s
        self.gone_at = gone_at
        self._next = 0.0

    def next(self, deadline: float | None, ticks_expected: bool) -> Tick | None:
        """Before the first tick the loop waits for one (no deadline): it comes at 0."""
        assert deadline is not None or self.now == 0.0, "a resting loop always has a beat"
        if self._next < self.gone_at and (deadline is None or self._next <= deadline):
            self.now = self._next
            self._next += self.resent_s
            return self.tick
        assert deadline is not None
        self.now = deadline
        return None


def test_at_rest_observers_get_one_state_a_second_also_once_the_executor_is_gone() -> None:
    resting = msgspec.structs.replace(tick(9, 0), resting=True)
    ticks = RestingExecutor(resting, resent_s=1.0, gone_at=3.5)
    loop, state = observed_loop(ticks, 10)
    sent_at = []
    while ticks.now < 6.0:
        published = len(state.payloads)
        loop.cycle()
        if len(state.payloads) > published:
            sent_at.append(ticks.now)
    gone = 3.0 + 1.0 + 0.05  # a heartbeat and the silence after the last resting tick
    assert sent_at == pytest.approx([0.0, 1.0, 2.0, 3.0, gone, gone + 1.0, gone + 2.0])
