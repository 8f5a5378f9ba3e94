"""Test fixtures: DDS stays on loopback, on a domain id private to this test run."""
import os
import sys

import pytest
from hypothesis import settings

# Property tests: reproducible (derandomized, no example database) and no wall-clock deadline,
# which a loaded 2-core CI machine would turn into flakes. Examples per test stay as each sets.
settings.register_profile('robot_control', deadline=None, derandomize=True, database=None)
settings.load_profile('robot_control')

# Before anything imports rclpy: never let discovery leave this machine.
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
# 1..70: clear of the ids that tests claim or fix for their own processes (end-to-end runs 71-80,
# robustness 81-92, two hosts 93-100, your own arm 98-99), so another suite running on this machine at the
# same time cannot talk to them
os.environ.setdefault('ROS_DOMAIN_ID', str(1 + os.getpid() % 70))
os.environ.pop('ROS_STATIC_PEERS', None)

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
for path in (ROOT, HERE):   # the package under test, and the shared helpers beside this file
    if path not in sys.path:
        sys.path.insert(0, path)

# The nodes' Fast DDS settings (non-blocking UDP, writers' heartbeat, readers' room) for every participant of this
# process, as the nodes' main() and the demo apply them: Fast DDS reads them with the process's first participant.
from robot_control.ros import dds  # noqa: E402
dds.apply_defaults()


@pytest.fixture
def ros_context():
    """A fresh rclpy context for one test, shut down afterwards."""
    import rclpy
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    try:
        yield ctx
    finally:
        rclpy.try_shutdown(context=ctx)
