"""Raw subscriptions with MessageInfo (robot_control.tools.taps) under both rclpy executors, over real DDS.

A publisher and a Tap live in one fresh context; every message must come back serialized, in order,
with its publication and reception times, whichever executor spins the node: SingleThreadedExecutor
calls a two-argument callback with (msg, info), rclpy 7.1's EventsExecutor with one (msg, info) tuple.
"""
import time

import pytest
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState

from robot_control.ros.spin import make_executor
from robot_control.tools.taps import Tap, WithMessageInfo, spin_for, spin_until_idle

QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE)


def joint_state(i):
    msg = JointState()
    msg.header.stamp.sec, msg.header.stamp.nanosec = i, 1000 * i
    msg.name = ['a']
    msg.position = [0.5 * i]
    return msg


@pytest.fixture(params=['single', 'events'])
def rig(request, ros_context):
    node = Node('taps_test', namespace=f'/taps_{request.param}', context=ros_context)
    executor = make_executor(request.param, context=ros_context)
    executor.add_node(node)
    try:
        yield node, executor
    finally:
        executor.shutdown()
        node.destroy_node()


def _matched(executor, pub, timeout=30.0):
    deadline = time.monotonic() + timeout
    while pub.get_subscription_count() < 1 and time.monotonic() < deadline:
        spin_for(executor, 0.01)
    return pub.get_subscription_count() >= 1


def test_tap_keeps_each_message_with_its_publication_and_reception_time(rig):
    node, executor = rig
    tap = Tap(node, {'states': JointState}, QOS)
    pub = node.create_publisher(JointState, 'states', QOS)
    assert _matched(executor, pub) and tap.publishers('states') == 1
    t0 = time.time_ns()
    for i in range(50):
        pub.publish(joint_state(i))
    t1 = time.time_ns()
    deadline = time.monotonic() + 30.0
    while tap.count() < 50 and time.monotonic() < deadline:
        spin_for(executor, 0.01)
    rows = tap.pop('states')
    assert [deserialize_message(data, JointState) for data, _, _ in rows] == [joint_state(i) for i in range(50)]
    for _, source, received in rows:
        assert t0 <= source <= t1 and source <= received <= time.time_ns()
    assert tap.count('states') == 0 and tap.pop('states') == []


def test_spin_until_idle_hands_over_what_dds_delivered(rig):
    """Messages that arrived while nobody spun come out in one call; it returns once nothing more comes."""
    node, executor = rig
    tap = Tap(node, {'states': JointState}, QOS)
    pub = node.create_publisher(JointState, 'states', QOS)
    assert _matched(executor, pub)
    for i in range(300):
        pub.publish(joint_state(i))
    assert pub.wait_for_all_acked(Duration(seconds=30))     # delivered by DDS (acknowledged), not handed over
    assert tap.count() == 0                                 # nothing spins
    limit = 30.0                         # generous: a busy machine hands them over more slowly
    t0 = time.monotonic()
    spin_until_idle(executor, tap.count, limit=limit)
    assert tap.count('states') == 300
    assert time.monotonic() - t0 < limit                    # it returned once idle, not at its limit


def test_a_callback_gets_the_message_info_under_either_calling_convention():
    got = []
    callback = WithMessageInfo(lambda msg, info: got.append((msg, info['received_timestamp'])))
    callback('m1', {'received_timestamp': 1})          # SingleThreadedExecutor: callback(msg, info)
    callback(('m2', {'received_timestamp': 2}))        # rclpy 7.1 EventsExecutor: callback((msg, info))
    assert got == [('m1', 1), ('m2', 2)]
