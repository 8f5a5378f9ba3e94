"""Drop-in for a user's ROS 2 system, end to end: the nodes as separate processes over DDS (loopback, a
claimed private domain), lockstep bridges (deterministic), driven like joint_trajectory_controller.

1. Two robots from one shipped config in one domain, each under its own namespace and clock
   (`-r __ns:=/r1 -r /clock:=/r1/clock --params-file config/polar_two_link.yaml`), each following its
   own trajectory; the parameters read back over the parameter services are the file's.
2. A MoveIt-style trajectory on the iiwa: the first point is the current state at 0 s, the others carry
   velocities and accelerations, the joints are named in a shuffled order; followed to 1e-3 rad; its goal
   tolerances met are reported OK on /diagnostics and logged.
3. An empty trajectory sent mid-motion stops the arm where it is and holds it there.
4. A path tolerance violated (a disturbance torque switched on in the bridge mid-trajectory): the
   controller holds the position and /diagnostics reports ERROR naming the joint.
"""
import numpy as np
import pytest

import robustness_helpers as rh
from e2e_helpers import E2E_DOMAINS, Lockstep
from robot_control.tools.demo_experiments import IIWA_POSTURE
from robot_control.tools.demo_procs import DomainClaim

IIWA = ('lbr_iiwa_joint_1', 'lbr_iiwa_joint_2', 'lbr_iiwa_joint_3', 'lbr_iiwa_joint_4', 'lbr_iiwa_joint_5',
        'lbr_iiwa_joint_6', 'lbr_iiwa_joint_7')
POLAR = ('theta1', 'r')
SHUFFLE = (3, 0, 6, 1, 5, 2, 4)                 # the order a planner names the iiwa's joints in
IIWA_BRIDGE = {'initial_positions': list(IIWA_POSTURE), 'surface.enable': False}
OMEGA_N = 6.0                                   # rad/s, config/iiwa.yaml and polar_two_link.yaml: 0.5 omega_res


def quintic_points(q0, q1, duration, count):
    """MoveIt-like samples of a rest-to-rest quintic from q0 to q1 (n,) over `duration` s: times (count,),
    positions, velocities, accelerations (count, n); the first point is q0 at 0 s."""
    t = np.linspace(0.0, duration, count)
    s = t / duration
    dq = np.asarray(q1) - np.asarray(q0)
    pos = np.asarray(q0) + np.outer(10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5, dq)
    vel = np.outer((30 * s ** 2 - 60 * s ** 3 + 30 * s ** 4) / duration, dq)
    acc = np.outer((60 * s - 180 * s ** 2 + 120 * s ** 3) / duration ** 2, dq)
    return t, pos, vel, acc


@pytest.fixture
def domain():
    with DomainClaim(E2E_DOMAINS, timeout=300.0) as claim:
        yield claim.domain_id


# -- 1. two namespaced robots ---------------------------------------------------------------------------
def test_two_namespaced_robots_from_one_config_follow_their_own_trajectories(tmp_path, domain):
    from rclpy.node import Node
    from rclpy.parameter_client import AsyncParameterClient
    from sensor_msgs.msg import JointState
    from trajectory_msgs.msg import JointTrajectory
    from robot_control.ros import conversions
    from robot_control.ros.qos import REFERENCE_QOS
    goals = {'/r1': np.array([0.5, 0.7]), '/r2': np.array([-0.4, 0.3])}
    with rh.processes() as procs, rh.ros_test_context(domain) as (ctx, ex):
        node = Node('two_robots_test', context=ctx)
        ex.add_node(node)
        last = {}       # namespace -> (stamp ns, q) of its newest joint_states

        def on_state(ns):
            return lambda m: last.__setitem__(ns, (conversions.stamp_to_ns(m.header.stamp), np.array(m.position)))
        subs = [node.create_subscription(JointState, f'{ns}/joint_states', on_state(ns), rh._qos(10)) for ns in goals]
        pubs = {ns: node.create_publisher(JointTrajectory, f'{ns}/controller/joint_trajectory', REFERENCE_QOS)
                for ns in goals}
        for ns in goals:
            procs.append(rh.bridge(domain, tmp_path, namespace=ns, mode='lockstep'))
            procs.append(rh.controller(domain, tmp_path, namespace=ns))
        # the loops run once both nodes are up; a trajectory is taken once its controller has a state
        running = lambda: (len(last) == 2 and all(p.get_subscription_count() for p in pubs.values())  # noqa: E731
                           and all(s.get_publisher_count() for s in subs))
        assert rh.spin_until(ex, running, 90.0), [p.output() for p in procs]
        started = {ns: last[ns][0] for ns in goals}
        assert rh.spin_until(ex, lambda: all(last[ns][0] > started[ns] + 0.05 * rh.NS for ns in goals), 30.0)
        for ns, goal in goals.items():
            pubs[ns].publish(conversions.joint_trajectory(POLAR, [0.5], [goal]))
        sent = {ns: last[ns][0] for ns in goals}
        done = lambda: all(last[ns][0] > sent[ns] + 1.5 * rh.NS for ns in goals)   # noqa: E731
        assert rh.spin_until(ex, done, 60.0), {ns: last[ns][0] / rh.NS for ns in goals}
        final = {ns: last[ns][1] for ns in goals}
        params = {}
        for ns in goals:
            client = AsyncParameterClient(node, f'{ns}/controller')
            assert rh.spin_until(ex, client.services_are_ready, 30.0)
            future = client.get_parameters(['model_params.gravity', 'use_sim_time', 'scenario', 'joints'])
            assert rh.spin_until(ex, future.done, 30.0)
            params[ns] = [v for v in future.result().values]
        logs = {p.name: p.output() for p in procs}
    for ns, goal in goals.items():
        err = np.abs(final[ns] - goal)
        print(f'{ns}: final |q - q_goal| = {err.tolist()} (at least 1 s after the end of its 0.5 s trajectory)')
        assert np.all(err < 1e-3), (ns, final[ns], goal)
        gravity, sim_time, scenario, joints = params[ns]
        assert gravity.double_value == 9.8 and sim_time.bool_value is True, (ns, gravity, sim_time)
        assert scenario.string_value == 'polar_two_link' and list(joints.string_array_value) == list(POLAR)
        text = logs[f'controller{ns.replace("/", "_")}']
        assert 'trajectory accepted' in text and '[WARN]' not in text and '[ERROR]' not in text, text
