"""The demos (`make demo`, `demo-offline`, `demo-ros2-control`, `demo-excite`) and the graph they
start."""
