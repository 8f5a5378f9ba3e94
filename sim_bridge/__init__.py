"""sim_bridge: a PyBullet world for every lecture system (world.py, no rclpy) and its ROS 2 node."""
