"""Numerical identification pipeline (paper Sects. 3-4). Never imports rclpy."""
