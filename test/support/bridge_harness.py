"""In-process test harness for the bridge node: the bridge and a probe node in one executor.

The probe subscribes to everything the bridge publishes, can answer each state like a
controller (lockstep handshake: the command carries the state's stamp) and calls the services.
Spinning is always bounded by a wall-clock deadline, a generous one (WAIT): a test waits for a
condition, and a machine busy with other work only makes the wait longer.
"""
import time

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import SetBool, Trigger

from robot_control.ros import conversions
from robot_control.ros.qos import CONTROL_QOS, DIAGNOSTICS_QOS
from robot_control.ros.spin import make_executor
from sim_bridge.bridge_node import CLOCK_QOS, SimBridge

NS = 1_000_000_000
WAIT = 30.0        # s of wall time a condition may take before a wait gives up


def overrides(**params):
    """Parameter list from keyword arguments; '__' in a name stands for '.' (surface__k_e)."""
    return [Parameter(k.replace('__', '.'), value=v) for k, v in params.items()]


class Probe(Node):
    """Records the bridge's output; `controller(t_ns, q, qd) -> tau` (or None) answers states."""

    def __init__(self, joints, context, controller=None):
        super().__init__('bridge_probe', context=context)
        self.joints = list(joints)
        self.controller = controller
        self.states = []          # (stamp_ns, names, q, qd, effort)
        self.clock = []           # stamp_ns
        self.wrenches = []        # (stamp_ns, frame_id, force (3,))
        self.diagnostics = []     # {status name: (level, message, values)}
        self.create_subscription(JointState, 'joint_states', self._on_state, CONTROL_QOS)
        self.create_subscription(Clock, '/clock', lambda m: self.clock.append(conversions.stamp_to_ns(m.clock)),
                                 CLOCK_QOS)
        self.create_subscription(WrenchStamped, 'ft_sensor/wrench', self._on_wrench, CONTROL_QOS)
        self.create_subscription(DiagnosticArray, '/diagnostics', self._on_diag, DIAGNOSTICS_QOS)
        self.pub = self.create_publisher(JointState, 'robot_joint_commands', CONTROL_QOS)
        self.pub_array = self.create_publisher(Float64MultiArray, 'effort_controller/commands', CONTROL_QOS)
        self.reset_client = self.create_client(Trigger, 'sim_bridge/reset')
        self.pause_client = self.create_client(SetBool, 'sim_bridge/pause')
        self._cmd = JointState()
        self._cmd.name = list(joints)

    def _on_state(self, msg):
        t = conversions.stamp_to_ns(msg.header.stamp)
        q = np.array(msg.position)
        qd = np.array(msg.velocity)
        self.states.append((t, list(msg.name), q, qd, np.array(msg.effort)))
        if self.controller is not None:
            tau = self.controller(t, q, qd)
            if tau is not None:
                self.send(tau, t)

    def send(self, tau, stamp_ns=0, names=None):
        self._cmd.name = self.joints if names is None else list(names)
        self._cmd.effort = [float(x) for x in tau]
        conversions.ns_to_stamp(stamp_ns, self._cmd.header.stamp)
        self.pub.publish(self._cmd)

    def _on_wrench(self, msg):
        f = msg.wrench.force
        self.wrenches.append((conversions.stamp_to_ns(msg.header.stamp), msg.header.frame_id,
                              np.array([f.x, f.y, f.z])))

    def _on_diag(self, msg):
        self.diagnostics.append({s.name.split(': ')[-1]: conversions.diagnostic_values(s) for s in msg.status})

    def last_diag(self, part):
        for d in reversed(self.diagnostics):
            if part in d:
                return d[part]
        return None


class Harness:
    """Bridge + probe in one executor of `context` ('single' or 'events'); close() destroys both."""

    def __init__(self, context, controller=None, executor='single', **params):
        self.context = context
        self.bridge = None
        self.probe = None
        self.executor = make_executor(executor, context)
        try:
            self.bridge = SimBridge(context=context, parameter_overrides=overrides(**params))
            self.probe = Probe(self.bridge.joint_names, context, controller)
            self.executor.add_node(self.bridge)
            self.executor.add_node(self.probe)
        except BaseException:
            self.close()
            raise

    def spin_until(self, predicate, timeout=WAIT):
        """Spin until predicate() is true or `timeout` s of wall time passed; returns predicate()."""
        deadline = time.monotonic() + timeout
        while not predicate():
            if time.monotonic() > deadline:
                return predicate()
            self.executor.spin_once(0.005)
        return True

    def run_until(self, t_ns, timeout=WAIT):
        """Spin until the probe has received the state stamped `t_ns` (or later)."""
        return self.spin_until(lambda: bool(self.probe.states) and self.probe.states[-1][0] >= t_ns, timeout)

    def state_at(self, t_ns):
        """The last received state stamped `t_ns`: (stamp, names, q, qd, effort)."""
        return [s for s in self.probe.states if s[0] == t_ns][-1]

    def spin_for(self, seconds):
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.executor.spin_once(max(0.0, min(0.005, deadline - time.monotonic())))

    def call(self, client, request, timeout=WAIT):
        assert self.spin_until(client.service_is_ready, timeout), f'{client.srv_name} not available'
        future = client.call_async(request)
        assert self.spin_until(future.done, timeout), f'{client.srv_name} did not answer'
        return future.result()

    def pause(self, on):
        return self.call(self.probe.pause_client, SetBool.Request(data=on))

    def reset(self):
        return self.call(self.probe.reset_client, Trigger.Request())

    def close(self):
        try:
            self.executor.shutdown()
        finally:
            for node in (self.probe, self.bridge):
                if node is not None:
                    node.destroy_node()


def run_lockstep(scenario, controller, ticks, timeout=2 * WAIT, executor='single', **params):
    """A lockstep run in a fresh context: (stamps, q, qd, effort) arrays of the first `ticks`+1 states."""
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    h = None
    try:
        h = Harness(ctx, controller, executor, scenario=scenario, mode='lockstep', **params)
        assert h.run_until(ticks * h.bridge.cfg.control_period_ns, timeout)
        states = {}
        for t, _, q, qd, eff in h.probe.states:
            states.setdefault(t, (q, qd, eff))
        stamps = sorted(states)[:ticks + 1]
        return (np.array(stamps), np.array([states[t][0] for t in stamps]),
                np.array([states[t][1] for t in stamps]), np.array([states[t][2] for t in stamps]))
    finally:
        if h is not None:
            h.close()
        rclpy.try_shutdown(context=ctx)
