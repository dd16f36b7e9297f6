"""One ROS 2 client of a cell's face in its own process: figure 12's subscriber to ``joint_states``.

  python -m motocell.tools.bench.ros2_client --domain D --namespace /NS --period-ms 10 \
      --seconds S --out OUT.npz

A lean rclpy subscriber (FastDDS, discovery on this host only), so that what it measures is the
face and not itself: one subscription to ``joint_states`` with MotoROS2's sensor_data QoS, spun
in the main thread; the callback stamps CLOCK_REALTIME first (the clock ROS stamps are on) and
CLOCK_MONOTONIC (the clock of the benchmark's windows), and stores each message in numpy
columns allocated up front for ``--seconds`` at the face's rate plus a quarter
(``recording.Columns``); later messages are counted, not stored. The garbage collector is off
once subscribed (``freeze_gc``). It prints ``ready`` at the first message, records until a line
or the end of stdin, and writes to OUT.npz:

- ``received_ns``: CLOCK_REALTIME when the callback began;
- ``received_mono_ns``: CLOCK_MONOTONIC just after;
- ``stamp_ns``: the message's ``header.stamp``;
- ``fresh``: 1 when its positions differ from the previous message's (a new tick's sample,
  stamped with the tick's time), 0 when they repeat them (the face holding its newest sample,
  stamped at publication, or a robot at rest);
- ``dropped``: messages past the capacity.
"""

from __future__ import annotations

import argparse
import math
import os
import time
from typing import Any

import numpy as np
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import JointState

from motocell.tools.bench.recording import (
    Columns,
    StdinControl,
    freeze_gc,
    report,
    take_the_cells_priority,
)

HEADROOM = 1.25
"""Rows beyond the nominal rate: a face that publishes faster than configured is still recorded."""
SPIN_S = 0.1
"""How long one spin waits for a message before stdin is looked at again."""
START_TIMEOUT_S = 30.0
COLUMNS = ("received_ns", "received_mono_ns", "stamp_ns", "fresh")


def capacity(seconds: float, period_ms: float) -> int:
    return math.ceil(seconds * 1000.0 / period_ms * HEADROOM) + 100


class JointStatesRecorder:
    """The subscription's callback: one row per message."""

    def __init__(self, rows: int) -> None:
        self.columns = Columns(rows, COLUMNS)
        self._previous: Any = None

    def __call__(self, message: JointState) -> None:
        received_ns = time.time_ns()
        received_mono_ns = time.monotonic_ns()
        stamp = message.header.stamp
        position = message.position
        fresh = int(position != self._previous)
        self._previous = position
        self.columns.add(
            received_ns, received_mono_ns, stamp.sec * 1_000_000_000 + stamp.nanosec, fresh
        )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--domain", type=int, required=True)
    parser.add_argument("--namespace", required=True)
    parser.add_argument("--period-ms", type=float, required=True, help="the face's period")
    parser.add_argument("--seconds", type=float, required=True, help="the longest recording")
    parser.add_argument("--out", required=True)
    args = parser.parse_args(argv)
    # Read by the RMW when rclpy starts: this client sees the face on this host only.
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    take_the_cells_priority()
    recorder = JointStatesRecorder(capacity(args.seconds, args.period_ms))
    context = Context()
    rclpy.init(
        context=context, domain_id=args.domain, signal_handler_options=SignalHandlerOptions.NO
    )
    node = Node(
        "bench_joint_states",
        namespace=args.namespace,
        context=context,
        enable_rosout=False,
        start_parameter_services=False,
    )
    node.create_subscription(JointState, "joint_states", recorder, qos_profile_sensor_data)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    control = StdinControl()
    deadline = time.monotonic() + START_TIMEOUT_S
    while recorder.columns.rows == 0 and time.monotonic() < deadline and not control.pending():
        executor.spin_once(timeout_sec=SPIN_S)
    if recorder.columns.rows == 0:
        report("error: no joint_states message")
        return
    freeze_gc()
    report("ready")
    while not control.pending():
        executor.spin_once(timeout_sec=SPIN_S)
    columns: dict[str, Any] = dict(recorder.columns.arrays())
    columns["dropped"] = np.int64(recorder.columns.dropped)
    np.savez(args.out, allow_pickle=False, **columns)
    executor.shutdown()
    node.destroy_node()
    rclpy.shutdown(context=context)


if __name__ == "__main__":
    main()
