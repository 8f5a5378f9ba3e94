"""The transport floors of benchmarks B2 and B3: bare rclpy exchanges between two processes.

    python -m benchmarks.bench_pingpong ping --joints theta1 r [--executor events] [--ros-args ...]
    python -m benchmarks.bench_pingpong pong --joints theta1 r [--executor single] [--ros-args ...]
    python -m benchmarks.bench_pingpong tick --joints a b c [--period 0.001] [--executor events] [--wrench]
    python -m benchmarks.bench_pingpong echo --joints a b c [--executor events] [--wrench]

B2 (lockstep), `ping` and `pong`:
Same messages, topics, QoS (the nodes' publisher and subscription profiles) and stamps as the
lockstep loop, nothing else: `ping` plays the bridge (publishes sensor_msgs/JointState on
`joint_states` stamped k * period and publishes the next one when the `robot_joint_commands`
answer stamped k arrives; re-publishes after 0.1 s without an answer, for discovery), `pong`
plays the controller (answers each state with a JointState of names and efforts carrying the
state's stamp). Messages are preallocated; both ends use rclpy's own message conversion.

B3 (real time), `tick` and `echo`: the bridge's real-time loop and the controller without physics and
without a law. `tick` paces as the bridge does (sim_bridge.pacing.RealtimePacer, a steady timer of one
period restarted when the pacing is anchored, every due tick run at once) and on each tick publishes the
state stamped k * period on `joint_states`; it reads the answers on `robot_joint_commands` and sends
their efforts back as the state's efforts. `echo` answers each state with a command of efforts carrying
the state's stamp. Both write and read the messages as serialized bytes with robot_control.ros.cdr, as
the bridge and the controller do, with the same topics and QoS. With `--wrench` both also carry the force
stream of a law that reads the measured force (hybrid control): `tick` publishes a
geometry_msgs/WrenchStamped (zeros) on `ft_sensor/wrench`, stamped like the state and published just before
it, as the bridge does; `echo` subscribes to it and decodes each one, as the controller does.
"""
import argparse
import sys
import time

import rclpy
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from geometry_msgs.msg import WrenchStamped
from sensor_msgs.msg import JointState

from robot_control import units
from robot_control.ros import cdr, spin
from robot_control.ros.qos import CONTROL_PUB_QOS, CONTROL_QOS
from sim_bridge.pacing import RealtimePacer

NS = units.NS_PER_S
REPUBLISH_S = 0.1
ZERO3 = (0.0, 0.0, 0.0)


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


class Tick(Node):
    """Publishes the state of every tick that falls due at 1 / period per second of the steady clock (after
    the tick's wrench when `wrench`)."""

    def __init__(self, joints, period_ns, wrench=False):
        super().__init__('floor_tick')
        self._period_ns = period_ns
        self._ticks = 0
        self._encoder = cdr.JointStateEncoder(joints)
        self._decoder = cdr.JointStateDecoder(arrays=False)
        self._zeros = [0.0] * len(joints)
        self._effort = self._zeros
        self._pacer = RealtimePacer(period_ns)
        self._pub = self.create_publisher(JointState, 'joint_states', CONTROL_PUB_QOS)
        self._wrench = cdr.WrenchEncoder() if wrench else None
        self._pub_wrench = self.create_publisher(WrenchStamped, 'ft_sensor/wrench', CONTROL_PUB_QOS) if wrench else None
        self.create_subscription(JointState, 'robot_joint_commands', self._on_command, CONTROL_QOS, raw=True)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        # as the bridge: one period of wall time, no faster than 2 kHz; restarted when pacing is anchored
        self._timer = self.create_timer(max(period_ns / NS, 0.0005), self._on_timer, clock=steady)
        self._publish()
        self._pacer.anchor(time.monotonic_ns(), 0)
        self._timer.reset()

    def _publish(self):
        stamp_ns = self._ticks * self._period_ns
        if self._wrench is not None:
            self._pub_wrench.publish(self._wrench.encode(stamp_ns, ZERO3, ZERO3))
        self._pub.publish(self._encoder.encode(stamp_ns, self._zeros, self._zeros, self._effort))

    def _on_command(self, data):
        msg = self._decoder.decode(data)
        if msg is not None and len(msg.effort) == len(self._zeros):
            self._effort = msg.effort

    def _on_timer(self):
        for _ in range(self._pacer.due(time.monotonic_ns(), self._ticks)):
            self._ticks += 1
            self._publish()


class Echo(Node):
    """Answers every state with a command of efforts (zeros) carrying the state's stamp; decodes each wrench
    when `wrench`."""

    def __init__(self, joints, wrench=False):
        super().__init__('floor_echo')
        self._decoder = cdr.JointStateDecoder(arrays=False)
        self._encoder = cdr.JointStateEncoder(joints, fields=('effort',))
        self._effort = [0.0] * len(joints)
        self._pub = self.create_publisher(JointState, 'robot_joint_commands', CONTROL_PUB_QOS)
        self.create_subscription(JointState, 'joint_states', self._on_state, CONTROL_QOS, raw=True)
        if wrench:
            self.create_subscription(WrenchStamped, 'ft_sensor/wrench', cdr.decode_wrench, CONTROL_QOS, raw=True)

    def _on_state(self, data):
        msg = self._decoder.decode(data)
        if msg is not None:
            stamp = msg.header.stamp
            self._pub.publish(self._encoder.encode(stamp.sec * NS + stamp.nanosec, effort=self._effort))


#: role -> the node it runs, from the parsed options
ROLES = {'ping': lambda o: Ping(o.joints, round(o.period * NS)), 'pong': lambda o: Pong(o.joints),
         'tick': lambda o: Tick(o.joints, round(o.period * NS), o.wrench), 'echo': lambda o: Echo(o.joints, o.wrench)}


def parse_args(argv):
    parser = argparse.ArgumentParser(prog='python -m benchmarks.bench_pingpong', description=__doc__.split('\n')[0])
    parser.add_argument('role', choices=tuple(ROLES))
    parser.add_argument('--joints', nargs='+', required=True, help='joint names in the messages')
    parser.add_argument('--executor', choices=('single', 'events'), default='single')
    parser.add_argument('--period', type=float, default=0.001,
                        help='ping: stamp increment; tick: the period and stamp increment, s')
    parser.add_argument('--wrench', action='store_true', help='tick and echo: also the ft_sensor/wrench stream')
    return parser.parse_args(argv)


def main(args=None):
    argv = sys.argv if args is None else args
    opts = parse_args(rclpy.utilities.remove_ros_args(argv)[1:])
    return spin.run_node(argv, lambda: ROLES[opts.role](opts), opts.executor)


if __name__ == '__main__':
    sys.exit(main())
