"""Whether ROS 2 (the ``ros2`` extra) is installed here, told without importing it."""

from __future__ import annotations

import importlib.util

INSTALL = "pip install 'motocell[ros2]'"


def missing_ros2() -> str | None:
    """Why the ROS 2 face cannot run here, in words that say what to install; None if it can."""
    if importlib.util.find_spec("rclpy") is None:
        return f"ROS 2 is not installed here; {INSTALL}"
    return None
