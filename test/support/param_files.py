"""ROS parameter files (config/*.yaml) as flat dicts."""
from robot_control.param_table import flatten  # noqa: F401
