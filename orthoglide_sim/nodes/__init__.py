"""The simulator's ROS 2 nodes: the Orthoglide driver, the ros2_control stand-in, its trajectory
action."""
