"""What the ROS 2 face needs besides its service: whether ROS 2 is installed, and its interfaces."""
