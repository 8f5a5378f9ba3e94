"""sim_bridge node: the PyBullet World as a ROS 2 robot (DESIGN §5).

Publishes `/clock` (rosgraph_msgs/Clock), `joint_states` (sensor_msgs/JointState: position,
velocity, effort = the torque actually applied; header.stamp = simulation time),
`ft_sensor/wrench` (geometry_msgs/WrenchStamped: force and torque the robot exerts on the
surface, world axes, frame `wrench_frame_id`) and `/diagnostics`. Subscribes
`robot_joint_commands` (sensor_msgs/JointState, names + efforts, joints matched by name) and
`effort_controller/commands` (std_msgs/Float64MultiArray in `joints` order). Services
`~/reset` (std_srvs/Trigger) and `~/pause` (std_srvs/SetBool). While paused, physics and
/clock stand still and the unchanged state is re-published every 0.1 s of wall time, so a
controller sees a live robot (its watchdog does not trip) and may be configured or given a
trajectory before the resume; in lockstep its first answer is applied on resume.

Pacing (parameter `mode`):
- lockstep: the state of tick k is published at t_k; the command stamped t_k (a
  Float64MultiArray, which has no stamp, answers the latest state) is applied, held for
  control_period (control_period / physics_step physics steps) and the next state published,
  all inside the command callback. Without an answer the state is re-published every
  lockstep_timeout of wall time; physics never runs without a command, so the same
  controller gives bit-identical runs. A rejected command still completes the handshake: the
  step runs with the last valid command (brakes if there is none), so a faulty controller
  cannot stall the simulation.
- realtime: a steady-clock timer runs the control ticks that are due at real_time_factor
  (sim_bridge.loop.RealtimePacer; it re-anchors after a stall of more than 0.1 s rather than
  bursting). The latest valid command is held; no valid command for command_timeout of
  simulation time (or none yet) engages the World's brakes, a fresh command releases them. A
  robot_joint_commands stamped (the state it answers) more than command_timeout before the current
  simulation time arrived too late (a network link that failed and came back): it is ignored and
  counted (outdated_commands on /diagnostics), never applied.

Bad commands (unknown, missing or duplicate joint names, wrong lengths, NaN or inf) never reach
PyBullet: a throttled warning, a count per reason on /diagnostics, and the last valid command
(or the brakes) stays in force. Mixing sources is refused: more than one publisher on a command
topic (the ROS graph, counted every 0.1 s and whenever a lockstep state is answered twice) or
commands on both command topics engage the brakes, with an ERROR on /diagnostics, until
command_timeout of simulation time has passed without such evidence.
The node never reads a parameter in the loop: it works on a validated snapshot
(sim_bridge.parameters.BridgeConfig) that the parameter callbacks replace.

Diagnostics: three statuses, `sim_bridge: pacing` (mode, sim_time, achieved_real_time_factor,
overruns, republished_states, late_commands), `sim_bridge: commands` (accepted, rejected and
rejected_<reason> counts, last_reject_reason, command_age, outdated_commands, publishers per topic,
publisher_conflicts) and `sim_bridge: brakes` (engaged, reason, events); published every
diagnostics_period and at once when the brakes change.

QoS: joint_states, ft_sensor/wrench and both command topics robot_control.ros.qos.CONTROL_QOS
(RELIABLE, KEEP_LAST 1, VOLATILE); /clock RELIABLE KEEP_LAST 1 (serves best-effort clock
subscribers too); /diagnostics DIAGNOSTICS_QOS (RELIABLE, KEEP_LAST 10). Timers run on the
steady clock, so `use_sim_time: true` given to this node by a shared YAML is harmless.

Speed: robot_joint_commands is taken as serialized bytes and read by robot_control.ros.cdr (rclpy
decodes what that declines); joint_states is a preallocated serialized message whose arrays the
World fills in place. joint_states goes out before /clock and the bookkeeping.

`main` spins rclpy's C++ EventsExecutor by default (`--executor single` for the Python one).
"""
import dataclasses
import sys
import time

import numpy as np
import rclpy
import rclpy.executors
import rclpy.utilities
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import InvalidParameterTypeException, ParameterException, ParameterUninitializedException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import SetBool, Trigger

from robot_control.validation import ArgumentError
from robot_control import units
from robot_control.ros import cdr, conversions, spin
from robot_control import scenarios
from robot_control.ros.qos import CONTROL_PUB_QOS, CONTROL_QOS, DIAGNOSTICS_QOS
from robot_control.ros.throttle import Throttle
from sim_bridge import parameters as bridge_params
from sim_bridge.loop import (CommandMapper, CommandWatchdog, DeadlineMeter, LockstepGate, RateMeter,
                               RealtimePacer, SourceGuard, stamp_ns)

NS = units.NS_PER_S
#: /clock: reliable (also serves rclpy's and rclcpp's best-effort clock subscriptions), newest only
CLOCK_QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)  # deep: see qos.CONTROL_PUB_QOS
COMMAND_TOPICS = ('robot_joint_commands', 'effort_controller/commands')
WARN_PERIOD_NS = NS   # throttled warnings: at most one per second of wall time
GRAPH_PERIOD = 0.1    # s of wall time between publisher counts on the command topics
PAUSED_STATE_PERIOD = 0.1   # s of wall time between re-published states while paused

_TYPES = {'bool': Parameter.Type.BOOL, 'double': Parameter.Type.DOUBLE, 'string': Parameter.Type.STRING,
          'double_array': Parameter.Type.DOUBLE_ARRAY, 'string_array': Parameter.Type.STRING_ARRAY}


_KIND_TEXT = {'bool': 'a bool', 'double': 'a double', 'string': 'a string', 'double_array': 'a list of doubles',
              'string_array': 'a list of strings'}


class BridgeParameterError(ValueError):
    """A bad start-up parameter; the message starts with its name."""


def _plain(value):
    """Parameter value -> plain Python (arrays as lists)."""
    if isinstance(value, (list, tuple)) or hasattr(value, 'tolist'):
        return list(value)
    return value


def make_world(cfg):
    """The World for a validated BridgeConfig (the only place that knows World's signature)."""
    from sim_bridge.world import World
    dist = None
    if np.any(cfg.disturbance_joint_torque) or np.any(cfg.disturbance_cartesian_force):
        dist = {'joint_torque': cfg.disturbance_joint_torque,
                'cartesian_force': cfg.disturbance_cartesian_force}
    surface = False
    if cfg.surface_enable:
        surface = dataclasses.replace(scenarios.get(cfg.scenario).surface, k_e=cfg.k_e, x_e=cfg.x_e)
    return World(cfg.scenario or None, gui=cfg.gui, dt=cfg.physics_step, params=cfg.sim_params or None,
                 urdf=cfg.urdf or None, joints=cfg.joints, q0=cfg.initial_positions, surface=surface,
                 disturbance=dist)


class SimBridge(Node):
    """The bridge node; `**kwargs` go to Node (context, parameter_overrides, cli_args, ...)."""

    def __init__(self, node_name='sim_bridge', *, world_factory=make_world, **kwargs):
        super().__init__(node_name, **kwargs)
        self._world = None
        self._values = {}
        self.cfg = self._declare_parameters()
        try:
            self._world = world_factory(self.cfg)
        except ValueError as exc:
            raise BridgeParameterError(str(exc)) from None
        cfg = self.cfg
        w = self._world
        self.joint_names = tuple(cfg.joints)
        n = len(self.joint_names)
        steady = Clock(clock_type=ClockType.STEADY_TIME)

        # -- preallocated messages: joint_states as serialized bytes (robot_control.ros.cdr: a few us, where
        # rclpy's conversion of a JointState costs tens), one Time shared by the other headers
        self._js_encoder = cdr.JointStateEncoder(self.joint_names)
        self._cmd_decoder = cdr.JointStateDecoder(arrays=False)          # efforts as floats: no numpy per tick
        self._stamp = conversions.ns_to_stamp(0)
        self._clock_msg = ClockMsg()
        self._clock_msg.clock = self._stamp
        self._wrench = WrenchStamped()
        self._wrench.header.stamp = self._stamp
        self._wrench.header.frame_id = cfg.wrench_frame_id
        self._force = self._wrench.wrench.force
        self._torque = self._wrench.wrench.torque

        # -- loop state
        self._mapper = CommandMapper(self.joint_names)
        self._have_cmd = False
        self._brake_reason = ''                           # '' = brakes released
        self._brake_events = 0
        self._paused = False
        self._pending = None                              # lockstep: answer stashed while paused
        self._ticks = 0
        self._republished = 0
        self._outdated_commands = 0                       # realtime: ignored, see _ignore_outdated
        self._wall_last_pub = 0
        self._reject_throttle = Throttle(WARN_PERIOD_NS)
        self._brake_throttle = Throttle(WARN_PERIOD_NS)
        self._watchdog = CommandWatchdog(cfg.command_timeout_ns)
        self._gate = LockstepGate()
        self._pacer = RealtimePacer(cfg.control_period_ns, cfg.real_time_factor)
        self._rate = RateMeter()
        self._achieved_rtf = None
        self._deadline = DeadlineMeter()

        # -- interfaces
        self._pub_clock = self.create_publisher(ClockMsg, '/clock', CLOCK_QOS)
        self._pub_js = self.create_publisher(JointState, 'joint_states', CONTROL_PUB_QOS)
        self._pub_wrench = self.create_publisher(WrenchStamped, 'ft_sensor/wrench', CONTROL_PUB_QOS)
        self._pub_diag = self.create_publisher(DiagnosticArray, '/diagnostics', DIAGNOSTICS_QOS)
        self._wrench_wanted = False                       # ft_sensor/wrench has a subscriber (see _publish_state)
        self._sub_js = self.create_subscription(JointState, COMMAND_TOPICS[0], self._on_joint_command_raw,
                                                CONTROL_QOS, raw=True)
        self._sub_array = self.create_subscription(Float64MultiArray, COMMAND_TOPICS[1], self._on_array_command,
                                                   CONTROL_QOS)
        self._subs = (self._sub_js, self._sub_array)
        self._guard = SourceGuard(cfg.command_timeout_ns, COMMAND_TOPICS)
        self._refresh_publisher_counts()
        self._graph_timer = self.create_timer(GRAPH_PERIOD, self._refresh_publisher_counts, clock=steady)
        self.create_service(Trigger, '~/reset', self._on_reset)
        self.create_service(SetBool, '~/pause', self._on_pause)
        self._diag_timer = self.create_timer(cfg.diagnostics_period, self._publish_diagnostics, clock=steady)
        if cfg.lockstep:
            self._pace_timer = self.create_timer(cfg.lockstep_timeout / 4.0, self._on_lockstep_timer, clock=steady)
        else:
            self._pace_timer = self.create_timer(self._realtime_timer_period(), self._on_realtime_timer,
                                                 clock=steady)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.add_post_set_parameters_callback(self._after_set_parameters)
        self._pending_cfg = None

        # -- first state
        self._restart_loop(cfg, w)
        self.get_logger().info(
            f'{cfg.scenario or cfg.urdf}: {n} joints {list(self.joint_names)}, {cfg.mode}, physics step '
            f'{cfg.physics_step} s, control period {cfg.control_period} s'
            + ('' if cfg.lockstep else f', real-time factor {cfg.real_time_factor}'))

    # -- parameters ---------------------------------------------------------------------------
    def _declare(self, spec):
        desc = ParameterDescriptor(description=spec.description, read_only=spec.read_only)
        try:
            if spec.default is None:
                self.declare_parameter(spec.name, _TYPES[spec.kind], desc)
            else:
                self.declare_parameter(spec.name, spec.default, desc)
            value = self.get_parameter(spec.name).value
        except ParameterUninitializedException:
            raise BridgeParameterError(f'{spec.name}: required for this robot') from None
        except InvalidParameterTypeException as exc:
            got = self._parameter_overrides.get(spec.name)
            got = f'{got.value!r} ({got.type_.name.lower()})' if got is not None else str(exc)
            raise BridgeParameterError(f'{spec.name}: expected {_KIND_TEXT[spec.kind]}, got {got}; '
                                       'YAML doubles need a decimal point, e.g. 1.0') from None
        except ParameterException as exc:
            raise BridgeParameterError(f'{spec.name}: {exc}') from None
        self._values[spec.name] = _plain(value)
        return self._values[spec.name]

    def _declare_parameters(self):
        try:
            for spec in bridge_params.robot_specs():
                self._declare(spec)
            scenario = bridge_params.check_scenario(self._values['scenario'])
            joints = bridge_params.check_joints(self._declare(bridge_params.joints_spec(scenario)))
            for spec in bridge_params.specs(scenario, len(joints)):
                self._declare(spec)
            known = set(self._parameters)
            unknown = sorted(set(self._parameter_overrides) - known)
            if unknown:
                raise ArgumentError(unknown[0], f'unknown parameter of {self.get_name()} '
                                 f'(known: {sorted(self._values)})')
            return bridge_params.validate(self._values)
        except BridgeParameterError:
            raise
        except ValueError as exc:
            raise BridgeParameterError(str(exc)) from None

    def _on_set_parameters(self, params):
        values = dict(self._values)
        for p in params:
            if p.name in values:
                values[p.name] = _plain(p.value)
        try:
            self._pending_cfg = (bridge_params.validate(values), values)
        except ValueError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _after_set_parameters(self, params):
        if self._pending_cfg is None:
            return
        old = self.cfg
        self.cfg, self._values = self._pending_cfg
        self._pending_cfg = None
        cfg = self.cfg
        self._watchdog.timeout_ns = cfg.command_timeout_ns
        self._guard.timeout_ns = cfg.command_timeout_ns
        if cfg.real_time_factor != old.real_time_factor:
            self._pacer.set_real_time_factor(cfg.real_time_factor, time.monotonic_ns(), self._ticks)
        if (not np.array_equal(cfg.disturbance_joint_torque, old.disturbance_joint_torque)
                or not np.array_equal(cfg.disturbance_cartesian_force, old.disturbance_cartesian_force)):
            self._world.set_disturbance(joint_torque=cfg.disturbance_joint_torque,
                                        cartesian_force=cfg.disturbance_cartesian_force)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        if cfg.diagnostics_period != old.diagnostics_period:
            self.destroy_timer(self._diag_timer)
            self._diag_timer = self.create_timer(cfg.diagnostics_period, self._publish_diagnostics, clock=steady)
        if cfg.lockstep and cfg.lockstep_timeout != old.lockstep_timeout:
            self.destroy_timer(self._pace_timer)
            self._pace_timer = self.create_timer(cfg.lockstep_timeout / 4.0, self._on_lockstep_timer, clock=steady)
        if not cfg.lockstep and cfg.real_time_factor != old.real_time_factor:
            self.destroy_timer(self._pace_timer)
            self._pace_timer = self.create_timer(self._realtime_timer_period(), self._on_realtime_timer,
                                                 clock=steady)

    def _realtime_timer_period(self):
        # one control tick of wall time, but no faster than 2 kHz: the pacer runs what is due
        return max(self.cfg.control_period / self.cfg.real_time_factor, 0.0005)

    # -- state out ----------------------------------------------------------------------------
    def _publish_state(self, in_loop=False):
        """Publish the tick's state: joint_states first (in lockstep the controller waits for it),
        after the tick's ft_sensor/wrench (the controller pairs them by stamp), then /clock.

        ft_sensor/wrench is VOLATILE: without a subscriber nobody misses it. `in_loop` (a tick of the
        running loop): whether it has one was counted after the previous state, off the loop's critical
        path (a count costs about 4 us there), so a subscriber that appears mid-run gets the wrench from
        the next tick on; a first or re-published state counts now."""
        w = self._world
        q, qd, tau = w.state_values()
        t = w.t_ns
        if not in_loop:
            self._wrench_wanted = self._pub_wrench.get_subscription_count() > 0
        if self._wrench_wanted:
            self._set_stamp(t)
            f, m = w.contact_wrench()
            force, torque = self._force, self._torque
            force.x, force.y, force.z = float(f[0]), float(f[1]), float(f[2])
            torque.x, torque.y, torque.z = float(m[0]), float(m[1]), float(m[2])
            self._pub_wrench.publish(self._wrench)
        self._pub_js.publish(self._js_encoder.encode(t, q, qd, tau))
        self._wall_last_pub = time.monotonic_ns()
        clock_ns = self.cfg.clock_period_ns
        if not clock_ns or t % clock_ns < self.cfg.control_period_ns:   # the tick that crosses a /clock period
            self._set_stamp(t)
            self._pub_clock.publish(self._clock_msg)
        self._deadline.state(t, self._wall_last_pub)
        self._wrench_wanted = self._pub_wrench.get_subscription_count() > 0    # for the next tick

    def _set_stamp(self, t_ns):
        """The Time shared by the /clock and ft_sensor/wrench messages."""
        self._stamp.sec, self._stamp.nanosec = units.split_ns(t_ns)

    def _step(self):
        """One control tick: hold the torque in force for control_period, publish the new state."""
        self._world.step(self.cfg.substeps)
        self._ticks += 1
        self._publish_state(in_loop=True)

    # -- commands in --------------------------------------------------------------------------
    def _on_joint_command_raw(self, data):
        """robot_joint_commands as DDS delivered it: decoded by robot_control.ros.cdr, or by rclpy when
        the fast decoder declines (e.g. big-endian CDR from another vendor)."""
        msg = self._cmd_decoder.decode(data)
        self._on_joint_command(deserialize_message(data, JointState) if msg is None else msg)

    def _on_joint_command(self, msg):
        stamp = msg.header.stamp
        t_cmd = stamp_ns(stamp.sec, stamp.nanosec)
        if self.cfg.lockstep:
            verdict = self._gate.classify(t_cmd)
            if verdict != LockstepGate.MATCH:
                if verdict == LockstepGate.LATE:      # answered twice: a re-published state or a 2nd controller
                    self._refresh_publisher_counts()
                self._guard.check(0, self._world.t_ns, t_cmd)
                return
            ok = self._guard.check(0, self._world.t_ns, t_cmd)
            if self._paused:
                self._pending = (msg, ok)
                return
            self._lockstep_answer(self._mapper.map_named(msg.name, msg.effort), ok)
        else:
            t = self._world.t_ns
            ok = self._guard.check(0, t, t_cmd)
            if self._watchdog.outdated(t, t_cmd):
                self._ignore_outdated(t_cmd, t)
                return
            reason = self._mapper.map_named(msg.name, msg.effort)
            if reason is None and ok:
                self._deadline.command(t_cmd, time.monotonic_ns())
            self._realtime_command(reason, ok)

    def _on_array_command(self, msg):
        ok = self._guard.check(1, self._world.t_ns)
        if self.cfg.lockstep:
            if self._paused:
                self._pending = (msg, ok)
                return
            self._lockstep_answer(self._mapper.map_array(msg.data), ok)
        else:
            self._realtime_command(self._mapper.map_array(msg.data), ok)

    def _map(self, msg):
        if isinstance(msg, Float64MultiArray):
            return self._mapper.map_array(msg.data)
        return self._mapper.map_named(msg.name, msg.effort)     # a JointState or a cdr.JointStateFrame

    def _reject(self, reason):
        if self._reject_throttle.ready(time.monotonic_ns()):
            self.get_logger().warning(
                f'rejected command: {reason}; {self._mapper.rejected_total} rejected so far; '
                f'{"the last valid command stays" if self._have_cmd else "the brakes stay"} in force')

    def _ignore_outdated(self, t_cmd, t):
        """Realtime: a command answering a state more than command_timeout old is never applied."""
        self._outdated_commands += 1
        if self._reject_throttle.ready(time.monotonic_ns()):
            self.get_logger().warning(
                f'ignored a command answering the state of t = {t_cmd / NS:.3f} s at t = {t / NS:.3f} s '
                f'(older than command_timeout = {self.cfg.command_timeout} s); {self._outdated_commands} so far')

    def _lockstep_answer(self, reason, ok):
        if reason is not None:
            self._reject(reason)
        if not ok:
            self._set_brakes('publisher conflict: ' + self._guard.reason)
        elif reason is None:
            self._have_cmd = True
            if self._brake_reason:
                self._set_brakes('')
            else:
                self._world.hold_torque(self._mapper.values)
        elif not self._have_cmd:
            self._set_brakes('no valid command yet')
        self._step()
        self._gate.expected_ns = self._world.t_ns

    def _realtime_command(self, reason, ok):
        if reason is not None:
            self._reject(reason)
            return
        t = self._world.t_ns
        if not ok:
            self._update_brakes(t)
            return
        self._watchdog.fresh(t)
        self._have_cmd = True
        if self._brake_reason:
            self._update_brakes(t)
        if not self._brake_reason:
            self._world.hold_torque(self._mapper.values)

    # -- brakes -------------------------------------------------------------------------------
    def _update_brakes(self, t_ns, log=True):
        """Realtime: brakes on while mixing is seen or the command is stale, else off."""
        if self._guard.in_conflict(t_ns):
            reason = 'publisher conflict: ' + self._guard.reason
        elif self._watchdog.stale(t_ns):
            reason = ('no command yet' if self._watchdog.last_ns is None
                      else f'stale command (none valid for more than command_timeout = {self.cfg.command_timeout} s)')
        else:
            reason = ''
        if reason != self._brake_reason:
            self._set_brakes(reason, log)

    def _set_brakes(self, reason, log=True):
        was = bool(self._brake_reason)
        self._brake_reason = reason
        on = bool(reason)
        if on == was:
            if on and log and self._brake_throttle.ready(time.monotonic_ns()):
                self.get_logger().warning(f'brakes stay engaged at t = {self._world.t_ns / NS:.3f} s: {reason}')
            return
        self._world.brake(on)
        if not on:
            self._world.hold_torque(self._mapper.values)
        self._brake_events += 1
        if log and self._brake_throttle.ready(time.monotonic_ns()):
            if on:
                self.get_logger().warning(f'brakes engaged at t = {self._world.t_ns / NS:.3f} s: {reason}')
            else:
                self.get_logger().info(f'brakes released at t = {self._world.t_ns / NS:.3f} s: fresh command')
        self._publish_diagnostics()

    # -- pacing -------------------------------------------------------------------------------
    def _on_realtime_timer(self):
        if self._paused:
            self._heartbeat()
            return
        due = self._pacer.due(time.monotonic_ns(), self._ticks)
        w = self._world
        for _ in range(due):
            t = w.t_ns
            if self._brake_reason or self._watchdog.stale(t) or self._guard.in_conflict(t):
                self._update_brakes(t)
            self._deadline.step(t)
            self._step()

    def _on_lockstep_timer(self):
        if self._paused:
            self._heartbeat()
        elif time.monotonic_ns() - self._wall_last_pub >= self.cfg.lockstep_timeout * NS:
            self._republished += 1
            self._publish_state()

    def _heartbeat(self):
        """Paused: re-publish the unchanged state every PAUSED_STATE_PERIOD of wall time.

        A paused robot is a live robot standing still: the controller keeps answering (in lockstep
        the first answer is kept for the resume) and its wall-clock watchdog does not trip.
        """
        if time.monotonic_ns() - self._wall_last_pub >= PAUSED_STATE_PERIOD * NS:
            self._publish_state()

    # -- services -----------------------------------------------------------------------------
    def _on_pause(self, request, response):
        t = self._world.t_ns / NS
        if bool(request.data) == self._paused:
            response.success = True
            response.message = f'already {"paused" if self._paused else "running"} at t = {t:.3f} s'
            return response
        self._paused = bool(request.data)
        if self._paused:
            response.message = f'paused at t = {t:.3f} s'
        else:
            response.message = f'resumed at t = {t:.3f} s'
            if self.cfg.lockstep:
                pending, self._pending = self._pending, None
                if pending is not None:
                    msg, ok = pending
                    self._lockstep_answer(self._map(msg), ok)
                else:
                    self._publish_state()
            else:
                now = time.monotonic_ns()
                self._pacer.anchor(now, self._ticks)
                self._rate.reset(now, self._world.t_ns)
        response.success = True
        self.get_logger().info(response.message)
        self._publish_diagnostics()
        return response

    def _on_reset(self, request, response):
        w = self._world
        w.reset()                                         # keeps the disturbance in force
        cfg = self.cfg
        self._ticks = 0
        self._mapper.clear()
        self._have_cmd = False
        self._pending = None
        self._watchdog.clear()
        self._guard.reset()
        # the rebuilt world has no brakes; put them back as the loop expects
        self._brake_reason = ''
        self._restart_loop(cfg, w)
        response.success = True
        response.message = f'world rebuilt, t = {w.t_ns / NS:.3f} s'
        self.get_logger().info(response.message)
        return response

    # -- diagnostics --------------------------------------------------------------------------
    def _refresh_publisher_counts(self):
        # realtime: commands had come and stopped (stale): a publisher appearing now replaces a dead one
        # (a SIGKILLed controller stays in the graph for its DDS lease) and is not refused as a second one
        t = self._world.t_ns
        silent = not self.cfg.lockstep and self._watchdog.last_ns is not None and self._watchdog.stale(t)
        for i, sub in enumerate(self._subs):
            self._guard.set_count(i, self.count_publishers(sub.topic_name), silent=silent)

    def _publish_diagnostics(self):
        cfg, w = self.cfg, self._world
        t = w.t_ns
        wall = time.monotonic_ns()
        if not cfg.lockstep and not self._paused:
            rtf = self._rate.read(wall, t)
            if rtf is not None:
                self._achieved_rtf = rtf
        self._refresh_publisher_counts()
        counts = self._guard.counts
        hw = cfg.scenario or cfg.urdf
        m = self._mapper
        pacing = {
            'mode': cfg.mode, 'sim_time': t / NS, 'paused': self._paused, 'control_ticks': self._ticks,
            'physics_step': cfg.physics_step, 'control_period': cfg.control_period,
        }
        if cfg.lockstep:
            pacing.update({'republished_states': self._republished, 'late_commands': self._gate.late,
                           'future_commands': self._gate.future})
            pacing_level, pacing_msg = 'OK', 'lockstep'
        else:
            pacing.update({'real_time_factor': cfg.real_time_factor,
                           'achieved_real_time_factor': self._achieved_rtf if self._achieved_rtf else 'n/a',
                           'overruns': self._pacer.overruns,
                           'deadline_hits': self._deadline.hits, 'deadline_misses': self._deadline.misses,
                           'latency_p50_ms': self._deadline.latency_ms(50) or 'n/a',
                           'latency_p99_ms': self._deadline.latency_ms(99) or 'n/a'})
            pacing_level, pacing_msg = 'OK', f'realtime x{cfg.real_time_factor}'
            if self._pacer.overruns:
                pacing_level, pacing_msg = 'WARN', f'{pacing_msg}: {self._pacer.overruns} overruns (stalls > 0.1 s)'
        if self._paused:
            pacing_msg += ', paused'
        cmd_values = {'accepted': m.accepted, 'rejected': m.rejected_total}
        cmd_values.update({f'rejected_{k}': v for k, v in m.rejected.items()})
        cmd_values['last_reject_reason'] = m.last_reason
        age = self._watchdog.age_ns(t)
        cmd_values['command_age'] = 'n/a' if (cfg.lockstep or age is None) else age / NS
        cmd_values['command_timeout'] = cfg.command_timeout
        cmd_values['outdated_commands'] = self._outdated_commands
        for topic, count in zip(COMMAND_TOPICS, counts):
            cmd_values[f'publishers {topic}'] = count
        cmd_values['publisher_conflicts'] = self._guard.conflicts
        conflict = self._guard.in_conflict(t)
        dup = [f'{c} publishers on {topic}' for topic, c in zip(COMMAND_TOPICS, counts) if c > 1]
        if conflict:
            cmd_level, cmd_msg = 'ERROR', f'refusing to mix commands: {self._guard.reason}'
        elif dup:
            cmd_level, cmd_msg = 'WARN', 'duplicate publishers: ' + '; '.join(dup)
        elif m.rejected_total:
            cmd_level, cmd_msg = 'WARN', f'{m.rejected_total} commands rejected, last: {m.last_reason}'
        else:
            cmd_level, cmd_msg = 'OK', f'{m.accepted} commands accepted'
        brake_values = {'engaged': bool(self._brake_reason), 'reason': self._brake_reason,
                        'events': self._brake_events}
        brake_level = 'WARN' if self._brake_reason else 'OK'
        brake_msg = f'engaged: {self._brake_reason}' if self._brake_reason else 'released'
        statuses = [
            conversions.diagnostic_status(f'{self.get_name()}: pacing', pacing_level, pacing_msg, pacing, hw),
            conversions.diagnostic_status(f'{self.get_name()}: commands', cmd_level, cmd_msg, cmd_values, hw),
            conversions.diagnostic_status(f'{self.get_name()}: brakes', brake_level, brake_msg, brake_values, hw),
        ]
        self._pub_diag.publish(conversions.diagnostic_array(statuses, t))

    # -- introspection for tests and tools ------------------------------------------------------
    @property
    def world(self):
        return self._world

    @property
    def brakes_engaged(self):
        return bool(self._brake_reason)

    @property
    def brake_reason(self):
        return self._brake_reason

    @property
    def paused(self):
        return self._paused

    @property
    def rejected(self):
        return dict(self._mapper.rejected)

    def _restart_loop(self, cfg, w):
        """Start pacing from the world's current time and publish its first state (start-up, reset)."""
        if not cfg.lockstep:
            self._update_brakes(w.t_ns, log=False)
            now = time.monotonic_ns()
            self._pacer.anchor(now, 0)
            self._rate.reset(now, w.t_ns)
        self._gate.expect(w.t_ns)
        self._publish_state()

    def destroy_node(self):
        world, self._world = self._world, None
        if world is not None and hasattr(world, 'close'):
            world.close()
        return super().destroy_node()


def _parse_args(argv):
    import argparse
    parser = argparse.ArgumentParser(
        prog='sim_bridge_node', description='PyBullet simulation of a robot_control scenario as a ROS 2 robot.',
        epilog='ROS arguments follow --ros-args, e.g. --ros-args --params-file config/polar_two_link.yaml '
               '-p mode:=lockstep')
    parser.add_argument('--executor', choices=('events', 'single'), default='events',
                        help='rclpy executor: events (C++ EventsExecutor, fastest; default) or single '
                             '(SingleThreadedExecutor)')
    return parser.parse_args(argv)


def main(args=None):
    """Entry point of `sim_bridge_node` and `python -m sim_bridge.bridge_node`; returns the exit code."""
    argv = sys.argv if args is None else args
    opts = _parse_args(rclpy.utilities.remove_ros_args(argv)[1:])
    return spin.run_node(argv, SimBridge, opts.executor, startup_errors=(BridgeParameterError,),
                         startup_message='bad parameter:', startup_code=2)


if __name__ == '__main__':
    sys.exit(main())
