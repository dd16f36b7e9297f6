"""The ROS 2 face: MotoROS2's ROS 2 API from an rclpy node of the cell (docs/ros2.md)."""
