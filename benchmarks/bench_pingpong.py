"""The transport floor of benchmark B2: a bare rclpy ping-pong between two processes.

    python -m benchmarks.bench_pingpong ping --joints theta1 r [--executor events] [--ros-args ...]
    python -m benchmarks.bench_pingpong pong --joints theta1 r [--executor single] [--ros-args ...]

Same messages, topics, QoS (the nodes' publisher and subscription profiles) and stamps as the
lockstep loop, nothing else: `ping` plays the bridge (publishes sensor_msgs/JointState on
`joint_states` stamped k * period and publishes the next one when the `robot_joint_commands`
answer stamped k arrives; re-publishes after 0.1 s without an answer, for discovery), `pong`
plays the controller (answers each state with a JointState of names and efforts carrying the
state's stamp). Messages are preallocated; both ends use rclpy's own message conversion.
"""
import argparse
import sys
import time

import rclpy
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from sensor_msgs.msg import JointState

from robot_control import units
from robot_control.ros import spin
from robot_control.ros.qos import CONTROL_PUB_QOS, CONTROL_QOS

NS = units.NS_PER_S
REPUBLISH_S = 0.1


def _joint_state(names, fields):
    msg = JointState()
    msg.name = list(names)
    for field in fields:
        setattr(msg, field, [0.0] * len(names))
    return msg


class Ping(Node):
    """Publishes state k, waits for the answer stamped k, publishes state k + 1."""

    def __init__(self, joints, period_ns):
        super().__init__('pingpong_ping')
        self._period_ns = period_ns
        self._state = _joint_state(joints, ('position', 'velocity', 'effort'))
        self._expected = 0
        self._pub = self.create_publisher(JointState, 'joint_states', CONTROL_PUB_QOS)
        self.create_subscription(JointState, 'robot_joint_commands', self._on_answer, CONTROL_QOS)
        self._last_pub_ns = 0
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(REPUBLISH_S / 4.0, self._on_timer, clock=steady)
        self._publish()

    def _publish(self):
        stamp = self._state.header.stamp
        stamp.sec, stamp.nanosec = divmod(self._expected, NS)
        self._pub.publish(self._state)
        self._last_pub_ns = time.monotonic_ns()

    def _on_answer(self, msg):
        stamp = msg.header.stamp
        if stamp.sec * NS + stamp.nanosec == self._expected:
            self._expected += self._period_ns
            self._publish()

    def _on_timer(self):
        if time.monotonic_ns() - self._last_pub_ns >= REPUBLISH_S * NS:
            self._publish()


class Pong(Node):
    """Answers every state with a command of names and efforts carrying the state's stamp."""

    def __init__(self, joints):
        super().__init__('pingpong_pong')
        self._command = _joint_state(joints, ('effort',))
        self._pub = self.create_publisher(JointState, 'robot_joint_commands', CONTROL_PUB_QOS)
        self.create_subscription(JointState, 'joint_states', self._on_state, CONTROL_QOS)

    def _on_state(self, msg):
        self._command.header.stamp = msg.header.stamp
        self._pub.publish(self._command)


def parse_args(argv):
    parser = argparse.ArgumentParser(prog='python -m benchmarks.bench_pingpong', description=__doc__.split('\n')[0])
    parser.add_argument('role', choices=('ping', 'pong'))
    parser.add_argument('--joints', nargs='+', required=True, help='joint names in the messages')
    parser.add_argument('--executor', choices=('single', 'events'), default='single')
    parser.add_argument('--period', type=float, default=0.001, help='ping: stamp increment, s')
    return parser.parse_args(argv)


def main(args=None):
    argv = sys.argv if args is None else args
    opts = parse_args(rclpy.utilities.remove_ros_args(argv)[1:])
    if opts.role == 'ping':
        return spin.run_node(argv, lambda: Ping(opts.joints, round(opts.period * NS)), opts.executor)
    return spin.run_node(argv, lambda: Pong(opts.joints), opts.executor)


if __name__ == '__main__':
    sys.exit(main())
