"""What the ROS 2 face needs outside its own process: whether the ``ros2`` extra is installed
(``extra``), and the interface packages PyPI lacks, built with rosidl (``interfaces``). Nothing
here imports rclpy at module level, so motocell imports and type-checks without it."""
