"""The demo's own ROS side: the metrics collector, the reference publisher and the run control
(pause/resume of the bridge, confirmations from the controller's log).

Both nodes are spun by one executor of the demo, rclpy's EventsExecutor. The collector keeps
every message of the run's topics serialized, with the DDS source (publication) and reception
timestamps (robot_control.tools.taps); its readers' queues are deep (KEEP_LAST DEPTH) and DDS's
own threads acknowledge, so nothing is lost while the demo's Python thread is busy between two
spins. Messages are deserialized after the run (and the newest of a topic when the progress
line or the run's end asks for it).
"""
import time

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from rcl_interfaces.msg import Log
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool, Trigger
from trajectory_msgs.msg import JointTrajectory

from robot_control.ros import conversions, dds
from robot_control.ros.qos import REFERENCE_QOS
from robot_control.tools.taps import Tap, spin_for

#: the collector's and the recorder's reader depth, samples per topic: DDS's threads take every sample in while the
#: demo's Python thread is behind, and a reader drops the oldest unread one past its depth. Beside stress-ng --cpu 2
#: the demo fell more than 5000 ticks behind a lockstep run of 21 s (it kept 0.82 of its ticks); 100000 holds the
#: backlog of any demo experiment (the readers' room: robot_control/ros/fastdds_profile.xml, which context_with_domain
#: loads). A reader's history grows as samples wait: 8 readers of depth 10000 or 200000 start with the same RSS.
DEPTH = 100000
SPIN_ROUND = 0.005    # s, one round of RunControl.spin_until
STARTUP_WAIT = 10.0   # s for a service of a node already running to be discovered
COLLECT_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=DEPTH, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.VOLATILE)
ROSOUT_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.TRANSIENT_LOCAL)

#: topic -> message type the collector takes (names absolute: the nodes run in the root namespace)
COLLECT = {
    '/joint_states': JointState,
    '/robot_joint_commands': JointState,
    '/controller/reference': JointState,
    '/controller/error': JointState,
    '/ft_sensor/wrench': WrenchStamped,
    '/diagnostics': DiagnosticArray,
}

#: every topic of a run, with its type (the recorder subscribes to these before the nodes start)
RUN_TOPICS = {
    '/clock': 'rosgraph_msgs/msg/Clock',
    '/joint_states': 'sensor_msgs/msg/JointState',
    '/robot_joint_commands': 'sensor_msgs/msg/JointState',
    '/ft_sensor/wrench': 'geometry_msgs/msg/WrenchStamped',
    '/controller/reference': 'sensor_msgs/msg/JointState',
    '/controller/error': 'sensor_msgs/msg/JointState',
    '/controller/joint_trajectory': 'trajectory_msgs/msg/JointTrajectory',
    '/controller/wrench_reference': 'geometry_msgs/msg/WrenchStamped',
    '/diagnostics': 'diagnostic_msgs/msg/DiagnosticArray',
    '/rosout': 'rcl_interfaces/msg/Log',
}


class Collector:
    """The run's topics (COLLECT), serialized, with their DDS timestamps; its node is spun by `executor`."""

    def __init__(self, context, executor, name='demo_collector'):
        self.node = Node(name, context=context, enable_rosout=False, start_parameter_services=False)
        self.tap = Tap(self.node, COLLECT, COLLECT_QOS)
        self.raw = self.tap.rows     # topic -> [(bytes, source_ns, received_ns)]
        self.executor = executor
        executor.add_node(self.node)

    def publishers(self, topic):
        return self.tap.publishers(topic)

    def count(self, topic):
        return self.tap.count(topic)

    def latest(self, topic):
        """The newest message of `topic`, deserialized, or None."""
        msgs = self.raw[topic]
        return deserialize_message(msgs[-1][0], COLLECT[topic]) if msgs else None

    def messages(self, topic):
        """[(msg, source_ns, received_ns)] of `topic`, deserialized."""
        cls = COLLECT[topic]
        return [(deserialize_message(d, cls), s, r) for d, s, r in self.raw[topic]]

    def last_stamps_ns(self, topic, k):
        """The stamps (ns) of the newest k messages of `topic`, oldest first (fewer when fewer came)."""
        return [conversions.stamp_to_ns(deserialize_message(d, COLLECT[topic]).header.stamp)
                for d, _, _ in self.raw[topic][-k:]]

    def last_stamp_ns(self, topic='/joint_states'):
        msg = self.latest(topic)
        return None if msg is None else conversions.stamp_to_ns(msg.header.stamp)

    def destroy(self):
        self.executor.remove_node(self.node)
        self.node.destroy_node()


class RunControl:
    """The demo's control node: reference publishers, the bridge's pause service, the controller's log."""

    def __init__(self, context, executor, name='demo'):
        self.node = Node(name, context=context, start_parameter_services=False)
        self.node.get_logger().set_level(rclpy.logging.LoggingSeverity.WARN)  # the recorder's per-topic INFO
        self.executor = executor
        executor.add_node(self.node)
        self.traj_pub = self.node.create_publisher(JointTrajectory, '/controller/joint_trajectory', REFERENCE_QOS)
        self.wrench_pub = self.node.create_publisher(WrenchStamped, '/controller/wrench_reference', REFERENCE_QOS)
        self.pause_client = self.node.create_client(SetBool, '/sim_bridge/pause')
        self.param_clients = {}     # node name -> rclpy's AsyncParameterClient, made when first needed
        self.trigger_clients = {}   # service name -> its std_srvs/Trigger client, made when first needed
        self.log = []    # (logger name, level, text) from /rosout
        self.node.create_subscription(Log, '/rosout', self._on_log, ROSOUT_QOS)

    def _on_log(self, msg):
        self.log.append((msg.name, int(msg.level), msg.msg))

    def spin(self, duration=0.0):
        """Run the callbacks that come within `duration` s."""
        spin_for(self.executor, duration)

    def spin_until(self, predicate, timeout, poll=None, what='condition'):
        """Spin until predicate() or TimeoutError after `timeout` s of wall time; poll() every SPIN_ROUND s."""
        deadline = time.monotonic() + timeout
        while True:
            if poll is not None:
                poll()
            value = predicate()
            if value:
                return value
            if time.monotonic() >= deadline:
                raise TimeoutError(f'timed out after {timeout:g} s waiting for {what}')
            spin_for(self.executor, SPIN_ROUND)

    def subscribed(self, topic, node_name):
        """True when node `node_name` subscribes to `topic` (graph)."""
        return any(i.node_name == node_name for i in self.node.get_subscriptions_info_by_topic(topic))

    def pause(self, on, timeout=15.0, poll=None):
        """Pause (True) or resume (False) the bridge; returns its message (pausing is idempotent: _answer)."""
        self.spin_until(self.pause_client.service_is_ready, timeout, poll, 'the service /sim_bridge/pause')
        result = self._answer(lambda: self.pause_client.call_async(SetBool.Request(data=bool(on))), timeout, poll,
                              f'/sim_bridge/pause({on}) to answer', drop=self.pause_client.remove_pending_request)
        if result is None or not result.success:
            raise RuntimeError(f'/sim_bridge/pause({on}) failed: {None if result is None else result.message}')
        return result.message

    def _answer(self, send, timeout, poll, what, drop=None, retry=2.0):
        """The result of the request send() makes (it returns the Future of a service call), the request re-sent
        every `retry` s without an answer, until `timeout` s: a response can be lost while the server has not
        yet matched this client's response reader (ROS 2 service discovery race). Only idempotent requests come
        here. drop(future) forgets an unanswered one (None: it stays pending, harmless)."""
        deadline = time.monotonic() + timeout
        while True:
            future = send()
            try:
                self.spin_until(future.done, min(retry, max(0.0, deadline - time.monotonic())), poll, what)
                return future.result()
            except TimeoutError:
                if drop is not None:
                    drop(future)
                if time.monotonic() >= deadline:
                    raise TimeoutError(f'timed out after {timeout:g} s waiting for {what}') from None

    def set_bridge_parameters(self, values, timeout=10.0, poll=None):
        """Set run-time parameters of the bridge ({name: value}); RuntimeError naming a refused one."""
        from rclpy.parameter import Parameter
        client = self._parameter_client('sim_bridge', timeout, poll)
        parameters = [Parameter(k, value=v) for k, v in values.items()]
        answer = self._answer(lambda: client.set_parameters(parameters), timeout, poll,
                              '/sim_bridge to set its parameters')
        for name, result in zip(values, answer.results):
            if not result.successful:
                raise RuntimeError(f'/sim_bridge refused {name} = {values[name]!r}: {result.reason}')

    def get_parameters(self, node_name, names, timeout=10.0, poll=None):
        """{name: value} of the parameters `names` of node `node_name` (None for one it has not set)."""
        from rclpy.parameter import parameter_value_to_python
        client = self._parameter_client(node_name, timeout, poll)
        answer = self._answer(lambda: client.get_parameters(list(names)), timeout, poll,
                              f'/{node_name} to give its parameters')
        return {name: parameter_value_to_python(value) for name, value in zip(names, answer.values)}

    def _parameter_client(self, node_name, timeout, poll):
        """The AsyncParameterClient of `node_name`, its services ready."""
        from rclpy.parameter_client import AsyncParameterClient
        if node_name not in self.param_clients:
            self.param_clients[node_name] = AsyncParameterClient(self.node, node_name)
        client = self.param_clients[node_name]
        self.spin_until(client.services_are_ready, timeout, poll, f'the parameter services of /{node_name}')
        return client

    def call_trigger(self, service, poll=None):
        """Call the std_srvs/Trigger `service` once it is there; the future of its answer."""
        if service not in self.trigger_clients:
            self.trigger_clients[service] = self.node.create_client(Trigger, service)
        client = self.trigger_clients[service]
        self.spin_until(client.service_is_ready, STARTUP_WAIT, poll, f'the service {service}')
        return client.call_async(Trigger.Request())

    def controller_said(self, text, since=0):
        """Index of the first controller log line after `since` containing `text`, or None."""
        for i in range(since, len(self.log)):
            name, _, msg = self.log[i]
            if name == 'controller' and text in msg:
                return i
        return None

    def controller_rejections(self, since=0):
        return [m for n, _, m in self.log[since:] if n == 'controller' and m.startswith('rejected')]

    def send_trajectory(self, joints, spec, stamp_ns):
        msg = conversions.joint_trajectory(joints, spec.times, spec.positions, spec.velocities,
                                           spec.accelerations, stamp_ns=stamp_ns)
        self.traj_pub.publish(msg)

    def send_force(self, axes, values, stamp_ns=0):
        """Publish a force reference; stamped ahead, the controller applies it from that time."""
        self.wrench_pub.publish(conversions.wrench_along(axes, values, stamp_ns=stamp_ns))

    def destroy(self):
        self.executor.remove_node(self.node)
        self.node.destroy_node()


def first_by_stamp(messages):
    """{stamp_ns: (msg, source_ns, received_ns)} keeping the first message of each stamp."""
    out = {}
    for m, s, r in messages:
        out.setdefault(conversions.stamp_to_ns(m.header.stamp), (m, s, r))
    return out


def last_before(messages, limit_by_stamp):
    """{stamp_ns: source_ns} of the last publication of each stamp before limit_by_stamp[stamp]."""
    out = {}
    for m, s, _ in messages:
        k = conversions.stamp_to_ns(m.header.stamp)
        lim = limit_by_stamp.get(k)
        if lim is not None and s <= lim:
            out[k] = s
    return out


def controller_diagnostics(collector):
    """(effort_limit dict {joint: limit}, saturated_ticks) from the controller's newest /diagnostics."""
    limits, sat = {}, None
    for data, _, _ in reversed(collector.raw['/diagnostics']):
        msg = deserialize_message(data, DiagnosticArray)
        for st in msg.status:
            if st.name.startswith('controller: effort saturation'):
                values = {kv.key: kv.value for kv in st.values}
                limits = {k.split('.', 1)[1]: float(v) for k, v in values.items() if k.startswith('effort_limit.')}
                sat = int(values.get('saturated_ticks', 0))
                return limits, sat
    return limits, sat


def align(collector, joints, joint_units, force_axes, force_axis_index, law, origin_ns, end_ns, effort_limit=None,
          lockstep=True):
    """RunData of the ticks in [origin_ns, end_ns] the controller answered (see demo_metrics).

    `lost`: in lockstep every tick is answered, so a tick missing here was lost on the way to this
    process. In realtime the bridge steps on without waiting, and the controller answers the newest
    state only: `expected_ticks` counts the simulated ticks and nothing is reported lost.
    """
    from robot_control.tools.demo_metrics import RunData
    cmds = first_by_stamp(collector.messages('/robot_joint_commands'))
    states_all = collector.messages('/joint_states')
    states = first_by_stamp(states_all)
    refs = first_by_stamp(collector.messages('/controller/reference'))
    errs = first_by_stamp(collector.messages('/controller/error'))
    wrenches = first_by_stamp(collector.messages('/ft_sensor/wrench'))
    stamps = sorted(k for k in cmds if origin_ns <= k <= end_ns and k in states and k in refs and k in errs)
    seen = sorted(set(cmds) | set(states))
    period = int(np.median(np.diff(seen))) if len(seen) > 1 else 0
    expected = range(origin_ns, end_ns + 1, period) if period > 0 else ()
    lost = {topic: [k for k in expected if k not in d] for topic, d in
            (('/robot_joint_commands', cmds), ('/joint_states', states), ('/controller/reference', refs),
             ('/controller/error', errs))} if lockstep else {}
    if not stamps:
        raise RuntimeError('no control tick was recorded (no command with a matching state/reference/error)')
    state_src = last_before(states_all, {k: cmds[k][1] for k in stamps})
    n = len(joints)

    def by_name(msg, names, field):
        values = getattr(msg, field)
        index = {s: i for i, s in enumerate(msg.name)}
        return [values[index[s]] for s in names]

    ref_names = tuple(refs[stamps[0]][0].name)
    cols = {k: [] for k in ('q', 'qd', 'tau_a', 'tau_c', 'rp', 'rv', 'ra', 'ep', 'ev', 'f', 'sw', 'cw')}
    for k in stamps:
        st, cm, rf, er = states[k][0], cmds[k][0], refs[k][0], errs[k][0]
        cols['q'].append(by_name(st, joints, 'position'))
        cols['qd'].append(by_name(st, joints, 'velocity'))
        cols['tau_a'].append(by_name(st, joints, 'effort') if len(st.effort) == len(st.name) else [np.nan] * n)
        cols['tau_c'].append(by_name(cm, joints, 'effort'))
        cols['rp'].append(by_name(rf, ref_names, 'position'))
        cols['rv'].append(by_name(rf, ref_names, 'velocity'))
        cols['ra'].append(by_name(rf, ref_names, 'effort'))
        cols['ep'].append(by_name(er, ref_names, 'position'))
        cols['ev'].append(by_name(er, ref_names, 'velocity'))
        w = wrenches.get(k)
        if w is None:
            cols['f'].append([np.nan] * 3)
        else:
            f = w[0].wrench.force
            cols['f'].append([f.x, f.y, f.z])
        cols['sw'].append(state_src.get(k, states[k][1]))
        cols['cw'].append(cmds[k][1])
    t = (np.array(stamps, dtype=np.int64) - origin_ns) * 1e-9
    limit = None
    if effort_limit:
        limit = [effort_limit.get(j, np.inf) for j in joints]
    data = RunData(t=t, joints=joints, joint_units=joint_units, q=cols['q'], qd=cols['qd'],
                   tau_applied=cols['tau_a'], tau_cmd=cols['tau_c'], ref_names=ref_names, ref_pos=cols['rp'],
                   ref_vel=cols['rv'], ref_acc=cols['ra'], err_pos=cols['ep'], err_vel=cols['ev'],
                   force_xyz=cols['f'], force_axes=force_axes, force_axis_index=force_axis_index, law=law,
                   effort_limit=limit, state_wall_ns=cols['sw'], cmd_wall_ns=cols['cw'])
    data.lost = {topic: [(k - origin_ns) / 1e9 for k in v] for topic, v in lost.items() if v}
    data.expected_ticks = len(expected)
    return data


def context_with_domain(domain_id):
    """A fresh rclpy Context on `domain_id` (the caller shuts it down), with the nodes' Fast DDS settings
    (robot_control.ros.dds; they take effect when this is the process's first participant)."""
    from rclpy.signals import SignalHandlerOptions
    dds.apply_defaults()
    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=int(domain_id), signal_handler_options=SignalHandlerOptions.NO)
    return ctx
