"""A ``CellPort`` for unit tests (as httpcore's MockStream): the test sets the cell's state and
the other services' replies, and reads what the gateway sent and asked."""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass

from motocell.services.gateway.core.cell_state import CellState
from motocell.services.gateway.core.motion import MotionHandler
from motocell.services.gateway.core.response import Response
from motocell.services.gateway.core.robot_io import RobotIoHandler
from motocell.services.gateway.core.sources import Source
from motocell.shared.bus.schemas import (
    CommandReply,
    CommandRequest,
    ControllerStatus,
    Point,
    QueueState,
    Slot,
)
from motocell.shared.config import Cell, parse_cell
from motocell.shared.protocol.constants import Result
from motocell.shared.protocol.messages import Message, MotoMotionReply, UnknownMessage
from motocell.testing.statuses import ready_status

INSTANCE = 7
"""The interpolator process every group's slot reports come from."""
EPOCH = 3
CAPACITY = 200
SYNC_SEED = 1000
NOW = 1000.0
"""The instant samples arrive at in tests that do not age the state."""
OK_REPLY = CommandReply(int(Result.SUCCESS))


def one_group() -> Cell:
    return parse_cell({})


def two_groups() -> Cell:
    return parse_cell({"groups": [{"name": "R1"}, {"name": "R2"}]})


def status(
    ready: bool = True,
    subcode: int = 0,
    missing: Sequence[str] = (),
    seq: int = 1,
    heartbeat: int = 100,
) -> ControllerStatus:
    return ready_status(
        seq=seq,
        heartbeat_ms=heartbeat,
        servo_on=ready,
        operating=ready,
        job_ready=ready,
        missing_services=list(missing),
        motion_ready=ready,
        not_ready_subcode=subcode,
    )


def queue(
    depth: int = 0,
    epoch: int = EPOCH,
    command_pulses: Sequence[int] = (0,) * 8,
    ready: bool = True,
    heartbeat: int = 100,
) -> QueueState:
    return QueueState(
        epoch=epoch,
        received=0,
        depth=depth,
        capacity=CAPACITY,
        command_pulses=list(command_pulses),
        tick=0,
        ready=ready,
        heartbeat_ms=heartbeat,
    )


def slot(taken: int = 0, trajectory_id: int = 0, instance: int = INSTANCE) -> Slot:
    return Slot(taken_id=taken, epoch=EPOCH, instance=instance, trajectory_id=trajectory_id)


@dataclass
class Call:
    service: str
    verb: str
    request: CommandRequest | None
    timeout: float


class FakeCell:
    def __init__(self, groups: int, pending_points: int = 1) -> None:
        self.state = CellState(groups, pending_points)
        self.alive = True
        self.sent: list[tuple[int, Point]] = []
        self.calls: list[Call] = []
        self.replies: dict[str, CommandReply | None] = {}
        """By "service/verb"; a missing entry answers SUCCESS, None does not answer."""
        self.effects: dict[str, Callable[[], None]] = {}
        """By "service/verb": what the command does to the cell before it replies."""
        self.while_waiting: list[Callable[[], None]] = []
        """Changes the cell goes through while the gateway waits on it, then they are gone."""
        self.waits: list[float] = []

    @contextmanager
    def current(self) -> Iterator[CellState]:
        """The test feeds ``state`` directly: it is always current."""
        yield self.state

    def controller_alive(self) -> bool:
        return self.alive

    def send_point(self, group: int, point: Point) -> None:
        self.sent.append((group, point))

    def _call(
        self, service: str, verb: str, request: CommandRequest | None, timeout: float
    ) -> CommandReply | None:
        self.calls.append(Call(service, verb, request, timeout))
        key = f"{service}/{verb}"
        if key in self.effects:
            self.effects[key]()
        return self.replies.get(key, OK_REPLY)

    def controller(
        self, verb: str, request: CommandRequest | None = None, timeout: float = 2.0
    ) -> CommandReply | None:
        return self._call("controller", verb, request, timeout)

    def executor(
        self, verb: str, request: CommandRequest | None = None, timeout: float = 1.0
    ) -> CommandReply | None:
        return self._call("executor", verb, request, timeout)

    def wait_for(self, condition: Callable[[], bool], timeout: float) -> bool:
        self.waits.append(timeout)
        if not condition():
            for change in self.while_waiting:
                change()
            self.while_waiting.clear()
        return condition()

    def verbs(self, service: str) -> list[str]:
        return [call.verb for call in self.calls if call.service == service]

    # -- the rest of the cell, as its samples would arrive --------------------------------
    def ready(self, heartbeat: int = 100) -> FakeCell:
        """Motion-ready: controller status, executor rings and every interpolator heard (at
        NOW, the status and queue states announcing ``heartbeat`` ms)."""
        self.state.on_status(status(heartbeat=heartbeat), NOW)
        for group in range(len(self.state.groups)):
            self.state.on_queue(group, queue(heartbeat=heartbeat), NOW)
            self.state.on_slot(group, slot())
        return self

    def take_all(self, group: int = 0, trajectory_id: int = 1) -> None:
        """The group's interpolator reports every point published to it taken, running the
        trajectory begun by point ``trajectory_id``."""
        self.state.on_slot(group, slot(self.state.groups[group].published, trajectory_id))


def gateway(cell: Cell | None = None) -> tuple[MotionHandler, FakeCell]:
    """A motion handler on a ready fake cell."""
    cell = cell or one_group()
    fake = FakeCell(len(cell.groups), cell.pending_points).ready()
    sync_ids = itertools.count(SYNC_SEED + 1)
    return MotionHandler(cell, fake, RobotIoHandler(fake), sync_ids, Source.SIMPLE_MESSAGE), fake


def exchange(handler: MotionHandler, request: Message | UnknownMessage) -> Response:
    """One request as the TCP server handles it: the response, then its ``then``."""
    response = handler.respond(request)
    if response.then is not None:
        response.then()
    return response


def reply_of(message: Message | None) -> MotoMotionReply:
    assert message is not None
    body = message.body
    assert isinstance(body, MotoMotionReply)
    return body


def verdict_of(message: Message | None) -> tuple[int, int]:
    body = reply_of(message)
    return body.result, body.subcode
