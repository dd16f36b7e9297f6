"""The floor under the ROS 2 face's cost: what rclpy alone spends to publish figure 12's
``joint_states`` (the four-group cell's 15 joints) every 10 ms to one reader, with nothing of
motocell around it.

    python -m motocell.tools.bench.ros2_floor [--seconds 10]

The reader is figure 12's own subscriber (``tools.bench.ros2_client``, a process of its own);
this process publishes from its main thread, sleeping between messages as the face does, each
message packed as the face packs it (``services.ros2.core.joint_state_cdr``: CDR bytes, which
rclpy sends as they are), and prints its CPU (every thread: rclpy's and FastDDS's) per message,
spaced and back to back. The difference between the two is what a message costs a process that
wakes for it.
"""

from __future__ import annotations

import argparse
import os
import random
import select
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import rclpy
from rclpy.context import Context
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import JointState

from motocell.services.ros2.core.joint_state_cdr import JointStateCdr
from motocell.tools.bench.ros2_client import START_TIMEOUT_S

PERIOD_S = 0.01
JOINTS = 15
"""Figure 12's cell: two 6-axis arms, a track and a two-axis positioner."""
BACK_TO_BACK = 2000


def cpu_per_message_us(publish: Callable[[], None], count: int, period_s: float) -> float:
    """This process's CPU per call of ``publish`` over ``count`` calls ``period_s`` apart."""
    started = time.process_time()
    for _ in range(count):
        publish()
        if period_s:
            time.sleep(period_s)
    return (time.process_time() - started) / count * 1e6


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=10.0)
    args = parser.parse_args(argv)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    domain, namespace = random.randrange(1, 101), f"/floor{os.getpid()}"
    context = Context()
    rclpy.init(context=context, domain_id=domain, signal_handler_options=SignalHandlerOptions.NO)
    node = Node("floor", namespace=namespace, context=context, enable_rosout=False)
    publisher = node.create_publisher(JointState, "joint_states", qos_profile_sensor_data)
    layout = JointStateCdr([f"joint_{index}" for index in range(JOINTS)])
    positions, velocities = (0.1,) * JOINTS, (0.0,) * JOINTS

    def publish() -> None:
        stamp = divmod(time.time_ns(), 10**9)
        publisher.publish(layout.encode(stamp, positions, velocities))

    with tempfile.TemporaryDirectory() as directory:
        options = ["--domain", str(domain), "--namespace", namespace, "--period-ms", "10"]
        options += ["--seconds", str(args.seconds * 2), "--out", str(Path(directory) / "x.npz")]
        reader = subprocess.Popen(
            [sys.executable, "-m", "motocell.tools.bench.ros2_client", *options],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
        )
        assert reader.stdin is not None and reader.stdout is not None
        try:
            # The reader says "ready" at its first message: publish until it does.
            deadline = time.monotonic() + START_TIMEOUT_S
            while not select.select([reader.stdout], [], [], PERIOD_S)[0]:
                if time.monotonic() > deadline:
                    raise SystemExit("ros2_floor: the reader got no message")
                publish()
            spaced = cpu_per_message_us(publish, round(args.seconds / PERIOD_S), PERIOD_S)
            packed = cpu_per_message_us(publish, BACK_TO_BACK, 0.0)
        finally:
            reader.stdin.close()
            reader.wait(START_TIMEOUT_S)
            reader.stdout.close()
    print(
        f"rclpy alone, {JOINTS}-joint JointState as CDR bytes to one reader: "
        f"{spaced:.0f} us CPU a message "
        f"every {PERIOD_S * 1000:.0f} ms ({spaced / PERIOD_S / 1e4:.1f} % of one core), "
        f"{packed:.0f} us back to back"
    )
    node.destroy_node()
    rclpy.shutdown(context=context)
    sys.exit(0)


if __name__ == "__main__":
    main()
