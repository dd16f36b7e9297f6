"""The ROS 2 face: MotoROS2's ROS 2 API from an rclpy node of the cell (docs/ros2.md).

Wiring only: ``core`` decides what to publish and when, ``loop`` runs the thread that carries a
state sample to the topics, ``bus`` feeds it the cell's ``state``, and ``node`` is the rclpy
node. ROS 2 is an extra: without it the face says in one line what to install.
"""

from __future__ import annotations

import logging
import os
import sys
from collections.abc import Sequence

from motocell.services.ros2.bus import StateFeed, ZenohBus
from motocell.services.ros2.core.face import Face
from motocell.services.ros2.core.point_queue import Modes
from motocell.services.ros2.core.topics import names_by_group
from motocell.services.ros2.goal_runner import GoalRunner
from motocell.services.ros2.loop import FaceLoop
from motocell.services.ros2.motion_api import MotionApi
from motocell.services.ros2.motoros2_services import Motoros2Services
from motocell.shared.config import EXIT_CONFIG
from motocell.shared.protocol.codec import ByteOrder
from motocell.shared.ros2.extra import missing_ros2
from motocell.shared.ros2.interfaces import BuildError, NotInstalledError, ensure
from motocell.shared.running_service import running_service
from motocell.shared.service import argument_parser

log = logging.getLogger("ros2")

AMENT_PREFIX_PATH = "AMENT_PREFIX_PATH"


def main(argv: Sequence[str] | None = None) -> None:
    parser = argument_parser("ros2", "MotoROS2's ROS 2 API from an rclpy node of the cell.")
    args = parser.parse_args(argv)
    missing = missing_ros2()
    if missing is not None:
        print(f"motocell ros2/0: {missing}", file=sys.stderr)
        raise SystemExit(EXIT_CONFIG)
    with_interfaces()
    # Only now, so that a missing extra is the one line above, not an ImportError.
    from motocell.services.ros2.node import FaceNode  # noqa: PLC0415

    with running_service("ros2", "0", args) as ctx:
        cell = ctx.cell
        face = cell.ros2
        if face is None:  # running_service refuses a service the cell lacks
            raise SystemExit(EXIT_CONFIG)
        bus = ZenohBus(ctx.session)
        motion = MotionApi(bus, ctx.keys, ByteOrder(cell.byte_order))
        decisions = Face(cell, face)
        feedback_ns = face.update_periods.action_feedback_publisher_period * 1_000_000
        runner = GoalRunner(motion, decisions.newest, cell.groups, feedback_ns)
        modes = Modes(names_by_group(cell, face))
        services = Motoros2Services(motion, cell.groups, modes)
        feed = StateFeed(bus, ctx.keys, ctx.stop)
        node = FaceNode(cell, face, services, runner, decisions.newest, readers_changed=feed.ring)
        log.info(
            "node %s%s on ROS domain %d (discovery %s)",
            face.node_namespace.rstrip("/") + "/" if face.node_namespace else "/",
            face.node_name,
            face.ros_domain_id,
            "beyond this host" if face.open_discovery else "this host only",
        )
        if face.open_discovery:
            log.warning(
                "ROS 2 discovery reaches beyond this host (open_discovery): any ROS 2 node "
                "that sees this face can move the robot"
            )
        feed.start()
        node.start()
        ctx.alive.announce()
        try:
            FaceLoop(decisions, feed, node).run(ctx.stop)
        finally:
            ctx.stop.set()  # on an error too: it ends the waker
            feed.close()
            node.close()


def with_interfaces() -> None:
    """Go on in a process that has the interface packages PyPI lacks: built (once, cached) and
    in its environment from its start, since the loader reads LD_LIBRARY_PATH only then. The
    first time this process starts itself again, once."""
    try:
        interfaces, built = ensure()
    except (NotInstalledError, BuildError) as error:
        print(f"motocell ros2/0: the ROS 2 interfaces: {error}", file=sys.stderr)
        raise SystemExit(EXIT_CONFIG) from None
    if built:
        print(
            f"motocell ros2/0: built the ROS 2 interfaces in {interfaces.prefix}", file=sys.stderr
        )
    environment = interfaces.environment()
    if os.environ.get(AMENT_PREFIX_PATH) != environment[AMENT_PREFIX_PATH]:
        os.execve(sys.executable, sys.orig_argv, environment)


if __name__ == "__main__":
    main()
