"""Your own arm: two arms the package does not ship, taken from the example-robot-data wheel as a new user
would, closed in-process around the simulated World with the library's laws (no ROS).

xArm7: its `link_eef` has no <inertial>. The URDF (and Pinocchio) make it massless; PyBullet, left to
itself, gives it 1 kg and 1 kg m^2: from this start, gravity compensation let the arm fall 3.9 rad in
2 s and computed torque (w_n 20 rad/s) missed the move below by 1.5 rad. The World loads it massless.
Measured: gravity compensation holds it to 2.5e-13 rad over 2 s (checked at 1e-6); computed torque
tracks a 2 s quintic move within 5.6e-5 rad (checked at 1e-3).

SO-100: its link and its joint are both named `gripper`; the controller on the five arm joints (the
gripper locked) must build, and its g(q) is PyBullet's with the gripper at the same position (measured
difference 5e-16 N m on 20 states, |g| up to 0.46 N m; checked at 1e-9).
"""
import numpy as np
import pybullet
import pytest

from robot_control.gains import ServoGains
from robot_control.laws import computed_torque, gravity_compensation
from robot_control.models import make_model
from robot_control.trajectory import point_to_point
from sim_bridge import physics_check
from sim_bridge.world import World

XARM = 'xarm_description/urdf/xarm7.urdf'
XARM_JOINTS = tuple(f'joint{i}' for i in range(1, 8))
XARM_Q0 = np.array([0.3, -0.5, 0.2, 0.6, -0.3, 0.8, 0.4])
SO100 = 'so_arm_description/urdf/so100.urdf'
SO100_ARM = ('shoulder_pan', 'shoulder_lift', 'elbow_flex', 'wrist_flex', 'wrist_roll')
W_N = 20.0


@pytest.fixture
def xarm():
    world = World(None, urdf=XARM, joints=XARM_JOINTS, q0=XARM_Q0)
    try:
        yield world, make_model('urdf', urdf=XARM, joints=XARM_JOINTS)
    finally:
        world.close()


def test_the_xarm7_held_by_gravity_compensation_stays_put(xarm):
    world, model = xarm
    assert world.report == []                  # PyBullet simulates the URDF: nothing to report
    for _ in range(2000):
        world.set_torque(gravity_compensation(model, world.state()[0]))
        world.step()
    q, qd, _ = world.state()
    assert np.abs(q - XARM_Q0).max() < 1e-6, np.abs(q - XARM_Q0).max()
    assert np.abs(qd).max() < 1e-6


def test_computed_torque_tracks_a_two_second_move_of_the_xarm7(xarm):
    world, model = xarm
    goal = XARM_Q0 + np.array([0.6, 0.5, -0.4, 0.5, 0.6, -0.5, 0.8])
    path = point_to_point(XARM_Q0, goal, 2.0)
    gains = ServoGains.uniform(7, W_N ** 2, 2 * W_N)
    worst = 0.0
    for _ in range(2500):
        q, qd, _ = world.state()
        q_d, qd_d, qdd_d = path.sample(world.t)
        worst = max(worst, np.abs(q_d - q).max())
        world.set_torque(computed_torque(model, q, qd, q_d, qd_d, qdd_d, gains))
        world.step()
    assert worst < 1e-3, worst
    assert np.abs(world.state()[0] - goal).max() < 1e-3


def test_the_so100_arm_without_its_gripper_is_pybullets_robot_with_the_gripper_locked():
    """Joint and link 'gripper': the model on the five arm joints builds, the gripper locked at 0.7 rad,
    and g(q) is PyBullet's with the gripper there; the World holds the arm with it (gripper at 0)."""
    model = make_model('urdf', urdf=SO100, joints=SO100_ARM, q_locked={'gripper': 0.7})
    assert model.joint_names == SO100_ARM
    world = World(None, urdf=SO100, joints=SO100_ARM, q0=[0.2, 0.5, -0.6, 0.4, 0.3])
    client = pybullet.connect(pybullet.DIRECT)
    try:
        pybullet.setGravity(0.0, 0.0, -9.81, physicsClientId=client)
        body = pybullet.loadURDF(world.urdf, useFixedBase=True, flags=pybullet.URDF_USE_INERTIA_FROM_FILE,
                                 physicsClientId=client)
        movable = list(physics_check.movable_joints(client, body))
        assert movable == [*SO100_ARM, 'gripper']
        rng = np.random.default_rng(20261126)
        lower, upper = model.position_limits
        for _ in range(20):
            q = rng.uniform(np.maximum(lower, -2.0), np.minimum(upper, 2.0))
            g_b = pybullet.calculateInverseDynamics(body, [*q, 0.7], [0.0] * 6, [0.0] * 6, physicsClientId=client)
            np.testing.assert_allclose(model.g(q), g_b[:5], rtol=1e-9, atol=1e-9)
        assert np.abs(model.g(q)).max() > 0.05
        held = make_model('urdf', urdf=SO100, joints=SO100_ARM)
        q0 = world.state()[0]
        for _ in range(1000):
            world.set_torque(gravity_compensation(held, world.state()[0]))
            world.step()
        assert np.abs(world.state()[0] - q0).max() < 1e-6
    finally:
        pybullet.disconnect(client)
        world.close()
