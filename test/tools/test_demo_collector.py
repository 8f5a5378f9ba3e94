"""The demo's collector (robot_control.tools.demo_ros.Collector) keeps every sample of a run whose ticks come
faster than the demo's Python thread takes them: DDS's threads hold them in the reader's history, deep
enough (demo_ros.DEPTH, with the readers' room of robot_control/ros/fastdds_profile.xml) for the backlog of a
lockstep run on a busy machine. RunControl re-sends a service request that got no answer."""
import time

import pytest
from rclpy.node import Node
from sensor_msgs.msg import JointState

from robot_control.ros.qos import CONTROL_PUB_QOS
from robot_control.ros.spin import make_executor
from robot_control.tools import demo_ros

#: samples published while the collector is not spun: more than Fast DDS's default 5000 a reader would keep
BACKLOG = 30000
#: published in bursts of BURST, PAUSE s apart: the pace of a lockstep loop, which DDS's threads keep up with
BURST, PAUSE = 1000, 0.05


def test_the_collector_keeps_a_backlog_of_30000_ticks_published_while_it_was_not_spun(ros_context):
    executor = make_executor('events', context=ros_context)
    collector = demo_ros.Collector(ros_context, executor, name='collector_backlog')
    node = Node('bridge_stand_in', context=ros_context)
    pub = node.create_publisher(JointState, '/joint_states', CONTROL_PUB_QOS)
    try:
        deadline = time.monotonic() + 30.0
        while pub.get_subscription_count() < 1 and time.monotonic() < deadline:
            executor.spin_once(0.05)
        assert pub.get_subscription_count() == 1, 'the collector did not match the publisher within 30 s'
        msg = JointState(name=['j'], position=[0.0], velocity=[0.0], effort=[0.0])
        for k in range(BACKLOG):
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(k * 1_000_000, 1_000_000_000)
            pub.publish(msg)
            if k % BURST == BURST - 1:
                time.sleep(PAUSE)
        deadline = time.monotonic() + 120.0
        while collector.count('/joint_states') < BACKLOG and time.monotonic() < deadline:
            executor.spin_once(0.05)
        assert collector.count('/joint_states') == BACKLOG
        stamps = collector.last_stamps_ns('/joint_states', BACKLOG)
        assert stamps == [k * 1_000_000 for k in range(BACKLOG)], 'samples lost or out of order'
    finally:
        executor.shutdown()
        collector.destroy()
        node.destroy_node()


def test_an_unanswered_request_is_sent_again_until_one_is_answered(ros_context):
    """RunControl's service calls (pause, bridge parameters) re-send an idempotent request that got no answer
    within `retry` s (a response lost to the service discovery race), forget the unanswered one, and give the
    first answer; with none by `timeout`, TimeoutError naming what it waited for."""
    from rclpy.task import Future
    control = demo_ros.RunControl(ros_context, make_executor(context=ros_context), name='retry_test')
    try:
        sent, dropped = [], []

        def send():
            future = Future()
            if len(sent) == 2:                  # the third request is answered
                future.set_result('answer')
            sent.append(future)
            return future
        assert control._answer(send, 5.0, None, 'the answer', drop=dropped.append, retry=0.05) == 'answer'
        assert len(sent) == 3 and dropped == sent[:2]
        with pytest.raises(TimeoutError, match='^timed out after 0.2 s waiting for nothing$'):
            control._answer(Future, 0.2, None, 'nothing', retry=0.05)
    finally:
        control.node.destroy_node()
