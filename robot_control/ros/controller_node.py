"""controller_node: the robot_control controller as a managed (lifecycle) ROS 2 node.

Topics (names relative, remappable; QoS from robot_control.ros.qos):
  sub joint_states                sensor_msgs/JointState       CONTROL_QOS   robot state, by name
  sub ~/joint_trajectory          trajectory_msgs/JointTrajectory REFERENCE_QOS joint reference
  sub ~/wrench_reference          geometry_msgs/WrenchStamped  REFERENCE_QOS desired force (force axes);
                                                                             stamped ahead: applied from that time
                                                                             (dropped if time goes back first)
  sub ft_sensor/wrench            geometry_msgs/WrenchStamped  CONTROL_QOS   measured contact force
  sub robot_description           std_msgs/String              transient local: the URDF, when model is
                                                                             'urdf' and neither urdf nor
                                                                             robot_description is given
  pub robot_joint_commands        sensor_msgs/JointState       CONTROL_QOS   name + effort
  pub effort_controller/commands  std_msgs/Float64MultiArray   CONTROL_QOS   if publish_effort_array
  pub ~/reference                 sensor_msgs/JointState       REFERENCE_QOS reference of the tick
  pub ~/error                     sensor_msgs/JointState       REFERENCE_QOS tracking error of the tick
  pub /diagnostics                diagnostic_msgs/DiagnosticArray DIAGNOSTICS_QOS  every diagnostics_period
  srv ~/identify_payload          std_srvs/Trigger             identify the tip's payload, set payload.mass
                                                                             and payload.com (robot_control.ros.payload_service)

Event-driven: while active, each valid joint_states message gets exactly one command, computed
from the reference sampled at that message's header.stamp and stamped with the same stamp. An
invalid one (a controlled joint missing, duplicate names, position/velocity lengths not matching
name, NaN/inf in a controlled joint) gets no command, a count and a reason on /diagnostics and a
throttled warning. Names that are not controlled are ignored.

~/reference and ~/error carry, per entry of the law's space (the joints, the task axes of hybrid,
the force axis of force): ~/reference position = q_d | x_d | f_d, velocity = its rate, effort = its
second derivative; ~/error position = E, velocity = Ed, effort = the error integral (zeros without
integral action). On force axes the values are forces (N, N/s, N/s^2, N s).

Trajectories on ~/joint_trajectory, as joint_trajectory_controller takes them: names in any order;
the first point may be at 0 s; header.stamp 0 starts now, a later stamp then, a past one as if the
trajectory began then; an empty trajectory cancels the motion and holds the current position;
allow_partial_joints_goal lets a goal leave joints out (they hold); the constraints.* parameters
give goal and path tolerances (a violation holds the position and reports ERROR); a path beyond the
URDF's position or velocity limits is refused.

Lifecycle (rclpy.lifecycle): parameters are declared and checked when the node is created;
configure builds the model and the controller (a ControllerSession, robot_control.ros.
controller_session) and checks the parameters that depend on the model; activate starts commanding
from the current state (the reference holds where the robot is: no torque jump); deactivate stops
commanding (the robot's driver then falls back on its command timeout: the simulation bridge
engages its brakes in realtime mode and waits in lockstep mode); cleanup and shutdown release
everything. With autostart (default true) the node configures and activates itself, so `ros2 run`
starts a controller; a bad parameter then ends the process with status 2 (robot_control.ros.entry).

Parameters: the table robot_control.ros.controller_params, declared and checked by the parameter engine
(robot_control.ros.param_engine; a refusal's reason names the parameter), built into a
ControllerConfig by robot_control.ros.config_builder; a run-time change is applied by swapping
the core's configuration. A start-up parameter the controller does not have is refused.

Run: python -m robot_control.ros.controller_node --ros-args --params-file config/polar_two_link.yaml
(--help lists the parameters with their units and defaults.)
"""
import sys

from rclpy.lifecycle import LifecycleNode, TransitionCallbackReturn
from std_msgs.msg import String

from robot_control.ros import controller_params as params, entry
from robot_control.ros.config_builder import ConfigBuilder
from robot_control.ros.controller_session import ControllerSession
from robot_control.ros.param_engine import ParameterEngine, ParameterNode
from robot_control.param_table import ParameterError
from robot_control.ros.qos import DESCRIPTION_QOS


class ControllerNode(ParameterNode, LifecycleNode):
    """The robot_control controller (any law of robot_control.laws.LAWS), a managed node.

    kwargs go to rclpy.node.Node (context=, parameter_overrides=, cli_args=, ...). Raises
    ParameterError naming the parameter when the start-up parameters are invalid (with autostart,
    also those that configure checks).
    """

    def __init__(self, node_name='controller', **kwargs):
        super().__init__(node_name, **kwargs)
        self.session = None
        self._error = None
        self._description_sub = None
        try:
            self._builder = ConfigBuilder()
            self._params = ParameterEngine(self, params.TABLE, self._builder, apply=self._apply_parameters,
                                           deferred=True)
            self._autostart = self._params.current.values['autostart']
            if self._needs_description():
                self._description_sub = self.create_subscription(String, 'robot_description', self._on_description,
                                                                 DESCRIPTION_QOS)
                self.get_logger().info('waiting for the URDF on robot_description')
            elif self._autostart:
                self._start()
        except BaseException:
            self.destroy_node()
            raise

    # -- public for tests and tools ----------------------------------------------------------------
    @property
    def core(self):
        """The ControllerCore of the configured controller (None while unconfigured)."""
        return None if self.session is None else self.session.core

    @property
    def counters(self):
        """Commands sent, trajectories accepted, rejected inputs (robot_control.core.status.Counters)."""
        return self.session.counters

    @property
    def watchdog_tripped(self):
        return self.session.watchdog.tripped

    @property
    def trips(self):
        return self.session.watchdog.trips

    @property
    def wrench_received(self):
        return self.session.counters.wrench_seen

    @property
    def rejected(self):
        return self.session.counters.rejected

    @property
    def last_rejection(self):
        return self.session.counters.last_rejection

    @property
    def commands_sent(self):
        return self.session.counters.commands_sent

    @property
    def trajectories_accepted(self):
        return self.session.counters.trajectories_accepted

    def diagnostics(self):
        """The DiagnosticStatus list /diagnostics carries now."""
        return self.session.diagnostics()

    # -- robot_description ---------------------------------------------------------------------------
    def _needs_description(self):
        values = self._params.current.values
        return values['model'] == 'urdf' and not values['urdf'] and not values['robot_description']

    def _on_description(self, msg):
        """The URDF from robot_description: the model of the next configure (autostart: configure now)."""
        first = self._builder.description is None
        self._builder.description = msg.data
        self.get_logger().info(f'robot_description received ({len(msg.data)} characters)')
        if first and self._autostart and self.session is None:
            try:
                self._start()
            except ParameterError as exc:
                self.get_logger().error(entry.bad_parameter(exc))

    # -- lifecycle -------------------------------------------------------------------------------------
    def _start(self):
        """autostart: configure and activate; a configure failure raises its ParameterError."""
        self.trigger_configure()
        if self.session is None:
            raise self._error
        self.trigger_activate()

    def on_configure(self, state):
        try:
            if self._needs_description() and self._builder.description is None:
                raise ParameterError('robot_description', 'no URDF received on the robot_description topic yet')
            snapshot = self._params.configure()
        except ParameterError as exc:
            self._error = exc
            self.get_logger().error(f'configure failed: {exc}')
            return TransitionCallbackReturn.FAILURE
        self.session = ControllerSession(self, snapshot)
        cfg = snapshot.config
        self._params.report(params.gains_in_force(cfg))
        self.get_logger().info(
            f'ready: law {cfg.law}{" (PID)" if cfg.integral else ""}, model {snapshot.values["model"]}, '
            f'joints {list(cfg.joints)}, force axes {list(cfg.control_law.force_task.force_axes)}, '
            f'kp {list(params.gains_in_force(cfg)["gains.kp"])}')
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state):
        self.session.activate()
        self.get_logger().info('active: commanding from the next joint_states on, from where the robot is')
        return super().on_activate(state)

    def on_deactivate(self, state):
        self.session.deactivate()
        self.get_logger().info('inactive: not commanding')
        return super().on_deactivate(state)

    def on_cleanup(self, state):
        self._release()
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state):
        self._release()
        return TransitionCallbackReturn.SUCCESS

    def destroy_node(self):
        """Release the session (its interfaces, the ~/identify_payload helper and its thread), then the node."""
        if self.session is not None:
            self.session.destroy()
            self.session = None
        super().destroy_node()

    def _release(self):
        if self.session is not None:
            self.session.destroy()
            self.session = None
        self._params.release()

    # -- parameters ------------------------------------------------------------------------------------
    def _apply_parameters(self, old, snapshot, changed):
        """After the engine committed a run-time change: the controller's new configuration (when configured)."""
        if self.session is not None:
            self.session.apply(old, snapshot, changed)
            self._params.report(params.gains_in_force(snapshot.config))
        self.get_logger().info(f'parameters set: {sorted(changed)}')


ENTRY = entry.Entry('controller_node', 'robot_control controller node.', ControllerNode, params.TABLE,
                    example='--params-file config/polar_two_link.yaml')


def main(args=None):
    """Entry point: spin the controller until Ctrl-C / SIGTERM (exit 0); 2 on a bad parameter
    (robot_control.ros.entry)."""
    return ENTRY.main(args)


if __name__ == '__main__':
    sys.exit(main())
