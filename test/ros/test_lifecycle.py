"""The managed controller: lifecycle transitions in-process, and the model from robot_description.

A fresh context per test; the controller and a 'robot' node (tests/ros/test_controller_node.Robot)
in one executor with deadlines.
"""
import numpy as np
from lifecycle_msgs.msg import State
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_msgs.msg import String

from robot_control import urdf
from robot_control.ros.controller_node import ControllerNode
from robot_control.ros.qos import DESCRIPTION_QOS
from test_controller_node import DEADLINE, POLAR, POLAR_JOINTS, T0_NS, DT_NS, Robot, spin_until
from rclpy.executors import SingleThreadedExecutor


def _rig(context, **params):
    ctrl = ControllerNode(context=context, parameter_overrides=[Parameter(k, value=v) for k, v in params.items()])
    robot = Robot(context)
    ex = SingleThreadedExecutor(context=context)
    ex.add_node(ctrl)
    ex.add_node(robot.node)
    return ex, ctrl, robot


def _close(ex, *nodes):
    ex.shutdown()
    for node in nodes:
        node.destroy_node()


def _answered(ex, robot, stamp, q, timeout=DEADLINE):
    """Publish a state stamped `stamp` until answered or `timeout` (generous when an answer is expected; a
    check that none comes passes its own short one, which load cannot turn into a failure); True when a
    command came."""
    msg = robot.state(POLAR_JOINTS, q, np.zeros(2), stamp)
    return spin_until(ex, lambda: stamp in robot.commands, timeout, every=0.05,
                      action=lambda: robot.state_pub.publish(msg))


def _state_id(ctrl):
    return ctrl._state_machine.current_state[0]


def test_autostart_false_walks_the_lifecycle_by_hand(ros_context):
    """unconfigured -> configure (inactive: no command) -> activate (commands, from where the robot is)
    -> deactivate (no command) -> cleanup (no command publisher left) -> shutdown."""
    ex, ctrl, robot = _rig(ros_context, **POLAR, autostart=False)
    try:
        q = np.array([0.2, 0.6])
        assert ctrl.core is None and _state_id(ctrl) == State.PRIMARY_STATE_UNCONFIGURED
        assert not _answered(ex, robot, T0_NS, q, 0.3)
        ctrl.trigger_configure()
        assert _state_id(ctrl) == State.PRIMARY_STATE_INACTIVE and ctrl.core is not None
        assert spin_until(ex, lambda: robot.node.count_subscribers('robot_joint_commands') >= 0) and \
            spin_until(ex, lambda: ctrl.count_subscribers('joint_states') == 1)
        assert not _answered(ex, robot, T0_NS + DT_NS, q, 0.3)
        ctrl.trigger_activate()
        assert _answered(ex, robot, T0_NS + 2 * DT_NS, q)
        tau = robot.commands[T0_NS + 2 * DT_NS][3]
        np.testing.assert_allclose(tau, ctrl.core.config.model.g(q), rtol=0, atol=1e-9)   # holds: no jump
        np.testing.assert_array_equal(ctrl.core.joint_reference[0], q)
        ctrl.trigger_deactivate()
        assert not _answered(ex, robot, T0_NS + 3 * DT_NS, q, 0.3)
        ctrl.trigger_cleanup()
        assert ctrl.core is None and _state_id(ctrl) == State.PRIMARY_STATE_UNCONFIGURED
        assert ctrl.count_publishers('robot_joint_commands') == 0
        ctrl.trigger_shutdown()
        assert _state_id(ctrl) == State.PRIMARY_STATE_FINALIZED
    finally:
        _close(ex, ctrl, robot.node)


def test_activation_restarts_from_the_current_state_without_a_torque_jump(ros_context):
    """Active, moving to a goal; deactivated; the robot is moved; activated again: the reference holds
    the new position and the first torque is the law at zero error there."""
    ex, ctrl, robot = _rig(ros_context, **POLAR)
    try:
        q = np.array([0.2, 0.6])
        assert _answered(ex, robot, T0_NS, q)
        ctrl.set_parameters([Parameter('q_d', value=[0.8, 0.9])])
        for k in range(1, 50):
            assert _answered(ex, robot, T0_NS + k * DT_NS, q)
        ctrl.trigger_deactivate()
        moved = np.array([0.35, 0.7])
        ctrl.trigger_activate()
        stamp = T0_NS + 60 * DT_NS
        assert _answered(ex, robot, stamp, moved)
        np.testing.assert_array_equal(ctrl.core.joint_reference[0], moved)
        np.testing.assert_allclose(robot.commands[stamp][3], ctrl.core.config.model.g(moved), rtol=0, atol=1e-9)
    finally:
        _close(ex, ctrl, robot.node)


def test_without_a_urdf_the_model_comes_from_robot_description(ros_context):
    """model 'urdf' with neither urdf nor robot_description: the controller waits unconfigured, then
    configures itself from the URDF on robot_description (transient local, published before)."""
    describer = Node('describer', context=ros_context)
    pub = describer.create_publisher(String, 'robot_description', DESCRIPTION_QOS)
    with open(urdf.resolve('polar_two_link'), encoding='utf-8') as f:
        pub.publish(String(data=f.read()))
    ex, ctrl, robot = _rig(ros_context, model='urdf', joints=list(POLAR_JOINTS), effort_limits=[200.0, 200.0],
                           **{'model_params.gravity': 9.8})
    ex.add_node(describer)
    try:
        assert ctrl.core is None
        assert spin_until(ex, lambda: ctrl.core is not None)
        assert _state_id(ctrl) == State.PRIMARY_STATE_ACTIVE
        q = np.array([0.3, 0.5])
        assert _answered(ex, robot, T0_NS, q)
        np.testing.assert_allclose(robot.commands[T0_NS][3], [2.0 * 9.8 * 0.5 * np.cos(0.3), 2.0 * 9.8 * np.sin(0.3)],
                                   rtol=0, atol=1e-9)   # the polar robot's gravity: the URDF's model
    finally:
        _close(ex, ctrl, robot.node, describer)
