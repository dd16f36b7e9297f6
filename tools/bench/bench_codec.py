"""Figure 1: Simple Message codec throughput, decode and encode, in frames per second on one
core.

    python -m motocell.tools.bench.run --only 1 [--quick]

Decoding is timed as the gateway does it: 64 KiB reads fed to ``receive_data``, each drained
with ``next_event``. Each case runs several times; the figure is the median and the spread.
Goal: decoding at DECODE_GOAL frames/s or more.
"""

from __future__ import annotations

import functools
import time
from typing import Any

from motocell.shared.protocol.codec import NEED_DATA, ByteOrder, Role, SimpleMessageCodec
from motocell.shared.protocol.constants import MsgType
from motocell.shared.protocol.messages import JointFeedback, JointFeedbackEx, Message
from motocell.shared.protocol.replies import state_message, traj_point
from motocell.tools.bench.measuring import figure_result

FIGURE = 1
RUNS = 5
FRAMES = 50_000
QUICK_FRAMES = 5_000
READ_SIZE = 65_536
DECODE_GOAL = 200_000.0

JOINTS = (0.5, -1.25, 0.75, 1.5, -0.25, 2.0)
POINT = traj_point(0, 7, 0.5, JOINTS, JOINTS, accelerations=JOINTS)


def feedback_ex(groups: int) -> Message:
    """A MOTO_JOINT_FEEDBACK_EX as a cell with ``groups`` groups sends it (unused slots zero)."""
    slots = tuple(JointFeedback(g, 6, 0.0, JOINTS, JOINTS, ()) for g in range(groups))
    return state_message(MsgType.MOTO_JOINT_FEEDBACK_EX, JointFeedbackEx(groups, slots))


# (name, message, the role that sends it)
CASES: list[tuple[str, Message, Role]] = [
    ("JOINT_TRAJ_PT_FULL (14)", POINT, Role.CLIENT),
    ("JOINT_FEEDBACK_EX (2017), 2 groups", feedback_ex(2), Role.CONTROLLER),
    ("JOINT_FEEDBACK_EX (2017), 4 groups", feedback_ex(4), Role.CONTROLLER),
]


def peer(role: Role) -> Role:
    return Role.CONTROLLER if role is Role.CLIENT else Role.CLIENT


def decode_rate(message: Message, sender: Role, order: ByteOrder, frames: int) -> float:
    data = SimpleMessageCodec(sender, order).send(message) * frames
    reads = [data[at : at + READ_SIZE] for at in range(0, len(data), READ_SIZE)]
    codec = SimpleMessageCodec(peer(sender), order)
    decoded = 0
    start = time.perf_counter()
    for read in reads:
        codec.receive_data(read)
        while codec.next_event() is not NEED_DATA:
            decoded += 1
    elapsed = time.perf_counter() - start
    assert decoded == frames
    return frames / elapsed


def encode_rate(message: Message, sender: Role, order: ByteOrder, frames: int) -> float:
    send = SimpleMessageCodec(sender, order).send
    start = time.perf_counter()
    for _ in range(frames):
        send(message)
    return frames / (time.perf_counter() - start)


def run(quick: bool) -> list[dict[str, Any]]:
    frames = QUICK_FRAMES if quick else FRAMES
    order = ByteOrder.LITTLE
    results = []
    for name, message, sender in CASES:
        for operation, rate in (("decode", decode_rate), ("encode", encode_rate)):
            once = functools.partial(rate, message, sender, order, frames)
            goal = (">=", DECODE_GOAL) if operation == "decode" else None
            rates = [once() for _ in range(RUNS)]
            title = f"{operation} {name}, {order.value}-endian"
            results.append(figure_result(FIGURE, title, "frames/s", rates, goal=goal))
    return results
