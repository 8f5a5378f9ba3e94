"""controller_node in an in-process executor, with a test node playing the robot.

Every test: a fresh rclpy context, the controller and a 'robot' node in one SingleThreadedExecutor,
bounded spinning with deadlines (a state is re-published until its command arrives: the
controller answers a repeated stamp with the same command and does not integrate twice).
"""
import contextlib
import math
import os
import select
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import WrenchStamped
from rosgraph_msgs.msg import Clock as ClockMsg
from rclpy.duration import Duration
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory

from support.cdr import big_endian, big_endian_wrench
from robot_control import units
from robot_control.ros import cdr
from robot_control.ros import conversions as cv
from robot_control.ros.controller_node import ControllerNode
from robot_control.gains import ServoGains, design
from robot_control.laws import (computed_torque, force_1dof, hybrid, independent_joint, saturate,
                                spring_force)
from robot_control.models import for_scenario, make_model
from robot_control.ros.qos import CONTROL_QOS, REFERENCE_QOS
from robot_control.trajectory import from_points

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
RNG = np.random.default_rng(20261125)
T0_NS = 1_000_000_000_000          # first stamp of every test, ns
DT_NS = 1_000_000                  # 1 ms between states
DEADLINE = 30.0                    # s of wall time per wait: generous, a busy machine only waits longer
RECORD_QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)


def spin_until(executor, predicate, timeout=DEADLINE, every=None, action=None):
    """Spin until predicate() or the deadline; call action() every `every` s (re-publish)."""
    deadline = time.monotonic() + timeout
    next_action = time.monotonic() + (every or math.inf)
    while time.monotonic() < deadline:
        if predicate():
            return True
        if action is not None and time.monotonic() >= next_action:
            action()
            next_action = time.monotonic() + every
        executor.spin_once(timeout_sec=0.005)
    return predicate()


class Robot:
    """Plays the robot: publishes joint_states/wrenches/references, records what the controller sends."""

    def __init__(self, context, controller='controller'):
        self.node = Node('robot', context=context)
        n = self.node
        self.state_pub = n.create_publisher(JointState, 'joint_states', CONTROL_QOS)
        self.ft_pub = n.create_publisher(WrenchStamped, 'ft_sensor/wrench', CONTROL_QOS)
        self.traj_pub = n.create_publisher(JointTrajectory, f'{controller}/joint_trajectory', REFERENCE_QOS)
        self.wref_pub = n.create_publisher(WrenchStamped, f'{controller}/wrench_reference', REFERENCE_QOS)
        self.commands, self.references, self.errors, self.arrays, self.diagnostics = {}, {}, {}, [], []
        n.create_subscription(JointState, 'robot_joint_commands', self._record(self.commands), RECORD_QOS)
        n.create_subscription(JointState, f'{controller}/reference', self._record(self.references), RECORD_QOS)
        n.create_subscription(JointState, f'{controller}/error', self._record(self.errors), RECORD_QOS)
        n.create_subscription(Float64MultiArray, 'effort_controller/commands',
                              lambda m: self.arrays.append(cv.effort_array_values(m)), RECORD_QOS)
        n.create_subscription(DiagnosticArray, '/diagnostics', self.diagnostics.append, RECORD_QOS)

    @staticmethod
    def _record(store):
        def callback(msg):
            names, stamp, pos, vel, eff = cv.joint_state_arrays(msg)
            store[stamp] = (names, pos, vel, eff)
        return callback

    def wait_connected(self, executor):
        # ft_sensor/wrench is subscribed only while the law reads the measured force (send_until waits)
        pubs = (self.state_pub, self.traj_pub, self.wref_pub)
        node = self.node
        assert spin_until(executor, lambda: all(p.get_subscription_count() >= 1 for p in pubs)
                          and node.count_publishers('/robot_joint_commands') >= 1
                          and node.count_publishers('/controller/reference') >= 1)

    def state(self, names, q, qd, stamp_ns):
        return cv.joint_state(names, stamp_ns, q, qd, np.zeros(len(names)))

    def step(self, executor, names, q, qd, stamp_ns):
        """Publish a state; wait for its command, reference and error; return them."""
        msg = self.state(names, q, qd, stamp_ns)
        self.state_pub.publish(msg)
        ok = spin_until(executor, lambda: all(stamp_ns in s for s in (self.commands, self.references, self.errors)),
                        every=0.25, action=lambda: self.state_pub.publish(msg))
        assert ok, f'no command for the state stamped {stamp_ns}'
        return self.commands[stamp_ns], self.references[stamp_ns], self.errors[stamp_ns]

    def send_until(self, executor, publisher, msg, predicate):
        """Publish `msg` once, and spin until predicate(). Not re-published: a second trajectory replaces the
        first, and a busy machine takes any fixed time to hand a message over; the controller's reliable
        subscription has it once the publisher's samples are acknowledged (after it matched: ft_sensor/wrench
        is subscribed only while the law reads the measured force)."""
        assert spin_until(executor, lambda: publisher.get_subscription_count() >= 1), 'no subscription matched'
        publisher.publish(msg)
        assert publisher.wait_for_all_acked(Duration(seconds=DEADLINE)), 'not acknowledged by the controller'
        assert spin_until(executor, predicate)


@contextlib.contextmanager
def rig(context, **params):
    """(executor, controller, robot) with `params` as parameter overrides; nodes destroyed after. The states
    come from the test, one by one, with set-ups between them that a busy machine can stretch past the
    default 0.5 s: state_timeout is 30 s unless a test sets it (the watchdog test does)."""
    params = {'state_timeout': 30.0, **params}
    overrides = [Parameter(k, value=v) for k, v in params.items()]
    controller = ControllerNode(context=context, parameter_overrides=overrides)
    robot = None
    executor = SingleThreadedExecutor(context=context)
    try:
        robot = Robot(context)
        executor.add_node(controller)
        executor.add_node(robot.node)
        robot.wait_connected(executor)
        yield executor, controller, robot
    finally:
        executor.shutdown()
        if robot is not None:
            robot.node.destroy_node()
        controller.destroy_node()


POLAR = dict(scenario='polar_two_link', effort_limits=[200.0, 200.0], diagnostics_period=0.1)
POLAR_JOINTS = ('theta1', 'r')


def shuffled_with_extra(joints, q, qd):
    """Names reversed plus an uncontrolled joint carrying NaN (ignored by the controller)."""
    names = ['gripper'] + list(joints)[::-1]
    return names, [math.nan] + list(q)[::-1], [0.0] + list(qd)[::-1]


# -- 1. published torque = library law, for every law ------------------------------------------------------
def _expected_polar_ct(integral):
    model = make_model('polar_two_link', m=2.0, gravity=9.8)
    gains = design(1.0, 12.0, integral=integral).gains(2)
    return lambda q, qd, ref, err, f: computed_torque(model, q, qd, ref[1], ref[2], ref[3], gains,
                                                      err[3] if integral else None)


def _expected_polar_ij(integral):
    gains = ServoGains([50.0, 80.0], [10.0, 20.0], [5.0, 8.0] if integral else [0.0, 0.0])
    return lambda q, qd, ref, err, f: independent_joint(q, qd, ref[1], ref[2], gains, err[3] if integral else None)


def _expected_force(integral):
    model = make_model('force_1dof', m=1.0)
    gains = design(1.0, 12.0, integral=integral).gains(1)

    def law(q, qd, ref, err, f_meas):
        f, fdot = spring_force(model.fk(q), model.J(q) @ qd, 0.1, 1000.0)
        return force_1dof(1.0, f, fdot, ref[1], ref[2], ref[3], 1000.0, gains, err[3] if integral else None)
    return law


def _expected_hybrid(scenario, force_axis, k_e, x_e, sensor, q_posture):
    """Library hybrid law; the posture reference is the joint reference, held at the start state q_posture."""
    model = for_scenario(scenario)
    mask = np.array([a == force_axis for a in model.task_axes])
    K_e = np.where(mask, k_e, 1.0)

    def make(integral):
        d = design(1.0, 12.0, integral=integral)

        def law(q, qd, ref, err, f_meas):
            x, xd = model.fk(q), model.J(q) @ qd
            f = np.where(mask, f_meas if sensor else k_e * (x - x_e), 0.0)
            fdot = np.where(mask, k_e * xd, 0.0)
            return hybrid(model, q, qd, ref[1], ref[2], ref[3], ref[1], ref[2], ref[3], f, fdot, mask, K_e,
                          d.gains(model.task_dim), d.gains(1), q_posture=q_posture, k_posture=(25.0, 10.0),
                          int_E=err[3] if integral else None)
        return law
    return make


IIWA_Q0 = np.array((0.0, 0.5, 0.0, -1.2, 0.0, 1.0, 0.0))
LAW_CASES = {
    'computed_torque': (dict(POLAR, q_d=[0.3, 0.7], move_time=0.05), POLAR_JOINTS, np.array([0.2, 0.6]),
                        _expected_polar_ct, None),
    'independent_joint': (dict(POLAR, law='independent_joint', kp=[50.0, 80.0], kv=[10.0, 20.0], ki=[5.0, 8.0],
                               q_d=[0.3, 0.7], move_time=0.05),
                          POLAR_JOINTS, np.array([0.2, 0.6]), _expected_polar_ij, None),
    'force': (dict(scenario='force_1dof', law='force', force_feedback='model', f_d=[4.0], force_ramp_time=0.01,
                   effort_limits=[200.0]),
              ('x',), np.array([0.1003]), _expected_force, None),
    'hybrid_sensor': (dict(scenario='hybrid_cartesian_xy', law='hybrid', force_feedback='sensor', f_d=[5.0],
                           force_ramp_time=0.01, effort_limits=[200.0, 200.0]),
                      ('x', 'y'), np.array([0.3002, 0.1]),
                      _expected_hybrid('hybrid_cartesian_xy', 'x', 1000.0, 0.3, True, None), [2.5, 0.0]),
    'hybrid_iiwa_redundant': (dict(scenario='iiwa', law='hybrid', force_feedback='model', f_d=[-10.0],
                                   force_ramp_time=0.01, x_e=[0.6035]),
                              tuple(f'lbr_iiwa_joint_{i}' for i in range(1, 8)), IIWA_Q0,
                              _expected_hybrid('iiwa', 'z', 20000.0, 0.6035, False, IIWA_Q0), None),
}


@pytest.mark.parametrize('integral', [False, True])
@pytest.mark.parametrize('case', sorted(LAW_CASES))
def test_published_torque_equals_the_library_law(ros_context, case, integral):
    params, joints, q0, make_expected, f_meas = LAW_CASES[case]
    expected_law = make_expected(integral)
    with rig(ros_context, integral=integral, **params) as (ex, ctrl, robot):
        limit = ctrl.core.config.effort_limit
        if f_meas is not None:
            robot.send_until(ex, robot.ft_pub, cv.wrench_along(('x', 'y', 'z'), [*f_meas, 0.0]),
                             lambda: ctrl.wrench_received)
        for k in range(25):
            q = q0 + RNG.uniform(-2e-4, 2e-4, q0.shape[0])
            qd = RNG.uniform(-0.01, 0.01, q0.shape[0])
            if case == 'hybrid_iiwa_redundant':
                q = q0.copy()  # the first state sets the posture reference: keep it at q0
            names, pos, vel = shuffled_with_extra(joints, q, qd)
            cmd, ref, err = robot.step(ex, names, pos, vel, T0_NS + k * DT_NS)
            assert cmd[0] == joints
            want = saturate(expected_law(q, qd, ref, err, f_meas), limit)[0]
            np.testing.assert_allclose(cmd[3], want, rtol=0, atol=1e-12)
        if integral and case != 'hybrid_iiwa_redundant':
            assert np.any(err[3] != 0.0)


def test_command_answers_the_state_stamp_with_joint_names_and_efforts(ros_context):
    with rig(ros_context, **POLAR, publish_effort_array=True) as (ex, ctrl, robot):
        stamp = T0_NS + 123_456
        cmd, _, _ = robot.step(ex, ['r', 'theta1'], [0.5, 0.1], [0.0, 0.0], stamp)
        names, pos, vel, eff = cmd
        assert names == POLAR_JOINTS and pos.size == 0 and vel.size == 0
        np.testing.assert_allclose(eff, [19.6 * 0.5 * math.cos(0.1), 19.6 * math.sin(0.1)], rtol=0, atol=1e-12)
        assert spin_until(ex, lambda: len(robot.arrays) >= 1)
        np.testing.assert_array_equal(robot.arrays[-1], eff)


def test_one_command_per_state_message(ros_context):
    with rig(ros_context, **POLAR) as (ex, ctrl, robot):
        for k in range(10):
            robot.step(ex, POLAR_JOINTS, [0.1, 0.5], [0.0, 0.0], T0_NS + k * DT_NS)
        assert sorted(robot.commands) == [T0_NS + k * DT_NS for k in range(10)]
        assert ctrl.commands_sent == ctrl.core.ticks


def test_a_big_endian_state_is_answered_like_a_little_endian_one(ros_context):
    """joint_states arrive as bytes (robot_control.ros.cdr decodes them); a big-endian writer's (another DDS
    vendor, another CPU) are left to rclpy's decoder and answered the same."""
    with rig(ros_context, **POLAR) as (ex, ctrl, robot):
        little = T0_NS
        robot.step(ex, POLAR_JOINTS, [0.1, 0.5], [0.2, -0.1], little)
        big = T0_NS + DT_NS
        raw = big_endian({'names': list(POLAR_JOINTS), 'stamp_ns': big, 'frame_id': '', 'position': [0.1, 0.5],
                          'velocity': [0.2, -0.1], 'effort': []})
        assert ctrl.session._state_decoder.decode(raw) is None
        robot.send_until(ex, robot.state_pub, raw, lambda: big in robot.commands)
        assert robot.commands[big][0] == POLAR_JOINTS
        np.testing.assert_array_equal(robot.commands[big][3], robot.commands[little][3])
        assert ctrl.rejected['joint_states'] == 0


# -- 2. trajectories -------------------------------------------------------------------------------------
def _ref_of(ref):
    return ref[1], ref[2], ref[3]


def test_trajectory_is_accepted_and_followed_by_the_reference(ros_context):
    with rig(ros_context, **POLAR) as (ex, ctrl, robot):
        q = np.array([0.1, 0.5])
        robot.step(ex, POLAR_JOINTS, q, [0.0, 0.0], T0_NS)
        msg = cv.joint_trajectory(['r', 'theta1'], [0.01, 0.02], [[0.6, 0.3], [0.55, 0.4]])
        robot.send_until(ex, robot.traj_pub, msg, lambda: ctrl.trajectories_accepted == 1)
        expected = from_points(0.0, (q, None, None), [0.01, 0.02], [[0.3, 0.6], [0.4, 0.55]])
        for k in range(1, 30):
            _, ref, _ = robot.step(ex, POLAR_JOINTS, q, [0.0, 0.0], T0_NS + k * DT_NS)
            for got, want in zip(_ref_of(ref), expected.sample(units.seconds(k * DT_NS))):
                np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
        np.testing.assert_allclose(ref[1], [0.4, 0.55], rtol=0, atol=1e-12)   # last point held


@pytest.mark.parametrize('bad, match', [
    (cv.joint_trajectory(['theta1', 'elbow'], [0.5], [[0.1, 0.2]]), "joint_names: unknown ['elbow']"),
    (cv.joint_trajectory(POLAR_JOINTS, [0.5, 0.5], [[0.1, 0.2], [0.2, 0.3]]), 'points[1].time_from_start'),
    (cv.joint_trajectory(POLAR_JOINTS, [0.5, 0.25], [[0.1, 0.2], [0.2, 0.3]]), 'points[1].time_from_start'),
    (cv.joint_trajectory(POLAR_JOINTS, [0.5], [[0.1, math.nan]]), 'points[0].positions: not finite'),
])
def test_bad_trajectories_are_rejected_and_the_reference_keeps_holding(ros_context, bad, match):
    with rig(ros_context, **POLAR) as (ex, ctrl, robot):
        q = np.array([0.1, 0.5])
        robot.step(ex, POLAR_JOINTS, q, [0.0, 0.0], T0_NS)
        robot.send_until(ex, robot.traj_pub, bad, lambda: ctrl.rejected['joint_trajectory'] == 1)
        assert match in ctrl.last_rejection and ctrl.trajectories_accepted == 0
        _, ref, _ = robot.step(ex, POLAR_JOINTS, q + 0.01, [0.0, 0.0], T0_NS + DT_NS)
        np.testing.assert_array_equal(ref[1], q)
        np.testing.assert_array_equal(ref[2], [0.0, 0.0])


def test_trajectory_before_any_state_is_rejected(ros_context):
    with rig(ros_context, **POLAR) as (ex, ctrl, robot):
        msg = cv.joint_trajectory(POLAR_JOINTS, [0.5], [[0.1, 0.2]])
        robot.send_until(ex, robot.traj_pub, msg, lambda: ctrl.rejected['joint_trajectory'] == 1)
        assert 'controller not running' in ctrl.last_rejection


def test_new_trajectory_replaces_the_active_one_without_a_reference_jump(ros_context):
    with rig(ros_context, **POLAR) as (ex, ctrl, robot):
        q = np.array([0.1, 0.5])
        robot.step(ex, POLAR_JOINTS, q, [0.0, 0.0], T0_NS)
        robot.send_until(ex, robot.traj_pub, cv.joint_trajectory(POLAR_JOINTS, [0.04], [[0.9, 0.9]]),
                         lambda: ctrl.trajectories_accepted == 1)
        for k in range(1, 16):
            _, ref, _ = robot.step(ex, POLAR_JOINTS, q, [0.0, 0.0], T0_NS + k * DT_NS)
        before = _ref_of(ref)
        assert np.all(np.abs(before[1]) > 1.0)          # mid-move
        robot.send_until(ex, robot.traj_pub, cv.joint_trajectory(POLAR_JOINTS, [0.03], [[0.0, 0.4]]),
                         lambda: ctrl.trajectories_accepted == 2)
        t_r = units.seconds(15 * DT_NS)
        expected = from_points(t_r, before, [0.03], [[0.0, 0.4]])
        prev = before
        for k in range(16, 50):
            _, ref, _ = robot.step(ex, POLAR_JOINTS, q, [0.0, 0.0], T0_NS + k * DT_NS)
            now = _ref_of(ref)
            for got, want in zip(now, expected.sample(units.seconds(k * DT_NS))):
                np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
            dt = DT_NS * 1e-9
            assert np.all(np.abs(now[0] - prev[0]) <= np.abs(prev[1]) * dt + 0.5 * np.abs(prev[2]) * dt ** 2 + 1e-4)
            prev = now


def test_wrench_reference_sets_the_force_target(ros_context):
    with rig(ros_context, scenario='force_1dof', law='force', force_feedback='model', force_ramp_time=0.0,
             effort_limits=[200.0]) as (ex, ctrl, robot):
        robot.step(ex, ['x'], [0.1], [0.0], T0_NS)
        robot.send_until(ex, robot.wref_pub, cv.wrench_along(('x',), [7.5]),
                         lambda: ctrl.core.force_target.tolist() == [7.5])
        _, ref, _ = robot.step(ex, ['x'], [0.1], [0.0], T0_NS + DT_NS)
        assert ref[0] == ('x',) and ref[1].tolist() == [7.5]



def test_a_wrench_reference_stamped_ahead_applies_from_the_first_state_at_its_stamp(ros_context):
    with rig(ros_context, scenario='force_1dof', law='force', force_feedback='model', force_ramp_time=0.0,
             f_d=[2.0], effort_limits=[200.0]) as (ex, ctrl, robot):
        robot.step(ex, ['x'], [0.1], [0.0], T0_NS)
        at = T0_NS + 3 * DT_NS + 1                                   # between two states: the next one applies it
        robot.send_until(ex, robot.wref_pub, cv.wrench_along(('x',), [7.5], stamp_ns=at),
                         lambda: ctrl.rejected['wrench_reference'] > 0 or ctrl.core.force_pending is not None)
        targets = []
        for k in range(1, 7):
            _, ref, _ = robot.step(ex, ['x'], [0.1], [0.0], T0_NS + k * DT_NS)
            targets.append(ref[1][0])
        assert targets == [2.0, 2.0, 2.0, 7.5, 7.5, 7.5]
        robot.send_until(ex, robot.wref_pub, cv.wrench_along(('x',), [3.0]),      # unstamped: at once
                         lambda: ctrl.core.force_target.tolist() == [3.0])

def test_a_wrench_reference_stamped_ahead_is_dropped_when_time_goes_back(ros_context):
    """A simulator reset sends time back: the core restarts from the current state and drops a pending
    trajectory; a force reference stamped ahead on the old timeline must not apply on the new one."""
    with rig(ros_context, scenario='force_1dof', law='force', force_feedback='model', force_ramp_time=0.0,
             f_d=[2.0], effort_limits=[200.0]) as (ex, ctrl, robot):
        robot.step(ex, ['x'], [0.1], [0.0], T0_NS + 10 * DT_NS)
        at = T0_NS + 13 * DT_NS
        robot.send_until(ex, robot.wref_pub, cv.wrench_along(('x',), [7.5], stamp_ns=at),
                         lambda: ctrl.rejected['wrench_reference'] > 0 or ctrl.core.force_pending is not None)
        restarts = ctrl.core.restarts
        targets = [robot.step(ex, ['x'], [0.1], [0.0], T0_NS + k * DT_NS)[1][1][0] for k in range(0, 20)]
        assert ctrl.core.restarts == restarts + 1 and ctrl.rejected['wrench_reference'] == 0
        assert targets == [2.0] * 20           # stamps 0 .. 19 ms: past 13 ms, nothing pending applied


class Witness:
    """A node of its own, spun by its own executor, on joint_states and ft_sensor/wrench: `wait(stamp)` returns
    once both the state and the wrench stamped `stamp` have reached this process (the controller's
    subscriptions, in the same DDS participant, have them too), without handing anything to the controller."""

    def __init__(self, context):
        self.node = Node('witness', context=context)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.states, self.wrenches = set(), set()
        self.node.create_subscription(JointState, 'joint_states',
                                      lambda m: self.states.add(cv.stamp_to_ns(m.header.stamp)), RECORD_QOS)
        self.node.create_subscription(WrenchStamped, 'ft_sensor/wrench',
                                      lambda m: self.wrenches.add(cv.stamp_to_ns(m.header.stamp)), RECORD_QOS)

    def wait(self, stamp):
        return spin_until(self.executor, lambda: stamp in self.states and stamp in self.wrenches)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.executor.shutdown()
        self.node.destroy_node()


def test_each_state_is_answered_with_the_wrench_published_before_it(ros_context):
    """The bridge publishes a tick's wrench, then its state. Switching force_feedback to sensor at run
    time subscribes ft_sensor/wrench after joint_states, so an executor that finds both waiting runs the
    state's callback first: the answer must still use the wrench of its own tick, not the previous one."""
    params, joints, q0, make_expected, _ = LAW_CASES['hybrid_sensor']
    expected_law = make_expected(False)
    with rig(ros_context, **dict(params, force_feedback='model')) as (ex, ctrl, robot), \
            Witness(ros_context) as witness:
        assert ctrl.set_parameters([Parameter('force_feedback', value='sensor')])[0].successful
        assert spin_until(ex, lambda: robot.ft_pub.get_subscription_count() >= 2)     # the controller, the witness
        assert spin_until(ex, lambda: robot.state_pub.get_subscription_count() >= 2)
        for k in range(8):
            f_k = [2.0 + 0.5 * k, 0.0]                       # a different force every tick
            q = q0 + RNG.uniform(-2e-4, 2e-4, 2)
            qd = RNG.uniform(-0.01, 0.01, 2)
            stamp = T0_NS + k * DT_NS
            robot.ft_pub.publish(cv.wrench_along(('x', 'y', 'z'), [*f_k, 0.0], stamp_ns=stamp))
            robot.state_pub.publish(robot.state(joints, q, qd, stamp))
            assert witness.wait(stamp)                       # both arrived before the executor looks
            assert spin_until(ex, lambda: all(stamp in s for s in (robot.commands, robot.references, robot.errors)))
            cmd, ref, err = robot.commands[stamp], robot.references[stamp], robot.errors[stamp]
            want = saturate(expected_law(q, qd, ref, err, np.array(f_k)), ctrl.core.config.effort_limit)[0]
            np.testing.assert_allclose(cmd[3], want, rtol=0, atol=1e-12, err_msg=f'tick {k}')


def test_a_big_endian_wrench_is_used_like_a_little_endian_one(ros_context):
    """ft_sensor/wrench arrives as bytes (robot_control.ros.cdr decodes it); a big-endian writer's is left to
    rclpy's decoder, and the state of its tick is answered with that force."""
    params, joints, q0, make_expected, _ = LAW_CASES['hybrid_sensor']
    expected_law = make_expected(False)
    with rig(ros_context, **params) as (ex, ctrl, robot):
        assert spin_until(ex, lambda: robot.ft_pub.get_subscription_count() >= 1)
        for k, (f_k, big) in enumerate([([2.5, 0.0], False), ([3.25, 0.0], True)]):
            stamp = T0_NS + k * DT_NS
            if big:
                wrench = big_endian_wrench(stamp, 'world', [*f_k, 0.0], [0.0, 0.0, 0.0])
                assert cdr.decode_wrench(wrench) is None
            else:
                wrench = cv.wrench_along(('x', 'y', 'z'), [*f_k, 0.0], stamp_ns=stamp)
            robot.ft_pub.publish(wrench)
            robot.state_pub.publish(robot.state(joints, q0, np.zeros(2), stamp))
            assert spin_until(ex, lambda: all(stamp in s for s in (robot.commands, robot.references, robot.errors)))
            cmd, ref, err = robot.commands[stamp], robot.references[stamp], robot.errors[stamp]
            want = saturate(expected_law(q0, np.zeros(2), ref, err, np.array(f_k)), ctrl.core.config.effort_limit)[0]
            np.testing.assert_allclose(cmd[3], want, rtol=0, atol=1e-12, err_msg=f'tick {k}')
        assert ctrl.rejected['ft_sensor_wrench'] == 0


def test_a_paired_wrench_that_comes_late_is_waited_for_and_an_unpaired_stream_never_is(ros_context):
    """Once wrenches carry the stamps of the states (a tick answered with its own wrench), a state whose
    wrench is still on its way waits for it (at most wrench_wait); a stream without those stamps does not.

    Each step waits on what the controller did (the state held for its wrench, or answered at once), not
    on a few ms of wall time: the wrench that comes late is published once the state is seen held."""
    params, joints, q0, make_expected, _ = LAW_CASES['hybrid_sensor']
    expected_law = make_expected(False)
    with rig(ros_context, **params) as (ex, ctrl, robot):
        wrench_wait = ctrl.get_parameter('wrench_wait').value
        assert wrench_wait == 0.005
        assert spin_until(ex, lambda: robot.ft_pub.get_subscription_count() >= 1)
        pairing = lambda: ctrl.session.controller._pairing          # noqa: E731
        answered = lambda stamp: all(stamp in s for s in (robot.commands, robot.references, robot.errors))  # noqa

        def wrench(f_k, stamp):
            robot.ft_pub.publish(cv.wrench_along(('x', 'y', 'z'), [*f_k, 0.0], stamp_ns=stamp))

        def state(stamp):
            """Publish the state stamped `stamp`; True once the controller holds it for its wrench, False
            once it answered it at once (a held state is seen before its release: one callback per spin)."""
            robot.state_pub.publish(robot.state(joints, q0, np.zeros(2), stamp))
            assert spin_until(ex, lambda: answered(stamp) or pairing().held is not None)
            return pairing().held is not None

        def used_force(stamp, candidates):
            assert spin_until(ex, lambda: answered(stamp))
            tau, ref, err = robot.commands[stamp][3], robot.references[stamp], robot.errors[stamp]
            for f in candidates:
                want = saturate(expected_law(q0, np.zeros(2), ref, err, np.array(f)), ctrl.core.config.effort_limit)[0]
                if np.allclose(tau, want, rtol=0, atol=1e-12):
                    return f
            return None

        def wrench_taken(stamp):
            """Wait until the controller has taken the wrench stamped `stamp` (the latest it took)."""
            assert spin_until(ex, lambda: pairing().wrench_ns == stamp), f'wrench {stamp} not taken'

        stamp = T0_NS
        wrench([2.0, 0.0], stamp)                                    # tick 0: the wrench, then its state
        state(stamp)
        assert used_force(stamp, ([2.0, 0.0],)) == [2.0, 0.0]
        wrench_taken(stamp)                                          # the stream is paired
        # the wrench comes after its state: held, then answered with it once it comes within wrench_wait. A
        # machine too busy to hand it over within wrench_wait sees the wait end first (the old force): the
        # tick is tried again, a few times, with the next stamp
        for attempt in range(5):
            stamp += DT_NS
            assert state(stamp), f'the state stamped {stamp} was answered without waiting for its wrench'
            wrench([3.0, 0.0], stamp)
            force = used_force(stamp, ([3.0, 0.0], [2.0, 0.0]))
            wrench_taken(stamp)
            if force == [3.0, 0.0]:
                break
        assert force == [3.0, 0.0], 'a held state was never answered with the wrench that came for it'
        # its wrench does not come: held for wrench_wait, answered with the force it has (a lower bound on
        # the wait: load only makes it longer); a wrench stamped 0 comes after, and unpairs the stream
        stamp += DT_NS
        t0 = time.monotonic()
        assert state(stamp)
        assert used_force(stamp, ([3.0, 0.0],)) == [3.0, 0.0]
        assert time.monotonic() - t0 >= wrench_wait
        wrench([4.0, 0.0], 0)
        wrench_taken(0)
        stamp += DT_NS                                               # unpaired stream: answered at once
        assert not state(stamp), 'a state of an unpaired stream was held for a wrench'
        assert used_force(stamp, ([4.0, 0.0],)) == [4.0, 0.0]


def test_with_wrench_wait_0_a_state_waits_for_its_own_wrench_however_late_it_comes(ros_context):
    """wrench_wait 0 (the demo's lockstep runs): a state of paired streams is answered only with the wrench of its
    own tick, also when that comes 20x the default wait later and the state was re-published meanwhile (a lockstep
    simulator does so after lockstep_timeout without an answer)."""
    params, joints, q0, _, _ = LAW_CASES['hybrid_sensor']
    with rig(ros_context, **params, wrench_wait=0.0) as (ex, ctrl, robot):
        assert spin_until(ex, lambda: robot.ft_pub.get_subscription_count() >= 1)
        pairing = lambda: ctrl.session.controller._pairing          # noqa: E731

        def wrench(f_x, stamp):
            robot.ft_pub.publish(cv.wrench_along(('x', 'y', 'z'), [f_x, 0.0, 0.0], stamp_ns=stamp))
            assert spin_until(ex, lambda: pairing().wrench_ns == stamp), f'wrench {stamp} not taken'

        def state(stamp):
            robot.state_pub.publish(robot.state(joints, q0, np.zeros(2), stamp))

        wrench(2.0, T0_NS)                                           # tick 0: paired from here on
        state(T0_NS)
        assert spin_until(ex, lambda: T0_NS in robot.commands)
        stamp = T0_NS + DT_NS
        state(stamp)
        assert spin_until(ex, lambda: pairing().held is not None and pairing().held[0] == stamp)
        t0 = time.monotonic()
        while time.monotonic() - t0 < 0.1:                           # 20x the default wrench_wait
            ex.spin_once(timeout_sec=0.01)
        state(stamp)                                                 # re-published: still waiting
        t0 = time.monotonic()        # (a machine too busy to deliver it within 0.1 s passes here without it)
        while time.monotonic() - t0 < 0.1:
            ex.spin_once(timeout_sec=0.01)
        assert stamp not in robot.commands and pairing().held[0] == stamp
        wrench(3.0, stamp)
        assert spin_until(ex, lambda: stamp in robot.commands)
        assert pairing().held is None and pairing().last_state_ns == stamp


# -- 3. parameters ---------------------------------------------------------------------------------------
def test_valid_parameter_change_takes_effect_on_the_next_tick(ros_context):
    with rig(ros_context, **POLAR) as (ex, ctrl, robot):
        q, qd = np.array([0.1, 0.5]), np.array([0.2, -0.1])
        robot.step(ex, POLAR_JOINTS, q, qd, T0_NS)
        result = ctrl.set_parameters([Parameter('zeta', value=2.0), Parameter('omega_res', value=10.0)])
        assert all(r.successful for r in result)
        cmd, ref, _ = robot.step(ex, POLAR_JOINTS, q, qd, T0_NS + DT_NS)
        gains = design(2.0, 10.0).gains(2)                         # kv = 2 zeta w_n = 20
        np.testing.assert_array_equal(ctrl.core.config.control_law.motion_gains.kv, [20.0, 20.0])
        want = computed_torque(make_model('polar_two_link', m=2.0, gravity=9.8), q, qd, *_ref_of(ref), gains)
        np.testing.assert_allclose(cmd[3], want, rtol=0, atol=1e-12)


@pytest.mark.parametrize('name, value, reason', [
    ('zeta', 0.5, 'zeta: 0.5 breaks the rule zeta >= 1'),
    ('omega_n', 7.0, 'omega_n: 7 rad/s > 0.5 * 12 rad/s'),
    ('kp', [36.0, 36.0, 36.0], 'kp: expected 2 values'),
    ('kp', [-1.0, 36.0], 'kp: expected non-negative values'),
    ('law', 'pid', "law: unknown 'pid'"),
    ('effort_limits', [10.0], 'effort_limits: expected a scalar or length 2'),
    ('effort_limits', [10.0, 0.0], 'effort_limits: expected positive values'),
    ('omega_res', -1.0, 'omega_res: expected a positive number'),
    ('state_timeout', 0.0, 'state_timeout: expected a positive number'),
    ('q_d', [0.1], 'q_d: expected empty or 2 values'),
    ('force_axes', ['q'], "force_axes: ['q'] not among the model's task axes"),
    ('model_params.m', -2.0, 'model_params.m: expected a positive number'),
    ('law', 'force', 'law: force is the 1-DOF force servo'),
    ('force_feedback', 'psychic', "force_feedback: unknown 'psychic'"),
])
def test_invalid_parameter_is_rejected_with_a_reason_and_the_old_value_stays(ros_context, name, value, reason):
    with rig(ros_context, **POLAR) as (ex, ctrl, robot):
        old_value = ctrl.get_parameter(name).value
        old_config = ctrl.core.config
        result = ctrl.set_parameters([Parameter(name, value=value)])[0]
        assert not result.successful
        assert result.reason.startswith(reason), result.reason
        assert ctrl.get_parameter(name).value == old_value
        assert ctrl.core.config is old_config


#: (rule broken, value, the parameter that allows it, the kv designed then: 2 zeta w_n)
GAIN_RULES = [('zeta', 0.5, 'allow_underdamped', 6.0),          # w_n = 0.5 omega_res = 6
              ('omega_n', 7.0, 'allow_resonance', 14.0)]        # zeta = 1


@pytest.mark.parametrize('name, value, override, kv', GAIN_RULES)
def test_a_gain_rule_refusal_names_the_parameter_that_overrides_it_and_that_parameter_does(ros_context, name,
                                                                                         value, override, kv):
    """`ros2 param set /controller zeta 0.5` is refused with 'override: set the parameter allow_underdamped:
    true'; that parameter exists (false by default, settable at run time) and, once set, the value is taken;
    clearing it again while the design needs it is refused."""
    with rig(ros_context, **POLAR) as (ex, ctrl, robot):
        assert ctrl.get_parameter(override).value is False
        refused = ctrl.set_parameters([Parameter(name, value=value)])[0]
        assert not refused.successful
        assert refused.reason.endswith(f'override: set the parameter {override}: true'), refused.reason
        assert ctrl.set_parameters([Parameter(override, value=True)])[0].successful
        assert ctrl.set_parameters([Parameter(name, value=value)])[0].successful
        assert list(ctrl.get_parameter('gains.kv').value) == [kv, kv]
        back = ctrl.set_parameters([Parameter(override, value=False)])[0]
        assert not back.successful and override in back.reason
        assert ctrl.get_parameter(override).value is True


@pytest.mark.parametrize('name, value, override, kv', GAIN_RULES)
def test_a_gain_rule_override_given_at_start_up_designs_the_gains(ros_context, name, value, override, kv):
    with rig(ros_context, **POLAR, **{name: value, override: True}) as (ex, ctrl, robot):
        np.testing.assert_array_equal(ctrl.core.config.control_law.motion_gains.kv, [kv, kv])


SO100_ARM = dict(model='urdf', urdf='so_arm_description/urdf/so100.urdf', tip='gripper', law='impedance',
                 joints=['shoulder_pan', 'shoulder_lift', 'elbow_flex', 'wrist_flex', 'wrist_roll'])


@pytest.mark.parametrize('changes, name', [
    ({'task_space': 'pose'}, 'task_space'),                                       # 5 joints cannot hold a pose
    ({'cartesian_stiffness': [1000.0, 1000.0, 1000.0, 100.0, 100.0, 100.0]}, 'cartesian_stiffness'),  # auto: position
])
def test_a_configuration_that_cannot_work_stops_the_node_at_start_up_naming_the_parameter(ros_context, changes,
                                                                                         name):
    from robot_control.ros.controller_params import ParameterError
    overrides = [Parameter(k, value=v) for k, v in dict(SO100_ARM, **changes).items()]
    with pytest.raises(ParameterError, match=f'^{name}: ') as err:
        ControllerNode(context=ros_context, parameter_overrides=overrides)
    assert err.value.name == name


def test_a_configuration_that_cannot_work_is_refused_at_run_time_naming_the_parameter(ros_context):
    """The SO-100's position task space: rotational stiffness set while running is refused, the law runs on."""
    with rig(ros_context, **SO100_ARM) as (ex, ctrl, robot):
        result = ctrl.set_parameters([Parameter('cartesian_stiffness', value=[800.0, 800.0, 800.0, 0.0, 0.0, 20.0])])
        assert not result[0].successful and result[0].reason.startswith('cartesian_stiffness: rz = 20 act on the '
                                                                        'orientation'), result[0].reason
        assert ctrl.get_parameter('cartesian_stiffness').value in ((), [])
        assert ctrl.set_parameters([Parameter('cartesian_stiffness', value=[800.0, 800.0, 800.0, 0.0, 0.0, 0.0])])[
            0].successful
        np.testing.assert_array_equal(ctrl.core.config.control_law.K, [800.0, 800.0, 800.0])


def test_read_only_parameters_cannot_change(ros_context):
    with rig(ros_context, **POLAR) as (ex, ctrl, robot):
        for name, value in (('joints', ['a', 'b']), ('model', 'single_link'), ('scenario', 'iiwa')):
            result = ctrl.set_parameters([Parameter(name, value=value)])[0]
            assert not result.successful and 'read-only' in result.reason


def test_parameter_service_accepts_integers_and_empty_lists(ros_context):
    """What `ros2 param set /controller omega_res 10` and `kp "[]"` send: an integer, an empty bool array."""
    from rclpy.parameter_client import AsyncParameterClient
    with rig(ros_context, **POLAR, kp=[50.0, 50.0], kv=[10.0, 10.0]) as (ex, ctrl, robot):
        client = AsyncParameterClient(robot.node, 'controller')
        assert spin_until(ex, client.services_are_ready)
        future = client.set_parameters([Parameter('omega_res', Parameter.Type.INTEGER, 10),
                                        Parameter('kp', Parameter.Type.BOOL_ARRAY, []),
                                        Parameter('kv', Parameter.Type.BOOL_ARRAY, [])])
        assert spin_until(ex, future.done)
        assert [r.successful for r in future.result().results] == [True, True, True]
        assert ctrl.get_parameter('omega_res').value == 10.0
        np.testing.assert_array_equal(ctrl.core.config.control_law.motion_gains.kp, [25.0, 25.0])    # designed again
        future = client.set_parameters([Parameter('zeta', Parameter.Type.DOUBLE, 0.7)])
        assert spin_until(ex, future.done)
        result = future.result().results[0]
        assert not result.successful and result.reason.startswith('zeta:')


def test_invalid_start_up_parameter_raises_naming_it(ros_context):
    from robot_control.ros.controller_params import ParameterError
    with pytest.raises(ParameterError, match='^omega_n:'):
        ControllerNode(context=ros_context, parameter_overrides=[Parameter('omega_n', value=100.0)])
    with pytest.raises(ParameterError, match='^scenario:'):
        ControllerNode(context=ros_context, parameter_overrides=[Parameter('scenario', value='moon_rover')])
    with pytest.raises(ParameterError, match='^zeta: expected type DOUBLE'):
        ControllerNode(context=ros_context, parameter_overrides=[Parameter('zeta', value=1)])
    with pytest.raises(ParameterError, match='^zetta: unknown parameter of controller; did you mean zeta') as err:
        ControllerNode(context=ros_context, parameter_overrides=[Parameter('zetta', value=1.0)])
    assert err.value.name == 'zetta'


def test_switching_law_and_gains_at_run_time_is_bumpless(ros_context):
    """PID computed torque -> PID independent joint (set atomically): the torque does not jump."""
    with rig(ros_context, **POLAR, integral=True) as (ex, ctrl, robot):
        q, qd = np.array([0.09, 0.48]), np.array([0.0, 0.0])
        robot.step(ex, POLAR_JOINTS, [0.1, 0.5], qd, T0_NS)
        for k in range(1, 200):
            cmd, _, _ = robot.step(ex, POLAR_JOINTS, q, qd, T0_NS + k * DT_NS)
        result = ctrl.set_parameters_atomically([
            Parameter('law', value='independent_joint'), Parameter('kp', value=[50.0, 80.0]),
            Parameter('kv', value=[10.0, 20.0]), Parameter('ki', value=[30.0, 40.0])])
        assert result.successful, result.reason
        after, ref, err = robot.step(ex, POLAR_JOINTS, q, qd, T0_NS + 200 * DT_NS)
        np.testing.assert_allclose(after[3], cmd[3], rtol=0, atol=1e-9)
        gains = ServoGains([50.0, 80.0], [10.0, 20.0], [30.0, 40.0])
        np.testing.assert_allclose(after[3], independent_joint(q, qd, ref[1], ref[2], gains, err[3]), rtol=0,
                                   atol=1e-12)
        result = ctrl.set_parameters([Parameter('integral', value=False)])[0]   # now without integral action:
        assert result.successful                                                # exactly the PD law
        after, ref, _ = robot.step(ex, POLAR_JOINTS, q, qd, T0_NS + 201 * DT_NS)
        np.testing.assert_allclose(after[3], independent_joint(q, qd, ref[1], ref[2], gains), rtol=0, atol=1e-12)


def test_a_switch_to_a_force_law_takes_the_force_reference_of_f_d(ros_context):
    """The force axes belong to the law's force setup: a joint law has none, so f_d waits for the switch to
    hybrid, which starts its force reference from it (ramping from the force measured at the switch)."""
    with rig(ros_context, scenario='hybrid_cartesian_xy', law='computed_torque', force_feedback='model', f_d=[5.0],
             force_ramp_time=0.0, effort_limits=[200.0, 200.0]) as (ex, ctrl, robot):
        robot.step(ex, ['x', 'y'], [0.3002, 0.1], [0.0, 0.0], T0_NS)
        assert ctrl.core.force_target.tolist() == []
        assert ctrl.set_parameters([Parameter('law', value='hybrid')])[0].successful
        assert ctrl.core.force_target.tolist() == [5.0]
        _, ref, _ = robot.step(ex, ['x', 'y'], [0.3002, 0.1], [0.0, 0.0], T0_NS + DT_NS)
        assert ref[0] == ('x', 'y') and ref[1][0] == 5.0


def test_q_d_parameter_moves_the_reference_from_the_current_one(ros_context):
    with rig(ros_context, **POLAR, move_time=0.02) as (ex, ctrl, robot):
        q = np.array([0.1, 0.5])
        robot.step(ex, POLAR_JOINTS, q, [0.0, 0.0], T0_NS)
        assert ctrl.set_parameters([Parameter('q_d', value=[0.2, 0.6])])[0].successful
        expected = from_points(0.0, (q, None, None), [0.02], [[0.2, 0.6]])
        for k in range(1, 25):
            _, ref, _ = robot.step(ex, POLAR_JOINTS, q, [0.0, 0.0], T0_NS + k * DT_NS)
            for got, want in zip(_ref_of(ref), expected.sample(units.seconds(k * DT_NS))):
                np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


# -- 4. watchdog, rejected states, limits -------------------------------------------------------------------
def _status(robot, suffix):
    """The latest /diagnostics status whose name ends with `suffix`: (level, message, values)."""
    for array in reversed(robot.diagnostics):
        for s in array.status:
            if s.name.endswith(suffix):
                return cv.diagnostic_values(s)
    return None


def test_watchdog_trips_and_recovers_from_the_current_state(ros_context):
    with rig(ros_context, **POLAR, integral=True, state_timeout=0.2) as (ex, ctrl, robot):
        for k in range(20):
            robot.step(ex, POLAR_JOINTS, [0.1, 0.5] if k == 0 else [0.09, 0.49], [0.0, 0.0], T0_NS + k * DT_NS)
        assert np.all(ctrl.core.integral_value > 0.0)
        sent = len(robot.commands)
        assert spin_until(ex, lambda: ctrl.watchdog_tripped)
        assert spin_until(ex, lambda: (_status(robot, 'joint_states watchdog') or ('',))[0] == 'ERROR')
        assert len(robot.commands) == sent                      # nothing commanded while tripped
        q, qd = np.array([0.3, 0.7]), np.array([0.05, 0.0])
        cmd, ref, err = robot.step(ex, POLAR_JOINTS, q, qd, T0_NS + 5_000 * DT_NS)
        assert not ctrl.watchdog_tripped and ctrl.trips == 1 and ctrl.core.restarts == 1
        np.testing.assert_array_equal(ref[1], q)                # reference restarted: hold q
        np.testing.assert_array_equal(err[3], [0.0, 0.0])       # integral reset
        gains = design(1.0, 12.0, integral=True).gains(2)
        want = computed_torque(make_model('polar_two_link', m=2.0, gravity=9.8), q, qd, q, np.zeros(2),
                               np.zeros(2), gains, np.zeros(2))
        np.testing.assert_allclose(cmd[3], want, rtol=0, atol=1e-12)
        assert spin_until(ex, lambda: _status(robot, 'joint_states watchdog')[0] == 'OK')


def test_watchdog_trips_and_states_that_follow_the_last_one_resume_the_law(ros_context):
    """A trip while the robot's time stood still (the states' stamps go on one period after the last answered
    one, as a lockstep simulator's do when the machine held it up): the law resumes, its integral and
    reference as they were; the log says so."""
    with rig(ros_context, **POLAR, integral=True, state_timeout=0.2) as (ex, ctrl, robot):
        for k in range(20):
            robot.step(ex, POLAR_JOINTS, [0.1, 0.5] if k == 0 else [0.09, 0.49], [0.0, 0.0], T0_NS + k * DT_NS)
        integral, reference = ctrl.core.integral_value.copy(), ctrl.core.joint_reference[0].copy()
        assert spin_until(ex, lambda: ctrl.watchdog_tripped)
        msg = cv.joint_trajectory(POLAR_JOINTS, [0.5], [[0.1, 0.2]])       # no robot to move: refused meanwhile
        robot.send_until(ex, robot.traj_pub, msg, lambda: ctrl.rejected['joint_trajectory'] == 1)
        assert 'controller not running' in ctrl.last_rejection and ctrl.trajectories_accepted == 0
        cmd, ref, err = robot.step(ex, POLAR_JOINTS, [0.09, 0.49], [0.0, 0.0], T0_NS + 20 * DT_NS)
        assert not ctrl.watchdog_tripped and ctrl.trips == 1 and ctrl.core.restarts == 0
        np.testing.assert_array_equal(ref[1], reference)        # the reference goes on
        assert np.all(err[3] != 0.0) and np.all(np.sign(err[3]) == np.sign(integral))   # the integral goes on
        assert spin_until(ex, lambda: _status(robot, 'joint_states watchdog')[0] == 'OK')


def test_the_first_clock_after_answered_states_is_no_age_of_the_states(ros_context):
    """With use_sim_time, states answered before the first /clock (ROS time 0 then) age on the steady clock alone:
    the first /clock, at the simulator's time (100 s here), is no silence of 100 s. Under load DDS may match
    /clock's reader a second or more after joint_states'."""
    with rig(ros_context, **POLAR, use_sim_time=True, state_timeout=5.0) as (ex, ctrl, robot):
        for k in range(3):
            robot.step(ex, POLAR_JOINTS, [0.1, 0.5], [0.0, 0.0], T0_NS + k * DT_NS)
        assert ctrl.get_clock().now().nanoseconds == 0                  # no /clock yet
        clock = robot.node.create_publisher(ClockMsg, '/clock', CONTROL_QOS)
        msg = ClockMsg()
        msg.clock.sec = 100
        assert spin_until(ex, lambda: ctrl.get_clock().now().nanoseconds >= 100 * units.NS_PER_S, every=0.25,
                          action=lambda: clock.publish(msg))
        seen_ns = time.monotonic_ns()
        watchdog = ctrl.session.watchdog
        assert spin_until(ex, lambda: (watchdog.checked_ns or 0) > seen_ns)     # a check since /clock
        assert not ctrl.watchdog_tripped and ctrl.trips == 0


def _bad_states():
    good = dict(names=['theta1', 'r'], position=[0.1, 0.5], velocity=[0.0, 0.0])
    return {
        'missing joint': dict(good, names=['theta1', 'x'], reason="name: missing controlled joints ['r']"),
        'unknown joints only': dict(good, names=['a', 'b'], reason='name: missing controlled joints'),
        'duplicate': dict(good, names=['theta1', 'r', 'r'], position=[0.1, 0.5, 0.5], velocity=[0.0] * 3,
                          reason="name: duplicate joint 'r'"),
        'short position': dict(good, position=[0.1], reason='position: expected one entry per name'),
        'short velocity': dict(good, velocity=[0.0], reason='velocity: expected one entry per name (2) or none'),
        'nan': dict(good, position=[math.nan, 0.5], reason="position: not finite for 'theta1': nan"),
        'inf': dict(good, velocity=[0.0, -math.inf], reason="velocity: not finite for 'r': -inf"),
    }


@pytest.mark.parametrize('case', sorted(_bad_states()))
def test_rejected_state_gets_no_command_and_a_counted_diagnostic(ros_context, case):
    bad = _bad_states()[case]
    with rig(ros_context, **POLAR) as (ex, ctrl, robot):
        robot.step(ex, POLAR_JOINTS, [0.1, 0.5], [0.0, 0.0], T0_NS)
        bad_stamp = T0_NS + DT_NS
        msg = cv.joint_state(bad['names'], bad_stamp, bad['position'], bad['velocity'])
        robot.send_until(ex, robot.state_pub, msg, lambda: ctrl.rejected['joint_states'] >= 1)
        robot.step(ex, POLAR_JOINTS, [0.1, 0.5], [0.0, 0.0], T0_NS + 2 * DT_NS)
        assert bad_stamp not in robot.commands and bad_stamp not in robot.references
        assert ctrl.last_rejection.startswith(f'joint_states: {bad["reason"]}'), ctrl.last_rejection

        def counted():
            s = _status(robot, 'rejected inputs')
            return s is not None and s[0] == 'WARN' and int(s[2]['rejected.joint_states']) >= 1
        assert spin_until(ex, counted)
        level, message, values = _status(robot, 'rejected inputs')
        assert bad['reason'] in values['last_reason']


def test_a_state_without_velocities_is_answered_with_the_estimate(ros_context):
    """A driver that sends no velocities: the node answers with qd estimated from the positions (at rest: the
    torque of qd = 0) and /diagnostics names the estimate."""
    with rig(ros_context, **POLAR) as (ex, ctrl, robot):
        q = [0.1, 0.5]
        for k in range(3):
            cmd, _, _ = robot.step(ex, POLAR_JOINTS, q, [], T0_NS + k * DT_NS)
        gains = design(1.0, 12.0).gains(2)
        want = computed_torque(make_model('polar_two_link', m=2.0, gravity=9.8), np.array(q), np.zeros(2),
                               np.array(q), np.zeros(2), np.zeros(2), gains)
        np.testing.assert_allclose(cmd[3], want, rtol=0, atol=1e-12)
        assert ctrl.rejected['joint_states'] == 0
        assert spin_until(ex, lambda: (_status(robot, 'control law') or ('', '', {}))[2].get('velocity', '')
                          .startswith('estimated: first-order low-pass differentiator, Tustin, f_c = 50 Hz'))


def test_nothing_above_the_effort_limits_or_non_finite_is_published(ros_context):
    with rig(ros_context, **dict(POLAR, effort_limits=[5.0, 3.0]), integral=True, q_d=[1.5, 1.2],
             move_time=0.005) as (ex, ctrl, robot):
        for k in range(40):
            q = RNG.uniform([-1.0, 0.2], [1.0, 1.2])
            qd = RNG.uniform(-5.0, 5.0, 2)
            robot.step(ex, POLAR_JOINTS, q, qd, T0_NS + k * DT_NS)
        efforts = np.array([c[3] for c in robot.commands.values()])
        assert efforts.shape == (40, 2)
        assert np.all(np.isfinite(efforts))
        assert np.all(np.abs(efforts) <= [5.0, 3.0])
        assert np.any(np.abs(efforts) == [5.0, 3.0])
        assert spin_until(ex, lambda: (_status(robot, 'effort saturation') or ('',))[0] == 'WARN')
        assert int(_status(robot, 'effort saturation')[2]['saturated_ticks']) >= 1


def test_a_run_of_rejections_calls_the_logger_once_per_throttle_period(ros_context):
    """rclpy's throttle_duration_sec inspects the caller's source on every call (0.4 ms per rejected
    message measured); the node throttles before it calls the logger at all."""
    with rig(ros_context, **POLAR) as (ex, ctrl, robot):
        warnings = []

        class Logger:
            def warning(self, text, **kwargs):
                warnings.append(text)
        ctrl.session.log = Logger()                                # this controller only
        for k in range(100):
            ctrl.session.reject('joint_states', f'bad {k}')
        assert ctrl.rejected['joint_states'] == 100 and ctrl.last_rejection == 'joint_states: bad 99'
        assert warnings == ['rejected joint_states: bad 0']

class CapturedWarnings:
    """The controller's logger with its warnings captured as (wall time s, text); every other call passes on."""

    def __init__(self, logger):
        self.logger, self.lines = logger, []

    def warning(self, text, **kwargs):
        self.lines.append((time.monotonic(), text))

    def __getattr__(self, name):
        return getattr(self.logger, name)


def test_a_law_that_keeps_saturating_is_a_throttled_warning_in_the_node_s_log(ros_context):
    """Effort limits of 0.5 N m / N hold nothing: every tick saturates both joints. The node's log says so,
    naming the joints and the counts, at most once per the Controller's period (shortened to 0.3 s here
    from LAW_WARN_PERIOD) of the steady clock readings it is given, each window's counts following on from the
    last. (The log call comes a little after its reading, later under load: the times the lines were logged may
    lie a few us less than the period apart.)"""
    import re
    period = 0.3
    with rig(ros_context, **dict(POLAR, effort_limits=[0.5, 0.5])) as (ex, ctrl, robot):
        log = ctrl.session.log = CapturedWarnings(ctrl.session.log)
        controller, said_ns = ctrl.session.controller, []
        controller.law_watch.period_ns = units.to_ns(period)
        law_warning = controller.law_warning

        def recorded(steady_ns):
            text = law_warning(steady_ns)
            if text is not None:
                said_ns.append(steady_ns)
            return text
        controller.law_warning = recorded
        k, deadline = 0, time.monotonic() + 60.0
        while len(log.lines) < 3 and time.monotonic() < deadline:
            robot.step(ex, POLAR_JOINTS, [0.3, 0.7], [0.0, 0.0], T0_NS + k * DT_NS)
            k += 1
    assert len(log.lines) >= 3, log.lines
    said = re.compile(r'law computed_torque saturated the effort limits in (\d+) of the last (\d+) ticks '
                      r'\(theta1 in (\d+), r in (\d+)\)$')
    counts = [[int(g) for g in said.match(text).groups()] for _, text in log.lines]
    assert all(len(set(c)) == 1 for c in counts), counts          # every tick saturated both joints
    assert sum(c[0] for c in counts) <= k
    assert len(said_ns) == len(log.lines)
    gaps = np.diff(said_ns) / units.NS_PER_S
    print(f'{len(log.lines)} warnings over {k} ticks, {gaps.min():.3f} s apart at least: {log.lines[0][1]}')
    assert gaps.min() >= period


def test_diagnostics_are_throttled_to_their_period(ros_context):
    """/diagnostics comes periodically, at most once per diagnostics_period: the test waits for 4 arrays
    (however long a busy machine takes) and bounds their rate by the wall time that took. Load can delay
    a timer call, never bring one early, so the upper bound holds on any machine."""
    with rig(ros_context, **dict(POLAR, diagnostics_period=0.2)) as (ex, ctrl, robot):
        start, t0 = len(robot.diagnostics), time.monotonic()
        assert spin_until(ex, lambda: len(robot.diagnostics) >= start + 4)
        elapsed = time.monotonic() - t0
        count = len(robot.diagnostics) - start
        assert count <= elapsed / 0.2 + 2, f'{count} /diagnostics in {elapsed:.2f} s at a period of 0.2 s'


# -- main(): the executable ---------------------------------------------------------------------------------
def _run_node(*ros_args):
    env = dict(os.environ, PYTHONUNBUFFERED='1')
    return subprocess.Popen([sys.executable, '-m', 'robot_control.ros.controller_node', '--ros-args', *ros_args],
                            cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def _read_until(proc, text, timeout=DEADLINE):
    out, deadline = '', time.monotonic() + timeout
    while time.monotonic() < deadline and text not in out:
        ready, _, _ = select.select([proc.stdout], [], [], 0.1)
        if ready:
            line = proc.stdout.readline()
            if not line:
                break
            out += line
    return out


@pytest.mark.parametrize('sig', [signal.SIGTERM, signal.SIGINT])
def test_main_runs_with_a_params_file_and_stops_cleanly_on_a_signal(sig):
    proc = _run_node('--params-file', os.path.join(ROOT, 'config', 'polar_two_link.yaml'))
    try:
        out = _read_until(proc, 'ready:')
        assert 'ready: law computed_torque' in out and "'theta1', 'r'" in out, out
        proc.send_signal(sig)
        assert proc.wait(timeout=DEADLINE) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_main_exits_2_naming_a_bad_parameter_and_its_override():
    proc = _run_node('--params-file', os.path.join(ROOT, 'config', 'polar_two_link.yaml'), '-p', 'zeta:=0.5')
    try:
        out, _ = proc.communicate(timeout=DEADLINE)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 2
    assert ('controller_node: bad parameter zeta: 0.5 breaks the rule zeta >= 1 (the lecture: no underdamped '
            'response, for safety); override: set the parameter allow_underdamped: true') in out


# -- joint_trajectory_controller semantics through the node ------------------------------------------------
def test_constraints_parameters_hold_the_position_on_a_path_violation_and_report_error(ros_context):
    """constraints.<joint>.trajectory set at run time; the robot does not follow: the path tolerance
    trips, the reference holds where the robot is and /diagnostics' trajectory status is ERROR."""
    with rig(ros_context, **POLAR) as (ex, ctrl, robot):
        assert all(r.successful for r in ctrl.set_parameters([Parameter('constraints.theta1.trajectory', value=0.02),
                                                              Parameter('constraints.r.trajectory', value=0.02)]))
        assert ctrl.core.config.tolerances.trajectory.tolist() == [0.02, 0.02]
        q = np.array([0.1, 0.5])
        robot.step(ex, POLAR_JOINTS, q, [0.0, 0.0], T0_NS)
        robot.send_until(ex, robot.traj_pub, cv.joint_trajectory(POLAR_JOINTS, [0.0, 0.5], [q, [0.6, 0.5]]),
                         lambda: ctrl.trajectories_accepted == 1)
        k = 1
        while ctrl.core.goal.active and k < 500:
            robot.step(ex, POLAR_JOINTS, q, [0.0, 0.0], T0_NS + k * DT_NS)       # the robot stays put
            k += 1
        assert ctrl.core.goal.outcome == 'path' and 'theta1: |q_d - q| = 0.02' in ctrl.core.goal.reason
        _, ref, _ = robot.step(ex, POLAR_JOINTS, q, [0.0, 0.0], T0_NS + k * DT_NS)
        np.testing.assert_array_equal(ref[1], q)                                    # holds where it is
        status = {s.name.split(': ')[1]: s for s in ctrl.diagnostics()}['trajectory']
        assert status.level == DiagnosticStatus.ERROR and 'path' in status.message


def test_a_partial_goal_is_refused_unless_allowed_and_an_empty_one_cancels(ros_context):
    with rig(ros_context, **POLAR) as (ex, ctrl, robot):
        q = np.array([0.1, 0.5])
        robot.step(ex, POLAR_JOINTS, q, [0.0, 0.0], T0_NS)
        partial = cv.joint_trajectory(['r'], [0.5], [[0.7]])
        robot.send_until(ex, robot.traj_pub, partial, lambda: ctrl.rejected['joint_trajectory'] == 1)
        assert 'allow_partial_joints_goal is false' in ctrl.last_rejection
        assert ctrl.set_parameters([Parameter('allow_partial_joints_goal', value=True)])[0].successful
        robot.send_until(ex, robot.traj_pub, partial, lambda: ctrl.trajectories_accepted == 1)
        for k in range(1, 300):
            _, ref, _ = robot.step(ex, POLAR_JOINTS, q, [0.0, 0.0], T0_NS + k * DT_NS)
        assert ref[1][0] == pytest.approx(0.1, abs=1e-12) and 0.5 < ref[1][1] < 0.7    # theta1 held, r moving
        robot.send_until(ex, robot.traj_pub, cv.joint_trajectory(POLAR_JOINTS, [], np.zeros((0, 2))),
                         lambda: ctrl.trajectories_accepted == 2)
        _, ref, _ = robot.step(ex, POLAR_JOINTS, q, [0.0, 0.0], T0_NS + 300 * DT_NS)
        np.testing.assert_array_equal(ref[1], q)                                    # cancelled: holds q
        assert ctrl.core.goal.outcome == 'cancelled'


def test_the_gains_in_force_are_read_only_parameters_that_follow_every_change(ros_context):
    """Designed from zeta and omega: `ros2 param get /controller gains.kp` gives them (kp itself stays []),
    they follow a change of zeta, a set from outside is refused, and /diagnostics lists them."""
    with rig(ros_context, **POLAR) as (ex, ctrl, robot):
        assert list(ctrl.get_parameter('kp').value) == []
        assert list(ctrl.get_parameter('gains.kp').value) == [36.0, 36.0]
        assert list(ctrl.get_parameter('gains.kv').value) == [12.0, 12.0]
        assert ctrl.set_parameters([Parameter('zeta', value=2.0)])[0].successful
        assert list(ctrl.get_parameter('gains.kv').value) == [24.0, 24.0]       # 2 zeta w_n, w_n = 6
        refused = ctrl.set_parameters([Parameter('gains.kp', value=[1.0, 1.0])])[0]
        assert not refused.successful and refused.reason.startswith('gains.kp: read-only: in force')
        assert list(ctrl.get_parameter('gains.kp').value) == [36.0, 36.0]
        law = {s.name.split(': ')[1]: s for s in ctrl.diagnostics()}['control law']
        assert {v.key: v.value for v in law.values}['gains.kv'] == '[24.0, 24.0]'


#: bad values of the rows whose rules are the build's (custom), besides the generic ones (ki is read only with
#: integral action, off here)
CUSTOM_BAD = {'zeta': [('underdamped', 0.5)], 'omega_n': [('above omega_res / 2', 1000.0)],
              'kp': [('wrong size', [1.0] * 3)], 'kv': [('wrong size', [1.0] * 3)],
              'effort_limits': [('wrong size', [1.0] * 3)], 'q_d': [('wrong size', [0.0] * 3)]}


def test_every_bad_run_time_set_is_refused_naming_the_parameter_and_the_loop_runs_on(ros_context):
    """Every parameter that may change at run time, set through the parameter service (as `ros2 param set`) to
    what its type and rules refuse: each set is answered, refused with the reason naming the parameter, and
    changes nothing; the controller still answers each state with a command."""
    from robot_control.ros import controller_params
    from support import bad_params
    with rig(ros_context, **POLAR) as (ex, ctrl, robot):
        robot.step(ex, POLAR_JOINTS, [0.0, 0.5], [0.0, 0.0], T0_NS)
        set_ = bad_params.setter(robot.node, 'controller', lambda predicate: spin_until(ex, predicate))
        rows, values = bad_params.rows_and_values(controller_params.TABLE, ctrl)
        config, tried = ctrl.core.config, 0
        for row in rows:
            for what, value in bad_params.bad_values(row, values, CUSTOM_BAD.get(row.name, ())):
                bad_params.check_refused(set_(row.name, value), row.name, what)
                tried += 1
        assert ctrl.core.config is config and bad_params.rows_and_values(controller_params.TABLE, ctrl)[1] == values
        for k in range(1, 4):
            robot.step(ex, POLAR_JOINTS, [0.0, 0.5], [0.0, 0.0], T0_NS + k * DT_NS)
        assert tried >= 3 * len(rows)
