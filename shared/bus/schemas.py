"""Payloads that travel on Zenoh: msgspec Structs encoded as msgpack arrays.

One decoder per key. Schemas evolve only by appending fields with defaults, so an older
subscriber keeps decoding newer payloads. Pulse lists are Motoman axis order, 8 slots; joint
lists are ROS order, one entry per axis of the group.
"""

from __future__ import annotations

import math
from enum import IntEnum
from typing import Generic, TypeVar

import msgspec


class Alarm(msgspec.Struct, array_like=True, frozen=True):
    code: int
    subcode: int = 0


class ControllerStatus(msgspec.Struct, array_like=True, frozen=True):
    """``controller/status``: the simulated controller as MotoROS's status poller sees it."""

    seq: int
    servo_on: bool
    estop: bool
    hold: bool
    alarms: list[Alarm]
    error: int
    """Active error number (errors are not alarms: they block motion but not in_error)."""
    play: bool
    remote: bool
    operating: bool
    """A job is running (INIT_ROS parked at its WAIT counts)."""
    job_ready: bool
    """OT#889 latched on its rising edge (motoros1 §7.1)."""
    pfl_active: bool
    incmove_error: bool
    eco: bool
    missing_services: list[str]
    motion_ready: bool
    not_ready_subcode: int
    """The NOT_READY subcode (motoros1 §7.2) when not ready, else 0."""
    tools: list[int]
    """Selected tool per group."""
    heartbeat_ms: int = 100
    """The next status comes within this even when nothing changes
    (``shared.bus.liveness.heartbeat_ms``): subscribers that age what they hold, and the
    executor's controller-silence rule, count in these."""


class Point(msgspec.Struct, array_like=True, frozen=True):
    """``group/<g>/point``: a point the gateway accepted, for the group's interpolator.

    ``point_id`` counts every point the gateway published to this group, so the interpolator's
    ``Slot.taken_id`` tells the gateway whether the pending slot is free.
    """

    point_id: int
    sequence: int
    time: float
    positions: list[float]
    velocities: list[float]
    sync_id: int = 0
    sync_groups: list[int] = msgspec.field(default_factory=list)
    """On the first segment of a 2016 trajectory: an id the gateway gives that message, and
    all its groups. They must start in the same tick (see ``IncrementBatch.sync_groups``)."""
    epoch: int = 0
    """The executor ring epoch the gateway checked the point against. The interpolator does
    not take the point before it has seen that epoch itself, so a point can never be built
    on a ring that is about to be (or has just been) replaced."""


def point_fits(point: Point, axes: int) -> bool:
    """Whether ``point`` is one a gateway could have sent to a group of ``axes`` axes: a finite
    time not before 0, and ``axes`` finite positions and velocities. Anyone who may write a
    point may send any other; the interpolator must not build a trajectory of one."""
    return (
        math.isfinite(point.time)
        and point.time >= 0
        and len(point.positions) == len(point.velocities) == axes
        and all(math.isfinite(value) for value in (*point.positions, *point.velocities))
    )


class Slot(msgspec.Struct, array_like=True, frozen=True):
    """``group/<g>/slot``: the interpolator's pending-point slot, published on every change."""

    taken_id: int
    """Highest point id fully interpolated into the executor's queue (or dropped)."""
    epoch: int
    points_accepted: int = 0
    increments_sent: int = 0
    instance: int = 0
    """Which interpolator process this is; a new one has taken none of the earlier points."""
    trajectory_id: int = 0
    """The point id of the sequence-0 point behind the trajectory it runs; 0 for none."""


class IncrementBatch(msgspec.Struct, array_like=True, frozen=True):
    """``group/<g>/increments``: consecutive queue entries for one group.

    ``first_seq`` numbers entries within ``epoch``; the executor accepts a batch only if it
    continues exactly where the previous one ended (a gap stops motion with an alarm).
    ``increments`` is little-endian int32, ``count`` rows x 8 Motoman axes.
    """

    epoch: int
    first_seq: int
    count: int
    increments: bytes
    partial: list[int]
    """Row indices of partial-period entries (merged with the next entry by the executor)."""
    tool: int
    times_ns: list[int]
    sync_id: int = 0
    sync_groups: list[int] = msgspec.field(default_factory=list)
    """When set, the batch's first entry starts a trajectory shared with ``sync_groups``: the
    executor holds it until every one of those groups has its start entry (same ``sync_id``)
    at the head of its ring, so groups given the same timestamps start, and so arrive, in the
    same tick."""
    through: int = 0
    """The highest ``Point.point_id`` its interpolator is done with: every entry of every point
    up to it is in this batch or an earlier one (a point it dropped counts as done). A point
    the executor has heard of beyond it is still owed, and a ring left empty while owed is
    starved, not finished (docs/motion-safety.md, What a ring is owed)."""


class QueueState(msgspec.Struct, array_like=True, frozen=True):
    """``group/<g>/queue``: the executor's ring for one group, published when it changes.

    ``epoch`` changes whenever the ring is cleared; ``received`` is the next entry sequence the
    executor expects in this epoch, so the interpolator knows how many entries are in flight.
    ``command_pulses`` is exact whenever ``depth`` is 0 and nothing is in flight.
    """

    epoch: int
    received: int
    depth: int
    capacity: int
    command_pulses: list[int]
    tick: int
    ready: bool = False
    """Whether the executor itself takes increments now (it learns readiness from the
    controller a little after the controller decides it); the gateway waits for it."""
    heartbeat_ms: int = 100
    """The next queue state comes within this even when nothing changes: short while the
    executor's clock runs, long while it rests (``shared.bus.liveness``)."""


class GroupTick(msgspec.Struct, array_like=True, frozen=True):
    command_pulses: list[int]
    """The commanded position: every increment applied so far (what MotoROS's start-position
    check and the interpolators use)."""
    feedback_pulses: list[int]
    """The encoder: where the servo has taken each axis (docs/servo.md)."""
    increment: list[int]
    """What the command moved this period."""
    depth: int
    feedback_moved: list[float] = msgspec.field(default_factory=list)
    """What the feedback moved this period, in pulses (a fraction of a pulse too: the servo's
    position is finer than the encoder's): its velocity times the period."""


class Tick(msgspec.Struct, array_like=True, frozen=True):
    """``executor/tick``: what the motion system did this period."""

    tick: int
    deadline_ns: int
    """The tick's scheduled time on CLOCK_MONOTONIC."""
    lateness_ns: int
    missed: int
    """Periods missed since start (each is caught up, so simulated motion never slips)."""
    motion_ready: bool
    groups: list[GroupTick]
    resting: bool = False
    """The clock rests after this tick: nothing is queued, owed or settling, so no tick comes
    until motion is asked for again, and the cell stays exactly as this tick says."""


class CartesianPose(msgspec.Struct, array_like=True, frozen=True):
    """A frame of an arm in the arm's base frame, from its model's DH table (frames, units and
    conventions: docs/poses.md)."""

    position: list[float]
    """x, y, z in metres."""
    orientation: list[float]
    """A unit quaternion in the order x, y, z, w, with w >= 0."""


class GroupState(msgspec.Struct, array_like=True, frozen=True):
    group_no: int
    positions: list[float]
    velocities: list[float]
    command_positions: list[float]
    tool: int = 0
    """The tool selected for the group (MOTO_SELECT_TOOL) when the poses were computed."""
    flange: CartesianPose | None = None
    """The flange at ``positions``: arms only (None for positioners and tracks)."""
    tcp: CartesianPose | None = None
    """The tool centre point at ``positions``: the flange composed with ``tool``'s offset."""
    command_flange: CartesianPose | None = None
    """The flange at ``command_positions``."""
    command_tcp: CartesianPose | None = None
    """The tool centre point at ``command_positions``."""
    command_velocities: list[float] = msgspec.field(default_factory=list)
    """The commanded velocity (this period's increment); ``velocities`` is the feedback's."""


class RobotStatusFields(msgspec.Struct, array_like=True, frozen=True):
    drives_powered: int
    e_stopped: int
    error_code: int
    in_error: int
    in_motion: int
    mode: int
    motion_possible: int


class State(msgspec.Struct, array_like=True, frozen=True):
    """``state``: one state snapshot, what the broadcaster sends on port 50241."""

    seq: int
    tick: int
    tick_ns: int
    """CLOCK_MONOTONIC of the tick the feedback comes from (for feedback-age measurements)."""
    groups: list[GroupState]
    status: RobotStatusFields


class MotionHolder(IntEnum):
    """Which face holds trajectory mode: the fourth value of the gateway's ``connections``
    notice (a ``CommandRequest``'s ``args``: motion, state, I/O clients, then this)."""

    NOBODY = 0
    MOTION_PORT = 1
    """The motion port's Simple Message client."""
    ROS2_FACE = 2


class CommandRequest(msgspec.Struct, array_like=True, frozen=True):
    """Payload of ``*/cmd/<verb>`` queries."""

    group: int = 0
    value: int = 0
    args: list[int] = msgspec.field(default_factory=list)


class CommandReply(msgspec.Struct, array_like=True, frozen=True):
    """Reply of ``*/cmd/<verb>`` queries: MotoROS result and subcode (and a value if any)."""

    result: int
    subcode: int = 0
    value: int = 0
    detail: str = ""
    pulses: list[list[int]] = msgspec.field(default_factory=list)
    status_seq: int = 0
    """The controller status published before this reply went out, which already shows the
    command's effect; the gateway waits for it so its next answer cannot be stale."""


class Listening(msgspec.Struct, array_like=True, frozen=True):
    """A TCP port a service serves, as it bound it."""

    port_name: str
    """``motion``, ``state`` or ``io``."""
    host: str
    """The address it listens on (``0.0.0.0``: every address of ``ServiceInfo.host``)."""
    port: int


class ServiceInfo(msgspec.Struct, array_like=True, frozen=True):
    """Reply of the ``service/<service>/<instance>`` queryable every process declares."""

    cell: str
    service: str
    instance: str
    host: str
    pid: int
    started_unix_ns: int
    version: str
    listening: list[Listening] = msgspec.field(default_factory=list)
    """The TCP ports it serves, once it listens on them: the gateway's motion and I/O ports,
    the broadcaster's state port."""


class Percentiles(msgspec.Struct, array_like=True, frozen=True):
    """A rolling window of one measurement, in microseconds."""

    count: int
    p50_us: float
    p99_us: float
    max_us: float


class ExecutorMetrics(msgspec.Struct, array_like=True, frozen=True):
    """``executor/metrics``, every second: lateness of the ticks of the last second."""

    tick: int
    lateness: Percentiles
    missed_total: int
    queue_depths: list[int]
    realtime: bool


class MotionRequest(msgspec.Struct, array_like=True, frozen=True):
    """``gateway/cmd/motion``: one Simple Message request of the ROS 2 face, as the motion
    port's client would send it (the cell's byte order), for the gateway's motion API."""

    frame: bytes


class MotionResponse(msgspec.Struct, array_like=True, frozen=True):
    """The gateway's answer to a ``MotionRequest``: the reply frame, empty where the request
    gets none (a DISCONNECT that succeeded, a frame that was itself a reply)."""

    frame: bytes


class LateTicks(msgspec.Struct, array_like=True, frozen=True):
    """``executor/late``: the clock missed periods (ticks a period or more after their
    deadline), said as it happens: the first at once, later ones within a second gathered into
    the next sample."""

    tick: int
    """The latest of the latest ones."""
    deadline_ns: int
    """That tick's scheduled time on CLOCK_MONOTONIC."""
    lateness_ns: int
    """How late it came: the worst of the ticks this sample counts."""
    periods: int
    """Ticks a period or more late since the previous sample."""
    missed_total: int
    """Since the executor started (``Tick.missed``)."""


class RequestStats(msgspec.Struct, array_like=True, frozen=True):
    msg_type: int
    count: int
    reply: Percentiles
    """Request fully received -> reply written, over the last second."""


class GatewayMetrics(msgspec.Struct, array_like=True, frozen=True):
    """``gateway/metrics``, every second."""

    motion_clients: int
    io_clients: int
    requests: list[RequestStats]
    busy_total: int
    invalid_total: int
    not_ready_total: int
    busy_by_group: list[int]


class BroadcasterMetrics(msgspec.Struct, array_like=True, frozen=True):
    """``broadcaster/metrics``, every second: the state port's clients and how late its frames
    leave."""

    state_clients: int
    write_age: Percentiles
    """A tick's wake-up (``State.tick_ns``) -> its frames handed to every state client, over the
    last second. CLOCK_MONOTONIC: meaningful when the broadcaster shares the executor's host."""
    replaced_total: int
    """States a slow client never got because a newer one came first (it gets the newest,
    never a burst of old ones)."""
    stuck_closed_total: int
    """State clients closed because they took nothing for 2 s."""


class InterpolatorMetrics(msgspec.Struct, array_like=True, frozen=True):
    """``group/<g>/metrics``, every second."""

    points_accepted: int
    increments_sent: int
    slot_busy_s: float
    """How long the pending slot has been full in total (the gateway answers BUSY then)."""
    busy_episodes: int
    """How many times a point had to wait for room in the executor's ring."""


T = TypeVar("T")

_encoder = msgspec.msgpack.Encoder()


def encode(payload: msgspec.Struct) -> bytes:
    return _encoder.encode(payload)


class Decoder(Generic[T]):
    """One prebuilt decoder per payload type."""

    def __init__(self, payload_type: type[T]) -> None:
        self._decoder = msgspec.msgpack.Decoder(payload_type)

    def decode(self, data: bytes | bytearray | memoryview) -> T:
        return self._decoder.decode(data)
