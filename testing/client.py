"""A blocking Simple Message client: the codec in the client role over a socket.

Used by the demo, the tests and the benchmarks to talk to a cell exactly as motoman_driver
does: one request, then the next frame on the socket is its reply.
"""

from __future__ import annotations

import contextlib
import math
import socket
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

from motocell.shared.protocol.codec import (
    CLOSED,
    NEED_DATA,
    ByteOrder,
    Role,
    SimpleMessageCodec,
    readable_byte_order,
)
from motocell.shared.protocol.constants import PREFIX_SIZE, Command, Result, describe_reply
from motocell.shared.protocol.errors import PeerProtocolError
from motocell.shared.protocol.layouts import Direction
from motocell.shared.protocol.messages import (
    JointFeedback,
    JointFeedbackEx,
    Message,
    MotoMotionReply,
    RobotStatus,
    UnknownMessage,
)
from motocell.shared.protocol.replies import ex_group, motion_ctrl, traj_point, traj_point_ex


class ConnectionClosedError(ConnectionError):
    pass


class WrongByteOrderError(PeerProtocolError):
    """The controller's first frame reads as a frame only in the other byte order: it is an
    FS100 (big-endian) and we speak little-endian, or the reverse."""

    def __init__(self, error: PeerProtocolError, byte_order: ByteOrder) -> None:
        super().__init__(f"the controller looks {byte_order.value}-endian ({error})", error.subcode)
        self.byte_order = byte_order


def connect(host: str, port: int, timeout: float = 5.0) -> socket.socket:
    sock = socket.create_connection((host, port), timeout=timeout)
    try:
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    except OSError:  # the peer reset it already
        sock.close()
        raise
    return sock


LISTEN_POLL_S = 0.01
"""How often ``connect_once_listening`` tries again while nothing listens yet."""


def connect_once_listening(host: str, port: int, timeout: float) -> socket.socket:
    """A connection to ``host:port`` as soon as something listens there, tried again every
    LISTEN_POLL_S for ``timeout`` s (then TimeoutError). The connection is the caller's to use,
    not a probe: a client that first probes a motion port with a connection of its own and then
    connects again waits for the gateway to finish with the probe (MotoROS's 50 ms pause before
    it closes a connection, motoros1 §2.1; the gateway serves one client at a time). A socket
    whose kernel-chosen source port is ``port`` itself connects to itself with nobody
    listening (TCP simultaneous open): that one is closed and tried again."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            sock = connect(host, port, max(deadline - time.monotonic(), LISTEN_POLL_S))
        except ConnectionRefusedError:
            pass
        else:
            if sock.getsockname() != sock.getpeername():
                return sock
            sock.close()
        if time.monotonic() >= deadline:
            raise TimeoutError(f"nothing listened at {host}:{port} within {timeout:.0f} s")
        time.sleep(LISTEN_POLL_S)


class FrameReader:
    """Frames off a socket, one at a time."""

    def __init__(self, sock: socket.socket, byte_order: ByteOrder) -> None:
        self.sock = sock
        self.codec = SimpleMessageCodec(Role.CLIENT, byte_order)
        self._opening = b""
        """The connection's first bytes, up to one length prefix."""
        self._framed = False

    def next(self) -> Message | UnknownMessage:
        while True:
            try:
                event = self.codec.next_event()
            except PeerProtocolError as error:
                raise self._explained(error) from None
            if event is NEED_DATA:
                data = self.sock.recv(65536)
                self._opening += data[: PREFIX_SIZE - len(self._opening)]
                self.codec.receive_data(data)
                continue
            if event is CLOSED:
                raise ConnectionClosedError("the controller closed the connection")
            assert isinstance(event, Message | UnknownMessage)
            self._framed = True
            return event

    def _explained(self, error: PeerProtocolError) -> PeerProtocolError:
        """A first frame that reads only in the other byte order says which one the
        controller speaks; anything later is plain garbage."""
        if self._framed or len(self._opening) < PREFIX_SIZE:
            return error
        readable = readable_byte_order(self._opening, Direction.TO_CLIENT)
        if readable is None or readable is self.codec.byte_order:
            return error
        return WrongByteOrderError(error, readable)


class MotionClient:
    """Port 50240 (or 50242 for I/O): request, then read exactly one reply."""

    def __init__(
        self,
        host: str,
        port: int,
        byte_order: ByteOrder = ByteOrder.LITTLE,
        timeout: float = 10.0,
        *,
        sock: socket.socket | None = None,
    ) -> None:
        """``sock``: a connection made already (``once_listening``), else one is made now."""
        self.sock = connect(host, port, timeout) if sock is None else sock
        self.reader = FrameReader(self.sock, byte_order)

    @classmethod
    def once_listening(
        cls, host: str, port: int, byte_order: ByteOrder, timeout: float
    ) -> MotionClient:
        """A client of a port that may not listen yet (a cell starting): connected as soon as
        it does (``connect_once_listening``)."""
        return cls(host, port, byte_order, sock=connect_once_listening(host, port, timeout))

    def send(self, message: Message) -> None:
        self.sock.sendall(self.reader.codec.send(message))

    def request(self, message: Message) -> Message | UnknownMessage:
        self.send(message)
        return self.reader.next()

    def motion(self, message: Message) -> MotoMotionReply:
        reply = self.request(message)
        if not isinstance(reply, Message) or not isinstance(reply.body, MotoMotionReply):
            raise AssertionError(f"expected a MOTO_MOTION_REPLY, got type {reply.msg_type}")
        return reply.body

    def command(self, command: Command, group: int = 0) -> MotoMotionReply:
        return self.motion(motion_ctrl(command, group))

    def close(self) -> None:
        self.sock.close()

    def __enter__(self) -> MotionClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@dataclass
class Feedback:
    received_ns: int
    groups: dict[int, JointFeedback] = field(default_factory=dict)
    status: RobotStatus | None = None
    ex: JointFeedbackEx | None = None


class StateListener:
    """Port 50241: reads every frame in a thread and keeps the history of state cycles."""

    def __init__(
        self, host: str, port: int, byte_order: ByteOrder = ByteOrder.LITTLE, keep: int = 100_000
    ) -> None:
        self.sock = connect(host, port)
        self.sock.settimeout(None)
        self.reader = FrameReader(self.sock, byte_order)
        self.cycles: list[Feedback] = []
        self.frames: list[Message] = []
        self.keep = keep
        self.changed = threading.Condition()
        self._current = Feedback(0)
        self.closed = False
        self.failure: PeerProtocolError | None = None
        """What the controller sent that could not be read (the reading stopped there)."""
        self.thread = threading.Thread(target=self._run, name="state-listener", daemon=True)

    def start(self) -> StateListener:
        """Start reading in the listener's thread (``close`` ends it); returns the listener."""
        self.thread.start()
        return self

    def _run(self) -> None:
        try:
            while True:
                frame = self.reader.next()
                if isinstance(frame, Message):
                    self._take(frame)
        except PeerProtocolError as error:
            self._end(error)
        except (ConnectionError, OSError):
            self._end(None)

    def _end(self, failure: PeerProtocolError | None) -> None:
        with self.changed:
            self.failure = failure
            self.closed = True
            self.changed.notify_all()

    def _take(self, frame: Message) -> None:
        body = frame.body
        with self.changed:
            if len(self.frames) < self.keep:
                self.frames.append(frame)
            if isinstance(body, JointFeedback):
                self._current.groups[body.group_no] = body
            elif isinstance(body, JointFeedbackEx):
                self._current.ex = body
            elif isinstance(body, RobotStatus):
                # ROBOT_STATUS ends a cycle (motoros1 §6 order: feedback, feedback_ex, status).
                self._current.status = body
                self._current.received_ns = time.monotonic_ns()
                if len(self.cycles) < self.keep:
                    self.cycles.append(self._current)
                self._current = Feedback(0)
                self.changed.notify_all()

    def latest(self) -> Feedback | None:
        with self.changed:
            return self.cycles[-1] if self.cycles else None

    def wait_for(self, predicate: Callable[[Feedback], bool], timeout: float) -> Feedback:
        """The first state cycle, from now on, that satisfies ``predicate``; TimeoutError when
        none came in time or the connection closed first, or the PeerProtocolError that
        stopped the reading (e.g. a ``WrongByteOrderError``) as soon as it happens."""
        deadline = time.monotonic() + timeout
        with self.changed:
            start = max(0, len(self.cycles) - 1)
            while True:
                for cycle in self.cycles[start:]:
                    if predicate(cycle):
                        return cycle
                start = len(self.cycles)
                remaining = deadline - time.monotonic()
                if self.failure is not None:
                    raise self.failure
                if remaining <= 0 or self.closed:
                    raise TimeoutError(f"no matching state within {timeout} s")
                self.changed.wait(remaining)

    def wait_still(self, timeout: float = 30.0) -> Feedback:
        """The first state cycle, from now on, in which the robot is at rest: not in motion
        (nothing queued, the feedback within 30 pulses of the command) and no axis moving, so
        the feedback is the commanded position exactly (a servo settles after in_motion
        drops, docs/servo.md). The default ``timeout`` bounds a hang on a loaded machine."""
        return self.wait_for(
            lambda f: (
                f.status is not None
                and f.status.in_motion == 0
                and not any(any(g.velocities) for g in f.groups.values())
            ),
            timeout,
        )

    def close(self) -> None:
        with contextlib.suppress(OSError):
            self.sock.shutdown(socket.SHUT_RDWR)
        self.sock.close()
        self.thread.join(timeout=2.0)

    def __enter__(self) -> StateListener:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@dataclass(frozen=True)
class PlannedPoint:
    time: float
    positions: tuple[float, ...]
    velocities: tuple[float, ...]


def smooth_move(
    start: Sequence[float], goal: Sequence[float], duration: float, points: int
) -> list[PlannedPoint]:
    """A rest-to-rest move with a cosine velocity profile, sampled at ``points`` instants:
    what a planner such as MoveIt hands motoman_driver (positions and velocities, time from
    the start)."""
    result = []
    for i in range(points):
        t = duration * i / (points - 1)
        s = (1 - math.cos(math.pi * t / duration)) / 2
        ds = math.pi / (2 * duration) * math.sin(math.pi * t / duration)
        result.append(
            PlannedPoint(
                t,
                tuple(a + (b - a) * s for a, b in zip(start, goal, strict=True)),
                tuple((b - a) * ds for a, b in zip(start, goal, strict=True)),
            )
        )
    return result


@dataclass
class StreamResult:
    points: int = 0
    busy: int = 0
    last_reply: MotoMotionReply | None = None
    first_sent_ns: int = 0
    last_accepted_ns: int = 0

    @property
    def outcome(self) -> str:
        """The last reply as a person reads it: ``SUCCESS``, ``INVALID 3013 (too fast)``."""
        reply = self.last_reply
        return "no reply" if reply is None else describe_reply(reply.result, reply.subcode)


BUSY_RETRY_S = 0.005
"""motoman_driver sleeps 5 ms at the top of each streaming pass, which is its BUSY retry."""


def point_messages(group: int, trajectory: Sequence[PlannedPoint]) -> list[Message]:
    """One JOINT_TRAJ_PT_FULL (14) per point, sequence 0 first."""
    return [
        traj_point(group, sequence, point.time, point.positions, point.velocities)
        for sequence, point in enumerate(trajectory)
    ]


def ex_messages(trajectories: Mapping[int, Sequence[PlannedPoint]]) -> list[Message]:
    """One MOTO_JOINT_TRAJ_PT_FULL_EX (2016) per point for several groups (same length and
    times), as motoman_driver streams 2-4 groups."""
    lengths = {len(points) for points in trajectories.values()}
    assert len(lengths) == 1, "every group needs a point at every time"
    return [
        traj_point_ex(
            sequence,
            [
                ex_group(group, p[sequence].time, p[sequence].positions, p[sequence].velocities)
                for group, p in trajectories.items()
            ],
        )
        for sequence in range(lengths.pop())
    ]


def stream(
    client: MotionClient, trajectory: Sequence[PlannedPoint], group: int = 0
) -> StreamResult:
    """Stream like MotomanJointTrajectoryStreamer: resend on BUSY, stop at any other failure."""
    return stream_messages(client, point_messages(group, trajectory))


def stream_ex(
    client: MotionClient, trajectories: Mapping[int, Sequence[PlannedPoint]]
) -> StreamResult:
    """Stream several groups' trajectories as 2016 messages (see ``ex_messages``)."""
    return stream_messages(client, ex_messages(trajectories))


def stream_messages(client: MotionClient, messages: Sequence[Message]) -> StreamResult:
    """Send each message, resending it after 5 ms while the reply is BUSY."""
    result = StreamResult(first_sent_ns=time.monotonic_ns())
    for message in messages:
        while True:
            reply = client.motion(message)
            result.last_reply = reply
            if reply.result == Result.BUSY:
                result.busy += 1
                time.sleep(BUSY_RETRY_S)
                continue
            break
        if reply.result != Result.SUCCESS:
            return result
        result.points += 1
        result.last_accepted_ns = time.monotonic_ns()
    return result
