"""Bad input over real TCP, as fuzzing found it: every port answers what it documents and keeps
the connection where it should, and the gateway's memory and metrics stay bounded whatever
message types a client invents.

Per port: the motion port gets 2016s with bad group numbers, 2,000 seeded fuzz frames (2016s
whose count, groups and sequence say anything; unknown types; known types cut short), 2017s
and 10,000 unknown types; the I/O port 500 seeded fuzz frames; the state port, which never
reads, 64 KiB of garbage."""

from __future__ import annotations

import random
import struct
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
import zenoh

from motocell.shared.bus.schemas import Decoder, GatewayMetrics
from motocell.shared.protocol.constants import MAX_GROUPS, Command, InvalidSubcode, MsgType, Result
from motocell.shared.protocol.layouts import JOINT_BLOCK, JOINT_BLOCK_SIZE
from motocell.shared.protocol.messages import (
    JointFeedback,
    JointFeedbackEx,
    Message,
    MotoMotionReply,
)
from motocell.shared.protocol.replies import read_io_bit, state_message
from motocell.testing.client import ConnectionClosedError, MotionClient
from motocell.testing.processes import wait_until
from motocell.testing.running_cell import RunningCell

pytestmark = pytest.mark.cell

UNKNOWN_TYPES = range(100_000, 110_000)
"""10,000 distinct types no port knows."""
FLOOD_BATCH = 500
"""Unknown-type frames sent before their replies are read (the socket buffers hold them)."""
MOTION_FRAMES = 2_000
IO_FRAMES = 500
STATE_GARBAGE_BYTES = 64 * 1024
METRICS_LIMIT_BYTES = 2_048
"""The gateway's metrics message holds one entry per known type at most: a few hundred bytes,
whatever types a client invents (docs/behaviour.md, Protocol)."""
RSS_GROWTH_LIMIT_KIB = 16 * 1024
"""10,000 unknown types cost a bounded gateway about 0.1 MiB, an unbounded one about 100 MiB
(docs/behaviour.md, Protocol)."""
FULL_EX = 8 + MAX_GROUPS * JOINT_BLOCK_SIZE
"""2016's body padded to 4 groups."""
IO_REQUEST_SIZES = {2003: 4, 2005: 8, 2007: 4, 2009: 8, 2012: 4, 2013: 8}
I32_EDGES = [2**31 - 1, -(2**31)]
KNOWN_TYPES = frozenset(int(t) for t in MsgType)


def frame(msg_type: int, body: bytes = b"") -> bytes:
    return struct.pack("<4i", 12 + len(body), msg_type, 2, 0) + body


def ex_frame(
    sequence: int, groups: list[int], count: int | None = None, pad: bool = False
) -> bytes:
    """A 2016 listing ``groups`` (well-formed points at 0 rad) with ``count`` (by default the
    number of groups) in its count field."""
    body = struct.pack("<2i", len(groups) if count is None else count, sequence)
    for group in groups:
        body += struct.pack("<" + JOINT_BLOCK, group, 7, 0.1 * sequence, *[0.0] * 30)
    return frame(MsgType.MOTO_JOINT_TRAJ_PT_FULL_EX, body.ljust(FULL_EX, b"\0") if pad else body)


def motion_reply(client: MotionClient, data: bytes) -> MotoMotionReply:
    client.sock.sendall(data)
    reply = client.reader.next()
    assert isinstance(reply, Message) and isinstance(reply.body, MotoMotionReply), reply
    return reply.body


def still_answers(client: MotionClient) -> None:
    assert client.command(Command.CHECK_MOTION_READY).result in (Result.TRUE, Result.FALSE)


@pytest.fixture
def trajectory_mode(motion: MotionClient) -> Iterator[MotionClient]:
    """A motion client of a motion-ready cell, so points are checked past readiness."""
    reply = motion.command(Command.START_TRAJ_MODE)
    assert (reply.result, reply.subcode) == (Result.SUCCESS, 0)
    yield motion
    motion.command(Command.STOP_TRAJ_MODE)


# -- 2016 group numbers ------------------------------------------------------------------------


@pytest.mark.parametrize(
    "groups", [[1], [3], [4], [5], [-1], [I32_EDGES[0]], [I32_EDGES[1]], [0, 0], [1, 0], [0, 4]]
)
def test_2016_with_a_group_the_cell_lacks_is_invalid_3004_and_the_port_goes_on(
    trajectory_mode: MotionClient, groups: list[int]
) -> None:
    reply = motion_reply(trajectory_mode, ex_frame(1, groups))
    assert (reply.result, reply.subcode) == (Result.INVALID, InvalidSubcode.GROUPNO)
    assert (reply.command, reply.sequence) == (MsgType.MOTO_JOINT_TRAJ_PT_FULL_EX, 1)
    assert reply.group_no in groups
    still_answers(trajectory_mode)


# -- seeded fuzz, port by port -----------------------------------------------------------------


@dataclass
class Fuzzed:
    data: bytes
    expected: Callable[[MotoMotionReply], bool]


def fuzzed_ex(rng: random.Random) -> Fuzzed:
    """A 2016 whose count, groups and sequence may each say anything."""
    groups = [rng.choice([0, 1, 2, 4, -1, *I32_EDGES]) for _ in range(rng.randint(0, MAX_GROUPS))]
    count = rng.choice([len(groups), rng.randint(-2, 6), rng.randint(-(2**31), 2**31 - 1)])
    sequence = rng.choice([0, 1, 2, -1, *I32_EDGES])
    return Fuzzed(
        ex_frame(sequence, groups, count, pad=rng.random() < 0.3),
        lambda r: r.command == MsgType.MOTO_JOINT_TRAJ_PT_FULL_EX,
    )


def fuzzed_motion_frame(rng: random.Random) -> Fuzzed:
    """A 2016 as above, an unknown type, or a known type cut short: one reply each."""
    kind = rng.randrange(3)
    if kind == 0:
        return fuzzed_ex(rng)
    if kind == 1:
        unknown = rng.choice([0, 2, 2012, 2013, 777, -5, *I32_EDGES])
        return Fuzzed(
            frame(unknown, rng.randbytes(rng.randrange(64))),
            lambda r: (
                (r.result, r.subcode, r.command)
                == (Result.INVALID, InvalidSubcode.MSGTYPE, unknown)
            ),
        )
    short = rng.choice([14, 2001, 2016, 2018])
    return Fuzzed(
        frame(short, rng.randbytes(rng.randrange(8))),
        lambda r: (r.result, r.subcode) == (Result.INVALID, InvalidSubcode.MSGSIZE),
    )


def test_fuzzed_motion_frames_each_get_one_reply(trajectory_mode: MotionClient) -> None:
    rng = random.Random(13)
    for index in range(MOTION_FRAMES):
        fuzzed = fuzzed_motion_frame(rng)
        reply = motion_reply(trajectory_mode, fuzzed.data)
        assert fuzzed.expected(reply), (index, fuzzed.data.hex(), reply)
    still_answers(trajectory_mode)


@pytest.mark.parametrize("count", [0, 1, 2, 4, 5, -1, *I32_EDGES])
def test_2017_sent_to_the_motion_port_closes_it_without_a_reply(
    motion: MotionClient, count: int
) -> None:
    """motoros1 §2.7: a known size without a handler closes the connection, whatever it says."""
    zeros = (0.0,) * 10
    slots = tuple(JointFeedback(g, 6, 0.0, zeros, zeros, zeros) for g in (0, 1, 5, -1))
    motion.send(state_message(MsgType.MOTO_JOINT_FEEDBACK_EX, JointFeedbackEx(count, slots)))
    motion.sock.sendall(frame(MsgType.PING))
    with pytest.raises((ConnectionClosedError, ConnectionResetError)):
        motion.reader.next()


def test_fuzzed_io_frames_each_get_one_reply(cell: RunningCell) -> None:
    rng = random.Random(13)
    with cell.io() as io:
        for index in range(IO_FRAMES):
            msg_type = rng.choice([*IO_REQUEST_SIZES, 1, 2, 2016, 777])
            well_formed = msg_type in IO_REQUEST_SIZES and rng.random() < 0.7
            size = IO_REQUEST_SIZES[msg_type] if well_formed else rng.randrange(16)
            io.sock.sendall(frame(msg_type, rng.randbytes(size)))
            reply = io.reader.next()
            assert isinstance(reply, Message), (index, reply)
            if not well_formed and size != IO_REQUEST_SIZES.get(msg_type):
                assert isinstance(reply.body, MotoMotionReply), (index, msg_type, size, reply)
                assert reply.body.group_no == Result.INVALID
        assert isinstance(io.request(read_io_bit(10010)), Message)


def test_the_state_port_ignores_what_a_client_writes(cell: RunningCell) -> None:
    """The state server never reads (motoros1 §6): garbage changes nothing for its clients."""
    with cell.state() as state:
        state.wait_for(lambda f: f.status is not None, 10.0)
        state.sock.sendall(random.Random(13).randbytes(STATE_GARBAGE_BYTES))
        sent_ns = time.monotonic_ns()
        state.wait_for(lambda f: f.received_ns > sent_ns and f.status is not None, 10.0)


# -- 10,000 unknown message types --------------------------------------------------------------


def rss_kib(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise AssertionError(f"no VmRSS for {pid}")


class MetricsLog:
    """Every ``gateway/metrics`` sample from now on: its size in bytes and what it says."""

    def __init__(self, bus: zenoh.Session, key: str) -> None:
        self.samples: list[tuple[int, GatewayMetrics]] = []
        self._lock = threading.Lock()
        self._decoder = Decoder(GatewayMetrics)
        self.subscriber = bus.declare_subscriber(key, self._take)

    def _take(self, sample: zenoh.Sample) -> None:
        raw = sample.payload.to_bytes()
        with self._lock:
            self.samples.append((len(raw), self._decoder.decode(raw)))

    def wait_for(
        self, predicate: Callable[[GatewayMetrics], bool], what: str
    ) -> tuple[int, GatewayMetrics]:
        """The first sample that satisfies ``predicate``."""

        def found() -> tuple[int, GatewayMetrics] | None:
            with self._lock:
                return next((s for s in self.samples if predicate(s[1])), None)

        wait_until(lambda: found() is not None, 10.0, what)
        sample = found()
        assert sample is not None
        return sample


def other_count(metrics: GatewayMetrics) -> int:
    """Requests of the types ``MsgType`` does not name (all in the one bucket for them)."""
    return sum(r.count for r in metrics.requests if r.msg_type not in KNOWN_TYPES)


def flood_unknown_types(client: MotionClient) -> None:
    """One frame of each unknown type, pipelined in batches; every one answered 3003."""
    types = list(UNKNOWN_TYPES)
    for start in range(0, len(types), FLOOD_BATCH):
        batch = types[start : start + FLOOD_BATCH]
        client.sock.sendall(b"".join(frame(t) for t in batch))
        for msg_type in batch:
            reply = client.reader.next()
            assert isinstance(reply, Message) and isinstance(reply.body, MotoMotionReply)
            assert (reply.body.command, reply.body.subcode) == (msg_type, InvalidSubcode.MSGTYPE)


def test_10000_unknown_message_types_leave_the_gateway_bounded(
    cell: RunningCell, bus: zenoh.Session, motion: MotionClient
) -> None:
    [pid] = cell.service_pids("gateway")
    metrics = MetricsLog(bus, cell.keys.metrics("gateway"))
    try:
        still_answers(motion)
        before_bytes, before = metrics.wait_for(lambda m: True, "a metrics sample")
        before_kib = rss_kib(pid)
        flood_unknown_types(motion)
        flooded = other_count(before) + len(UNKNOWN_TYPES)
        after_bytes, after = metrics.wait_for(
            lambda m: other_count(m) >= flooded, "the flood counted in the metrics"
        )
        after_kib = rss_kib(pid)
        still_answers(motion)
    finally:
        metrics.subscriber.undeclare()
    print(
        f"\ngateway RSS {before_kib} KiB -> {after_kib} KiB after {len(UNKNOWN_TYPES)} unknown "
        f"types; metrics message {before_bytes} -> {after_bytes} bytes, "
        f"{len(after.requests)} request types"
    )
    assert len(after.requests) <= len(MsgType) + 1
    assert after_bytes < METRICS_LIMIT_BYTES
    assert after_kib - before_kib < RSS_GROWTH_LIMIT_KIB
