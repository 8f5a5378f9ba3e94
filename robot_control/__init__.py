"""robot_control: the lecture's robot control laws as a ROS 2 Jazzy package.

The library layer (models, laws, gains, trajectory) imports no rclpy and no message package.
"""
__version__ = '0.1.0'
