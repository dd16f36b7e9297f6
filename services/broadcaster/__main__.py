"""The state broadcaster: at the state period, one snapshot of the cell for the gateway's state
port and for anyone watching Zenoh.

It follows the executor's ticks (default 10 ms, 100 Hz: the first tick at or after each due
time), so feedback leaves as soon as its tick arrives and the rate is exact on average even
when the state period is not a whole number of ticks. MotoROS 1.9 sends "work time + 25 ms"
per client, a little under 40 Hz (§6); a steady configurable rate is what users ask for
(motoman#516).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import Generic, TypeVar

import zenoh

from shared.bus.schemas import (
    ControllerStatus,
    Decoder,
    GroupState,
    RobotStatusFields,
    State,
    Tick,
    encode,
)
from shared.bus.session import Inbox, Liveness, payload_of, publisher
from shared.config import Cell
from shared.motion.kinematics import AxisMap
from shared.service import ServiceContext, argument_parser, running_service

log = logging.getLogger("broadcaster")

T = TypeVar("T")

IN_MOTION_PULSES = 30
"""in_motion also while |feedback - command| exceeds 30 pulses on any axis (§6, v1.8.1)."""


def robot_status(
    status: ControllerStatus | None, tick: Tick, controller_alive: bool
) -> RobotStatusFields:
    in_motion = any(
        g.depth > 0
        or any(
            abs(f - c) > IN_MOTION_PULSES
            for f, c in zip(g.feedback_pulses, g.command_pulses, strict=True)
        )
        for g in tick.groups
    )
    if status is None or not controller_alive:
        # Without the controller nothing is known but that motion is impossible.
        return RobotStatusFields(-1, -1, -1, -1, int(in_motion), -1, 0)
    return RobotStatusFields(
        drives_powered=int(status.servo_on and not status.eco),
        e_stopped=int(status.estop),
        error_code=status.alarms[0].code if status.alarms else 0,
        in_error=int(bool(status.alarms)),
        in_motion=int(in_motion),
        # MotoROS sends 2 in PLAY, else 1 (the industrial_msgs convention; the FS100 capture
        # shows 2), not the 2012 spec's 0 = auto / 1 = manual.
        mode=2 if status.play else 1,
        motion_possible=int(status.motion_ready),
    )


class Snapshotter:
    """Turns the latest tick into per-group feedback in radians and ROS joint order."""

    def __init__(self, cell: Cell) -> None:
        self.maps = [AxisMap(group) for group in cell.groups]
        self.per_second = 1e9 / cell.period_ns

    def groups(self, tick: Tick) -> list[GroupState]:
        result = []
        for index, (axis_map, group) in enumerate(zip(self.maps, tick.groups, strict=True)):
            velocity = axis_map.pulses_to_ros(group.increment) * self.per_second
            result.append(
                GroupState(
                    group_no=index,
                    positions=axis_map.pulses_to_ros(group.feedback_pulses).tolist(),
                    velocities=velocity.tolist(),
                    command_positions=axis_map.pulses_to_ros(group.command_pulses).tolist(),
                )
            )
        return result


class Latest(Generic[T]):
    """Keeps the newest sample of a key; the Zenoh callback only stores it."""

    def __init__(self, session: zenoh.Session, key: str, decoder: Decoder[T]) -> None:
        self.value: T | None = None
        self._decoder = decoder
        self._subscriber = session.declare_subscriber(key, self._store)

    def _store(self, sample: zenoh.Sample) -> None:
        self.value = self._decoder.decode(sample.payload.to_bytes())


class Schedule:
    """When to send state, on the executor's own clock: the first tick at or after each due
    time. Feedback then leaves the moment the tick that produced it arrives (no wait for a
    second clock), and the rate is exact on average even when the state period is not a
    whole number of ticks (10 ms at 4 ms: 8 and 12 ms alternately)."""

    def __init__(self, period_ns: int) -> None:
        self.period_ns = period_ns
        self.next_due: int | None = None

    def due(self, tick_ns: int) -> bool:
        if self.next_due is None:
            self.next_due = tick_ns
        if tick_ns < self.next_due:
            return False
        self.next_due += self.period_ns
        if self.next_due <= tick_ns:
            self.next_due = tick_ns + self.period_ns  # fell behind: no burst to catch up
        return True


def run(ctx: ServiceContext) -> None:
    keys = ctx.keys
    session = ctx.session
    snapshotter = Snapshotter(ctx.cell)
    state_pub = publisher(session, keys.state, realtime=True, latest=True)
    ticks = Inbox(maxsize=64)
    tick_subscriber = session.declare_subscriber(
        keys.executor_tick, ticks.feed("tick", payload_of(Decoder(Tick)))
    )
    statuses = Latest(session, keys.controller_status, Decoder(ControllerStatus))
    controller_key = keys.alive("controller", "0")
    alive = Liveness(session, controller_key)
    schedule = Schedule(ctx.cell.state_period_ns)
    # Without ticks (no executor) the state port still beats, from the last tick, so clients
    # see motion_possible drop instead of silence.
    silence_s = max(0.05, 3 * ctx.cell.state_period_ns / 1e9)
    last: Tick | None = None
    seq = 0
    while not ctx.stop.is_set():
        item = ticks.get(timeout=silence_s)
        if item is not None:
            last = item[1]
            assert isinstance(last, Tick)
            if not schedule.due(last.deadline_ns):
                continue
        elif last is None:
            continue
        seq += 1
        state = State(
            seq=seq,
            tick=last.tick,
            tick_ns=last.deadline_ns + last.lateness_ns,
            groups=snapshotter.groups(last),
            status=robot_status(statuses.value, last, controller_key in alive.present()),
        )
        state_pub.put(encode(state))
    tick_subscriber.undeclare()


def main(argv: Sequence[str] | None = None) -> None:
    args = argument_parser("broadcaster", "Controller state at the state period.").parse_args(argv)
    with running_service("broadcaster", "0", args) as ctx:
        run(ctx)


if __name__ == "__main__":
    main()
