"""The configured controller: its core and its ROS interfaces, from configure to cleanup.

A ControllerSession exists while the managed controller node (robot_control.ros.controller_node)
is configured. It owns the Controller (robot_control.core.controller), the publishers, subscriptions
and timers, and turns messages and timers into Controller calls and its results into messages:
joint_states -> command (only while active), ft_sensor/wrench, trajectories and force references,
the watchdog timer, /diagnostics. The rclpy-free Controller decides: the time line, the pairing of a
state with the wrench of its own tick (a state waits in it, answered from the wrench callback or the
one-shot timer), the law and its references, the watchdog, the content of /diagnostics.

joint_states and ft_sensor/wrench are taken as serialized bytes and read by robot_control.ros.cdr
(rclpy decodes what that declines, e.g. big-endian CDR); the command is written as serialized bytes
too. Only reading the state, the law and the publish run before the command goes out; the
bookkeeping follows.
"""
import time

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, WrenchStamped
from rclpy.clock import Clock, ClockType
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory

from robot_control import units
from robot_control.core.controller import Command, Controller
from robot_control.core.status import needs_wrench
from robot_control.ros import cdr, conversions
from robot_control.ros.payload_service import PayloadService
from robot_control.ros.reference_inputs import ReferenceInputs
from robot_control.ros.qos import CONTROL_PUB_QOS, CONTROL_QOS, DIAGNOSTICS_QOS, REFERENCE_PUB_QOS, REFERENCE_QOS
from robot_control.core.throttle import Throttle

#: throttle of the warnings about rejected input, s
WARN_THROTTLE = 1.0


class ControllerSession:
    """The configured controller on `node`, from the parameter Snapshot `snapshot` (values, config).

    Commands only while active (activate / deactivate); destroy() releases every interface.
    """

    def __init__(self, node, snapshot):
        self._node = node
        self.log = node.get_logger()
        cfg = snapshot.config
        self.active = False
        self.controller = Controller(cfg, snapshot.values['state_timeout'])
        self._core = self.controller.core
        self._joints = cfg.joints
        self._task_axes = cfg.model.task_axes
        self.counters = self.controller.counters
        self.timeline = self.controller.timeline
        self._warn_throttle = Throttle(units.to_ns(WARN_THROTTLE))
        self._contact_trips = 0
        self._inputs = ReferenceInputs(self)
        self._first_state_ns = None
        self.allow_partial = snapshot.values['allow_partial_joints_goal']
        self._make_messages(cfg)
        self._apply_references(snapshot.values, initial=True)
        self._make_interfaces(snapshot.values, cfg)
        self._payload = PayloadService(node, self.controller, snapshot.values, lambda: self.active)

    @property
    def core(self):
        """The Controller's ControllerCore, the law's tick (read it, do not drive it from another thread)."""
        return self._core

    @property
    def watchdog(self):
        """The joint_states StateWatchdog."""
        return self.controller.watchdog

    def activate(self):
        """Command from the next state on, starting from that state (the core restarts there: no jump)."""
        self.controller.restart()
        self.active = True

    def deactivate(self):
        """Stop commanding: states are no longer answered (the robot's driver then acts on its own
        command timeout: the bridge engages its brakes)."""
        self.active = False
        self.controller.deactivate()
        self._wrench_timer.cancel()
        self._payload.stop()

    def destroy(self):
        """Release every publisher, subscription and timer."""
        self.active = False
        self._payload.destroy()
        node = self._node
        for pub in (self._cmd_pub, self._array_pub, self._ref_pub, self._err_pub, self._diag_pub):
            if pub is not None:
                node.destroy_publisher(pub)
        for sub in self._subs + [self._ft_sub]:
            if sub is not None:
                node.destroy_subscription(sub)
        for timer in (self._wrench_timer, self._watchdog_timer, self._diag_timer):
            node.destroy_timer(timer)

    def apply(self, old, snapshot, changed):
        """A run-time parameter change the engine committed (`old`, `snapshot`: Snapshots before and after)."""
        results = self.controller.configure(snapshot.config)
        self._set_ft_subscription(snapshot.config)
        self._publish(results, time.perf_counter_ns())
        values = snapshot.values
        self._payload.configure(values)
        self._apply_references(values, changed=changed, old_axes=old.config.control_law.force_task.force_axes)
        self.allow_partial = values['allow_partial_joints_goal']
        if 'state_timeout' in changed:
            self._set_watchdog(values['state_timeout'])
        if 'diagnostics_period' in changed:
            self._set_diagnostics_timer(values['diagnostics_period'])
        if 'publish_effort_array' in changed:
            self._set_array_publisher(values['publish_effort_array'])

    def _make_messages(self, cfg):
        """Readers and writers of the messages the loop handles, made once."""
        # joint_states in and the command out as serialized bytes (robot_control.ros.cdr)
        self._state_decoder = cdr.JointStateDecoder(arrays=False)    # floats: checked before any numpy call
        self._command_encoder = cdr.JointStateEncoder(cfg.joints, fields=('effort',))
        self._effort_array = Float64MultiArray()
        self._reference_msg = JointState()
        self._error_msg = JointState()

    def _make_interfaces(self, values, cfg):
        node = self._node
        self._cmd_pub = node.create_publisher(JointState, 'robot_joint_commands', CONTROL_PUB_QOS)
        self._array_pub = None
        self._set_array_publisher(values['publish_effort_array'])
        self._ref_pub = node.create_publisher(JointState, '~/reference', REFERENCE_PUB_QOS)
        self._err_pub = node.create_publisher(JointState, '~/error', REFERENCE_PUB_QOS)
        self._diag_pub = node.create_publisher(DiagnosticArray, '/diagnostics', DIAGNOSTICS_QOS)
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        # a state of paired streams waits for its own tick's wrench wrench_wait s (core.pairing); 0: until it comes
        self._wrench_wait = values['wrench_wait']
        self._wrench_timer = node.create_timer(self._wrench_wait or 1.0, self._on_wrench_wait_over,
                                               clock=self._steady, autostart=False)
        self._ft_sub = None
        self._set_ft_subscription(cfg)
        inputs = self._inputs
        self._subs = [node.create_subscription(JointState, 'joint_states', self._on_joint_states_raw, CONTROL_QOS,
                                               raw=True)] + [
            node.create_subscription(kind, topic, callback, REFERENCE_QOS)
            for kind, topic, callback in ((JointTrajectory, '~/joint_trajectory', inputs.on_trajectory),
                                          (WrenchStamped, '~/wrench_reference', inputs.on_wrench_reference),
                                          (PoseStamped, '~/target_pose', inputs.on_target_pose),
                                          (WrenchStamped, '~/target_wrench', inputs.on_target_wrench))]
        self._watchdog_timer = self._diag_timer = None
        self._set_watchdog(values['state_timeout'])
        self._set_diagnostics_timer(values['diagnostics_period'])

    # -- state -> command --------------------------------------------------------------------------
    def _on_joint_states_raw(self, data):
        """joint_states as DDS delivered it: decoded by robot_control.ros.cdr, or by rclpy when the fast
        decoder declines (e.g. big-endian CDR from another vendor)."""
        if not self.active:
            return
        t_in = time.perf_counter_ns()
        msg = self._state_decoder.decode(data)
        msg = deserialize_message(data, JointState) if msg is None else msg
        stamp_ns = conversions.stamp_to_ns(msg.header.stamp)
        if self._first_state_ns is None:
            self._first_state_ns = stamp_ns
        self._publish(self.controller.state_arrived(stamp_ns, msg.name, msg.position, msg.velocity,
                                                    self._wrench_publisher), t_in)
        if self.controller.waiting and self._wrench_wait:
            self._wrench_timer.reset()
        self._payload.on_state(stamp_ns, msg.name, msg.effort)

    def _wrench_publisher(self):
        return self._node.count_publishers(self._ft_sub.topic_name) > 0

    def _on_ft_sensor_raw(self, data):
        """ft_sensor/wrench as DDS delivered it: decoded by robot_control.ros.cdr, or by rclpy when the fast
        decoder declines."""
        t_in = time.perf_counter_ns()
        msg = cdr.decode_wrench(data)
        msg = deserialize_message(data, WrenchStamped) if msg is None else msg
        try:
            f = conversions.wrench_force(msg, self._task_axes)
        except ValueError as exc:  # keep the last valid measurement
            self.reject('ft_sensor_wrench', exc)
            return
        self._publish(self.controller.wrench_arrived(conversions.stamp_to_ns(msg.header.stamp), f), t_in)
        if not self.controller.waiting:
            self._wrench_timer.cancel()

    def _on_wrench_wait_over(self):
        self._wrench_timer.cancel()
        self._publish(self.controller.wait_over(), time.perf_counter_ns())

    def _publish(self, results, t_in):
        """The Controller's results: each Command goes out at once (in lockstep the simulator waits for
        it), then its bookkeeping; a Rejection is logged (counted by the Controller)."""
        for result in results:
            if type(result) is not Command:
                self._warn_rejected()
                continue
            self._cmd_pub.publish(self._command_encoder.encode(result.stamp_ns, effort=result.values))
            if self._array_pub is not None:
                self._array_pub.publish(conversions.effort_array(result.tau, self._effort_array))
            tick_ns = time.perf_counter_ns() - t_in
            self._after_answer(result.stamp_ns, tick_ns)

    def _after_answer(self, stamp_ns, tick_ns):
        """Bookkeeping of an answered state: watchdog, counts, ~/reference, ~/error, diagnostics."""
        steady_ns = time.monotonic_ns()
        recovered = self.controller.sent(self._node.get_clock().now().nanoseconds, steady_ns, tick_ns)
        warning = self.controller.law_warning(steady_ns)
        if warning is not None:
            self.log.warning(warning)
        if self.counters.commands_sent == 1:
            self.log.info(f'loop closed: the first command answers the state stamped '
                                   f'{units.seconds(stamp_ns):.3f} s (first state received: '
                                   f'{units.seconds(self._first_state_ns):.3f} s)')
        if self._core.goal.outcome:
            self._inputs.report_goal()
        if recovered:
            self.log.info(f'joint_states are back: {recovered}')
        guard = self._core.contact_guard
        if guard is not None and guard.trips != self._contact_trips:
            self._contact_trips = guard.trips
            self.log.error(guard.reason)
            self.publish_diagnostics()
        # ~/reference and ~/error are VOLATILE: with no subscriber the message is not even built
        names = self._core.reference_names
        if self._ref_pub.get_subscription_count():
            pos, vel, acc = self._core.reference
            self._ref_pub.publish(conversions.joint_state(names, stamp_ns, pos, vel, acc, out=self._reference_msg))
        if self._err_pub.get_subscription_count():
            E, Ed = self._core.error
            self._err_pub.publish(conversions.joint_state(names, stamp_ns, E, Ed, self._core.integral_value,
                                                          out=self._error_msg))
        if recovered:
            self.publish_diagnostics()

    def reject(self, source, reason):
        self.controller.reject(source, reason)
        self._warn_rejected()

    def _warn_rejected(self):
        if self._warn_throttle.ready(time.monotonic_ns()):   # not rclpy's throttle: see robot_control.core.throttle
            self.log.warning(f'rejected {self.counters.last_rejection}')

    # -- watchdog and diagnostics ------------------------------------------------------------------
    def _set_watchdog(self, timeout):
        if self._watchdog_timer is not None:
            self._node.destroy_timer(self._watchdog_timer)
        self.controller.set_state_timeout(timeout)
        # on the steady clock: with use_sim_time a dead simulator also stops /clock
        self._watchdog_timer = self._node.create_timer(self.watchdog.period, self._check_watchdog, clock=self._steady)

    def _check_watchdog(self):
        now, steady = self._node.get_clock().now().nanoseconds, time.monotonic_ns()
        if self.controller.check_watchdog(now, steady):
            self.log.error(f'no joint_states for {self.controller.state_age(now, steady):.3f} s (state_timeout '
                           f'{self.watchdog.timeout:g} s): stopped commanding')
            self.publish_diagnostics()

    def _set_diagnostics_timer(self, period):
        if self._diag_timer is not None:
            self._node.destroy_timer(self._diag_timer)
        self._diag_timer = self._node.create_timer(period, self.publish_diagnostics, clock=self._steady)

    def diagnostics(self):
        """The DiagnosticStatus list /diagnostics carries now."""
        name = self._node.get_fully_qualified_name().lstrip('/')
        statuses = self.controller.statuses(name, self._node.get_clock().now().nanoseconds, time.monotonic_ns())
        return [conversions.diagnostic_status(*status, name) for status in statuses]

    def publish_diagnostics(self):
        self._diag_pub.publish(conversions.diagnostic_array(self.diagnostics(), self._node.get_clock().now().nanoseconds))

    def _apply_references(self, values, initial=False, changed=(), old_axes=()):
        """q_d and f_d of the parameters, when set, changed or (f_d) the law's force axes changed."""
        axes = self._core.config.control_law.force_task.force_axes
        k = len(axes)
        if values['q_d'] and (initial or 'q_d' in changed):
            self._core.set_goal(values['q_d'])
        if k and (initial or 'f_d' in changed or axes != old_axes):
            self._core.set_force_reference(values['f_d'] or np.zeros(k))

    def _set_ft_subscription(self, cfg):
        """Subscribe ft_sensor/wrench only while the law reads the measured force: each message wakes
        the executor, at the bridge's control rate."""
        needed = needs_wrench(cfg)
        if needed and self._ft_sub is None:
            self._ft_sub = self._node.create_subscription(WrenchStamped, 'ft_sensor/wrench', self._on_ft_sensor_raw,
                                                          CONTROL_QOS, raw=True)
        elif not needed and self._ft_sub is not None:
            self._node.destroy_subscription(self._ft_sub)
            self._ft_sub = None
            self._wrench_timer.cancel()

    def _set_array_publisher(self, enabled):
        if enabled and self._array_pub is None:
            self._array_pub = self._node.create_publisher(Float64MultiArray, 'effort_controller/commands', CONTROL_PUB_QOS)
        elif not enabled and self._array_pub is not None:
            self._node.destroy_publisher(self._array_pub)
            self._array_pub = None
