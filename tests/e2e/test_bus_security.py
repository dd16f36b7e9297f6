"""Only the cell's own services act on its bus (docs/security.md).

Foreign clients try everything that could move the robot or raise a fault: no credentials, a
wrong password, and the two valid outside identities (observer, operator) putting on every
command, point, increment, status and queue key and querying every command. Zenoh gives a
sender no error for a denied put, so the test watches the cell: the commanded position stays
where it was in every tick, no fault appears, and a trajectory still runs afterwards.
"""

from __future__ import annotations

import numpy as np
import pytest
import zenoh

from motocell.services.controller.core.dispatch import FaultKind, Verb
from motocell.shared.bus.access import Identity
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.credentials import Credentials, load
from motocell.shared.bus.schemas import (
    Alarm,
    CommandReply,
    CommandRequest,
    ControllerStatus,
    Decoder,
    IncrementBatch,
    Point,
    QueueState,
    encode,
)
from motocell.shared.bus.session import open_session
from motocell.shared.protocol.constants import Command, Result
from motocell.testing.client import MotionClient, StateListener, smooth_move, stream
from motocell.testing.processes import wait_until
from motocell.testing.running_cell import RunningCell, TickLog

pytestmark = pytest.mark.cell

WATCH_TICKS = 2
"""How long the cell is watched for an effect after an attack, in the executor's ticks. The
robot rests, so its clock publishes its resting tick once a second (docs/timing.md): two are
far more than any put or query needs to arrive (well under 10 ms on loopback), and a point
that got through would wake the clock, every tick of it seen here. Counted in ticks, which come
through the same router as the attack, so a loaded machine watches as much of the cell's life
as an idle one. The tick rate itself is benchmark figures 3 and 6."""
DEADLINE_S = 60.0
"""For what an idle machine does at once: a bound for a hang, not a speed."""


def attacks(cell: RunningCell) -> list[tuple[str, bytes]]:
    """(key, payload) for every put that would move the robot or change the controller."""
    keys = cell.keys
    far = [3.0] * 6
    big = np.full((4, 8), 20_000, dtype="<i4").tobytes()
    status = ControllerStatus(
        *(10**9, False, True, True, [Alarm(4100, 0)], 2010, False, False, True),
        *(False, True, True, False, [], False, 5003, [0]),
    )
    return [
        (keys.group_point(0), encode(Point(10**6, 0, 0.0, far, [0.0] * 6))),
        (keys.group_point(0), encode(Point(10**6 + 1, 1, 0.5, far, [0.0] * 6))),
        (keys.group_increments(0), encode(IncrementBatch(1, 0, 4, big, [], 0, [0] * 4))),
        (keys.group_queue(0), encode(QueueState(1, 0, 0, 200, [0] * 8, 0, False))),
        (keys.controller_status, encode(status)),
        (keys.controller_cmd("incmove_error"), encode(CommandReply(int(Result.FAILURE)))),
        (keys.controller_cmd("connections"), encode(CommandRequest(args=[0, 0, 0]))),
    ]


def attack(session: zenoh.Session, cell: RunningCell) -> None:
    for key, payload in attacks(cell):
        session.put(key, payload)
    keys = cell.keys
    on = encode(CommandRequest(value=1, args=[4100, 0]))
    for verb in Verb:
        list(session.get(keys.controller_cmd(verb), payload=encode(CommandRequest()), timeout=0.5))
    for kind in FaultKind:
        list(session.get(keys.controller_fault(kind), payload=on, timeout=0.5))
    list(session.get(keys.executor_cmd("stop"), payload=encode(CommandRequest()), timeout=0.5))


def credentials_of(cell: RunningCell, role: Role) -> Credentials:
    assert cell.credentials is not None, "the harness starts secured cells"
    return load(cell.credentials, cell.cell.name, Identity(role))


def assert_untouched(cell: RunningCell, ticks: TickLog, bus: zenoh.Session, mark: int) -> None:
    """No tick of the WATCH_TICKS since ``mark`` moved the robot; the controller shows no
    fault."""
    wait_until(lambda: len(ticks) >= mark + WATCH_TICKS, DEADLINE_S, "the executor's ticks")
    seen = ticks.since(mark)
    first = seen[0].groups[0].command_pulses
    assert all(t.groups[0].command_pulses == first for t in seen), "the robot moved"
    assert all(t.motion_ready for t in seen), "motion-ready dropped"
    replies = list(bus.get(cell.keys.service_info("controller", "0"), timeout=DEADLINE_S))
    assert replies, "the controller still answers"
    status = latest_status(bus, cell)
    assert not (status.estop or status.hold or status.alarms or status.error), status
    assert status.servo_on and status.play and status.remote and not status.incmove_error


def latest_status(bus: zenoh.Session, cell: RunningCell) -> ControllerStatus:
    decoder = Decoder(ControllerStatus)
    received: list[ControllerStatus] = []
    subscriber = bus.declare_subscriber(
        cell.keys.controller_status, lambda s: received.append(decoder.decode(s.payload.to_bytes()))
    )
    try:
        # The controller republishes its status at least every second.
        wait_until(lambda: bool(received), DEADLINE_S, "the controller's status")
    finally:
        subscriber.undeclare()
    return received[-1]


def still_moves(motion: MotionClient, state: StateListener) -> None:
    start = state.wait_still().groups[0].positions[:6]
    result = stream(motion, smooth_move(start, [p + 0.05 for p in start], 0.3, 4))
    assert result.points == 4, result.last_reply


def test_without_credentials_or_with_a_wrong_password_nobody_joins(cell: RunningCell) -> None:
    right = credentials_of(cell, Role.GATEWAY)
    wrong = Credentials(right.user, "not-the-password")
    for credentials in (None, wrong):
        with pytest.raises(ConnectionError, match="refused"):
            open_session("client", [cell.zenoh_endpoint], wait=False, credentials=credentials)


@pytest.mark.parametrize("role", [Role.OBSERVER, Role.OPERATOR])
def test_outside_identities_cannot_move_the_robot_or_raise_a_fault(
    cell: RunningCell,
    role: Role,
    motion: MotionClient,
    state: StateListener,
    ticks: TickLog,
    bus: zenoh.Session,
) -> None:
    assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
    state.wait_still()
    outsider = open_session(
        "client", [cell.zenoh_endpoint], wait=False, credentials=credentials_of(cell, role)
    )
    try:
        mark = len(ticks)
        if role is Role.OPERATOR:
            # Faults are the operator's to inject: everything else is attacked.
            attack_without_faults(outsider, cell)
        else:
            attack(outsider, cell)
        assert_untouched(cell, ticks, bus, mark)
    finally:
        outsider.close()
    still_moves(motion, state)


def attack_without_faults(session: zenoh.Session, cell: RunningCell) -> None:
    for key, payload in attacks(cell):
        session.put(key, payload)
    for verb in Verb:
        list(session.get(cell.keys.controller_cmd(verb), timeout=0.5))
    list(session.get(cell.keys.executor_cmd("stop"), timeout=0.5))


def test_the_operator_may_inject_a_fault_and_clear_it(
    cell: RunningCell, motion: MotionClient, state: StateListener, bus: zenoh.Session
) -> None:
    """The positive control: the same query path works for the identity allowed to use it."""
    on, off = encode(CommandRequest(value=1)), encode(CommandRequest(value=0))
    replies = list(bus.get(cell.keys.controller_fault("hold"), payload=on, timeout=DEADLINE_S))
    assert any(reply.ok for reply in replies)
    state.wait_for(lambda f: f.status is not None and f.status.motion_possible == 0, DEADLINE_S)
    list(bus.get(cell.keys.controller_fault("hold"), payload=off, timeout=DEADLINE_S))
    assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
