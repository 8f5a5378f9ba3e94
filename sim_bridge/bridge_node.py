"""sim_bridge node: the PyBullet World as a ROS 2 robot. The decisions (pacing, lockstep handshake,
brakes, pause and reset, refused sources, diagnostics content) are sim_bridge.bridge_loop.BridgeLoop's;
this node translates messages to and from it.

Publishes `/clock` (rosgraph_msgs/Clock, every clock_period of simulation time), `joint_states`
(sensor_msgs/JointState: position, velocity, effort = the joint torque a link-side torque sensor
measures, i.e. the actuator torque applied less the drive's friction and rotor inertia;
header.stamp = the simulation time of the measurement), `ft_sensor/wrench`
(geometry_msgs/WrenchStamped: force and torque the robot exerts on the surface, world axes, frame
`wrench_frame_id`; only while it has a subscriber), both as the robot's driver delivers them (noise,
encoder counts, bias, measurement delay: sim_bridge.sensors; by default exactly as simulated), and
`/diagnostics` (statuses `<node name>: pacing`, `: commands`, `: brakes`, hardware_id the scenario
or URDF, stamped with simulation time; every diagnostics_period and at once when the brakes
change) and `robot_description` (std_msgs/String, transient local: the URDF of the simulated robot,
as robot_state_publisher offers it). Subscribes `robot_joint_commands` (sensor_msgs/JointState, names + efforts, joints
matched by name) and `effort_controller/commands` (std_msgs/Float64MultiArray in `joints` order).
Services `~/reset` (std_srvs/Trigger) and `~/pause` (std_srvs/SetBool). The publishers on the
command topics are counted every 0.1 s of wall time. The node never reads a parameter in the
loop: it works on a validated snapshot (sim_bridge.bridge_params.BridgeConfig) that the parameter
callbacks replace.

QoS: joint_states, ft_sensor/wrench and both command topics robot_control.ros.qos.CONTROL_QOS
(RELIABLE, KEEP_LAST 1, VOLATILE); /clock RELIABLE KEEP_LAST 1 (serves best-effort clock
subscribers too); /diagnostics DIAGNOSTICS_QOS (RELIABLE, KEEP_LAST 10). Timers run on the
steady clock, so `use_sim_time: true` given to this node by a shared YAML is harmless.

Speed: robot_joint_commands is taken as serialized bytes and read by robot_control.ros.cdr (rclpy
decodes what that declines); joint_states and ft_sensor/wrench are preallocated serialized messages
written from the World's state as floats. joint_states goes out before /clock and the bookkeeping.

`main` spins rclpy's C++ EventsExecutor by default (`--executor single` for the Python one); `--help`
lists the parameters with their units and defaults; exit statuses as robot_control.ros.entry.
"""
import sys
import time

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from rclpy.clock import Clock, ClockType
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String
from std_srvs.srv import SetBool, Trigger

from robot_control import units
from robot_control.ros import cdr, conversions, entry
from robot_control.ros.param_engine import ParameterEngine, ParameterNode
from robot_control.ros.qos import CONTROL_PUB_QOS, CONTROL_QOS, DESCRIPTION_QOS, DIAGNOSTICS_QOS
from robot_control.validation import ArgumentError
from sim_bridge import bridge_params
from sim_bridge.bridge_loop import COMMAND_TOPICS, make_loop
from sim_bridge.engines import world_of_config as make_world

stamp_ns = units.stamp_ns
#: /clock: reliable (also serves rclpy's and rclcpp's best-effort clock subscriptions), newest only
CLOCK_QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)  # deep: see qos.CONTROL_PUB_QOS
GRAPH_PERIOD = 0.1    # s of wall time between publisher counts on the command topics

class SimBridge(ParameterNode):
    """The bridge node; `**kwargs` go to Node (context, parameter_overrides, cli_args, ...).

    Raises ParameterError naming the parameter when the start-up parameters are invalid.
    """

    def __init__(self, node_name='sim_bridge', *, world_factory=make_world, **kwargs):
        super().__init__(node_name, **kwargs)
        self._world = None
        try:
            self._params = ParameterEngine(self, bridge_params.TABLE, bridge_params.build,
                                           apply=self._apply_parameters)
            self.cfg = self._params.current.config
            try:
                self._world = world_factory(self.cfg)
            except ArgumentError as exc:        # the World's argument names, mapped to the parameters
                raise self._params.error(exc) from None
        except BaseException:
            self.destroy_node()
            raise
        cfg = self.cfg
        self.joint_names = tuple(cfg.joints)
        self._make_messages(cfg)
        self._make_interfaces()
        self._loop = make_loop(self._world, cfg, publish_state=self._publish_state,
                               count_publishers=self._count_command_publishers,
                               publish_diagnostics=self._publish_diagnostics, log=self._log,
                               restart_timer=self._restart_pace_timer)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._graph_timer = self.create_timer(GRAPH_PERIOD, self._loop.refresh_publisher_counts, clock=steady)
        self._diag_timer = self.create_timer(cfg.diagnostics_period, self._publish_diagnostics, clock=steady)
        if cfg.lockstep:
            self._pace_timer = self.create_timer(cfg.lockstep_timeout / 4.0, self._loop.on_timer, clock=steady)
        else:
            self._pace_timer = self.create_timer(self._realtime_timer_period(), self._loop.on_timer, clock=steady)
        self._loop.start()
        self.get_logger().info(
            f'{cfg.scenario or cfg.urdf}: {cfg.n} joints {list(self.joint_names)} on {cfg.engine}, {cfg.mode}, '
            f'physics step {cfg.physics_step} s, control period {cfg.control_period} s'
            + ('' if cfg.lockstep else f', real-time factor {cfg.real_time_factor}'))
        for line in self._world.report:            # the URDF's warnings, physics unlike the URDF's
            self.get_logger().warn(line)

    def _make_messages(self, cfg):
        """Preallocated messages: joint_states and ft_sensor/wrench as serialized bytes (robot_control.ros.cdr,
        cheaper than rclpy's conversion of a message), the Time of /clock."""
        self._js_encoder = cdr.JointStateEncoder(self.joint_names)
        self._cmd_decoder = cdr.JointStateDecoder(arrays=False)          # efforts as floats: no numpy per tick
        self._stamp = conversions.ns_to_stamp(0)
        self._clock_msg = ClockMsg()
        self._clock_msg.clock = self._stamp
        self._wrench_encoder = cdr.WrenchEncoder(cfg.wrench_frame_id)

    def _make_interfaces(self):
        self._pub_clock = self.create_publisher(ClockMsg, '/clock', CLOCK_QOS)
        self._pub_js = self.create_publisher(JointState, 'joint_states', CONTROL_PUB_QOS)
        self._pub_wrench = self.create_publisher(WrenchStamped, 'ft_sensor/wrench', CONTROL_PUB_QOS)
        self._pub_diag = self.create_publisher(DiagnosticArray, '/diagnostics', DIAGNOSTICS_QOS)
        self._wrench_wanted = False                       # ft_sensor/wrench has a subscriber (see _publish_state)
        self._subs = (
            self.create_subscription(JointState, COMMAND_TOPICS[0], self._on_joint_command, CONTROL_QOS, raw=True),
            self.create_subscription(Float64MultiArray, COMMAND_TOPICS[1], self._on_array_command, CONTROL_QOS))
        self.create_service(Trigger, '~/reset', self._on_reset)
        self.create_service(SetBool, '~/pause', self._on_pause)
        # the URDF of the simulated robot, as robot_state_publisher would offer it (transient local)
        self._pub_description = self.create_publisher(String, 'robot_description', DESCRIPTION_QOS)
        with open(self._world.urdf, encoding='utf-8') as f:
            self._pub_description.publish(String(data=f.read()))

    # -- parameters ---------------------------------------------------------------------------
    def _apply_parameters(self, old, new, changed):
        """After the engine committed a run-time change: the new BridgeConfig in force (`old`, `new`:
        Snapshots before and after)."""
        old, cfg = old.config, new.config
        self.cfg = cfg
        self._loop.configure(cfg)
        if cfg.friction != old.friction:
            self._world.set_friction(cfg.friction)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        if cfg.diagnostics_period != old.diagnostics_period:
            self.destroy_timer(self._diag_timer)
            self._diag_timer = self.create_timer(cfg.diagnostics_period, self._publish_diagnostics, clock=steady)
        if cfg.lockstep and cfg.lockstep_timeout != old.lockstep_timeout:
            self.destroy_timer(self._pace_timer)
            self._pace_timer = self.create_timer(cfg.lockstep_timeout / 4.0, self._loop.on_timer, clock=steady)
        if not cfg.lockstep and cfg.real_time_factor != old.real_time_factor:
            self.destroy_timer(self._pace_timer)
            self._pace_timer = self.create_timer(self._realtime_timer_period(), self._loop.on_timer, clock=steady)

    def _restart_pace_timer(self):
        """The loop anchored its pacing: the pacing timer's calls follow from now (see BridgeLoop)."""
        self._pace_timer.reset()

    def _realtime_timer_period(self):
        # one control tick of wall time, but no faster than 2 kHz: the loop runs what is due
        return max(self.cfg.control_period / self.cfg.real_time_factor, 0.0005)

    # -- out: what the loop asks for -------------------------------------------------------------
    def _publish_state(self, in_loop, with_clock):
        """Publish the measured state (the loop's `measured`: the World's readings as its driver delivers them,
        sim_bridge.sensors, stamped when measured): the tick's ft_sensor/wrench (the controller pairs them by
        stamp), joint_states (in lockstep the controller waits for it), then /clock (the World's time) when
        `with_clock`; returns the wall time (ns) at which joint_states went out.

        ft_sensor/wrench is VOLATILE: without a subscriber nobody misses it. `in_loop` (a tick of the
        running loop): whether it has one was counted after the previous state, off the loop's critical
        path (a count is a query of the ROS graph), so a subscriber that appears mid-run gets the wrench from
        the next tick on; a first or re-published state counts now."""
        m = self._loop.measured
        q, qd, tau = m.state_values()
        t = m.t_ns
        if not in_loop:
            self._wrench_wanted = self._pub_wrench.get_subscription_count() > 0
        if self._wrench_wanted:
            self._pub_wrench.publish(self._wrench_encoder.encode(t, *m.contact_wrench()))
        self._pub_js.publish(self._js_encoder.encode(t, q, qd, tau))
        wall = time.monotonic_ns()
        if with_clock:
            self._set_stamp(self._world.t_ns)
            self._pub_clock.publish(self._clock_msg)
        self._wrench_wanted = self._pub_wrench.get_subscription_count() > 0    # for the next tick
        return wall

    def _set_stamp(self, t_ns):
        """The Time of the /clock message."""
        self._stamp.sec, self._stamp.nanosec = units.split_ns(t_ns)

    def _publish_diagnostics(self):
        hw = self.cfg.scenario or self.cfg.urdf
        statuses = [conversions.diagnostic_status(f'{self.get_name()}: {s.name}', s.level, s.message, s.values, hw)
                    for s in self._loop.diagnostics()]
        self._pub_diag.publish(conversions.diagnostic_array(statuses, self._world.t_ns))

    def _count_command_publishers(self):
        return [self.count_publishers(sub.topic_name) for sub in self._subs]

    def _log(self, level, text):
        # one call site per severity: rclpy's logger refuses a second severity from the same line
        if level == 'warning':
            self.get_logger().warning(text)
        else:
            self.get_logger().info(text)

    # -- in: messages, timers, services ----------------------------------------------------------
    def _on_joint_command(self, data):
        """robot_joint_commands as DDS delivered it: decoded by robot_control.ros.cdr, or by rclpy when
        the fast decoder declines (e.g. big-endian CDR from another vendor)."""
        msg = self._cmd_decoder.decode(data)
        if msg is None:
            msg = deserialize_message(data, JointState)
        stamp = msg.header.stamp
        self._loop.on_joint_command(stamp_ns(stamp.sec, stamp.nanosec), msg.name, msg.effort)

    def _on_array_command(self, msg):
        self._loop.on_array_command(msg.data)

    def _on_pause(self, request, response):
        response.message = self._loop.pause(bool(request.data))
        response.success = True
        return response

    def _on_reset(self, request, response):
        response.message = self._loop.reset()
        response.success = True
        return response

    # -- introspection for tests and tools --------------------------------------------------------
    @property
    def world(self):
        return self._world

    @property
    def loop(self):
        """The bridge_loop.LockstepLoop or RealtimeLoop that decides (counters, mapper, lockstep gate)."""
        return self._loop

    @property
    def brakes_engaged(self):
        return self._loop.brakes_engaged

    @property
    def brake_reason(self):
        return self._loop.brake_reason

    @property
    def paused(self):
        return self._loop.paused

    @property
    def rejected(self):
        return dict(self._loop.mapper.rejected)

    def destroy_node(self):
        world, self._world = self._world, None
        if world is not None and hasattr(world, 'close'):
            world.close()
        return super().destroy_node()


ENTRY = entry.Entry('sim_bridge_node', 'PyBullet simulation of a robot_control scenario as a ROS 2 robot.', SimBridge,
                    bridge_params.TABLE, example='--params-file config/polar_two_link.yaml -p mode:=lockstep')


def main(args=None):
    """Entry point of `sim_bridge_node` and `python -m sim_bridge.bridge_node`: spin until Ctrl-C / SIGTERM
    (exit 0); 2 on a bad parameter (robot_control.ros.entry)."""
    return ENTRY.main(args)


if __name__ == '__main__':
    sys.exit(main())
