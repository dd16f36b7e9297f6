"""Simple Message codec throughput: decode and encode, in frames per second on one core.

    python -m motocell.tools.bench.bench_codec [--quick] [--runs N] [--big-endian]

Decoding is timed as the gateway does it: 64 KiB reads fed to ``receive_data``, each drained
with ``next_event``. Each case runs several times; the table shows the median and the spread.
"""

from __future__ import annotations

import argparse
import functools
import json
import platform
import statistics
import time
from collections.abc import Callable
from typing import Any

from motocell.shared.protocol.codec import NEED_DATA, ByteOrder, Role, SimpleMessageCodec
from motocell.shared.protocol.constants import MsgType
from motocell.shared.protocol.messages import JointFeedback, JointFeedbackEx, Message
from motocell.shared.protocol.replies import state_message, traj_point
from motocell.tools.bench.measuring import RESULTS_DIR

RUNS = 5
FRAMES = 50_000
QUICK_FRAMES = 5_000
READ_SIZE = 65_536
RESULTS_FILE = RESULTS_DIR / "codec.json"

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


def measure(name: str, runs: int, once: Callable[[], float]) -> dict[str, Any]:
    rates = [once() for _ in range(runs)]
    return {
        "name": name,
        "unit": "frames/s",
        "median": statistics.median(rates),
        "min": min(rates),
        "max": max(rates),
        "runs": rates,
    }


def run(
    quick: bool, runs: int = RUNS, orders: tuple[ByteOrder, ...] = (ByteOrder.LITTLE,)
) -> list[dict[str, Any]]:
    frames = QUICK_FRAMES if quick else FRAMES
    results = []
    for order in orders:
        for name, message, sender in CASES:
            for operation, rate in (("decode", decode_rate), ("encode", encode_rate)):
                once = functools.partial(rate, message, sender, order, frames)
                results.append(measure(f"{operation} {name}, {order.value}-endian", runs, once))
    return results


def table(results: list[dict[str, Any]]) -> str:
    width = max(len(r["name"]) for r in results)
    lines = [f"{'case':<{width}}  {'median':>10}  {'min - max':>21}  frames/s"]
    for r in results:
        spread = f"{r['min']:,.0f} - {r['max']:,.0f}"
        lines.append(f"{r['name']:<{width}}  {r['median']:>10,.0f}  {spread:>21}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="Simple Message codec throughput")
    parser.add_argument("--quick", action="store_true", help=f"{QUICK_FRAMES} frames per run")
    parser.add_argument("--runs", type=int, default=RUNS, help="runs per case (default 5)")
    parser.add_argument("--big-endian", action="store_true", help="also time FS100 byte order")
    args = parser.parse_args(argv)
    orders = (ByteOrder.LITTLE, ByteOrder.BIG) if args.big_endian else (ByteOrder.LITTLE,)
    results = run(args.quick, args.runs, orders)
    print(table(results))
    RESULTS_FILE.parent.mkdir(parents=True, exist_ok=True)
    report = {
        "python": platform.python_version(),
        "machine": platform.machine(),
        "results": results,
    }
    RESULTS_FILE.write_text(json.dumps(report, indent=2) + "\n")
    print(f"written to {RESULTS_FILE}")


if __name__ == "__main__":
    main()
