"""~/identify_payload on the controller node (robot_control.ros.payload_service), in process with the bridge in
lockstep carrying a payload the controller was not told of: the call is answered with the figures and
payload.mass and payload.com are set on the controller, while the executor went on serving the control loop."""
import time

import numpy as np
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_srvs.srv import Trigger

from robot_control.ros.controller_node import ControllerNode
from robot_control.ros.payload_service import answered_stamp_ns
from robot_control.ros.spin import make_executor
from sim_bridge.bridge_node import SimBridge
from support.bridge_harness import overrides
from support.realism import PAYLOAD, typical_profile

#: wall-clock limit of the whole identification, s (a loaded 2-core machine runs lockstep slowly)
DEADLINE = 600.0


def _spin_until(executor, done, deadline):
    end = time.monotonic() + deadline
    while not done() and time.monotonic() < end:
        executor.spin_once(0.1)
    return done()


def test_identify_payload_answers_with_the_figures_and_sets_the_payload_parameters(ros_context):
    bridge = SimBridge(context=ros_context, parameter_overrides=[
        Parameter(name, value=value) for name, value in
        {**typical_profile('iiwa', mass_errors=False), **PAYLOAD, 'scenario': 'iiwa', 'mode': 'lockstep',
         'surface.enable': False}.items()])
    controller = ControllerNode(context=ros_context, parameter_overrides=overrides(
        scenario='iiwa', law='joint_impedance', payload_identification__move_time=0.8,
        payload_identification__settle_time=0.2, payload_identification__sample_time=0.2))
    client_node = Node('identify_client', context=ros_context)
    executor = make_executor('events', context=ros_context)
    try:
        for node in (bridge, controller, client_node):
            executor.add_node(node)
        client = client_node.create_client(Trigger, '/controller/identify_payload')
        assert _spin_until(executor, client.service_is_ready, 30.0)
        assert _spin_until(executor, lambda: controller.commands_sent > 100, 60.0)
        sent, called_ns = controller.commands_sent, bridge.world.t_ns
        future = client.call_async(Trigger.Request())
        assert _spin_until(executor, future.done, DEADLINE)
        answer = future.result()
        assert answer.success, answer.message
        assert answer.message.startswith('mass ') and 'residual' in answer.message
        # the answer names the joint state the identification ended at: after its 8 moves of 0.8 s
        assert called_ns + 8 * 800_000_000 < answered_stamp_ns(answer.message) <= bridge.world.t_ns, answer.message
        assert controller.commands_sent > sent + 5000      # the loop ran on while the call waited
        mass = controller.get_parameter('payload.mass').value
        com = np.array(controller.get_parameter('payload.com').value)
        assert abs(mass - 2.0) < 0.03 * 2.0, answer.message
        assert np.linalg.norm(com - [0.0, 0.0, 0.05]) < 0.005, answer.message
        assert f'{mass:.4f} kg' in answer.message
        assert controller.core.config.model.payload[0] == mass     # the model carries it now
    finally:
        executor.shutdown()
        for node in (client_node, controller, bridge):
            node.destroy_node()


def test_a_call_to_an_inactive_controller_is_refused_at_once(ros_context):
    controller = ControllerNode(context=ros_context, parameter_overrides=overrides(scenario='iiwa'))
    client_node = Node('identify_client', context=ros_context)
    executor = make_executor('events', context=ros_context)
    try:
        for node in (controller, client_node):
            executor.add_node(node)
        controller.trigger_deactivate()
        client = client_node.create_client(Trigger, '/controller/identify_payload')
        assert _spin_until(executor, client.service_is_ready, 30.0)
        future = client.call_async(Trigger.Request())
        assert _spin_until(executor, future.done, 30.0)
        assert not future.result().success
        assert future.result().message == 'the controller is not active'
        assert controller.get_parameter('payload.mass').value == 0.0
    finally:
        executor.shutdown()
        for node in (client_node, controller):
            node.destroy_node()
