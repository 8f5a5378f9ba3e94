"""controller_node: the ROS 2 layer around ControllerCore (DESIGN §5, issue 4).

Topics (names relative, remappable; QoS from robot_control.ros.qos):
  sub joint_states                sensor_msgs/JointState       CONTROL_QOS   robot state, by name
  sub ~/joint_trajectory          trajectory_msgs/JointTrajectory REFERENCE_QOS joint reference
  sub ~/wrench_reference          geometry_msgs/WrenchStamped  REFERENCE_QOS desired force (force axes);
                                                                             stamped ahead: applied from that time
                                                                             (dropped if time goes back first)
  sub ft_sensor/wrench            geometry_msgs/WrenchStamped  CONTROL_QOS   measured contact force
  pub robot_joint_commands        sensor_msgs/JointState       CONTROL_QOS   name + effort
  pub effort_controller/commands  std_msgs/Float64MultiArray   CONTROL_QOS   if publish_effort_array
  pub ~/reference                 sensor_msgs/JointState       REFERENCE_QOS reference of the tick
  pub ~/error                     sensor_msgs/JointState       REFERENCE_QOS tracking error of the tick
  pub /diagnostics                diagnostic_msgs/DiagnosticArray DIAGNOSTICS_QOS  every diagnostics_period

Event-driven: each valid joint_states message gets exactly one command, computed from the
reference sampled at that message's header.stamp (the node clock's now() if the stamp is zero)
and stamped with the same stamp. An invalid one (a controlled joint missing, duplicate names,
position/velocity lengths not matching name, NaN/inf in a controlled joint) gets no command, a
count and a reason on /diagnostics and a throttled warning. Names that are not controlled are
ignored, as ros2_control users expect from a joint_states shared with other hardware.

~/reference and ~/error carry, per entry of the law's space (joints for computed_torque and
independent_joint; task axes for hybrid; the force axis for force):
  ~/reference: position = q_d | x_d | f_d, velocity = first derivative, effort = second
               derivative (JointState has no acceleration field);
  ~/error:     position = E, velocity = Ed, effort = the error integral int E (zeros without
               integral action). On force axes the values are forces (N, N/s, N/s^2, N s).

Trajectories: like joint_trajectory_controller (names in any order, exactly the controlled
joints, strictly increasing time_from_start > 0, finite values, velocities/accelerations in
every point or none). header.stamp zero = start at the last state's time; the current reference
is the implicit first point, so a new trajectory replaces the active one without a jump in the
reference; the last point is held. A single point is a quintic point-to-point move. Accepted
only while the controller runs (after the first state, not while the watchdog is tripped).

Watchdog: a timer on the node clock (sim time when use_sim_time) checks that a joint_states
arrived within state_timeout; if not, the core stops (nothing is commanded anyway: commands
only answer states) and /diagnostics reports ERROR at once. When states return, the core
restarts: integral reset, reference = hold the current position (no torque jump beyond what the
law gives for zero error). Note: with use_sim_time, a stopped /clock also stops the watchdog
(no simulated time passes); /diagnostics runs on the wall clock and keeps reporting.

Speed: joint_states is taken as serialized bytes and read by robot_control.ros.cdr (rclpy decodes
what that declines, e.g. big-endian CDR); the command is written into a preallocated serialized
message. Only reading the state, the law and the publish run before the command goes out; the
bookkeeping (watchdog times, counts, ~/reference, ~/error) follows it.

Parameters: the table robot_control.ros.params, declared and checked by the parameter engine
(robot_control.ros.param_engine: one on-set callback whose reason names the parameter), built into
a ControllerConfig by robot_control.ros.controller_config, applied after the engine committed it by
swapping the core's configuration snapshot; nothing reads the parameter server per tick.
A start-up parameter the controller does not have is refused.

Run: python -m robot_control.ros.controller_node --ros-args --params-file config/polar_two_link.yaml
(the YAML's top key `controller` is the node name; use `/**:` for a renamed node).
"""
import sys
import time

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from rclpy.clock import Clock, ClockType
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory

from robot_control import units
from robot_control.ros import cdr, conversions, spin
from robot_control.core.controller import ControllerCore
from robot_control.ros import params
from robot_control.ros.controller_config import ConfigBuilder
from robot_control.ros.param_engine import ParameterNode, ParameterEngine
from robot_control.ros.param_table import ParameterError
from robot_control.ros.qos import CONTROL_PUB_QOS, CONTROL_QOS, DIAGNOSTICS_QOS, REFERENCE_PUB_QOS, REFERENCE_QOS
from robot_control.ros.throttle import Throttle

NS = units.NS_PER_S
#: rejected-input sources, in the order /diagnostics lists them
INPUTS = ('joint_states', 'joint_trajectory', 'wrench_reference', 'ft_sensor_wrench')
#: s of wall time a state waits for the wrench of its own tick (paired streams only, see _take_wrenches)
WRENCH_WAIT = 0.005
WRENCH_POLL = 0.0001
#: smallest watchdog check period, s
MIN_WATCHDOG_PERIOD = 0.001
#: throttle of the warnings about rejected input, s
WARN_THROTTLE = 1.0


class TickStats:
    """Wall time of the joint_states callback (message in -> command published), ns."""

    def __init__(self):
        self.count = 0
        self.total_ns = 0
        self.max_ns = 0
        self.last_ns = 0

    def add(self, ns):
        self.count += 1
        self.total_ns += ns
        self.last_ns = ns
        self.max_ns = max(self.max_ns, ns)

    @property
    def mean_us(self):
        return self.total_ns / self.count / 1e3 if self.count else 0.0


class ControllerNode(ParameterNode):
    """Computed-torque / independent-joint / force / hybrid controller over ROS 2 topics.

    kwargs go to rclpy.node.Node (context=, parameter_overrides=, cli_args=, ...). Raises
    ParameterError naming the parameter when the start-up parameters are invalid.
    """

    def __init__(self, node_name='controller', **kwargs):
        super().__init__(node_name, **kwargs)
        try:
            self._setup()
        except BaseException:
            self.destroy_node()
            raise

    def _setup(self):
        self._params = ParameterEngine(self, params.TABLE, ConfigBuilder(), apply=self._apply_parameters)
        snapshot = self._params.current
        cfg = snapshot.config
        self._core = ControllerCore(cfg)
        self._joints = cfg.joints
        self._task_axes = cfg.model.task_axes
        self._reader = conversions.JointStateReader(cfg.joints)
        # joint_states in and the command out as serialized bytes (robot_control.ros.cdr: a few us each,
        # where rclpy's conversion of a JointState costs tens)
        self._state_decoder = cdr.JointStateDecoder(arrays=False)    # floats: checked before any numpy call
        self._command_encoder = cdr.JointStateEncoder(cfg.joints, fields=('effort',))
        self._effort_array = Float64MultiArray()
        self._reference_msg = JointState()
        self._error_msg = JointState()
        self._f_meas = np.zeros(len(self._task_axes))
        self._wrench_seen = False
        self._wrench_stamp_ns = None    # header.stamp of the last valid ft_sensor/wrench
        self._pending_force = None      # (stamp_ns, f_d) of a wrench_reference stamped ahead
        self._epoch_ns = None
        self._last_state_ns = None      # node clock at the last valid joint_states
        self._last_state_steady_ns = None   # steady clock at the last valid joint_states
        self._last_stamp_ns = None      # header.stamp of the last valid joint_states
        self._tripped = False
        self.trips = 0
        self.rejected = dict.fromkeys(INPUTS, 0)
        self._warn_throttle = Throttle(units.to_ns(WARN_THROTTLE))
        self.last_rejection = ''
        self.commands_sent = 0
        self.trajectories_accepted = 0
        self.tick_stats = TickStats()
        self._contact_trips = 0
        self._apply_references(snapshot.values, initial=True)

        self._cmd_pub = self.create_publisher(JointState, 'robot_joint_commands', CONTROL_PUB_QOS)
        self._array_pub = None
        self._set_array_publisher(snapshot.values['publish_effort_array'])
        self._ref_pub = self.create_publisher(JointState, '~/reference', REFERENCE_PUB_QOS)
        self._err_pub = self.create_publisher(JointState, '~/error', REFERENCE_PUB_QOS)
        self._diag_pub = self.create_publisher(DiagnosticArray, '/diagnostics', DIAGNOSTICS_QOS)
        # ft_sensor/wrench before joint_states: when a state and its wrench are both waiting, rclpy
        # runs the callbacks in creation order, so the tick's wrench is in place first
        self._ft_sub = None
        self._set_ft_subscription(cfg)
        self.create_subscription(JointState, 'joint_states', self._on_joint_states_raw, CONTROL_QOS, raw=True)
        self.create_subscription(JointTrajectory, '~/joint_trajectory', self._on_trajectory, REFERENCE_QOS)
        self.create_subscription(WrenchStamped, '~/wrench_reference', self._on_wrench_reference, REFERENCE_QOS)

        self._watchdog = None
        self._diag_timer = None
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._set_watchdog(snapshot.values['state_timeout'])
        self._set_diagnostics_timer(snapshot.values['diagnostics_period'])

        self.get_logger().info(
            f'ready: law {cfg.law}{" (PID)" if cfg.integral else ""}, model {snapshot.values["model"]}, '
            f'joints {list(cfg.joints)}, force axes {list(cfg.force_axes)}, '
            f'kp {cfg.gains.kp.tolist() if cfg.gains is not None else []}')

    # -- public for tests and tools ----------------------------------------------------------------
    @property
    def core(self):
        """The ControllerCore (read it, do not drive it from another thread)."""
        return self._core

    @property
    def watchdog_tripped(self):
        """True while no joint_states arrived within state_timeout."""
        return self._tripped

    @property
    def wrench_received(self):
        """True once a valid ft_sensor/wrench arrived."""
        return self._wrench_seen

    # -- state -> command ------------------------------------------------------------------------
    def _on_joint_states_raw(self, data):
        """joint_states as DDS delivered it: decoded by robot_control.ros.cdr, or by rclpy when the fast
        decoder declines (e.g. big-endian CDR from another vendor)."""
        msg = self._state_decoder.decode(data)
        self._on_joint_states(deserialize_message(data, JointState) if msg is None else msg)

    def _on_joint_states(self, msg):
        """Answer a state with the newest valid ft_sensor/wrench (see _take_wrenches, _answer)."""
        if self._ft_sub is not None:
            self._take_wrenches(conversions.stamp_to_ns(msg.header.stamp))
        self._answer(msg)

    def _take_wrenches(self, stamp_ns):
        """Bring the measured force up to the state stamped `stamp_ns` before it is answered.

        The bridge publishes a tick's wrench, then its state, both stamped t_k; they reach this
        process through two DDS readers, and under load the state can be handled first. So the
        waiting wrenches are taken here, and while the wrench stream is paired with the states (the
        previous state's stamp equals the newest wrench's), the tick's own wrench is waited for, at
        most WRENCH_WAIT s: every answer then uses the force of its own tick and lockstep runs repeat
        bit for bit. An unstamped, unpaired or silent wrench stream is never waited for.
        """
        self._drain_wrenches()
        last = self._last_stamp_ns
        if last is None or self._wrench_stamp_ns != last or stamp_ns <= last:
            return
        deadline = time.monotonic() + WRENCH_WAIT
        while self._wrench_stamp_ns < stamp_ns and time.monotonic() < deadline:
            time.sleep(WRENCH_POLL)
            self._drain_wrenches()

    def _drain_wrenches(self):
        sub = self._ft_sub
        with sub.handle:
            while True:
                taken = sub.handle.take_message(WrenchStamped, False)
                if taken is None:
                    return
                self._on_ft_sensor(taken[0])

    def _answer(self, msg):
        """State -> command. Only what the command needs runs before it is published (the loop's
        critical path: in lockstep the simulator waits for it); the bookkeeping follows."""
        t_in = time.perf_counter_ns()
        try:
            q, qd = self._reader.read(msg)
        except ValueError as exc:
            self._reject('joint_states', exc)
            return
        stamp = msg.header.stamp
        msg_stamp_ns = stamp.sec * NS + stamp.nanosec
        now_ns = None if msg_stamp_ns else self.get_clock().now().nanoseconds
        stamp_ns = msg_stamp_ns or now_ns
        if stamp_ns < 0:
            self._reject('joint_states', f'header.stamp: negative time {stamp_ns * 1e-9:.9f} s')
            return
        last = self._last_stamp_ns
        if (last is not None and not self._tripped and self._core.active
                and abs(stamp_ns - last) > self._state_timeout * NS):
            self._reject('joint_states', f'header.stamp: {(stamp_ns - last) * 1e-9:+.6g} s from the previous state, '
                                         f'more than state_timeout {self._state_timeout:g} s (a clock reset restarts '
                                         'the controller once the watchdog trips)')
            return
        self._last_stamp_ns = stamp_ns
        if self._epoch_ns is None:
            self._epoch_ns = stamp_ns
        recovered, self._tripped = self._tripped, False
        pending = self._pending_force
        if pending is not None and (recovered or (last is not None and stamp_ns < last)):
            # the core restarts (time went back: a simulator reset; or after the watchdog) and drops a pending
            # trajectory; a force reference stamped ahead on the old timeline goes too
            self._pending_force = pending = None
        if pending is not None and stamp_ns >= pending[0]:
            self._pending_force = None
            self._core.set_force_reference(pending[1])
        try:
            tau = self._core.update_checked((stamp_ns - self._epoch_ns) * 1e-9, q, qd, self._f_meas)
        except ValueError as exc:  # defensive: the core falls back to gravity hold before this
            self._reject('joint_states', f'controller: {exc}')
            return
        # lockstep: stamped t_k, even 0; the torque as the list the core made (no numpy call to serialize it)
        self._cmd_pub.publish(self._command_encoder.encode(msg_stamp_ns, effort=self._core.tau_values))
        if self._array_pub is not None:
            self._array_pub.publish(conversions.effort_array(tau, self._effort_array))
        self.tick_stats.add(time.perf_counter_ns() - t_in)
        self._after_answer(stamp_ns, now_ns, recovered)

    def _after_answer(self, stamp_ns, now_ns, recovered):
        """Bookkeeping of an answered state: watchdog times, counts, ~/reference, ~/error, diagnostics."""
        self._last_state_steady_ns = time.monotonic_ns()
        self._last_state_ns = self.get_clock().now().nanoseconds if now_ns is None else now_ns
        self.commands_sent += 1
        if recovered:
            self.get_logger().info('joint_states are back: restarting from the current state')
        guard = self._core.contact_guard
        if guard is not None and guard.trips != self._contact_trips:
            self._contact_trips = guard.trips
            self.get_logger().error(guard.reason)
            self._publish_diagnostics()
        # ~/reference and ~/error are VOLATILE: with no subscriber a sample reaches no one, so the
        # message is neither built nor serialized (a count query costs a fifth of a publish)
        names = self._core.reference_names
        if self._ref_pub.get_subscription_count():
            pos, vel, acc = self._core.reference
            self._ref_pub.publish(conversions.joint_state(names, stamp_ns, pos, vel, acc, out=self._reference_msg))
        if self._err_pub.get_subscription_count():
            E, Ed = self._core.error
            self._err_pub.publish(conversions.joint_state(names, stamp_ns, E, Ed, self._core.integral_value,
                                                          out=self._error_msg))
        if recovered:
            self._publish_diagnostics()

    def _on_ft_sensor(self, msg):
        try:
            f = conversions.wrench_force(msg, self._task_axes)
        except ValueError as exc:  # keep the last valid measurement
            self._reject('ft_sensor_wrench', exc)
            return
        self._f_meas[:] = f
        self._wrench_seen = True
        self._wrench_stamp_ns = conversions.stamp_to_ns(msg.header.stamp)

    def _time_of(self, stamp_ns):
        """A message stamp on the core's time base (None for a zero stamp = now)."""
        if stamp_ns == 0 or self._epoch_ns is None:
            return None
        return (stamp_ns - self._epoch_ns) * 1e-9

    def _on_trajectory(self, msg):
        try:
            goal = conversions.trajectory_goal(msg, self._joints)
            if not self._core.active:
                raise ValueError('controller not running (no joint_states yet, or watchdog tripped)')
            t0 = self._core.set_trajectory(goal.times, goal.positions, goal.velocities, goal.accelerations,
                                           t_start=self._time_of(goal.stamp_ns))
        except ValueError as exc:
            self._reject('joint_trajectory', exc)
            return
        self.trajectories_accepted += 1
        self.get_logger().info(f'trajectory accepted: {goal.times.shape[0]} points over {goal.times[-1]:g} s '
                               f'from t = {t0:.6f} s')

    def _on_wrench_reference(self, msg):
        """A force reference: at once (header.stamp zero or not ahead of the last state), or pending
        until the first state stamped at or after header.stamp (one pending; a new one replaces it)."""
        axes = self._core.config.force_axes
        try:
            if not axes:
                raise ValueError('no force axes configured (parameter force_axes)')
            f_d = conversions.wrench_force(msg, axes)
            stamp_ns = conversions.stamp_to_ns(msg.header.stamp)
            if stamp_ns and self._last_stamp_ns is not None and stamp_ns > self._last_stamp_ns:
                self._pending_force = (stamp_ns, f_d)
            else:
                self._pending_force = None
                self._core.set_force_reference(f_d)
        except ValueError as exc:
            self._reject('wrench_reference', exc)
            return
        when = f' from t = {self._time_of(stamp_ns):.6f} s' if self._pending_force is not None else ''
        self.get_logger().info(f'force reference {dict(zip(axes, f_d.tolist()))} N{when}')

    def _reject(self, source, reason):
        self.rejected[source] += 1
        self.last_rejection = f'{source}: {reason}'
        if self._warn_throttle.ready(time.monotonic_ns()):   # not rclpy's throttle: see robot_control.ros.throttle
            self.get_logger().warning(f'rejected {self.last_rejection}')

    # -- watchdog and diagnostics ------------------------------------------------------------------
    def _set_watchdog(self, timeout):
        if self._watchdog is not None:
            self.destroy_timer(self._watchdog)
        self._state_timeout = timeout
        # on the steady clock: with use_sim_time a dead simulator also stops /clock, and a ROS-time timer
        self._watchdog = self.create_timer(max(timeout / 5.0, MIN_WATCHDOG_PERIOD), self._check_watchdog,
                                           clock=self._steady)

    def _check_watchdog(self):
        if self._tripped or self._last_state_ns is None or not self._core.active:
            return
        age = (self.get_clock().now().nanoseconds - self._last_state_ns) * 1e-9
        age = max(age, (time.monotonic_ns() - self._last_state_steady_ns) * 1e-9)   # wall time too
        if age > self._state_timeout:
            self._tripped = True
            self.trips += 1
            self._core.stop()
            self.get_logger().error(f'no joint_states for {age:.3f} s (state_timeout {self._state_timeout:g} s): '
                                    'stopped commanding')
            self._publish_diagnostics()

    def _set_diagnostics_timer(self, period):
        if self._diag_timer is not None:
            self.destroy_timer(self._diag_timer)
        self._diag_timer = self.create_timer(period, self._publish_diagnostics, clock=self._steady)

    def diagnostics(self):
        """The DiagnosticStatus list /diagnostics carries now."""
        name = self.get_fully_qualified_name().lstrip('/')
        core, cfg = self._core, self._core.config
        hw = name
        if self._tripped:
            age = max((self.get_clock().now().nanoseconds - self._last_state_ns) * 1e-9,
                      (time.monotonic_ns() - self._last_state_steady_ns) * 1e-9)
            watchdog = ('ERROR', f'no joint_states for {age:.3f} s (state_timeout {self._state_timeout:g} s): '
                                 'not commanding')
        elif self._last_state_ns is None:
            watchdog = ('WARN', 'waiting for the first joint_states')
        else:
            watchdog = ('OK', 'receiving joint_states')
        status = [conversions.diagnostic_status(
            f'{name}: joint_states watchdog', *watchdog,
            {'state_timeout_s': self._state_timeout, 'trips': self.trips, 'restarts': core.restarts,
             'commands_sent': self.commands_sent}, hw)]
        sat = [j for j, s in zip(cfg.joints, core.saturated) if s]
        status.append(conversions.diagnostic_status(
            f'{name}: effort saturation', 'WARN' if sat else 'OK',
            f'saturated: {sat}' if sat else 'within effort limits',
            [('saturated_ticks', core.saturated_ticks), ('ticks', core.ticks)]
            + [(f'saturated_ticks.{j}', int(c)) for j, c in zip(cfg.joints, core.saturation_counts)]
            + [(f'effort_limit.{j}', float(v)) for j, v in zip(cfg.joints, cfg.effort_limit)], hw))
        total = sum(self.rejected.values())
        status.append(conversions.diagnostic_status(
            f'{name}: rejected inputs', 'WARN' if total else 'OK',
            f'{total} rejected; last {self.last_rejection}' if total else 'no rejected input',
            [(f'rejected.{k}', v) for k, v in self.rejected.items()] + [('last_reason', self.last_rejection)], hw))
        level, message = 'OK', f'{cfg.law}{" PID" if cfg.integral else ""}'
        if core.fallbacks:
            level, message = 'WARN', f'{message}; gravity-hold fallbacks: {core.fallbacks} (last: {core.last_fallback})'
        needs_sensor = cfg.force_axes and cfg.law in ('force', 'hybrid') and cfg.force_feedback == 'sensor'
        if needs_sensor and not self._wrench_seen:
            level, message = 'WARN', f'{message}; no ft_sensor/wrench received (force taken as 0)'
        guard = core.contact_guard
        if guard is not None and guard.active:
            level, message = 'ERROR', f'{message}; {guard.reason}'
        status.append(conversions.diagnostic_status(
            f'{name}: control law', level, message,
            [('law', cfg.law), ('integral', cfg.integral), ('fallbacks', core.fallbacks),
             ('contact_trips', guard.trips if guard is not None else 0),
             ('tick_mean_us', round(self.tick_stats.mean_us, 1)),
             ('tick_max_us', round(self.tick_stats.max_ns / 1e3, 1)), ('ticks', self.tick_stats.count)], hw))
        return status

    def _publish_diagnostics(self):
        self._diag_pub.publish(conversions.diagnostic_array(self.diagnostics(),
                                                            self.get_clock().now().nanoseconds))

    # -- parameters ------------------------------------------------------------------------------
    def _apply_parameters(self, old, snapshot, changed):
        """After the engine committed a run-time change: the core's new configuration, references,
        timers and publishers (`old`, `snapshot`: Snapshots before and after; `changed`: names)."""
        self._core.configure(snapshot.config)
        self._set_ft_subscription(snapshot.config)
        values = snapshot.values
        self._apply_references(values, changed=changed, old=old.values)
        if 'state_timeout' in changed:
            self._set_watchdog(values['state_timeout'])
        if 'diagnostics_period' in changed:
            self._set_diagnostics_timer(values['diagnostics_period'])
        if 'publish_effort_array' in changed:
            self._set_array_publisher(values['publish_effort_array'])
        self.get_logger().info(f'parameters set: {sorted(changed)}')

    def _apply_references(self, values, initial=False, changed=(), old=None):
        k = len(self._core.config.force_axes)
        if values['q_d'] and (initial or 'q_d' in changed):
            self._core.set_goal(values['q_d'])
        if k and (initial or 'f_d' in changed or values['force_axes'] != old['force_axes']):
            self._core.set_force_reference(values['f_d'] or np.zeros(k))

    def _set_ft_subscription(self, cfg):
        """Subscribe ft_sensor/wrench only while the law reads the measured force: each message wakes
        the executor, at the bridge's control rate."""
        needed = bool(cfg.force_axes) and cfg.law in ('force', 'hybrid') and cfg.force_feedback == 'sensor'
        if needed and self._ft_sub is None:
            self._f_meas[:] = 0.0
            self._wrench_seen = False
            self._wrench_stamp_ns = None
            self._ft_sub = self.create_subscription(WrenchStamped, 'ft_sensor/wrench', self._on_ft_sensor,
                                                    CONTROL_QOS)
        elif not needed and self._ft_sub is not None:
            self.destroy_subscription(self._ft_sub)
            self._ft_sub = None

    def _set_array_publisher(self, enabled):
        if enabled and self._array_pub is None:
            self._array_pub = self.create_publisher(Float64MultiArray, 'effort_controller/commands', CONTROL_PUB_QOS)
        elif not enabled and self._array_pub is not None:
            self.destroy_publisher(self._array_pub)
            self._array_pub = None


def _parse_args(argv):
    import argparse
    parser = argparse.ArgumentParser(prog='controller_node', description='robot_control controller node.',
                                     epilog='ROS arguments follow --ros-args, e.g. --ros-args --params-file '
                                            'config/polar_two_link.yaml')
    parser.add_argument('--executor', choices=spin.EXECUTORS, default='events',
                        help='rclpy executor: events (EventsExecutor, default) or single (SingleThreadedExecutor)')
    return parser.parse_args(argv)


def main(args=None):
    """Entry point: spin the controller until Ctrl-C / SIGTERM (exit 0); 1 on invalid parameters."""
    argv = sys.argv if args is None else args
    opts = _parse_args(rclpy.utilities.remove_ros_args(argv)[1:])
    return spin.run_node(argv, ControllerNode, opts.executor, startup_errors=(ParameterError,),
                         startup_message='invalid parameter', startup_code=1)


if __name__ == '__main__':
    sys.exit(main())
