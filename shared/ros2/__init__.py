"""ROS 2 (the ``ros2`` extra): nothing here imports rclpy at module level, so motocell imports
and type-checks without it."""
